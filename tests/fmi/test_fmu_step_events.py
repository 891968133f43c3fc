"""Step events: completedIntegratorStep after every accepted step of a Model Exchange FMU.

The FMU (tests/data/stepev, C, FMI 2.0 ME, built during the tests) integrates x' = 1, counts its
fmi2CompletedIntegratorStep calls (output ``calls``) and, after a step ending with
x >= 0.5005, asks for event mode, where it resets x to 0 (output ``resets``). Oracles: the step
grid (rk4 at 1 ms: 1000 accepted steps a second, resets at the first grid point past the
threshold, 0.501 s and 1.002 s) and fmpy.simulate_fmu, which calls completedIntegratorStep after
each step of its fixed-step Euler (exact on x' = 1, as rk4 is) and at each output of its CVode.
"""
import numpy as np
import pytest
from fmpy import simulate_fmu

import hybridsim as hs
from hybridsim.engine.cvode import CVode
from hybridsim.errors import FMUError
from hybridsim.fmi.fmu_block import FMUBlock, build_fmu, find_compiler

from conftest import ROOT

T_END = 1.2
OUT = ["y", "calls", "resets"]


def _build(tmp_path_factory, name, xml, model="stepev"):
    try:
        find_compiler()
    except FMUError:
        pytest.skip("no C compiler")
    d = ROOT / "tests" / "data" / model
    return build_fmu(tmp_path_factory.mktemp(name) / f"{model}.fmu", model, sorted(d.glob("*.c")), xml, {})


@pytest.fixture(scope="module")
def stepev(tmp_path_factory):
    return _build(tmp_path_factory, "stepev", (ROOT / "tests" / "data" / "stepev" / "modelDescription.xml").read_text())


@pytest.fixture(scope="module")
def not_needed(tmp_path_factory):
    """The same FMU with completedIntegratorStepNotNeeded="true": it must never be called."""
    xml = (ROOT / "tests" / "data" / "stepev" / "modelDescription.xml").read_text()
    xml = xml.replace('<ModelExchange modelIdentifier="stepev"/>',
                      '<ModelExchange modelIdentifier="stepev" completedIntegratorStepNotNeeded="true"/>')
    return _build(tmp_path_factory, "stepev_nn", xml)


def run(fmu, solver, parameters=None):
    d = hs.Diagram("s")
    d.add(FMUBlock("s", path=str(fmu), mode="me", parameters=parameters))
    return hs.Simulator(d.build(), solver, log=[f"s.{o}" for o in OUT], log_period=1e-3).run(T_END)


def fmpy_run(fmu, solver):
    kw = {"step_size": 1e-3} if solver == "Euler" else {}
    return simulate_fmu(str(fmu), fmi_type="ModelExchange", solver=solver, output_interval=1e-3,
                        stop_time=T_END, output=OUT, **kw)


def after_events(r):
    """fmpy's rows without the pre-event row it records at an event (hybridsim logs the state
    after a step event at its time, as after a time event)."""
    keep = np.append(r["time"][1:] != r["time"][:-1], True)
    return r[keep]


def test_step_events_on_rk4_match_fmpy_euler_and_count_every_step(stepev):
    res = run(stepev, hs.RK4(1e-3))
    ref = after_events(fmpy_run(stepev, "Euler"))
    assert np.allclose(res.t, ref["time"], rtol=0, atol=1e-12)
    assert np.max(np.abs(res["s.y"][:, 0] - ref["y"])) < 1e-12
    assert [t for t, _ in res.meta["events"]] == pytest.approx([0.501, 1.002], abs=1e-12)
    assert res["s.resets"][-1, 0] == ref["resets"][-1] == 2
    # one call per accepted step: T_END / h of them (a step event adds none)
    assert res["s.calls"][-1, 0] == ref["calls"][-1] == round(T_END / 1e-3)


