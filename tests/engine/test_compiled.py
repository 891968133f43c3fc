"""The compiled path (numba) gives the generic path's numbers, bit for bit."""
import numpy as np
import pytest

import hybridsim as hs
from hybridsim.errors import CompiledPathError, SimulationError

from conftest import DIAGRAMS, ROOT, integrator_without_kernels
from hybridsim.engine.block import Block

SMOOTH = ROOT / "tests" / "data" / "smooth_contact.yaml"


@pytest.mark.parametrize("path, extra", [
    (DIAGRAMS / "fig9_force_and_position.yaml", {"rate": 120, "t_end": 0.4}),
    (DIAGRAMS / "fig8_receding_surface.yaml", {"t_end": 1.2}),
    (SMOOTH, {"log_period": 1 / 120}),
    (DIAGRAMS / "fig9_force_and_position.yaml", {"t_end": 0.3, "ctrl.pid.rate": 60, "ctrl.fpi.rate": 120,
                                                 "log_period": 0.0007}),
    (ROOT / "tests" / "data" / "every_kernel_block.yaml", {}),
    (ROOT / "tests" / "data" / "discrete_only.yaml", {}),
    (ROOT / "tests" / "data" / "library_blocks.yaml", {}),
    (ROOT / "tests" / "data" / "held_before_logged.yaml", {}),
], ids=["fig9-friction", "fig8-moving-surface", "damped-log-at-ticks", "fig9-two-rates-odd-log",
        "every-kernel-block", "discrete-only", "standard-library", "held-before-logged"])
@pytest.mark.slow
def test_compiled_equals_generic(path, extra):
    a = hs.simulate(path, compiled=True, **extra)
    b = hs.simulate(path, fused=False, **extra)
    assert np.array_equal(hs.simulate(path, **extra).table(), b.table())  # the fused path too
    assert np.array_equal(a.t, b.t)
    assert np.array_equal(a.table(), b.table())
    assert a.meta["hits"] == b.meta["hits"]
    # the context after the run holds the same final state and wire values
    assert np.array_equal(a.context.xc, b.context.xc)
    for ya, yb in zip(a.context.y, b.context.y):
        for va, vb in zip(ya, yb):
            assert np.array_equal(va, vb)


@pytest.mark.slow
def test_one_compiled_module_serves_other_parameter_values():
    from hybridsim.engine import compiled

    a = hs.build(SMOOTH, compiled=True)[1]._compiled
    b = hs.build(SMOOTH, compiled=True, **{"ctrl.fpi.Kp": [0.2, 0.1], "Kr": 1.0e6})[1]._compiled
    assert a.glue is b.glue  # params are arguments, not compiled-in constants
    assert a.source == b.source and a.run_fn is b.run_fn  # and the core is every diagram's
    assert compiled.cache_dir().is_dir()
    res = hs.simulate(SMOOTH, compiled=True, **{"ctrl.fpi.Kp": [0.2, 0.1]})
    ref = hs.simulate(SMOOTH, **{"ctrl.fpi.Kp": [0.2, 0.1]})
    assert np.array_equal(res.table(), ref.table())


@pytest.mark.slow
def test_divergence_is_reported_on_the_compiled_path():
    ov = {"ctrl.fpi.Kp": [400.0, 300.0], "max_state": 50.0}
    with pytest.raises(SimulationError, match=r"diverged at t=.* block '(arm|wrist)'") as generic:
        hs.simulate(SMOOTH, **ov)
    with pytest.raises(SimulationError, match=r"diverged at t=.* block '(arm|wrist)'") as comp:
        hs.simulate(SMOOTH, compiled=True, **ov)
    t = lambda e: float(str(e.value).split("t=")[1].split(" ")[0])  # noqa: E731
    assert t(comp) <= t(generic)  # checked at every log point, not only at hits


