"""Events on every solver and path against closed forms: {integrator reach / leave / reset,
relay, bouncing ball, stick-slip, contact, an ME FMU} x {rk4, heun, radau, bdf, lsoda, rk45,
dop853} x {generic, fused, compiled}.

Each case is chosen so that its closed form is exact arithmetic for the methods: the states
are polynomials of degree <= 2 in time between events (RK4 and Heun integrate them without
error), or the events are driven by a source (located by bisection only). So every event
time must match to 1e-9 s, the number of events must be exact, and ``meta["events"]`` holds
one entry per event.
"""
import math
from typing import NamedTuple

import numpy as np
import pytest
from scipy.optimize import brentq

import hybridsim as hs
from hybridsim.engine.block import Block
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.engine.registry import lookup

SOLVERS = {
    "rk4": lambda: hs.RK4(1e-3),
    "heun": lambda: hs.Heun(1e-3),
    **{m.lower(): (lambda m=m: hs.ScipySolver(m, rtol=1e-10, atol=1e-12))
       for m in ("Radau", "BDF", "LSODA", "RK45", "DOP853")},
}
FIXED = ("rk4", "heun")
PATHS = [(s, "generic") for s in SOLVERS] + [(s, "fused") for s in FIXED] + [
    pytest.param(s, "compiled", marks=pytest.mark.slow) for s in FIXED]


# -- test blocks with kernels (so they run on the fused and compiled paths) ------------------
class MassParams(NamedTuple):
    m: float   # mass, kg
    fc: float  # Coulomb (sliding) friction force, N
    fs: float  # break-away (static) friction force, N


@kernel
def mass_output(p, t, x, u):
    return ((x[0],), (x[1],))


@kernel
def mass_derivatives(p, t, x, u):
    s = x[2]  # 0 stuck, +1 / -1 sliding forward / back
    return (x[1], 0.0 if s == 0.0 else (u[0][0] - p.fc * s) / p.m, 0.0)


@kernel
def mass_crossings(p, t, x, u):
    s = x[2]
    # stop (v s falls through 0 while sliding); break away forward / back while stuck
    return (x[1] * s if s != 0.0 else 1.0, u[0][0] - p.fs if s == 0.0 else -1.0,
            u[0][0] + p.fs if s == 0.0 else 1.0)


@kernel
def mass_event(p, t, x, u, fired):
    if fired[0]:
        return (x[0], 0.0, 0.0)
    if fired[1]:
        return (x[0], x[1], 1.0)
    if fired[2]:
        return (x[0], x[1], -1.0)
    return (x[0], x[1], x[2])


class StickSlipMass(Block):
    """A mass on a floor with Coulomb friction: stuck while |u| <= fs, sliding otherwise."""

    event_directions = (-1, 1, -1)
    kernels = Kernels(output=mass_output, derivatives=mass_derivatives, zero_crossings=mass_crossings,
                      event_action=mass_event)

    def __init__(self, name, m=1.0, fc=1.0, fs=1.0, v0=1.0):
        super().__init__(name)
        self.params = MassParams(m, fc, fs)
        self.v0 = v0
        self.declare_input("u", 1)
        self.declare_output("x", 1, depends_on=())
        self.declare_output("v", 1, depends_on=())
        self.declare_continuous_state(3)

    def initial_state(self, u=None):
        return np.array([0.0, self.v0, 1.0 if self.v0 > 0 else -1.0 if self.v0 < 0 else 0.0])


class FloorParams(NamedTuple):
    g: float  # gravity, m/s^2
    a: float  # push of the floor per mass while below it, m/s^2


@kernel
def floor_output(p, t, x, u):
    return ((x[0],),)


@kernel
def floor_derivatives(p, t, x, u):
    return (x[1], -p.g + (p.a if x[2] > 0.5 else 0.0), 0.0)


@kernel
def floor_crossings(p, t, x, u):
    # make contact (h falls through 0) while free; break it (h rises through 0) while in it
    return (x[0] if x[2] < 0.5 else 1.0, x[0] if x[2] > 0.5 else -1.0)


@kernel
def floor_event(p, t, x, u, fired):
    return (x[0], x[1], 1.0 if fired[0] else 0.0 if fired[1] else x[2])


