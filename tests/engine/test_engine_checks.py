"""Divergence and non-finite values where they happen, any number of states on every path,
and sampled blocks next to a Model Exchange FMU on the implicit solvers."""
import math

import numpy as np
import pytest

import hybridsim as hs
from hybridsim.app.cli import main
from hybridsim.errors import SimulationError
from hybridsim.engine.registry import lookup

from conftest import DIAGRAMS, write

UNSTABLE = """
name: unstable
blocks:
  c: {type: constant, value: 1.0}
  tf: {type: transfer_function, num: [1.0], den: [1.0, -5.0]}
wires: [c.y -> tf.u]
simulation: {t_end: 10.0, step: 1.0e-3}
log: [tf.y]
"""
#: x' = 5 x + 1 from 0: x = (exp(5 t) - 1) / 5 passes 1e6 at ln(5e6 + 1) / 5
T_DIVERGE = math.log(5e6 + 1) / 5

NAN = """
name: nan
blocks:
  c: {type: ramp, slope: -1.0, initial: 0.5}
  f: {type: math_function, function: sqrt}
  i: {type: integrator}
wires: [c.y -> f.u, f.y -> i.u]
simulation: {t_end: 1.0, step: 1.0e-3}
log: [i.y]
"""

SOLVER_PATHS = [("rk4", {"fused": False}), ("rk4", {}), ("heun", {}), ("radau", {}), ("bdf", {}),
                ("lsoda", {}), ("rk45", {}), ("dop853", {})]


@pytest.mark.parametrize("solver, kw", SOLVER_PATHS)
def test_divergence_is_caught_at_the_step_where_it_happens(tmp_path, solver, kw):
    p = write(tmp_path, UNSTABLE)
    with pytest.raises(SimulationError, match=r"diverged at t=(\S+) s: state 0 of block 'tf'") as err:
        hs.simulate(p, solver=solver, **kw)
    t = float(str(err.value).split("t=")[1].split(" ")[0])
    assert T_DIVERGE - 1e-6 <= t <= T_DIVERGE + 0.02  # within one step (scipy: its own step)


@pytest.mark.parametrize("solver, kw", SOLVER_PATHS)
def test_a_non_finite_block_output_names_the_block_and_time(tmp_path, solver, kw):
    p = write(tmp_path, NAN)  # sqrt of 0.5 - t: NaN from t = 0.5 s
    with pytest.raises(SimulationError, match=r"block 'f' \(math_function\) gave a non-finite output "
                                              r"at t=(\S+) s: y = \[nan\]") as err:
        hs.simulate(p, solver=solver, **kw)
    t = float(str(err.value).split("t=")[1].split(" ")[0])
    assert 0.5 < t <= 0.502


#: sqrt of cos(2 pi t): NaN on (0.25, 0.75); ``fn`` of it into an integrator
ABSORBED = """
name: absorbed
blocks:
  c: {type: cosine, amplitude: 1.0, frequency: 1.0}
  sq: {type: math_function, function: sqrt}
  fn: {type: math_function, function: FN}
  x: {type: integrator}
wires: [c.y -> sq.u, sq.y -> fn.u, fn.y -> x.u]
simulation: {t_end: 1.0, step: 1.0e-3, log_period: 0.1}
log: [x.y]
"""


@pytest.mark.parametrize("fn", ["sign", "round", "floor", "ceil", "sin"])
@pytest.mark.parametrize("solver, kw", [("rk4", {"fused": False}), ("rk4", {}), ("radau", {}), ("rk45", {})])
def test_a_function_of_nan_is_nan_so_the_run_stops_at_its_source(tmp_path, fn, solver, kw):
    # sign(NaN) read 0 and round(NaN) raised ValueError (exit 70): now NaN, caught at sq
    p = write(tmp_path, ABSORBED.replace("FN", fn))
    with pytest.raises(SimulationError, match=r"block 'sq' \(math_function\) gave a non-finite output at t=(\S+) s") as err:
        hs.simulate(p, solver=solver, **kw)
    t = float(str(err.value).split("t=")[1].split(" ")[0])
    assert 0.25 <= t <= (0.251 if solver == "rk4" else 0.75)  # a variable-step solver: in the step it took