@pytest.mark.slow
def test_discrete_divergence_is_reported_on_the_compiled_path():
    path = ROOT / "tests" / "data" / "discrete_only.yaml"
    # the 50 Hz delay shows at its last hit (0.48 s) what it took at 0.46 s: 2 x cnt.y = 2 x 47
    assert hs.simulate(path, compiled=True)["d.y"][-1, 0] == 94.0
    # an infinite gain is refused up front (InputError); a huge one overflows at the counter's
    # first count (0.01 s): the gain's output is named there, before the delay (0.02 s) stores it
    with pytest.raises(SimulationError, match=r"block 'g' \(gain\) gave a non-finite output at t=0.01 s"):
        hs.simulate(path, compiled=True, max_state=1.7e308, **{"g.K": 1e308})
    # within max_state's default (1e6) the delay's state 1e308 stops the run at once
    with pytest.raises(SimulationError, match=r"t=0 s: discrete state 0 of block 'd' is 1e\+308"):
        hs.simulate(path, compiled=True, **{"g.K": 1e308})


@pytest.mark.slow
def test_compiled_path_says_what_it_cannot_compile():
    d = integrator_without_kernels()
    with pytest.raises(CompiledPathError, match=r"no kernels .*: f \(Integrator\)"):
        hs.Simulator(d.build(), compiled=True)
    with pytest.raises(CompiledPathError, match="fixed-step Runge-Kutta"):
        hs.build(SMOOTH, compiled=True, solver="radau")
    # a library block with kernels in some configurations only points at its help
    from hybridsim.engine.compiled import problems
    from hybridsim.engine.registry import lookup

    d = hs.Diagram("wide")
    d.add(lookup("constant")("c", value=[float(k) for k in range(9)]))
    d.add(lookup("demux")("dm", widths=[1] * 9))
    d.connect("c.y", "dm.u")
    why = problems(d.build(), hs.RK4(1e-3))
    assert len(why) == 1 and "in this configuration: dm (demux) (`hybridsim blocks demux` says which" in why[0]


@pytest.mark.slow
def test_a_kernel_numba_cannot_compile_is_named():
    from hybridsim.engine.kernels import Kernels, kernel

    def twice(v):  # a helper not marked @kernel: numba cannot call it
        return 2.0 * v

    @kernel
    def labelled_output(p, t, x, u):
        return ((twice(u[0][0]),),)

    class Labelled(Block):
        kernels = Kernels(output=labelled_output)

        def __init__(self, name):
            super().__init__(name)
            self.declare_input("u", 1)
            self.declare_output("y", 1)

    d = hs.Diagram("bad_kernel")
    d.add(hs.registry.lookup("constant")("c", value=1.0))
    d.add(Labelled("lab"))
    d.connect("c.y", "lab.u")
    with pytest.raises(CompiledPathError, match=r"numba cannot compile .* lab \(Labelled\): Untyped global name .twice."):
        hs.Simulator(d.build(), log=["lab.y"], compiled=True).run(0.01)


@pytest.mark.slow
def test_same_wiring_with_other_block_types_is_another_module():
    def diagram(kind, **params):
        d = hs.Diagram("shape")
        d.add(hs.registry.lookup("constant")("c", value=1.0))
        d.add(hs.registry.lookup(kind)("m", **params))
        d.add(hs.registry.lookup("lowpass")("f", cutoff=50.0))
        d.connect("c.y", "m.u")
        d.connect("m.y", "f.u")
        return d.build()

    gain = hs.Simulator(diagram("gain", K=3.0), log=["f.y"], compiled=True)
    sel = hs.Simulator(diagram("selection", S=[1]), log=["f.y"], compiled=True)
    assert gain._compiled.glue is not sel._compiled.glue
    assert gain._compiled.run_fn is sel._compiled.run_fn  # one core for every diagram
    assert gain.run(0.5)["f.y"][-1, 0] == pytest.approx(3.0, abs=1e-6)  # unity-gain filter of 3 u
    assert sel.run(0.5)["f.y"][-1, 0] == pytest.approx(1.0, abs=1e-6)   # of S u = u


