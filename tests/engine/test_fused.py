"""The fused RK4 path gives the generic path's numbers, bit for bit."""
import numpy as np
import pytest

import hybridsim as hs
from hybridsim.engine import fused

from conftest import DIAGRAMS, ROOT, integrator_without_kernels


@pytest.mark.slow
@pytest.mark.parametrize("path, extra", [
    (DIAGRAMS / "fig9_force_and_position.yaml", {"rate": 120, "t_end": 0.4}),
    (DIAGRAMS / "fig8_receding_surface.yaml", {"t_end": 1.2}),
    (ROOT / "tests" / "data" / "smooth_contact.yaml", {}),
    # three rates, one with an offset, a delay's held output read before the block computes it
    (ROOT / "tests" / "data" / "every_kernel_block.yaml", {}),
    (ROOT / "tests" / "data" / "library_blocks.yaml", {}),
], ids=["fig9", "fig8-moving-surface", "damped", "every-kernel-block", "library"])
def test_fused_equals_generic(path, extra):
    assert hs.build(path, **extra)[1]._fused is not None
    a = hs.simulate(path, fused=True, **extra)
    b = hs.simulate(path, fused=False, **extra)
    assert np.array_equal(a.t, b.t)
    assert np.array_equal(a.table(), b.table())


def test_fused_only_where_every_block_has_kernels():
    system, sim, _ = hs.build(DIAGRAMS / "fig9_force_and_position.yaml")
    assert sim._fused is not None
    assert not fused.eligible(system, hs.ScipySolver("Radau"))
    system, sim, _ = hs.build(DIAGRAMS / "fig9_force_and_position.yaml", fused=False)
    assert sim._fused is None
    # a block without kernels on the right-hand side path keeps the generic path
    d = integrator_without_kernels()
    assert not fused.eligible(d.build(), hs.RK4())
    # a width-generic block with numpy kernels is eligible (and still exact)
    d = hs.Diagram("lp")
    d.add(hs.registry.lookup("constant")("c", value=1.0))
    d.add(hs.registry.lookup("lowpass")("f"))
    d.connect("c.y", "f.u")
    assert fused.eligible(d.build(), hs.RK4())


# -- kernels a user writes, each a class of input the fused path once got wrong (written in place
# or called): the generic path's numbers, or its error -----------------------------------------
import functools  # noqa: E402
import math  # noqa: E402

from hybridsim.engine.block import Block  # noqa: E402
from hybridsim.engine.kernels import Kernels, kernel  # noqa: E402

BIG = 10 ** 400
HALF = np.float64(0.25)


def _user_block(kernels, params=(), outputs=(("y", 1),)):
    class User(Block):
        def __init__(self, name):
            super().__init__(name)
            self.params = params
            self.declare_input("u", 1)
            for n, w in outputs:
                self.declare_output(n, w)

    User.kernels = kernels
    return User


@kernel
def _ramp_out(p, t, x, u):
    return ((x[0],),)


@kernel
def _ramp_der(p, t, x, u):
    return (1.0,)


@kernel
def _pass_der(p, t, x, u):
    return (u[0][0],)


@kernel
def _hold(p, t, x, u):
    return (u[0][0],)


class _Ramp(Block):  # x = 0.5 + t
    kernels = Kernels(output=_ramp_out, derivatives=_ramp_der)

    def __init__(self, name):
        super().__init__(name)
        self.declare_output("y", 1, depends_on=())
        self.declare_continuous_state(1)

    def initial_state(self, u=None):
        return np.array([0.5])


class _Integ(_Ramp):
    kernels = Kernels(output=_ramp_out, derivatives=_pass_der)

    def __init__(self, name):
        super().__init__(name)
        self.declare_input("u", 1)


class _Zoh(Block):
    kernels = Kernels(output=_ramp_out, update=_hold)

    def __init__(self, name):
        super().__init__(name)
        self.declare_input("u", 1)
        self.declare_output("y", 1, depends_on=())
        self.declare_rate(rate=1000)
        self.declare_discrete_state(1)


def _root(v):
    return (math.sqrt(v),)


_root = kernel(_root)


@kernel
def _conditional_call(p, t, x, u):  # the call is only made where its argument is positive
    a = u[0][0]
    return ((_root(0.505 - a)[0] if a < 0.505 else -1.0,),)


@kernel
def _unused_domain_error(p, t, x, u):
    a = u[0][0]
    unused = math.sqrt(0.5055 - a)  # raises from t = 0.0055 s on: the generic path raises too
    return ((a,),)


@kernel
def _numpy_constant(p, t, x, u):
    return ((u[0][0] * HALF,),)


@kernel
def _huge_int(p, t, x, u):
    return ((u[0][0] + BIG % 7 + (10 ** 5000) % 7,),)


@kernel
def _big_int_output(p, t, x, u):
    return ((10 ** 17 + 1,),)


@kernel
def _minus_big(p, t, x, u):
    return ((u[0][0] - 10 ** 17,),)


@kernel
def _array_power(p, t, x, u):
    return ((p[0][0] ** 1000.0 * 0.0 + u[0][0],),)  # numpy: inf * 0 = nan; Python floats: OverflowError


def _doubled(f):
    @functools.wraps(f)
    def wrapper(p, t, x, u):
        return ((2.0 * f(p, t, x, u)[0][0],),)
    return wrapper


@kernel
@_doubled
def _decorated(p, t, x, u):
    return ((u[0][0],),)


@kernel
def _port_as_number(p, t, x, u):
    return (u[0][0] * 2.0,)


@kernel
def _scaled32(p, t, x, u):
    return ((p[0] * u[0][0],),)