def test_math_functions_of_non_finite_numbers():
    from hybridsim.blocks.math.nonlinear import FUNCTIONS, apply_function

    for code, name in enumerate(FUNCTIONS):
        assert math.isnan(apply_function(code, math.nan)), name
        for v in (math.inf, -math.inf):  # a number or inf/NaN, never an exception
            got = apply_function(code, v)
            assert isinstance(got, float), name
    assert apply_function(FUNCTIONS.index("floor"), -math.inf) == -math.inf
    assert math.isnan(apply_function(FUNCTIONS.index("sin"), math.inf))


def test_lookup_2d_of_nan_is_nan():
    from hybridsim.blocks.math.nonlinear import cell

    i, w = cell(np.array([0.0, 1.0]), math.nan)
    assert i == 0 and math.isnan(w)  # the index stays in the table; the weight carries the NaN


@pytest.mark.parametrize("solver", ["rk4", "rk45", "radau", "bdf", "cvode"])
def test_an_action_that_leaves_a_state_not_finite_stops_the_run(tmp_path, solver):
    # a memory samples sqrt(cos(2 pi t)) at a pulse's rising edge, t = 0.3, where it is NaN: the
    # action's NaN state ended scipy's solvers in a ValueError (exit 70) when they restarted from it
    p = write(tmp_path, """
name: event_memory
blocks:
  c: {type: cosine, amplitude: 1.0, frequency: 1.0}
  sq: {type: math_function, function: sqrt}
  p: {type: pulse, amplitude: 1.0, period: 1.0, duty: 0.5, delay: 0.3}
  m: {type: memory}
  x: {type: integrator}
wires: [c.y -> sq.u, sq.y -> m.u, p.y -> m.trigger, m.y -> x.u]
simulation: {t_end: 1.0, step: 1.0e-3, log_period: 0.25}
log: [x.y]
""")
    with pytest.raises(SimulationError, match=r"block 'sq' .* at t=(\S+) s") as err:
        hs.simulate(p, solver=solver)
    assert 0.25 < float(str(err.value).split("t=")[1].split(" ")[0]) <= 0.301  # NaN from 0.25; sampled at 0.3


@pytest.mark.parametrize("solver, kw", [("rk4", {"fused": False}), ("rk4", {}), ("heun", {})])
def test_a_fixed_step_whose_stage_goes_non_finite_names_the_block(tmp_path, solver, kw):
    # x' = -sqrt(x), x(0) = 1: x = (1 - t/2)^2 reaches 0 at t = 2; the last step's later stages
    # take sqrt of a negative x. It said "state 0 of block 'x' is nan"
    p = write(tmp_path, """
name: drain
blocks:
  sq: {type: math_function, function: sqrt}
  g: {type: gain, K: -1.0}
  x: {type: integrator, initial: 1.0}
wires: [x.y -> sq.u, sq.y -> g.u, g.y -> x.u]
simulation: {t_end: 3.0, step: 1.0e-2}
log: [x.y]
""")
    with pytest.raises(SimulationError, match=r"block 'sq' \(math_function\) gave a non-finite output at t=(\S+) s") as err:
        hs.simulate(p, solver=solver, **kw)
    assert 1.99 <= float(str(err.value).split("t=")[1].split(" ")[0]) <= 2.0


@pytest.mark.parametrize("solver", ["lsoda", "radau", "bdf", "rk45"])
def test_tolerances_float64_cannot_meet_fail_the_solver_instead_of_hanging(tmp_path, solver):
    # atol 1e-20 on a first-order lag stepped at 0.1 s: LSODA took steps of 0 s for ever at t = 0.1
    p = write(tmp_path, """
name: tight
blocks: {src: {type: step, time: 0.1}, lag: {type: first_order, tau: 0.05}}
wires: [src.y -> lag.u]
simulation: {t_end: 0.3, rtol: 1.0e-8, atol: 1.0e-20}
log: [lag.y]
""")
    with pytest.raises(SimulationError, match=r"failed at t=0\.1 s: [Rr]equired step size is less than spacing"):
        hs.simulate(p, solver=solver)


