"""CVODE (hybridsim.engine.cvode) against closed forms, scipy's stiff solvers and fmpy's CVode.

Oracles: the exponential solution of a stiff linear system (eigenvalues -1 and -1000),
the bounce times of a ball (t1 = sqrt(2 h0 / g), each later flight 2 e^k t1), and
fmpy.simulate_fmu with its own CVode on the exported plant FMU (Model Exchange).
"""
import math

import numpy as np
import pytest

import hybridsim as hs
from hybridsim.engine.cvode import CVode
from hybridsim.errors import SimulationError

from conftest import ROOT

DIAGRAMS = ROOT / "diagrams"

# x' = A x, x(0) = (1, 0): x1 = 2 e^-t - e^-1000t, x2 = -e^-t + e^-1000t
A = np.array([[998.0, 1998.0], [-999.0, -1999.0]])


def exact(t):
    t = np.asarray(t, float)
    return np.stack([2 * np.exp(-t) - np.exp(-1000 * t), -np.exp(-t) + np.exp(-1000 * t)], axis=-1)


def test_stiff_linear_system_matches_the_closed_form_and_scipys_stiff_solvers():
    f = lambda t, x: A @ x  # noqa: E731
    t_out = np.linspace(0.001, 1.9, 40)
    got = {}
    for name, solver in (("cvode", CVode(rtol=1e-10, atol=1e-12)),
                         ("bdf", hs.ScipySolver("BDF", rtol=1e-10, atol=1e-12)),
                         ("radau", hs.ScipySolver("Radau", rtol=1e-10, atol=1e-12))):
        x1, outs = solver.advance(f, 0.0, 2.0, np.array([1.0, 0.0]), t_out)
        got[name] = np.vstack(outs + [x1])
    want = np.vstack([exact(t_out), exact(2.0)])
    for name, x in got.items():
        assert np.max(np.abs(x - want)) < 1e-8, name
    assert np.max(np.abs(got["cvode"] - got["radau"])) < 1e-8


def test_stiff_system_in_a_diagram_through_the_file_settings():
    import control

    d = hs.Diagram("stiff")
    d.add(hs.from_control(control.ss(A, np.zeros((2, 1)), np.eye(2), np.zeros((2, 1))), "plant", x0=[1.0, 0.0]))
    from hybridsim.blocks.sources.basic import Constant

    d.add(Constant("zero", [0.0]))
    d.connect("zero.y", "plant.u")
    res = hs.Simulator(d.build(), CVode(rtol=1e-10, atol=1e-12), log=["plant.y"], log_period=0.01).run(1.0)
    assert np.max(np.abs(res["plant.y"] - exact(res.t))) < 1e-8
    assert "CVode(BDF" in res.meta["solver"]


def bounce_times(n, h0=1.0, e=0.8, g=9.81):
    t1 = math.sqrt(2 * h0 / g)
    return [t1 + sum(2 * e ** k * t1 for k in range(1, m + 1)) for m in range(n)]


def test_bouncing_ball_bounces_at_the_closed_form_times():
    res = hs.simulate(DIAGRAMS / "bouncing_ball.yaml", solver="cvode", rtol=1e-12, atol=1e-12, t_end=3.5)
    times = [t for t, _ in res.meta["events"]]
    want = bounce_times(len(times))
    assert len(times) >= 5
    assert np.max(np.abs(np.array(times) - want)) < 1e-9
    # the logged height never goes below the floor: each bounce is a located stop
    assert res["ball.h"].min() > -1e-9


def test_restart_only_switch_is_never_stepped_across():
    # x' = 1 until x = 0.5, then x' = 0 (a hard stop): the crossing restarts CVODE at it, so
    # x(1) is 0.5 to round-off; stepped across (no event function) it ends far past it
    f = lambda t, x: np.array([1.0 if x[0] < 0.5 else 0.0])  # noqa: E731
    switch = lambda t, x: np.array([x[0] - 0.5])  # noqa: E731
    x1, _ = CVode(rtol=1e-6, atol=1e-8).advance(f, 0.0, 1.0, np.zeros(1), (), switch)
    assert abs(x1[0] - 0.5) < 1e-9
    x1, _ = CVode(rtol=1e-6, atol=1e-8).advance(f, 0.0, 1.0, np.zeros(1), (), None)
    assert abs(x1[0] - 0.5) > 1e-3