def test_cvode_calls_it_at_each_point_it_returns_as_fmpy_cvode(stepev):
    res = run(stepev, CVode())
    ref = fmpy_run(stepev, "CVode")
    assert res["s.calls"][-1, 0] == ref["calls"][-1] == round(T_END / 1e-3)  # the output points
    assert res["s.resets"][-1, 0] == ref["resets"][-1] == 2
    assert [t for t, _ in res.meta["events"]] == pytest.approx([0.501, 1.002], abs=1e-9)
    ref = after_events(ref)
    assert np.max(np.abs(res["s.y"][:, 0] - np.interp(res.t, ref["time"], ref["y"]))) < 1e-6


def test_a_scipy_solver_serves_the_step_event_after_the_step_that_crossed(stepev):
    res = run(stepev, hs.ScipySolver("RK45", max_step=0.01))
    times = [t for t, _ in res.meta["events"]]
    assert len(times) == 2 and 0.5005 < times[0] <= 0.5105
    assert np.max(res["s.y"]) < 0.5105  # reset within one step of the threshold
    k = np.searchsorted(res.t, times[0])
    assert res["s.y"][k, 0] == pytest.approx(res.t[k] - times[0], abs=1e-9)  # reset at the event
    assert res["s.calls"][-1, 0] >= T_END / 0.01  # at least one call per (max 10 ms) step


@pytest.mark.parametrize("solver", [lambda: hs.RK4(1e-3), CVode], ids=["rk4", "cvode"])
def test_an_fmu_that_does_not_need_it_is_never_called(not_needed, solver):
    res = run(not_needed, solver())
    ref = fmpy_run(not_needed, "Euler")
    assert res["s.calls"][-1, 0] == ref["calls"][-1] == 0
    assert res["s.resets"][-1, 0] == 0 and res.meta["events"] == []
    assert res["s.y"][-1, 0] == pytest.approx(T_END, abs=1e-9)


def test_terminate_simulation_from_it_ends_the_run_cleanly(stepev):
    res = run(stepev, hs.RK4(1e-3), parameters={"t_stop": 0.7005})
    assert res.meta["stopped"]["reason"] == "terminateSimulation"
    assert res.meta["stopped"]["block"] == "s"
    assert res.meta["t_end"] == pytest.approx(0.701, abs=1e-12)
    assert res.t[-1] == pytest.approx(0.7)
    # the last row is the FMU at 0.7 s, observed before the step that asked to stop: 700 steps done
    assert res["s.calls"][-1, 0] == 700


class Sawtooth(hs.Block):
    """x' = 1; its after_step counts the steps and asks for a step event at x >= 0.5005, whose
    action resets x (the FMU's behaviour, as a Python block)."""

    def __init__(self, name="saw"):
        super().__init__(name)
        self.declare_output("y", 1, depends_on=())
        self.declare_continuous_state(1)
        self.calls = []

    def initial_state(self, u=None):
        return np.zeros(1)

    def output(self, t, x, u):
        return (x,)

    def derivatives(self, t, x, u):
        return np.ones(1)

    def after_step(self, t, x, u):
        self.calls.append(t)
        return bool(x[0] >= 0.5005)

    def event_action(self, t, x, u, fired):
        return np.zeros(1)


@pytest.mark.parametrize("solver", [lambda: hs.RK4(1e-3), lambda: hs.Heun(1e-3)], ids=["rk4", "heun"])
def test_a_python_block_is_told_of_every_step_on_the_grid(solver):
    d = hs.Diagram("saw")
    saw = d.add(Sawtooth())
    res = hs.Simulator(d.build(), solver(), log=["saw.y"], log_period=1e-3).run(T_END)
    assert np.allclose(saw.calls, 1e-3 * np.arange(1, 1201), atol=1e-12)  # each step's end, once
    assert [t for t, _ in res.meta["events"]] == pytest.approx([0.501, 1.002], abs=1e-12)
    assert res["saw.y"][-1, 0] == pytest.approx(T_END - 1.002, abs=1e-12)