def test_radau_on_a_huge_finite_derivative_fails_cleanly(tmp_path):
    # 5e307: finite, but Radau's Jacobian overflows in its LU (scipy: ValueError, was exit 70)
    p = write(tmp_path, """
name: huge
blocks: {c: {type: constant, value: 5.0e307}, x: {type: integrator}}
wires: [c.y -> x.u]
simulation: {t_end: 1.0}
log: [x.y]
""")
    with pytest.raises(SimulationError, match="Radau failed at t=0 s|diverged"):
        hs.simulate(p, solver="radau")


def test_the_cli_exits_3_on_divergence(tmp_path, capsys):
    code = main(["run", str(write(tmp_path, UNSTABLE)), "-q", "-o", str(tmp_path / "out")])
    _, err = capsys.readouterr()
    assert code == 3 and "diverged at t=3.08" in err and "Traceback" not in err


def test_a_block_may_declare_non_finite_outputs():
    from hybridsim.engine.block import Block

    class Inf(Block):
        may_be_nonfinite = True

        def __init__(self, name):
            super().__init__(name)
            self.declare_output("y", 1)

        def output(self, t, x, u):
            return (np.array([np.inf]),)

    d = hs.Diagram("inf")
    d.add(Inf("s"))
    d.add(lookup("constant")("c", value=1.0))
    d.add(lookup("integrator")("i"))
    d.connect("c.y", "i.u")
    res = hs.Simulator(d.build(), hs.RK4(1e-2), log=["s.y", "i.y"], log_period=0.1).run(0.5)
    assert np.isinf(res["s.y"]).all() and res["i.y"][-1, 0] == pytest.approx(0.5)


def many_states(n):
    d = hs.Diagram("many")
    d.add(lookup("constant")("c", value=1.0))
    d.add(lookup("state_space")("ss", A=(-np.eye(n) * np.arange(1, n + 1)).tolist(), B=np.ones((n, 1)).tolist(),
                                C=np.ones((1, n)).tolist(), D=[[0.0]]))
    d.connect("c.y", "ss.u")
    return d.build()


def _many(path, n=200):
    system = many_states(n)
    res = hs.Simulator(system, hs.RK4(1e-3), log=["ss.y"], log_period=0.05, fused=path != "generic",
                       compiled=path == "compiled").run(0.5)
    exact = sum((1 - math.exp(-k * 0.5)) / k for k in range(1, n + 1))  # x_k' = -k x_k + 1
    assert res["ss.y"][-1, 0] == pytest.approx(exact, rel=1e-6)
    return res


DISCRETE = """
name: discrete_unstable
blocks:
  src: {type: step, time: 0.0}
  d: {type: discrete_state_space, A: [[1.5]], B: [[1.0]], C: [[1.0]], D: [[0.0]], rate: 100}
  n: {type: noise, rate: 1000, sigma: 0.0}
  c: {type: counter, rate: 1000}
wires: [src.y -> d.u]
simulation: {t_end: 1.0, max_state: 1.0e6}
log: [d.y, n.y, c.y]
"""


@pytest.mark.parametrize("path", ["generic", "fused"])  # compiled: tests/engine/test_compiled.py
def test_a_discrete_state_beyond_max_state_stops_the_run_but_a_count_does_not(tmp_path, path):
    """x[k+1] = 1.5 x[k] + 1 from 0 is 2 (1.5^k - 1): above 1e6 first at k = 33 (1.294e6), made by
    the update at the hit t = 0.32 s; the noise block's and the counter's counts (a thousand by then) are not bounded."""
    kw = {"generic": {"fused": False}, "fused": {}}[path]
    p = write(tmp_path, DISCRETE)
    with pytest.raises(SimulationError, match=r"t=0\.32 s: discrete state 0 of block 'd' is 1\.29e\+06"):
        hs.simulate(p, **kw)
    stable = write(tmp_path, DISCRETE.replace("[[1.5]]", "[[0.5]]").replace("1.0e6", "100.0"), "stable.yaml")
    r = hs.simulate(stable, **kw)
    assert r["c.y"][-1, 0] == 1000 and abs(r["d.y"][-1, 0] - 2.0) < 1e-9