def test_a_failing_right_hand_side_is_a_simulation_error():
    with pytest.raises(SimulationError, match="cvode"):
        CVode(rtol=1e-8).advance(lambda t, x: np.array([x[0] ** 2 * 1e6]), 0.0, 1.0, np.array([1.0]))


def test_a_singularity_fails_at_once_at_a_step_that_cannot_move_t(tmp_path):
    # y' = 1 / (t - 0.5): CVODE crawled toward 0.5 in steps of float spacings until max_num_steps
    # (77 s); a step of a few spacings of t is now its minimum, and the run fails there
    f = tmp_path / "sing.yaml"
    f.write_text("blocks:\n  c: {type: clock}\n  h: {type: constant, value: 0.5}\n  one: {type: constant, value: 1.0}\n"
                 "  d: {type: sum, signs: '+-'}\n  p: {type: product, ops: '*/'}\n  i: {type: integrator}\n"
                 "wires: [c.y -> d.u1, h.y -> d.u2, one.y -> p.u1, d.y -> p.u2, p.y -> i.u]\n"
                 "simulation: {t_end: 1.0, solver: cvode, log_period: 0.01}\nlog: [i.y]\n")
    with pytest.raises(SimulationError, match="min step"):
        hs.simulate(f)


@pytest.fixture(scope="module")
def plant(tmp_path_factory):
    from hybridsim.fmus.build import build_plant_fmu

    return build_plant_fmu(tmp_path_factory.mktemp("fmu") / "plant.fmu")


def open_loop(fmu, rtol, t_end=0.5, tau=(8.0, 20.0)):
    """The plant FMU (Model Exchange) alone, constant torques: hybridsim with CVODE."""
    from hybridsim.blocks.sources.basic import Constant
    from hybridsim.fmi.fmu_block import FMUBlock

    d = hs.Diagram("open_loop")
    d.add(FMUBlock("plant", path=str(fmu), mode="me", parameters=OPEN_LOOP))
    for name, value in (("tau", list(tau)), ("xs", [0.5]), ("vs", [0.0])):
        d.add(Constant(name, value))
    d.connect("tau.y", "plant.tau")
    d.connect("xs.y", "plant.x_surface")
    d.connect("vs.y", "plant.v_surface")
    # fmpy's CVode: absolute tolerances rtol times the states' nominals (all 1 here)
    return hs.Simulator(d.build(), CVode(rtol=rtol, atol=rtol), log=["plant.q", "plant.F"],
                        log_period=0.001).run(t_end)


OPEN_LOOP = {"balance": 1, "preload": 10.0, "surface_x0": 0.5}


def fmpy_open_loop(fmu, rtol, t_end=0.5, tau=(8.0, 20.0)):
    import fmpy

    return fmpy.simulate_fmu(str(fmu), fmi_type="ModelExchange", solver="CVode", relative_tolerance=rtol,
                             stop_time=t_end, output_interval=0.001, output=["q[1]", "q[2]", "F[1]"],
                             start_values={**OPEN_LOOP, "tau[1]": tau[0], "tau[2]": tau[1]})