class SoftFloorBall(Block):
    """A ball on a soft floor that pushes up with a constant force while in contact. The
    contact is a mode state (0 free, 1 in contact) with explicit make and break events, so
    no step integrates across the switch."""

    event_directions = (-1, 1)
    kernels = Kernels(output=floor_output, derivatives=floor_derivatives, zero_crossings=floor_crossings,
                      event_action=floor_event)

    def __init__(self, name, g=10.0, a=20.0, h0=0.2):
        super().__init__(name)
        self.params = FloorParams(g, a)
        self.h0 = h0
        self.declare_output("h", 1, depends_on=())
        self.declare_continuous_state(3)

    def initial_state(self, u=None):
        return np.array([self.h0, 0.0, 0.0])


# -- the cases: a diagram, the closed-form event times and a final value ------------------------
def _integrator(d, **kw):
    d.add(lookup("integrator")("i", **kw))
    return "i.y"


def reach():
    d = hs.Diagram("reach")
    d.add(lookup("constant")("c", value=1.0))
    _integrator(d, K=2.0, upper=1.5)
    d.connect("c.y", "i.u")
    return d, "i.y", 1.0, [0.75], 1.5


def leave():
    # x' = 1 - t from 0: reaches 0.3 at 1 - sqrt(0.4); held while u > 0; leaves at t = 1 (u = 0)
    d = hs.Diagram("leave")
    d.add(lookup("ramp")("u", initial=1.0, slope=-1.0))
    _integrator(d, upper=0.3)
    d.connect("u.y", "i.u")
    return d, "i.y", 1.5, [1 - math.sqrt(0.4), 1.0], 0.3 - 0.5 ** 2 / 2


def reset():
    d = hs.Diagram("reset")
    d.add(lookup("constant")("c", value=1.0))
    d.add(lookup("step")("r", time=0.5))
    _integrator(d, initial=0.25)
    d.connect("c.y", "i.u")
    d.connect("r.y", "i.reset")
    return d, "i.y", 1.0, [0.5], 0.25 + 0.5


def relay():
    # u = cos(2 pi t) starts above switch_on: the relay starts on (u(0) reconciled)
    d = hs.Diagram("relay")
    d.add(lookup("cosine")("u", amplitude=1.0, frequency=1.0))
    d.add(lookup("relay")("r", switch_on=0.5, switch_off=-0.5))
    d.connect("u.y", "r.u")
    return d, "r.y", 2.0, [1 / 3, 5 / 6, 4 / 3, 11 / 6], 1.0


def ball():
    g, e, h0 = 9.81, 0.8, 1.0
    t1 = math.sqrt(2 * h0 / g)
    bounces = [t1 + sum(2 * e ** k * t1 for k in range(1, m + 1)) for m in range(40)]
    d = hs.Diagram("ball")
    d.add(lookup("bouncing_ball")("ball", g=g, e=e, h0=h0))
    return d, "ball.v", 3.6, [t for t in bounces if t < 3.6], None


def stick_slip():
    # slides from v = 1 against 1 N: stops at t = 1; u = 2 (t - 1.5) breaks it away at t = 2;
    # then v = (t - 2)^2, x = 0.5 + (t - 2)^3 / 3
    d = hs.Diagram("stick_slip")
    d.add(lookup("ramp")("u", slope=2.0, start=1.5))
    d.add(StickSlipMass("m"))
    d.connect("u.y", "m.u")
    return d, "m.x", 2.5, [1.0, 2.0], 0.5 + 0.5 ** 3 / 3


def contact():
    # free fall from 0.2 m at g = 10: contact at 0.2 s (v = -2), 10 m/s^2 up while in it:
    # leaves at 0.6 s, apex at 0.8 s, and so on with period 0.8 s
    d = hs.Diagram("contact")
    d.add(SoftFloorBall("b"))
    return d, "b.h", 1.5, [0.2, 0.6, 1.0, 1.4], 0.2 - 10 * 0.1 ** 2 / 2


CASES = {f.__name__: f for f in (reach, leave, reset, relay, ball, stick_slip, contact)}