@pytest.mark.parametrize("path", ["generic", "fused"])
def test_two_hundred_states(path):
    a, b = _many(path), _many("generic")
    assert np.array_equal(a.table(), b.table())


# 31 and more states stopped numba (a tuple display it did not take). The state-space block's
# A x is a dot product: numpy (BLAS) and numba sum it in different orders, so these agree to
# rounding, not bit for bit (the bit-for-bit tests use blocks written element by element)
@pytest.mark.slow
@pytest.mark.parametrize("n", [31, 200])
def test_many_states_compiled(n):
    """Past the 30 states numba's tuple handling stopped at: the compiled core holds states in
    arrays, whatever their number."""
    a, b = _many("compiled", n), _many("generic", n)
    assert np.allclose(a.table(), b.table(), rtol=1e-13, atol=1e-13)


@pytest.fixture(scope="module")
def plant_fmu(tmp_path_factory):
    from hybridsim.errors import FMUError
    from hybridsim.fmi.fmu_block import find_compiler
    from hybridsim.fmus.build import build_plant_fmu

    try:
        find_compiler()
    except FMUError:
        pytest.skip("no C compiler")
    return build_plant_fmu(tmp_path_factory.mktemp("fmu") / "plant.fmu")


@pytest.mark.slow
def test_implicit_solvers_run_an_me_fmu_next_to_sampled_blocks(plant_fmu):
    # Fig 9 with the plant as an ME FMU and the 120 Hz controller: a hit restarts the solver
    # (it failed with "required step size is less than spacing between numbers" at rtol 1e-10)
    kw = dict(fmu=str(plant_fmu), rtol=1e-10, atol=1e-12, t_end=0.06, rate=120)
    rk4 = hs.simulate(DIAGRAMS / "fig9_fmu_me.yaml", solver="rk4", **kw)
    runs = [hs.simulate(DIAGRAMS / "fig9_fmu_me.yaml", solver=s, **kw) for s in ("radau", "bdf", "lsoda")]
    for res in runs:
        assert np.max(np.abs(res["plant.q"] - rk4["plant.q"])) < 1e-7
        assert len(res.meta["events"]) == len(rk4.meta["events"]) == 1  # contact made once
        assert abs(res.meta["events"][0][0] - rk4.meta["events"][0][0]) < 1e-5  # rk4's 0.1 ms step
        assert abs(res.meta["events"][0][0] - runs[0].meta["events"][0][0]) < 1e-8


def test_check_refuses_for_the_compiled_path_with_the_reason_and_takes_many_states(tmp_path, capsys):
    n = 31
    A = (-np.eye(n)).tolist()
    text = (f"name: many\nblocks:\n  c: {{type: constant, value: 1.0}}\n"
            f"  ss: {{type: state_space, A: {A}, B: {np.ones((n, 1)).tolist()}, C: {np.ones((1, n)).tolist()}, "
            "D: [[0.0]]}\nwires: [c.y -> ss.u]\nsimulation: {t_end: 0.1}\nlog: [ss.y]\n")
    p = write(tmp_path, text)
    assert main(["check", str(p), "--set", "simulation.compiled=true"]) == 0  # 31 states: no limit
    code = main(["check", str(p), "--set", "simulation.compiled=true", "--set", "simulation.solver=radau"])
    _, err = capsys.readouterr()
    assert code == 2 and "compiled path integrates with a fixed-step Runge-Kutta" in err