@pytest.mark.parametrize("rtol", [1e-6, 1e-9])
def test_plant_me_fmu_matches_fmpys_cvode_within_the_tolerances(plant, rtol):
    ours, ref = open_loop(plant, rtol), fmpy_open_loop(plant, rtol)
    # the joint angles agree to a few rtol (both control the local error only); the hand slides
    # along the surface and joint 2 moves out: a trajectory that is not a rest state
    assert abs(ours["plant.q[1]"][-1] - ours["plant.q[1]"][0]) > 1e-3
    for k, name in ((0, "q[1]"), (1, "q[2]")):
        want = np.interp(ours.t, ref["time"], ref[name])
        assert np.max(np.abs(ours[f"plant.q[{k}]"] - want)) < 50 * rtol, name
    assert abs(ours["plant.q[1]"][-1] - ref["q[2]"][-1]) < 50 * rtol
    # the contact force: 8e5 N/m of wrist spring on a 50-rtol position error
    f_err = np.abs(ours["plant.F[0]"] - np.interp(ours.t, ref["time"], ref["F[1]"]))
    assert np.median(f_err) < 8e5 * 50 * rtol


@pytest.mark.slow
def test_fig9_with_the_me_plant_converges_under_cvode_to_the_python_plant(plant):
    common = dict(fmu=str(plant), rate=120, t_end=0.3, solver="cvode")
    loose = hs.simulate(DIAGRAMS / "fig9_fmu_me.yaml", rtol=1e-8, **common)
    tight = hs.simulate(DIAGRAMS / "fig9_fmu_me.yaml", rtol=1e-10, **common)
    assert tight.meta["solver"].startswith("CVode") and len(tight.meta["events"]) >= 5  # stick-slip
    cf = tight["ctrl.ft.CF[0]"]
    assert np.max(np.abs(loose["ctrl.ft.CF[0]"] - cf)) < 1e-2  # measured 8e-4 N
    # the same plant in Python blocks (its switches restart CVODE): the sampled force, ~37 N at most
    py = hs.simulate(DIAGRAMS / "fig9_force_and_position.yaml", rate=120, t_end=0.3, solver="cvode", rtol=1e-10)
    assert np.max(np.abs(py["ctrl.ft.CF[0]"] - cf)) < 5e-2  # measured 1.6e-2 N


def test_me_fmu_ball_bounces_at_the_closed_form_times_under_cvode(tmp_path):
    # tests/data/ball: restitution 0.7, dropped from 1 m, an FMU event (event mode) at each bounce
    from hybridsim.fmi.fmu_block import FMUBlock, build_fmu

    d = ROOT / "tests" / "data" / "ball"
    fmu = build_fmu(tmp_path / "ball.fmu", "ball", sorted(d.glob("*.c")), (d / "modelDescription.xml").read_text(), {})
    diagram = hs.Diagram("ball")
    diagram.add(FMUBlock("ball", path=str(fmu), mode="me"))
    res = hs.Simulator(diagram.build(), CVode(rtol=1e-12, atol=1e-12), log=["ball.height"],
                       log_period=1e-3).run(2.4)
    bounces = []
    for t, _ in res.meta["events"]:  # state events: not the stair counter's whole seconds
        if abs(t - round(t)) > 1e-9 and (not bounces or t - bounces[-1] > 1e-6):
            bounces.append(t)
    want = bounce_times(6, e=0.7)
    assert np.max(np.abs(np.array(bounces[:6]) - want)) < 1e-9


def test_a_segment_in_one_call_gives_the_states_of_the_step_by_step_path():
    # without blocks told of every step CVODE runs a stretch's log times in one scikit-sundae call;
    # with one it returns to Python at each point: the same CVODE steps, the same numbers to the bit
    from hybridsim.blocks.continuous.bouncing import BouncingBall

    class ToldBall(BouncingBall):
        def after_step(self, t, x, u):
            return False  # told of every step, asks for nothing

    res = {}
    for cls in (BouncingBall, ToldBall):
        d = hs.Diagram("ball")
        d.add(cls("ball"))
        res[cls] = hs.Simulator(d.build(), CVode(rtol=1e-8, atol=1e-10), log=["ball.h"], log_period=0.002).run(2.0)
    fast, slow = res[BouncingBall], res[ToldBall]
    assert len(fast.meta["events"]) >= 3
    assert fast.meta["events"] == slow.meta["events"]
    assert np.array_equal(fast["ball.h"], slow["ball.h"])