def test_first_compile_is_announced_once(tmp_path, monkeypatch, caplog):
    from hybridsim.engine import compiled

    monkeypatch.setenv("HYBRIDSIM_CACHE", str(tmp_path))
    source = (f"# {tmp_path}\nimport math\n\n\n"
              "def hit(op, t, x, y, z, pf, pi, due, row):\n    return -1\n\n\n"
              "def rhs_params(pf, pi):\n    return ()\n\n\n"
              "def rhs_body(t, x, dx, at, y, z, PP):\n    dx[at] = -x[0]\n\n\n"
              "def rhs(t, x, dx, at, y, z, pf, pi):\n    dx[at] = -x[0]\n\n\n"
              "def steps(num, t_lim, x, xn, kk, xs, xm, y, z, pf, pi):\n    return t_lim\n\n\n"
              "def zc(t, x, g, y, z, pf, pi):\n    pass\n\n\n"
              "def act(t, x, xn, fired, y, z, pf, pi):\n    return 0\n\n\n"
              "def next_time(t, x, y, z, pf, pi):\n    return math.inf\n\n\n"
              "def timed(t, x, xn, y, z, pf, pi):\n    return 0\n\n\n"
              "def stepped(t, x, y, z, pf, pi):\n    return 0\n")
    with caplog.at_level("INFO", logger="hybridsim"):
        glue = compiled._load(source, {}, "tiny")
    assert glue.next_time.address  # a compiled first-class function
    assert "compiling 'tiny' with numba" in caplog.text
    assert len(list((tmp_path / "compiled").glob("glue_*.py"))) == 1
    caplog.clear()
    with caplog.at_level("INFO", logger="hybridsim"):
        compiled._loaded.clear()
        compiled._load(source, {}, "tiny")  # module file there: no announcement
    assert "compiling" not in caplog.text


def test_an_unwritable_cache_is_a_clear_error(tmp_path, monkeypatch):
    from hybridsim.engine import compiled

    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("HYBRIDSIM_CACHE", str(blocker))
    with pytest.raises(CompiledPathError, match="cannot write the compiled module .* HYBRIDSIM_CACHE"):
        compiled._load(f"# {tmp_path}\ndef run():\n    return 0\n", {}, "tiny")


@pytest.mark.slow
@pytest.mark.parametrize("model", ["stribeck", "lugre"])
def test_friction_models_run_identically_on_every_path(model):
    ov = {"t_end": 0.8, "arm.friction_model": model}
    generic = hs.simulate(DIAGRAMS / "fig10_force_ramp.yaml", fused=False, **ov)
    assert np.array_equal(hs.simulate(DIAGRAMS / "fig10_force_ramp.yaml", **ov).table(), generic.table())
    assert np.array_equal(hs.simulate(DIAGRAMS / "fig10_force_ramp.yaml", compiled=True, **ov).table(),
                          generic.table())


@pytest.mark.slow
def test_a_matrix_product_agrees_to_round_off(tmp_path):
    # numpy's and numba's BLAS sum the four terms of C x in different orders (docs/semantics.md)
    path = tmp_path / "ss4.yaml"
    path.write_text("blocks:\n  r: {type: sine, frequency: 3.0}\n"
                    "  ss: {type: state_space, A: [[-1.0, 0.5, 0, 0], [-0.5, -1.1, 0.5, 0], [0, -0.5, -1.2, 0.5],"
                    " [0, 0, -0.5, -1.3]], B: [[1.0], [0], [0], [0]], C: [[1.0, 1.0, 1.0, 1.0]]}\n"
                    "wires: [r.y -> ss.u]\nsimulation: {t_end: 1.0, step: 1.0e-3, log_period: 0.01}\nlog: [ss.y]\n")
    a, b = hs.simulate(path, compiled=True)["ss.y"], hs.simulate(path, fused=False)["ss.y"]
    assert np.max(np.abs(a - b)) <= 1e-15 * np.max(np.abs(b))