def simulate(case, solver, path):
    d, signal, t_end, times, final = CASES[case]()
    kw = {"fused": path != "generic", "compiled": path == "compiled"}
    sim = hs.Simulator(d.build(), SOLVERS[solver](), log=[signal], log_period=0.01, **kw)
    return sim.run(t_end), signal, times, final


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("solver, path", PATHS)
def test_event_times_and_counts_match_the_closed_form(case, solver, path):
    res, signal, times, final = simulate(case, solver, path)
    got = [t for t, _ in res.meta["events"]]
    assert len(got) == len(times), got  # one entry per event, no event missed or repeated
    assert np.max(np.abs(np.array(got) - times)) < 1e-9
    if final is not None:  # x of the stick-slip mass is cubic: Heun's second order shows there
        tol = 1e-6 if (case, solver) == ("stick_slip", "heun") else 1e-8
        assert res[signal][-1, 0] == pytest.approx(final, abs=tol)


@pytest.mark.parametrize("solver", ["rk4", "heun"])
def test_fixed_step_paths_agree_bit_for_bit(solver):
    for case in ("leave", "stick_slip", "relay"):
        a, _, _, _ = simulate(case, solver, "generic")
        b, _, _, _ = simulate(case, solver, "fused")
        assert np.array_equal(a.table(), b.table())
        assert a.meta["events"] == b.meta["events"]


@pytest.mark.slow
@pytest.mark.parametrize("case", ["leave", "stick_slip", "relay", "contact"])
def test_compiled_path_agrees_bit_for_bit(case):
    a, _, _, _ = simulate(case, "rk4", "generic")
    b, _, _, _ = simulate(case, "rk4", "compiled")
    assert np.array_equal(a.table(), b.table())
    assert a.meta["events"] == b.meta["events"]


def test_leaving_a_limit_inside_a_step_is_one_event():
    # u = cos(2 pi t) reverses inside a step of 1 ms at t = 0.25: held at 0.5 until then
    d = hs.Diagram("chatter")
    d.add(lookup("cosine")("u", amplitude=1.0, frequency=1.0))
    d.add(lookup("integrator")("i", K=10.0, upper=0.5))
    d.connect("u.y", "i.u")
    reach_t = brentq(lambda t: 10 * math.sin(2 * math.pi * t) / (2 * math.pi) - 0.5, 0.0, 0.25)
    for solver in ("rk4", "radau", "lsoda"):
        res = hs.Simulator(d.build(), SOLVERS[solver](), log=["i.y"]).run(1.0)
        got = [t for t, _ in res.meta["events"]]
        assert len(got) == 2
        assert abs(got[1] - 0.25) < 1e-9  # the leave: K u = 0, exactly
        assert abs(got[0] - reach_t) < 1e-8  # the reach: through the integration
        assert res["i.y"][-1, 0] == pytest.approx(0.5 - 10 / (2 * math.pi), abs=1e-6)


# -- an ME FMU with events (the ball of tests/data/ball) on every solver -----------------------
@pytest.fixture(scope="module")
def ball_fmu(tmp_path_factory):
    from hybridsim.errors import FMUError
    from hybridsim.fmi.fmu_block import build_fmu, find_compiler

    from conftest import ROOT

    try:
        find_compiler()
    except FMUError:
        pytest.skip("no C compiler")
    d = ROOT / "tests" / "data" / "ball"
    return build_fmu(tmp_path_factory.mktemp("ball") / "ball.fmu", "ball", sorted(d.glob("*.c")),
                     (d / "modelDescription.xml").read_text(), {})


@pytest.mark.parametrize("solver", list(SOLVERS))
def test_me_fmu_events_on_every_solver(ball_fmu, solver):
    from hybridsim.fmi.fmu_block import FMUBlock

    g, e = 9.81, 0.7
    t1 = math.sqrt(2 / g)
    bounces = [t1 + sum(2 * e ** k * t1 for k in range(1, m + 1)) for m in range(4)]
    d = hs.Diagram("ball")
    d.add(FMUBlock("ball", path=str(ball_fmu), mode="me"))
    res = hs.Simulator(d.build(), SOLVERS[solver](), log=["ball.height"], log_period=0.01).run(2.4)
    state = [t for t, _ in res.meta["events"] if abs(t - round(t)) > 1e-9]  # not the 1 s stairs
    bounce = [t for k, t in enumerate(state) if k == 0 or t - state[k - 1] > 1e-6]
    assert np.max(np.abs(np.array(bounce[:4]) - bounces)) < 1e-9
    assert len(res.meta["events"]) == len(set(res.meta["events"]))  # each event listed once