def test_more_log_times_in_one_interval_than_restarts():
    t_out = np.linspace(5e-5, 1 - 5e-5, 20_000)  # no sample hit between: one CVODE segment
    x1, outs = CVode(rtol=1e-9, atol=1e-12).advance(lambda t, x: -x, 0.0, 1.0, np.ones(1), t_out)
    assert len(outs) == 20_000
    assert np.max(np.abs(np.ravel(outs) - np.exp(-t_out))) < 1e-8 and abs(x1[0] - math.exp(-1)) < 1e-8


@pytest.mark.parametrize("where", ["rhs", "events"])
def test_a_callback_error_comes_after_the_checks_of_the_points_before_it(where):
    # x = 10 t; the block fails past t = 0.6, the divergence check at x > 5 (the log time 0.55):
    # CVODE runs the stretch in one call, and the points before the failure are checked first
    from hybridsim.engine.block import Block

    class Ramp(Block):
        def __init__(self, name="r"):
            super().__init__(name)
            self.declare_continuous_state(1)
            self.declare_output("y", 1, depends_on=())

        def output(self, t, x, u):
            return (x,)

        def derivatives(self, t, x, u):
            if where == "rhs" and t > 0.6:
                raise ValueError(f"rhs failed at t={t:g}")
            return [10.0]

        def zero_crossings(self, t, x, u):
            if where == "events" and t > 0.6:
                raise ValueError(f"event function failed at t={t:g}")
            return [x[0] + 1.0]  # never crosses

        def event_action(self, t, x, u, fired):
            return x

    def run(**kw):
        d = hs.Diagram("ramp")
        d.add(Ramp())
        return hs.Simulator(d.build(), CVode(rtol=1e-8), log=["r.y"], log_period=0.05, **kw).run(1.0)

    with pytest.raises(SimulationError, match="diverged at t=0.55"):
        run(max_state=5.0)
    with pytest.raises(ValueError, match=f"{where.replace('events', 'event function')} failed"):
        run()  # no divergence: the block's own error, not CVODE's failure after it


@pytest.mark.slow
def test_me_fmu_diagram_checks_and_runs_from_the_cli_on_cvode_and_on_a_scipy_solver(plant, tmp_path, capsys):
    from hybridsim.app.cli import main

    q = {}
    for solver in ("cvode", "bdf"):
        common = [str(DIAGRAMS / "fig9_fmu_me.yaml"), "--set", f"fmu={plant}", "--set", f"simulation.solver={solver}"]
        assert main(["check", *common]) == 0
        out = tmp_path / solver
        assert main(["run", *common, "--set", "simulation.t_end=0.005", "--set", "rate=120", "-q",
                     "-o", str(out)]) == 0
        table = np.genfromtxt(out / "fig9_fmu_me.csv", delimiter=",", names=True)
        q[solver] = table["plantq1"]
    assert "Traceback" not in "".join(capsys.readouterr())
    assert len(q["cvode"]) == len(q["bdf"]) == 11 and np.max(np.abs(q["cvode"] - q["bdf"])) < 1e-6


def test_repeated_log_times_are_each_logged():
    t_out = [0.25, 0.5, 0.5, 0.75]  # not a valid span for one CVODE call: taken one at a time
    x1, outs = CVode(rtol=1e-10, atol=1e-12).advance(lambda t, x: -x, 0.0, 1.0, np.ones(1), t_out)
    assert len(outs) == 4 and outs[1][0] == outs[2][0]
    assert np.max(np.abs(np.ravel(outs) - np.exp(-np.array(t_out)))) < 1e-8


def _dead_zone_crossing():
    # sin(2 pi t) through a dead zone of +-0.5: the hit_crossing's function sits exactly on 0 from
    # the start and leaves it rising at t = 1/12 s; CVODE leaves such a function out of its search
    from hybridsim.engine.registry import lookup

    d = hs.Diagram("dz")
    d.add(lookup("sine")("s", frequency=1.0))
    d.add(lookup("dead_zone")("dz", lower=-0.5, upper=0.5))
    d.add(lookup("hit_crossing")("h", direction="rising"))
    d.connect("s.y", "dz.u")
    d.connect("dz.y", "h.u")
    return d.build()