def test_a_compiled_context_starts_and_ends_as_the_generic_one():
    path = DIAGRAMS / "fig9_force_and_position.yaml"
    _, sim, _ = hs.build(path, compiled=True, t_end=0.05)
    _, gen, _ = hs.build(path, fused=False, t_end=0.05)
    a, numbers = sim._context({"ctrl.fpi.Kp": [0.5, 0.3]})  # the wrist's start needs the provisional outputs
    b = gen.system.create_context({"ctrl.fpi.Kp": [0.5, 0.3]})
    for x, y in ((a.xc, b.xc), (a.ywire, b.ywire), (a.z, b.z)):
        assert np.array_equal(x, y)
    # a non-finite output stops the glue's pass: the blocks then compute them, as the generic path does
    a.xc[:] = np.nan
    assert not sim._compiled.evaluate(numbers, 0.0, a)
    a.xc[:] = b.xc
    assert sim._compiled.evaluate(numbers, 0.0, a)


@pytest.mark.slow
def test_a_long_output_pass_is_compiled_in_parts_and_gives_the_same_numbers(tmp_path):
    # the hit's output pass in two functions (codegen.HIT_PART); one function of 120 blocks took
    # numba 100 s, growing with the square of its length
    from hybridsim.engine.codegen import HIT_PART

    n = HIT_PART + 4
    blocks = ["  src: {type: sine, frequency: 3.0}", "  hold: {type: zoh, rate: 50}"]
    wires = ["src.y -> hold.u", "hold.y -> g0.u"]
    for k in range(n):
        blocks.append(f"  g{k}: {{type: gain, K: {1.0 + 0.001 * k}}}")
        if k:
            wires.append(f"g{k - 1}.y -> g{k}.u")
    blocks.append("  i: {type: integrator}")
    wires += [f"g{n - 1}.y -> i.u"]
    f = tmp_path / "long.yaml"
    f.write_text("name: long\nblocks:\n" + "\n".join(blocks) + "\nwires: [" + ", ".join(wires) + "]\n"
                 f"log: [i.y, g{n - 1}.y]\nsimulation: {{t_end: 0.3, step: 1.0e-3, log_period: 0.0037}}\n")
    _, sim, _ = hs.build(f, **{"simulation.compiled": True})
    assert "def hit_part1(" in sim._compiled.source
    a = sim.run(0.3)
    b = hs.simulate(f, fused=False)
    assert np.array_equal(a.table(), b.table()) and a.table()[-1, 1] != 0.0


@pytest.mark.slow
def test_many_located_blocks_are_compiled_in_parts_and_give_the_same_events(tmp_path):
    # 17 limited integrators on cosines: the event functions and actions in parts reading the path's
    # outputs from y (one function of 40 such blocks took numba 24 s, growing with its square); the
    # right-hand side of the Runge-Kutta steps likewise, its outputs stored in y by one part for the next
    import math

    blocks, wires = [], []
    for k in range(17):
        f = 1.0 + 0.01 * k
        a = 0.6 / (2 * math.pi * f)
        blocks += [f"  s{k}: {{type: cosine, frequency: {f}}}", f"  I{k}: {{type: integrator, upper: {a}, lower: {-a}}}"]
        wires.append(f"s{k}.y -> I{k}.u")
    p = tmp_path / "limits.yaml"
    p.write_text("name: limits\nblocks:\n" + "\n".join(blocks) + "\nwires: [" + ", ".join(wires) + "]\n"
                 "log: [I0.y, I16.y]\nsimulation: {t_end: 1.0, step: 1.0e-3, log_period: 0.01}\n")
    _, sim, _ = hs.build(p, **{"simulation.compiled": True})
    assert "def zc_part0(" in sim._compiled.source and "def act_part0(" in sim._compiled.source
    assert "def rhs_part1(" in sim._compiled.source  # the right-hand side of the steps in parts too
    a = sim.run(1.0)
    b = hs.simulate(p, fused=False)
    assert np.array_equal(a.table(), b.table())
    assert a.meta["events"] == b.meta["events"] and len(a.meta["events"]) >= 34