@pytest.mark.parametrize("solver", ["radau", "bdf", "lsoda", "rk45", "rk23", "dop853", "cvode"])
def test_a_variable_step_solver_does_not_step_over_the_input_after_leaving_a_limit(solver, tmp_path):
    """x' = 2 sin(pi t), held at 0.5 from 0.431 s; it leaves at t = 1 s where the input is zero, and a
    first step chosen from f(1 s) = 0 alone spanned the whole next second (bdf kept x at 0.5, exit 0).
    Closed form after leaving: x = 0.5 - (2/pi)(1 + cos(pi t)), reaching -0.2 at t = 2 - acos(0.0996...)/pi."""
    import math

    import hybridsim as hs

    p = tmp_path / "lim.yaml"
    p.write_text("blocks:\n  src: {type: sine, amplitude: 1.0, frequency: 0.5}\n"
                 "  int: {type: integrator, K: 2.0, upper: 0.5, lower: -0.2}\n"
                 "wires: [src.y -> int.u]\n"
                 f"simulation: {{t_end: 1.7, solver: {solver}, log_period: 0.01}}\nlog: [int.y]\n")
    r = hs.simulate(str(p))
    times = [t for t, _ in r.meta["events"]]
    t_lower = 2.0 - math.acos(0.7 * math.pi / 2 - 1.0) / math.pi
    assert len(times) == 3 and abs(times[1] - 1.0) < 1e-9 and abs(times[2] - t_lower) < 1e-6, times
    assert abs(r.context.xc[0] + 0.2) < 1e-12


def test_check_refuses_a_block_too_large_for_the_compiled_glue(tmp_path, capsys):
    # a transport delay of 1000 buffer points holds 1003 states: numba takes tuples of < 1000 items.
    # check said OK and the run failed with "numba cannot compile the kernels"
    p = write(tmp_path, """
name: big
blocks:
  s: {type: sine}
  td: {type: transport_delay, delay: 0.1, buffer: 1000}
wires: [s.y -> td.u]
simulation: {t_end: 0.2, step: 1.0e-3, log_period: 0.01}
log: [td.y]
""")
    code = main(["check", str(p), "--set", "simulation.compiled=true"])
    _, err = capsys.readouterr()
    assert code == 2 and "fewer than 1000 items" in err and "td (transport_delay: 1003 continuous states)" in err
    assert main(["check", str(p)]) == 0  # the other paths take it


WRONG = '''
import math

import numpy as np
from hybridsim.engine.block import Block
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.engine.registry import register


@register("wrong_width")
class WrongWidth(Block):
    def __init__(self, name="w"):
        super().__init__(name)
        self.params = (1.0,)
        self.declare_input("u", 1)
        self.declare_output("y", 2)


@kernel
def wrong_output(p, t, x, u):
    return ((u[0][0],),)  # one element for a port of two


WrongWidth.kernels = Kernels(output=wrong_output)


@register("raising")
class Raising(Block):
    def __init__(self, name="r", limit=0.2):
        super().__init__(name)
        self.params = (float(limit),)
        self.declare_input("u", 1)
        self.declare_output("y", 1)


@kernel
def raising_output(p, t, x, u):
    if u[0][0] > p[0]:
        raise ValueError("input beyond the limit")
    return ((u[0][0],),)


Raising.kernels = Kernels(output=raising_output)


@register("factorial_past")
class FactorialPast(Raising):
    """Raising's ports and limit; its kernel fails in a math call, not by a raise."""


@kernel
def factorial_past_output(p, t, x, u):
    return ((math.factorial(u[0][0]) if u[0][0] > p[0] else 0.0,),)  # TypeError: not a whole number


FactorialPast.kernels = Kernels(output=factorial_past_output)
'''


@pytest.fixture
def odd_plugin(tmp_path, monkeypatch):
    (tmp_path / "oddblocks.py").write_text(WRONG)
    monkeypatch.syspath_prepend(str(tmp_path))
    return tmp_path