def test_a_function_leaving_zero_is_located_as_on_rk4():
    # CVODE leaves a function that starts on 0 out of its search: it ran on with 0 events, then
    # stopped saying it stepped over a crossing; g -+ 1e-300 searched in its place locate where it
    # leaves (the hit_crossing follows its input leaving 0 both ways as events: 1/12 up, 7/12 down)
    for solver in (hs.RK4(1e-3), CVode()):
        res = hs.Simulator(_dead_zone_crossing(), solver, log=["h.count"], log_period=0.01).run(1.0)
        assert np.allclose([t for t, _ in res.meta["events"]], [1 / 12, 7 / 12], rtol=0, atol=1e-9)


def test_a_crossing_just_before_a_hit_fires_after_it_as_on_rk4():
    # rising zeros of the sine 5e-13 s before each hit of a 1 Hz zoh: within the core's time
    # tolerance, so each fires just after its hit. CVODE's stop there lost every one (0 events,
    # exit 0) and integrated the interval again from its start
    from hybridsim.engine.registry import lookup

    def diagram():
        d = hs.Diagram("defer")
        d.add(lookup("sine")("s", frequency=1.0, phase=2 * math.pi * 5e-13))
        d.add(lookup("hit_crossing")("h", direction="rising"))
        d.add(lookup("zoh")("z", rate=1.0))
        d.connect("s.y", "h.u")
        d.connect("s.y", "z.u")
        return d.build()

    runs = {name: hs.Simulator(diagram(), solver, log=["h.count"], log_period=0.01).run(3.5)
            for name, solver in (("rk4", hs.RK4(1e-3)), ("cvode", CVode()))}
    assert runs["cvode"]["h.count"][-1, 0] == runs["rk4"]["h.count"][-1, 0] == 3
    assert np.all(np.diff(runs["cvode"].t) > 0)
    assert [round(t, 9) for t, _ in runs["cvode"].meta["events"]] == [round(t, 9) for t, _ in runs["rk4"].meta["events"]]


def test_the_core_compares_event_functions_only_where_cvode_did_not(monkeypatch):
    # past an integration's first point CVODE's own search covered every point it returned: the
    # core compares the functions at the first points after each start (and while one sits on 0),
    # not at each of the 2000 log points
    from hybridsim.engine import stepping
    from hybridsim.engine.registry import lookup

    d = hs.Diagram("limited")
    d.add(lookup("cosine")("u", amplitude=1.0, frequency=1.0))
    d.add(lookup("integrator")("i", K=10.0, upper=0.5))
    d.connect("u.y", "i.u")
    calls = []
    real = stepping.first_sign_change
    monkeypatch.setattr(stepping, "first_sign_change", lambda a, b, dirs: calls.append(1) or real(a, b, dirs))
    res = hs.Simulator(d.build(), CVode(), log=["i.y"], log_period=0.0005).run(1.0)
    assert [round(t, 9) for t, _ in res.meta["events"]] == [0.050861297, 0.25]  # reach, leave (closed form)
    assert res.t.size == 2001 and 0 < len(calls) < 50


def test_a_flat_function_leaving_zero_after_another_ones_event_is_not_lost():
    # the dead zone's crossing function as above, beside a hit_crossing on the sine itself, whose event
    # at the start restarted CVODE: the flat function, zero rate at that start, left 0 before CVODE's
    # first point and every one of its crossings was lost (counts 0, exit 0)
    from hybridsim.engine.registry import lookup

    d = hs.Diagram("dz2")
    d.add(lookup("sine")("s", frequency=1.0))
    d.add(lookup("dead_zone")("dz", lower=-0.5, upper=0.5))
    d.add(lookup("hit_crossing")("h"))
    d.add(lookup("hit_crossing")("hx"))
    for a, b in (("s.y", "dz.u"), ("dz.y", "h.u"), ("s.y", "hx.u")):
        d.connect(a, b)
    res = hs.Simulator(d.build(), CVode(), log=["h.count"], log_period=0.1).run(2.2)
    assert res["h.count"][-1, 0] == 4


