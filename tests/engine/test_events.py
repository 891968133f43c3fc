"""State events with resets, time events, event iteration, Zeno: on every solver and path."""
import math

import numpy as np
import pytest

import hybridsim as hs
from hybridsim.engine.block import Block
from hybridsim.errors import CompiledPathError, SimulationError
from hybridsim.engine.registry import lookup

G, E, H0 = 9.81, 0.8, 1.0
T1 = math.sqrt(2 * H0 / G)
BOUNCES = [T1 + sum(2 * E ** k * G * T1 / G for k in range(1, m + 1)) for m in range(10)]
ZENO = T1 * (1 + E) / (1 - E)  # 4.0637 s

PATHS = {
    "rk4-generic": (lambda: hs.RK4(1e-3), {"fused": False}),
    "rk4-fused": (lambda: hs.RK4(1e-3), {}),
    "rk4-compiled": (lambda: hs.RK4(1e-3), {"compiled": True}),
    "heun-generic": (lambda: hs.Heun(1e-4), {"fused": False}),
    "heun-compiled": (lambda: hs.Heun(1e-4), {"compiled": True}),
    **{m.lower(): (lambda m=m: hs.ScipySolver(m, rtol=1e-10, atol=1e-12), {})
       for m in ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")},
}


#: rk4 and heun on the generic, fused and compiled paths (arguments ``solver`` and ``path``)
def on_fixed_step_paths(test):
    paths = pytest.mark.parametrize("path", [{"fused": False}, {}, {"compiled": True}],
                                    ids=["generic", "fused", "compiled"])
    return paths(pytest.mark.parametrize("solver", ["rk4", "heun"])(test))


def ball(solver, log_period=0.01, **kw):
    d = hs.Diagram("ball")
    d.add(lookup("bouncing_ball")("ball", g=G, e=E, h0=H0))
    return hs.Simulator(d.build(), solver, log=["ball.h", "ball.v"], log_period=log_period, **kw)


@pytest.mark.parametrize("name", list(PATHS))
def test_bouncing_ball_hits_the_closed_form_bounce_times(name):
    make, kw = PATHS[name]
    res = ball(make(), **kw).run(3.9)
    times = [t for t, _ in res.meta["events"]][:10]
    assert np.max(np.abs(np.array(times) - BOUNCES)) < 1e-9
    assert all(names == ("ball",) for _, names in res.meta["events"])
    assert res["ball.h"].min() > -1e-9  # never through the floor


@pytest.mark.parametrize("name", ["rk4-generic", "rk4-fused", "rk4-compiled", "radau"])
def test_a_zeno_ball_stops_with_a_clear_message(name):
    make, kw = PATHS[name]
    with pytest.raises(SimulationError, match=r"events accumulate at t=4\.0637\d* s in block\(s\) ball: .*Zeno"):
        ball(make(), **kw).run(5.0)


@pytest.mark.parametrize("name", ["rk4-generic", "rk4-fused", "rk4-compiled", "rk45"])
def test_many_events_spread_over_a_long_run_are_not_zeno(name, monkeypatch):
    # a transport delay samples its input every delay / buffer s for as long as the run lasts: with
    # no sample hit in the diagram, MAX_EVENTS of them (100,000: 15.6 s of a 0.01 s delay) ended the
    # run as "Zeno". Here with the cap at 300: 600 events 1 ms apart run; the ball still stops
    from hybridsim.engine import events

    monkeypatch.setattr(events, "MAX_EVENTS", 300)
    make, kw = PATHS[name]
    d = hs.Diagram("delayed")
    d.add(lookup("sine")("s", frequency=1.0))
    d.add(lookup("transport_delay")("d", delay=0.004, buffer=4))
    d.connect("s.y", "d.u")
    res = hs.Simulator(d.build(), make(), log=["d.y"], log_period=0.01, **kw).run(0.6)
    assert len(res.meta["events"]) >= 599
    with pytest.raises(SimulationError, match=r"events accumulate at t=4\.0637"):
        ball(make(), **kw).run(5.0)


@pytest.mark.slow
def test_the_fixed_step_paths_agree_bit_for_bit_with_events():
    runs = [ball(hs.RK4(1e-3), **kw).run(3.9) for kw in ({"fused": False}, {}, {"compiled": True})]
    for r in runs[1:]:
        assert np.array_equal(runs[0].table(), r.table())
        assert runs[0].meta["events"] == r.meta["events"]


def test_logging_does_not_move_events():
    runs = [ball(hs.RK4(1e-3), log_period=p).run(3.9) for p in (0.01, 0.003, 0.0007)]
    for r in runs[1:]:
        assert r.meta["events"] == runs[0].meta["events"]
        assert np.array_equal(r.context.xc, runs[0].context.xc)


class Sawtooth(Block):
    """x' = 1, reset to 0 at every multiple of ``period`` (a time event)."""

    def __init__(self, name="saw", period=0.3):
        super().__init__(name)
        self.period = None
        self.every = period
        self.declare_output("y", 1, depends_on=())
        self.declare_continuous_state(1)

    def output(self, t, x, u):
        return (x,)

    def derivatives(self, t, x, u):
        return np.ones(1)

    def next_event_time(self, t, x):
        return (math.floor(t / self.every + 1e-9) + 1) * self.every

    def event_action(self, t, x, u, fired):
        return np.zeros(1)


@pytest.mark.slow
@pytest.mark.parametrize("solver", [hs.RK4(1e-3), hs.ScipySolver("RK45", rtol=1e-10, atol=1e-12)],
                         ids=["rk4", "rk45"])
def test_time_events_are_hit_exactly(solver):
    d = hs.Diagram("saw")
    d.add(Sawtooth())
    res = hs.Simulator(d.build(), solver, log=["saw.y"], log_period=0.05).run(1.0)
    times = [t for t, _ in res.meta["events"]]
    assert times == pytest.approx([0.3, 0.6, 0.9], abs=1e-15)
    # just before and after a reset: 0.25 s ramps to 0.25; at 0.35 s it restarted at 0.3
    y = dict(zip(np.round(res.t, 6), res["saw.y[0]"]))
    assert y[0.25] == pytest.approx(0.25, abs=1e-12) and y[0.35] == pytest.approx(0.05, abs=1e-12)
    with pytest.raises(CompiledPathError, match="time events"):
        hs.Simulator(d.build(), hs.RK4(1e-3), compiled=True)


class Flipper(Block):
    """x' = -1; at x = 0 the action flips the sign of x, which crosses zero again: chattering."""

    event_directions = (0,)

    def __init__(self, name="flip"):
        super().__init__(name)
        self.declare_output("y", 1, depends_on=())
        self.declare_continuous_state(1)

    def initial_state(self, u=None):
        return np.ones(1)

    def output(self, t, x, u):
        return (x,)

    def derivatives(self, t, x, u):
        return -np.ones(1)

    def zero_crossings(self, t, x, u):
        return np.array([x[0]])

    def event_action(self, t, x, u, fired):
        return -x


def test_an_event_iteration_that_never_settles_is_chattering():
    d = hs.Diagram("flip")
    d.add(Flipper())
    with pytest.raises(SimulationError, match=r"event iteration at t=1 s does not settle .*chattering.*flip"):
        hs.Simulator(d.build(), hs.RK4(1e-2), log=["flip.y"]).run(2.0)


def test_the_shipped_ball_diagram_runs():
    from conftest import DIAGRAMS

    res = hs.simulate(DIAGRAMS / "bouncing_ball.yaml")
    assert [t for t, _ in res.meta["events"]] == pytest.approx(BOUNCES[:9], abs=1e-9)


@pytest.mark.slow
def test_located_switches_run_bit_for_bit_on_every_path():
    from conftest import DIAGRAMS

    runs = [hs.simulate(DIAGRAMS / "fig9_force_and_position.yaml", rate=60, t_end=0.3, locate_switches=True, **kw)
            for kw in ({"fused": False}, {}, {"compiled": True})]
    assert len(runs[0].meta["events"]) >= 5  # stick/slip switches, located
    for r in runs[1:]:
        assert np.array_equal(runs[0].table(), r.table())
        assert runs[0].meta["events"] == r.meta["events"]


@pytest.mark.slow
@pytest.mark.parametrize("solver", ["cvode", "radau", "rk4"])
def test_two_crossings_within_round_off_of_a_hit_both_fire_after_it(solver):
    # the pulse's own switch and the memory's trigger cross a few ulps before the zoh's hit at
    # 2.64 s: the memory samples sin(2 pi 1.3 t) there (the second deferred crossing once took the
    # first's "before" values, and the memory kept its previous sample)
    from conftest import ROOT

    r = hs.simulate(ROOT / "tests" / "data" / "memory_edge_at_hit.yaml", solver=solver)
    assert abs(r["mem.y"][-1] - math.sin(2 * math.pi * 1.3 * 2.64)) < 1e-9
    at = [names for t, names in r.meta["events"] if abs(t - 2.64) < 1e-9]
    # one entry (the pulse's switch is located too, except on a fixed step)
    assert at == [("mem",) if solver == "rk4" else ("mem", "pul")]


@pytest.mark.parametrize("solver", ["rk4", "radau", "lsoda", "rk45", "cvode"])
def test_a_chain_of_resets_does_not_drift(solver):
    # each reset starts the next period: an event located up to 1e-12 s late made the 7th one
    # 3e-12 s late, past the instant, and the row at 1.25 s logged 0.25 instead of the reset value
    from conftest import ROOT

    r = hs.simulate(ROOT / "tests" / "data" / "sawtooth_resets.yaml", solver=solver)
    times = [t for t, _ in r.meta["events"]]
    assert len(times) == 7
    assert max(abs(t - 0.25 * (k + 1)) for k, t in enumerate(times)) < 1e-12
    at_resets = [r["integ.y"][k, 0] for k, t in enumerate(r.t) if t > 0 and abs(t / 0.25 - round(t / 0.25)) < 1e-9]
    assert at_resets == [0.0] * 7


STEP_INTO_INTEGRATOR = """name: stepint
blocks:
  r: {type: step, initial: 0.0, final: 1.0, time: 0.5}
  integ: {type: integrator}
wires: [r.y -> integ.u]
simulation: {t_end: 1.0, step: 1.0e-3, log_period: 0.01}
log: [integ.y]
"""


@pytest.mark.parametrize("solver", ["radau", "bdf", "rk45", "dop853", "cvode"])
def test_a_step_into_an_integrator_is_located(tmp_path, solver):
    # the step's jump is a switch: located, the integral of a unit step at 0.5 s is 0.5 at 1 s
    # (it was stepped over: the solver's step across it carried a first-order error)
    path = tmp_path / "stepint.yaml"
    path.write_text(STEP_INTO_INTEGRATOR)
    r = hs.simulate(path, solver=solver)
    assert abs(r["integ.y"][-1, 0] - 0.5) < 1e-8
    assert [names for _, names in r.meta["events"]] == [("r",)]


def test_a_switch_that_cannot_change_a_derivative_is_not_located(tmp_path):
    # a step into a zoh changes nothing between hits: no event, on any solver
    path = tmp_path / "sampled.yaml"
    path.write_text(STEP_INTO_INTEGRATOR.replace("r.y -> integ.u", "r.y -> z.u, z.y -> integ.u")
                    .replace("  integ: {type: integrator}", "  integ: {type: integrator}\n  z: {type: zoh, rate: 10}"))
    for solver in ("radau", "cvode"):
        assert hs.simulate(path, solver=solver).meta["events"] == []


@on_fixed_step_paths
def test_a_step_on_the_fixed_grid_is_integrated_exactly_with_located_switches(tmp_path, solver, path):
    # the jump at 0.5 s is a step's end: its last stage saw the new value (0.500167 on rk4); located,
    # the step is taken again to just before it
    f = tmp_path / "stepint.yaml"
    f.write_text(STEP_INTO_INTEGRATOR)
    r = hs.simulate(f, solver=solver, locate_switches=True, **path)
    assert abs(r["integ.y"][-1, 0] - 0.5) < 1e-12
    assert r.meta["events"] == [(0.5, ("r",))]



@on_fixed_step_paths
def test_a_jump_at_a_sample_hit_or_at_the_end_is_integrated_exactly_with_located_switches(tmp_path, solver, path):
    # the step at 0.5 s falls on a 10 Hz zoh's hit: the crossing fires after the hit, and the hit
    # took the step's own state, whose last stage saw the jump (0.500167 on rk4, 0.5005 on heun)
    f = tmp_path / "stephit.yaml"
    f.write_text(STEP_INTO_INTEGRATOR.replace("r.y -> integ.u", "r.y -> integ.u, integ.y -> z.u")
                 .replace("  integ: {type: integrator}", "  integ: {type: integrator}\n  z: {type: zoh, rate: 10}"))
    r = hs.simulate(f, solver=solver, locate_switches=True, **path)
    assert abs(r["integ.y"][-1, 0] - 0.5) < 1e-12
    assert r.meta["events"] == [(0.5, ("r",))]
    # a jump at the run's end: a square's edge at 1 s, its integral 0 (3.3e-5 on rk4)
    f.write_text(STEP_INTO_INTEGRATOR.replace("{type: step, initial: 0.0, final: 1.0, time: 0.5}",
                                              "{type: square, frequency: 1.0}"))
    r = hs.simulate(f, solver=solver, locate_switches=True, **path)
    assert abs(r.context.xc[0]) < 1e-12
    assert [names for _, names in r.meta["events"]] == [("r",)]  # the edge at 0.5 s; none at 0 or 1 s


DAMPED_FLOOR = """name: floor
blocks:
  grav: {type: constant, value: -9.81}
  free: {type: constant, value: 0.0}
  v: {type: integrator, initial: 0.0}
  x: {type: integrator, initial: 0.05}
  k: {type: gain, K: -10000.0}
  b: {type: gain, K: -20.0}
  spring: {type: sum, signs: "++"}
  floor: {type: switch, threshold: 0.0}
  acc: {type: sum, signs: "++"}
wires: [v.y -> x.u, x.y -> k.u, v.y -> b.u, k.y -> spring.u1, b.y -> spring.u2,
        free.y -> floor.u1, x.y -> floor.control, spring.y -> floor.u2,
        grav.y -> acc.u1, floor.y -> acc.u2, acc.y -> v.u]
log: [x.y]
simulation: {t_end: 0.125, step: 1.0e-3, locate_switches: true, log_period: 0.005}
"""


@pytest.mark.parametrize("path", [{"fused": False}, {}], ids=["generic", "fused"])
def test_a_switch_whose_right_hand_side_jumps_keeps_the_methods_order(tmp_path, path):
    # a mass dropped 5 cm onto a damped floor: at touch (x = 0, located) the acceleration jumps by
    # B v. The state at the event came from a fresh step whose last stage saw the jump: rk4 ran at
    # first order (differences halving with the step); each stage now lies before the crossing
    f = tmp_path / "floor.yaml"
    f.write_text(DAMPED_FLOOR)
    x = [hs.simulate(f, step=h, **path)["x.y"][-1, 0] for h in (1e-3, 5e-4, 2.5e-4, 1.25e-4)]
    d = np.abs(np.diff(x))
    assert np.all(d[:-1] / d[1:] > 12), d  # 16 at fourth order


THRESHOLD = """name: threshold
blocks:
  c: {type: clock}
  th: {type: constant, value: TH}
  cmp: {type: relational, op: "OP"}
  sw: {type: switch, threshold: TH}
  one: {type: constant, value: 1.0}
  zero: {type: constant, value: 0.0}
  icmp: {type: integrator}
  isw: {type: integrator}
wires: [c.y -> cmp.u1, th.y -> cmp.u2, cmp.y -> icmp.u, one.y -> sw.u1, c.y -> sw.control, zero.y -> sw.u2,
        sw.y -> isw.u]
simulation: {t_end: 1.0, step: 1.0e-3, log_period: 0.01, locate_switches: true}
log: [icmp.y, isw.y]
"""


@on_fixed_step_paths
@pytest.mark.parametrize("op", ["<", "<=", ">", ">="])
def test_a_comparison_whose_threshold_a_stage_lands_on_is_integrated_exactly(tmp_path, solver, path, op):
    # t >= 0.37 with h = 1 ms: a step's end (0.37) or its middle stages (0.3705) land on the threshold,
    # where the event function read zero, on the side before the crossing, while the output had
    # already switched: one stage of the wrong value (0.6301667 on rk4 for the switch)
    for th in (0.37, 0.3705):
        f = tmp_path / "th.yaml"
        f.write_text(THRESHOLD.replace("TH", str(th)).replace("OP", op))
        r = hs.simulate(f, solver=solver, **path)
        on = th if op in ("<", "<=") else 1.0 - th
        got = r["icmp.y"][-1, 0], r["isw.y"][-1, 0]
        assert abs(got[0] - on) < 1e-12 and abs(got[1] - (1.0 - th)) < 1e-12, (th, got)
        assert [round(t, 12) for t, _ in r.meta["events"]] == [th]


PID_AT_REST = """name: pidrest
blocks:
  r: {type: step, initial: 0.0, final: 1.0, time: T}
  pid: {type: pid, Kp: 5.0, Ki: 5.0, Kd: 0.1, N: 50.0, lower: -0.8, upper: 0.8}
  plant: {type: first_order, tau: 0.05}
wires: [r.y -> pid.r, plant.y -> pid.y, pid.u -> plant.u]
simulation: {t_end: 0.1, step: 1.0e-3, log_period: 0.01, locate_switches: true}
log: [pid.u]
"""


@on_fixed_step_paths
@pytest.mark.parametrize("time", [0.02, 0.0195])
def test_a_jump_at_or_inside_a_fixed_step_is_one_event_at_its_time(tmp_path, solver, path, time):
    # the PID's e = r - y sits at exactly 0 until the setpoint steps; the step's dense output, bent by
    # its last stage past the jump, left zero before it (0.019, 0.01975 and 0.02 were listed on rk4):
    # fresh steps say where the functions cross
    f = tmp_path / "pidrest.yaml"
    f.write_text(PID_AT_REST.replace("time: T", f"time: {time}"))
    r = hs.simulate(f, solver=solver, **path)
    [(t, names)] = r.meta["events"]
    assert names == ("pid", "r") and 0.0 <= t - time < 1e-14
    assert r["pid.u"][-1, 0] == 0.8


LIMIT_AT_A_SWITCH = """name: limit_at_switch
blocks:
  u: {type: step, initial: 1.0, final: -1.0, time: 0.3}
  L: {type: integrator, K: 1.0, upper: 0.25}
  st: {type: step, initial: 0.0, final: 1.0, time: 0.25}
  C: {type: integrator, K: 1.0}
wires: [u.y -> L.u, st.y -> C.u]
simulation: {t_end: 0.5, step: 1.0e-3, log_period: LOG, locate_switches: true}
log: [L.y]
"""


@pytest.mark.parametrize("log_period", [0.01, 0.0007])
@pytest.mark.parametrize("solver", ["cvode", "radau", "rk45", "rk4"])
def test_a_limit_reached_at_the_instant_another_block_switches_is_not_dropped(tmp_path, solver, log_period):
    # L reaches its limit at 0.25 s, as the step st switches; CVODE reported st's root only and, at the
    # restart, took L (on its surface, its rate unchanged by st's action) for a function that had just
    # fired: L ran through its limit (0.1 at 0.5 s, not 0.25 - 0.2 = 0.05)
    f = tmp_path / "limsw.yaml"
    f.write_text(LIMIT_AT_A_SWITCH.replace("LOG", str(log_period)))
    r = hs.simulate(f, solver=solver)
    assert abs(r["L.y"][-1, 0] - (0.25 - (r.t[-1] - 0.3))) < 1e-9  # the last row: 0.5 s, or 0.4998 s
    assert [names for _, names in r.meta["events"]] == [("L", "st"), ("L", "u")]
    assert np.allclose([t for t, _ in r.meta["events"]], [0.25, 0.3], atol=1e-12, rtol=0)


CROSSING_A_HAIR_AFTER_A_SWITCH = """name: hair
blocks:
  one: {type: constant, value: 1.0}
  B: {type: integrator, K: 1.0}
  hit: {type: hit_crossing, offset: 0.1500000000000006, direction: rising}
  pul: {type: pulse, period: 0.2, duty: 0.5, delay: 0.05}
  C: {type: integrator, K: 1.0}
wires: [one.y -> B.u, B.y -> hit.u, pul.y -> C.u]
simulation: {t_end: 0.2, step: 1.0e-3, log_period: 0.01, locate_switches: true}
log: [hit.count]
"""


@on_fixed_step_paths
def test_a_crossing_a_hair_after_a_switch_is_acted_on_once(tmp_path, solver, path):
    # B = t crosses 0.1500000000000006 two ulps after the pulse falls at 0.15: the switch's state is
    # a fresh step to just before it, where B has not crossed, yet hit was acted on there (its dense
    # output had) and again when B crossed: hit.count 2
    f = tmp_path / "hair.yaml"
    f.write_text(CROSSING_A_HAIR_AFTER_A_SWITCH)
    r = hs.simulate(f, solver=solver, **path)
    assert r["hit.count"][-1, 0] == 1.0
    assert [names for _, names in r.meta["events"]] == [("pul",), ("hit", "pul")]


PID_AT_LIMIT = """blocks:
  r: {type: table, times: [0.0, 1.0, 1.0, 2.0], values: [1.0, 1.0, -1.0, -1.0]}
  y: {type: constant, value: 0.0}
  p: {type: pid, Kp: 0.5, Ki: 2.0, upper: 1.5, lower: -10.0}
wires: [r.y -> p.r, y.y -> p.y]
simulation: {t_end: 2.0, solver: SOLVER, step: 1.0e-3, log_period: 0.05, locate_switches: true}
log: [p.u]
"""


@pytest.mark.parametrize("solver,fused", [("heun", False), ("heun", True), ("rk4", True)])
def test_a_switch_sitting_on_its_surface_at_a_jump_does_not_hang_a_located_fixed_step_run(tmp_path, solver, fused):
    # a PID held at its limit (its function at +4e-16) when the setpoint jumps inside a step: the bent
    # dense output put a crossing 8e-10 s after each restart, a million events to cross one step (heun
    # ran for minutes); a switch located more than 20 times between two hits is stepped over, as on
    # the variable-step solvers
    import signal

    def hang(signum, frame):
        raise TimeoutError("the run hangs")

    path = tmp_path / "d.yaml"
    path.write_text(PID_AT_LIMIT.replace("SOLVER", solver))
    old = signal.signal(signal.SIGALRM, hang)
    signal.alarm(60)
    try:
        res = hs.simulate(path, fused=fused)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    assert len(res.meta["events"]) < 50
    assert res["p.u"][-1, 0] == pytest.approx(-1.5, abs=2e-3)  # u = Kp e + I, I from 1 (held) down at Ki e