@pytest.mark.parametrize("path", ["generic", "fused", "compiled"])
def test_an_output_of_the_wrong_width_breaks_the_block_contract(odd_plugin, capsys, path):
    # a 1-element output for a 2-wide port passed the plugin check (it broadcasts): the generic path
    # spread it over both (exit 0), the fused one ended in an IndexError (exit 70), the compiled one
    # in numba's own words without the block
    p = write(odd_plugin, "blocks:\n  s: {type: ramp}\n  b: {type: wrong_width}\n"
                          "  d: {type: demux, widths: [1, 1]}\nwires: [s.y -> b.u, b.y -> d.u]\n"
                          "simulation: {t_end: 0.1}\nlog: [b.y]\n")
    sets = {"generic": ["--set", "simulation.fused=false"], "fused": [],
            "compiled": ["--set", "simulation.compiled=true"]}[path]
    code = main(["run", str(p), "--plugin", "oddblocks", "-q", "-o", str(odd_plugin / "out")] + sets)
    _, err = capsys.readouterr()
    assert code == 6 and "block 'b' (wrong_width): output 'y' returned shape (1,); the block declares width 2" in err


def test_a_kernel_that_raises_on_the_compiled_path_is_named_as_on_the_python_path(odd_plugin, capsys):
    # numba printed the exception as "ignored" (once per call: 53 tracebacks) and the run ended in
    # "simulation failed (status 2)"
    p = write(odd_plugin, "blocks:\n  s: {type: ramp}\n  b: {type: raising, limit: 0.2}\n"
                          "wires: [s.y -> b.u]\nsimulation: {t_end: 0.5, compiled: true}\nlog: [b.y]\n")
    code = main(["run", str(p), "--plugin", "oddblocks", "-q", "-o", str(odd_plugin / "out")])
    _, err = capsys.readouterr()
    assert code == 6 and "raised ValueError: input beyond the limit" in err
    assert "Traceback" not in err and "Exception ignored" not in err


@pytest.mark.parametrize("path", ["generic", "fused"])
def test_a_plugin_kernel_that_raises_where_it_is_written_in_place_is_the_plugins_fault(odd_plugin, capsys, path):
    # on the fused path the kernel's body runs inside the generated code: its error was "a bug in
    # hybridsim" (exit 70) with a traceback through that code
    p = write(odd_plugin, "blocks:\n  s: {type: ramp}\n  b: {type: factorial_past, limit: 0.2}\n  i: {type: integrator}\n"
                          "wires: [s.y -> b.u, b.y -> i.u]\nsimulation: {t_end: 0.5}\nlog: [i.y]\n")
    sets = {"generic": ["--set", "simulation.fused=false"], "fused": []}[path]
    code = main(["run", str(p), "--plugin", "oddblocks", "-q", "-o", str(odd_plugin / "out")] + sets)
    _, err = capsys.readouterr()
    assert code == 6 and "plugin 'oddblocks'" in err and "raised TypeError" in err
    assert "Traceback" not in err
    assert "block 'b' (factorial_past) raised" in err  # the kernel has no self: the block its caller ran
    if path == "fused":
        assert "written in place" in err


class _Spike(hs.Block):
    """NaN for 0.10549 <= t < 0.10551 (between RK4's step ends at h = 1 ms), declared possible."""
    may_be_nonfinite = True
    time_varying = True

    def __init__(self, name="spike"):
        super().__init__(name)
        self.params = ()
        self.declare_output("y", 1)

    def output(self, t, x, u):
        return (np.array([math.nan if 0.10549 <= t < 0.10551 else 1.0]),)


@pytest.mark.parametrize("fused", [False, True])
def test_a_state_gone_nan_from_a_value_never_seen_at_a_check_says_not_a_number(fused):
    # the spike reaches the integrator only at RK4's midpoint stage; no output at a checked point is
    # NaN, so no block can be named: it said only "the closed loop may be unstable"
    d = hs.Diagram("spike")
    d.add(_Spike("s"))
    d.add(lookup("gain")("g", K=2.0))
    d.add(lookup("integrator")("P"))
    d.connect("s.y", "g.u")
    d.connect("g.y", "P.u")
    with pytest.raises(SimulationError, match=r"diverged at t=0\.106 s: state 0 of block 'P' is nan .*Not a number: "
                                              r"a value it was computed from went NaN \(a block's output between"):
        hs.Simulator(d.build(), hs.RK4(1e-3), log=["P.y"], fused=fused).run(0.3)