@pytest.mark.parametrize("other", ["hit_crossing", "relay"])
def test_a_flat_function_leaving_zero_at_another_ones_crossing_fires_with_it(other):
    # a dead zone's output sits on 0 and leaves it at the very instant cos(2 pi t) crosses +-0.5, where
    # another block's function crosses: CVODE reported that root only, and every crossing of the
    # hit_crossings on the dead zone was lost (counts 0, exit 0); RK4 finds one at each of 1/3, 5/6,
    # 4/3 and 11/6 s
    from hybridsim.engine.registry import lookup

    def diagram():
        d = hs.Diagram("coincide")
        d.add(lookup("cosine")("s", frequency=1.0))
        d.add(lookup("dead_zone")("dz", lower=-0.5, upper=0.5))
        d.add(lookup("hit_crossing")("he", direction="falling"))
        d.add(lookup("hit_crossing")("hr", direction="rising"))
        if other == "relay":
            d.add(lookup("relay")("o", switch_on=0.5, switch_off=-0.5))
            d.connect("s.y", "o.u")
        else:
            d.add(lookup("hit_crossing")("o", offset=[0.5, -0.5], width=2))
            d.add(lookup("mux")("m", widths=[1, 1]))
            d.connect("s.y", "m.u1")
            d.connect("s.y", "m.u2")
            d.connect("m.y", "o.u")
        for a, b in (("s.y", "dz.u"), ("dz.y", "he.u"), ("dz.y", "hr.u")):
            d.connect(a, b)
        return d.build()

    runs = {name: hs.Simulator(diagram(), solver, log=["he.count", "hr.count", "he.time", "hr.time"],
                               log_period=0.1).run(2.2) for name, solver in (("rk4", hs.RK4(1e-3)), ("cvode", CVode()))}
    for r in runs.values():
        assert r["he.count"][-1, 0] == r["hr.count"][-1, 0] == 2
        assert abs(r["he.time"][-1, 0] - 4 / 3) < 1e-9 and abs(r["hr.time"][-1, 0] - 11 / 6) < 1e-9


PID_ON_ITS_LIMIT = """blocks:
  sp: {type: SETPOINT}
  y0: {type: constant, value: 0.0}
  z: {type: zoh, rate: 100}
  pid: {type: pid, Kp: 0.5, Ki: 2.0, upper: 1.5}
  it: {type: integrator}
wires: [sp.y -> pid.r, y0.y -> z.u, z.y -> pid.y, pid.u -> it.u]
simulation: {t_end: T_END, solver: cvode, log_period: 0.01}
log: [it.y]
"""


@pytest.mark.parametrize("setpoint, t_end", [("constant, value: 3.0", 0.3),
                                              ("step, initial: 0.0, final: 3.0, time: 0.2", 0.4)])
def test_a_pid_held_exactly_at_its_limit_does_not_hang_cvode(tmp_path, setpoint, t_end):
    # Kp r = 1.5 = upper: the PID's switch reached its surface and CVODE restarted every 3e-14 s, no event
    # counted, for ever (from t = 0, or from a setpoint jump at a sample hit); now muted after 20 restarts
    import signal

    def hang(signum, frame):
        raise TimeoutError("the run hangs")

    p = tmp_path / "d.yaml"
    p.write_text(PID_ON_ITS_LIMIT.replace("SETPOINT", setpoint).replace("T_END", str(t_end)))
    old = signal.signal(signal.SIGALRM, hang)
    signal.alarm(60)
    try:
        res = hs.simulate(p)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    held = t_end - (0.2 if "step" in setpoint else 0.0)
    assert res["it.y"][-1, 0] == pytest.approx(1.5 * held, abs=1e-6)  # u = 1.5 while r = 3