def test_diagrams_without_such_blocks_get_no_hook():
    class Plain(Sawtooth):
        after_step = None

    d = hs.Diagram("plain")
    d.add(Plain())
    sim = hs.Simulator(d.build(), hs.RK4(1e-3), log=["saw.y"])
    assert sim.system.after_step == []
    res = sim.run(1.0)
    assert res.meta["events"] == [] and res["saw.y"][-1, 0] == pytest.approx(1.0)


def test_an_fmi3_fmu_that_needs_it_is_called_through_fmi3CompletedIntegratorStep(tmp_path_factory):
    """tests/data/ball3 (FMI 3.0) declares nothing: not called; with needsCompletedIntegratorStep
    it is called after every step (its answer: no event), and the bounces are unchanged."""
    d = ROOT / "tests" / "data" / "ball3"
    xml = (d / "modelDescription.xml").read_text()
    fmus = [_build(tmp_path_factory, "ball3", xml, "ball3"),
            _build(tmp_path_factory, "ball3_needs", xml.replace(
                '<ModelExchange modelIdentifier="ball3"/>',
                '<ModelExchange modelIdentifier="ball3" needsCompletedIntegratorStep="true"/>'), "ball3")]
    runs, calls = [], []
    for fmu in fmus:
        block = FMUBlock("ball", path=str(fmu), mode="me")
        if block.has_after_step:
            real = block.after_step

            def counted(t, x, u):
                calls.append(t)
                return real(t, x, u)

            block.after_step = counted
        dg = hs.Diagram("b")
        dg.add(block)
        runs.append(hs.Simulator(dg.build(), hs.RK4(1e-3), log=["ball.height"]).run(1.0))
    assert not FMUBlock("b", path=str(fmus[0]), mode="me").has_after_step
    assert np.array_equal(runs[0]["ball.height"], runs[1]["ball.height"])
    bounces = [t for t, _ in runs[1].meta["events"] if abs(t - round(t)) > 1e-9]
    # every grid step and each located event's end: a bounce is one (the ball leaves it just above
    # the floor, in FMI's domain z > 0; at exactly 0 its leaving was a second event 1e-12 s later)
    assert len(calls) == 1000 + len(bounces)


@pytest.mark.parametrize("solver", ["rk4", "bdf", "cvode"])
@pytest.mark.parametrize("before", [1e-12, 0.0])
def test_an_fmus_time_event_is_taken_when_another_event_comes_just_before_it(tmp_path_factory, tmp_path,
                                                                          solver, before):
    # tests/data/ball counts up at t = 1 through nextEventTime; a relay on u = t fires 1e-12 s
    # before it (or at the same instant); the time event was then taken as already passed and
    # never acted on: count stayed 0 until the ball's next bounce, or for good
    fmu = _build(tmp_path_factory, "ball_te", (ROOT / "tests" / "data" / "ball" / "modelDescription.xml").read_text(),
                 "ball")
    path = tmp_path / "d.yaml"
    path.write_text(f"blocks:\n  b: {{type: fmu, path: {fmu}, mode: me}}\n"
                    "  tab: {type: table, times: [0.0, 2.0], values: [0.0, 2.0]}\n"
                    f"  r: {{type: relay, switch_on: {1.0 - before!r}, switch_off: 0.5}}\n"
                    "wires: [tab.y -> r.u]\n"
                    "simulation: {t_end: 1.06, step: 1.0e-3, log_period: 0.01}\nlog: [b.count, r.y]\n")
    res = hs.simulate(path, solver=solver)
    t, count = res.t, np.ravel(res["b.count"])
    assert np.all(count[t > 1.0] == 1.0) and np.all(count[t < 1.0 - 1e-9] == 0.0)
    assert np.ravel(res["r.y"])[-1] == 1.0