def _closure():
    @kernel
    def f(p, t, x, u):
        if u[0][0] > 10.0:
            return ((late,),)
        return ((u[0][0],),)
    late = None
    del late
    return f


USER_KERNELS = {
    "conditional-call": (_conditional_call, ()),
    "unused-domain-error": (_unused_domain_error, ()),
    "numpy-constant": (_numpy_constant, ()),
    "huge-int": (_huge_int, ()),
    "float64-array-overflow": (_array_power, (np.array([10.0, 2.0]),)),
    "decorated": (_decorated, ()),
    "port-as-number": (_port_as_number, ()),
    "float32-param": (_scaled32, (np.float32(0.1),)),
    "empty-closure-cell": (_closure(), ()),
}


def _run(blocks, fused):
    d = hs.Diagram("user")
    d.add(_Ramp("I"))
    for b in blocks:
        d.add(b)
    d.add(_Integ("S"))
    d.add(_Zoh("Z"))
    names = ["I"] + [b.name for b in blocks]
    for a, b in zip(names, names[1:]):
        d.connect(f"{a}.y", f"{b}.u")
    d.connect(f"{names[-1]}.y", "S.u")
    d.connect(f"{names[-1]}.y", "Z.u")
    try:
        return hs.Simulator(d.build(), hs.RK4(1e-3), log=["S.y", "Z.y"], fused=fused).run(0.01).table()
    except Exception as exc:  # noqa: BLE001 - the two paths must fail alike
        return type(exc)


@pytest.mark.parametrize("name", list(USER_KERNELS))
def test_a_users_kernel_gives_the_generic_paths_numbers_or_error(name):
    f, params = USER_KERNELS[name]
    blocks = lambda: [_user_block(Kernels(output=f), params)("b")]  # noqa: E731
    a, b = _run(blocks(), False), _run(blocks(), True)
    if isinstance(a, type):
        assert a is b
    else:
        assert not isinstance(b, type), b
        assert np.array_equal(a, b, equal_nan=True)


def test_an_int_output_reaches_the_next_block_as_the_wire_holds_it():
    """10**17 + 1 is 10**17 as a float64: the next block subtracts 10**17 and gives 0."""
    blocks = lambda: [_user_block(Kernels(output=_big_int_output))("a"),  # noqa: E731
                      _user_block(Kernels(output=_minus_big))("b")]
    a, b = _run(blocks(), False), _run(blocks(), True)
    assert np.array_equal(a, b) and a[-1, 2] == 0.0


def test_many_branches_with_returns_are_called_not_written_out(tmp_path):
    import importlib.util
    import time

    lines = ["def f(p, t, x, u):", "    a = u[0][0]"]
    for k in range(14):
        lines += [f"    if a > {k}.0:", f"        if a > {k}.5:", "            return ((1.0,),)"]
    path = tmp_path / "branches.py"
    path.write_text("\n".join(lines + ["    return ((0.0,),)", ""]))
    spec = importlib.util.spec_from_file_location("branches", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    f = kernel(module.f)
    system = _system_with(f)
    t0 = time.process_time()
    sim = hs.Simulator(system, hs.RK4(1e-3), log=["S.y"])
    assert time.process_time() - t0 < 5.0
    b = [blk.name for blk in system.blocks].index("b")
    assert (b, "output") in sim._fused.stage.kept


def _system_with(f):
    d = hs.Diagram("d")
    d.add(_Ramp("I"))
    d.add(_user_block(Kernels(output=f))("b"))
    d.add(_Integ("S"))
    d.connect("I.y", "b.u")
    d.connect("b.y", "S.u")
    return d.build()


# library kernels on Python floats raise where the generic path's float64 arrays give inf or nan:
# the run is repeated on the generic path (its answer, or its error)
SINGULAR = """blocks:
  q:  {type: constant, value: [0.3, 0.0]}
  X:  {type: sine, amplitude: [1.0, 0.5], frequency: 3.0}
  ij: {type: inverse_jacobian}
  z:  {type: integrator, width: 2}
wires: [q.y -> ij.q, X.y -> ij.X, ij.qe -> z.u]
simulation: {t_end: 0.1, solver: rk4, step: 1.0e-3, log_period: 0.01}
"""
OVERFLOW = """blocks:
  p:  {type: constant, value: [0.0, 0.0, -0.01]}
  tw: {type: sine, amplitude: [1.0e200, 0.0, 0.0, 0.0, 0.0, 0.0], frequency: 3.0, phase: 0.5}
  pc: {type: plane_contact, stiffness: 1.0e4, mu: 0.3}
  z:  {type: integrator, width: 6}
wires: [p.y -> pc.p, tw.y -> pc.twist, pc.wrench -> z.u]
simulation: {t_end: 0.05, solver: rk4, step: 1.0e-3, log_period: 0.01}
log: [z.y, pc.wrench]
"""


@pytest.mark.parametrize("text", [SINGULAR, OVERFLOW], ids=["zero-division", "overflow"])
def test_an_arithmetic_error_on_python_floats_gives_the_generic_paths_answer(tmp_path, text):
    path = tmp_path / "d.yaml"
    path.write_text(text)
    assert hs.build(path)[1]._fused is not None
    out = {}
    for fused in (False, True):
        try:
            out[fused] = hs.simulate(path, fused=fused).table()
        except hs.SimulationError as exc:
            out[fused] = str(exc)
    if isinstance(out[False], str):
        assert out[True] == out[False] and "non-finite output" in out[False]
    else:
        assert np.array_equal(out[True], out[False], equal_nan=True)
