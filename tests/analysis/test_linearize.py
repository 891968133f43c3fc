"""Linearization against independent calculations (python-control, simulation)."""
import control
import numpy as np
import pytest

import hybridsim as hs
from hybridsim.analysis.jacobians import zoh
from hybridsim.analysis.linearize import Linearization, LinearizationError

from hybridsim.blocks.continuous.linear import StateSpace

from hybridsim.blocks.math.signals import Sum

from hybridsim.blocks.discrete.hold import ZeroOrderHold
from hybridsim.blocks.paper.controllers import PositionPID
from hybridsim.blocks.sources.basic import Constant
from conftest import DIAGRAMS, ROOT

M, B, K = 2.0, 3.0, 400.0  # mass-spring-damper: m x'' + b x' + k x = u


def msd_loop(kp, ki, rate=50.0):
    """Unity feedback of the mass-spring-damper position under a sampled PI."""
    d = hs.Diagram("msd")
    d.add(Constant("r", value=0.0))
    d.add(Sum("e", signs="+-"))
    d.add(PositionPID("pi", Kp=kp, Ki=ki, Kd=0.0, rate=rate, width=1))
    d.add(StateSpace("plant", A=[[0, 1], [-K / M, -B / M]], B=[[0], [1 / M]], C=[[1, 0]]))
    d.connect("r.y", "e.u1")
    d.connect("plant.y", "e.u2")
    d.connect("e.y", "pi.e")
    d.connect("r.dy", "pi.ed")
    d.connect("pi.tau", "plant.u")
    return d.build()


def reference_poles(kp, ki, rate=50.0):
    """python-control: ZOH plant, PI(z) = Kp + Ki T z/(z-1), negative feedback."""
    T = 1 / rate
    P = control.sample_system(control.ss([[0, 1], [-K / M, -B / M]], [[0], [1 / M]], [[1, 0]], 0), T, "zoh")
    z = control.tf("z")
    z.dt = T
    C = kp + ki * T * z / (z - 1)
    return control.feedback(C * P, 1).poles()


def test_zoh_matches_python_control():
    A, Bm = np.array([[0, 1], [-K / M, -B / M]]), np.array([[0], [1 / M]])
    Phi, Gam = zoh(A, Bm, 0.02)
    ref = control.sample_system(control.ss(A, Bm, np.eye(2), 0), 0.02, "zoh")
    assert Phi == pytest.approx(ref.A, abs=1e-12) and Gam == pytest.approx(ref.B, abs=1e-12)


@pytest.mark.parametrize("kp, ki", [(50.0, 100.0), (200.0, 2000.0)])
def test_sampled_pi_poles_match_python_control(kp, ki):
    cl = Linearization(msd_loop(kp, ki)).closed_loop()
    ours = np.sort_complex(cl.poles[np.abs(cl.poles) > 1e-9])
    ref = np.sort_complex(reference_poles(kp, ki))
    assert ours == pytest.approx(ref, abs=1e-7)
    assert cl.period == pytest.approx(0.02)


def test_loop_transfer_and_margins_match_python_control():
    kp, ki, T = 200.0, 2000.0, 0.02
    L = Linearization(msd_loop(kp, ki)).loop("pi.tau[0]")
    P = control.sample_system(control.ss([[0, 1], [-K / M, -B / M]], [[0], [1 / M]], [[1, 0]], 0), T, "zoh")
    z = control.tf("z")
    z.dt = T
    ref = (kp + ki * T * z / (z - 1)) * P
    w = np.array([0.5, 3.0, 20.0, 100.0])
    assert np.asarray(L(np.exp(1j * w * T))).ravel() == pytest.approx(np.asarray(ref(np.exp(1j * w * T))).ravel(), rel=1e-6)
    gm, pm, *_ = control.stability_margins(L)
    gm_ref, pm_ref, *_ = control.stability_margins(ref)
    assert gm == pytest.approx(gm_ref, rel=1e-5) and pm == pytest.approx(pm_ref, rel=1e-5)


def test_stability_boundary_in_kp_matches_python_control():
    # the boundary is where the reference's largest |z| crosses 1; bisect it independently
    def rho_ref(kp):
        return max(abs(reference_poles(kp, 0.0)))

    lo, hi = 1.0, 5000.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if rho_ref(mid) >= 1 else (mid, hi)
    for kp, expect in ((0.9 * lo, True), (1.1 * lo, False)):
        cl = Linearization(msd_loop(kp, 0.0)).closed_loop()
        assert cl.stable is expect


def test_multirate_lifting_matches_simulated_map():
    """PI at 100 Hz behind a 50 Hz zero-order hold: hyperperiod 20 ms; the lifted
    closed loop equals the finite-difference Jacobian of the simulated map."""
    d = hs.Diagram("mr")
    d.add(Constant("r", value=0.0))
    d.add(Sum("e", signs="+-"))
    d.add(ZeroOrderHold("s", rate=50))
    d.add(PositionPID("pi", Kp=100.0, Ki=300.0, Kd=0.0, rate=100, width=1))
    d.add(StateSpace("plant", A=[[0, 1], [-K / M, -B / M]], B=[[0], [1 / M]], C=[[1, 0]]))
    for a, b in [("r.y", "e.u1"), ("plant.y", "e.u2"), ("e.y", "s.u"), ("s.y", "pi.e"),
                 ("r.dy", "pi.ed"), ("pi.tau", "plant.u")]:
        d.connect(a, b)
    system = d.build()
    cl = Linearization(system).closed_loop()
    assert cl.period == pytest.approx(0.02)
    sim = hs.Simulator(system, hs.RK4(1e-5), log_period=0.02)
    pi = system.index["pi"]

    def F(x):  # (plant x, pi integrator) over one hyperperiod
        ctx = system.create_context()
        ctx.xc = x[:2].copy()
        ctx.xd[pi] = x[2:].copy()
        c = sim.run(0.02, context=ctx).context
        return np.concatenate([c.xc, c.xd[pi]])

    x0 = np.zeros(3)
    J = np.column_stack([(F(x0 + 1e-6 * e) - F(x0 - 1e-6 * e)) / 2e-6 for e in np.eye(3)])
    ours = np.sort_complex(cl.poles[np.abs(cl.poles) > 1e-9])
    assert ours == pytest.approx(np.sort_complex(np.linalg.eigvals(J)), abs=1e-6)
    with pytest.raises(LinearizationError, match="single-rate"):
        Linearization(system).loop("pi.tau[0]")


def test_hand_mode_in_linearized_plant():
    lin = Linearization(hs.build(DIAGRAMS / "hybrid_controller.yaml", friction=False)[0])
    A, _ = lin.continuous()
    f = [abs(e.imag) / (2 * np.pi) for e in np.linalg.eigvals(A)]
    eq18 = np.sqrt((9e5 + 8e5) / 0.58) / (2 * np.pi)
    assert min(abs(x - eq18) for x in f) / eq18 < 0.01  # measured 269.96 vs 272.48 Hz


SMOOTH = ROOT / "tests" / "data" / "smooth_contact.yaml"
STABLE = {"ctrl.fpi.Ki": [24.0, 22.0], "force_cmd.time": 10.0}  # Kfi / 10: a stable linear loop


def test_linear_step_matches_nonlinear_simulation():
    system, _, _ = hs.build(SMOOTH, **STABLE)
    G = Linearization(system).io("force_cmd.y[0]", "ctrl.ft.CF[0]")
    n, T = 60, G.dt
    lin = 0.05 * np.ravel(control.step_response(G, T=np.arange(n) * T).outputs)
    res = hs.simulate(SMOOTH, **{**STABLE, "force_cmd.initial": [10.05, 0.0]}, t_end=n * T, log_period=T)
    # a 0.05 N step keeps tau_e inside the limiter band: measured 3.1e-7 N apart
    assert np.max(np.abs(res["ctrl.ft.CF[0]"][:n] - 10.0 - lin)) < 1e-5
    assert lin[-1] == pytest.approx(0.05, abs=1e-3)


@pytest.mark.slow
def test_predicted_gain_boundary_brackets_nonlinear_instability():
    from hybridsim.analysis.stability import critical_scale

    kfp = np.array([0.4, 0.3])
    c = critical_scale(SMOOTH, STABLE, "ctrl.fpi.Kp", kfp)
    assert 2.0 < c < 5.0  # measured x3.28 of the Appendix A Kfp

    def error_growth(scale):
        ov = {**STABLE, "ctrl.fpi.Kp": (kfp * scale).tolist(), "force_cmd.initial": [10.05, 0.0]}
        r = hs.simulate(SMOOTH, **ov, t_end=2.0)
        e = np.abs(r["ctrl.ft.CF[0]"] - 10.05)
        return e[r.t > 1.8].max() / e[r.t < 0.2].max()

    assert error_growth(0.9 * c) < 0.01   # decays (measured 1e-3)
    assert error_growth(1.1 * c) > 1.0    # grows (measured 3.7)


def test_a_diagram_without_continuous_state_linearizes():
    # counter -> gain -> delay: only discrete states; the counter's count is held (a count, no dynamics)
    sysm, sim, _ = hs.build(ROOT / "tests" / "data" / "discrete_only.yaml")
    model = Linearization(sysm, sysm.create_context()).closed_loop()
    # the delay's state is dropped (its column vanishes: z = 0); the count was a pole at z = 1
    assert model.names == [] and model.poles.size == 0 and model.stable


def test_an_unknown_analysis_setting_is_refused_at_its_line(tmp_path, capsys):
    """A misspelt key of the 'analysis' section used to be ignored (the analysis ran without it)."""
    from conftest import write
    from hybridsim.app.cli import main

    p = write(tmp_path, f"extends: {DIAGRAMS / 'hybrid_controller.yaml'}\nanalysis:\n  rate_parm: rate\n")
    assert main(["analyze", str(p)]) == 2
    err = capsys.readouterr().err
    assert "d.yaml:3" in err and "unknown analysis setting 'rate_parm' (did you mean 'rate_param'?)" in err
    q = write(tmp_path, f"extends: {DIAGRAMS / 'hybrid_controller.yaml'}\nanalysis:\n  at: -1\n")
    assert main(["analyze", str(q)]) == 2
    assert "'at' must be a time in seconds >= 0" in capsys.readouterr().err


@pytest.fixture(scope="module")
def fig9_analysis():
    import warnings

    from hybridsim.analysis import stability as an

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return an.analyze(DIAGRAMS / "fig9_force_and_position.yaml", sweeps=False)


@pytest.mark.slow
def test_reported_margins_lie_on_the_loops_own_frequency_response(fig9_analysis):
    """python-control's polynomial margins put Fig 9's force-loop crossover where |L| = 615 (and the
    position loop's where |L| = 0.08); the margins reported are checked against L and, where they miss,
    found on a dense grid of L's response."""
    res = fig9_analysis
    for name, m in res["loops"].items():
        L = res["_objects"]["loops"][name]
        at = lambda hz: complex(np.asarray(L(np.exp(2j * np.pi * hz * L.dt))).ravel()[0])  # noqa: E731
        if m["phase_margin_deg"] is not None:
            r = at(m["gain_crossover_hz"])
            assert abs(abs(r) - 1.0) < 0.01, name
            assert m["phase_margin_deg"] == pytest.approx(180.0 + np.degrees(np.angle(r)), abs=0.5), name
        if m["gain_margin"] is not None:
            r = at(m["phase_crossover_hz"])
            assert abs(r) * m["gain_margin"] == pytest.approx(1.0, rel=0.01) and r.real < 0, name


@pytest.mark.parametrize("L, open_unstable, closed_stable, hidden", [
    (control.tf([2.0], [1.0, 1.0]), 0, True, 0),            # 1 + L: s + 3
    (control.tf([2.0], [1.0, -1.0]), 1, True, 0),           # unstable opened, 1 + L: s + 1
    (control.tf([0.5], [1.0, -1.0]), 1, False, 0),          # 1 + L: s - 0.5
    (control.tf([0.3], [1.0, -0.5], 0.1), 0, True, 0),      # 1 + L: z - 0.2
    (control.tf([3.0], [1.0, -0.5], 0.1), 0, False, 0),     # 1 + L: z + 2.5
    (control.tf([1.0], [1.0, -1.0], 0.1), 0, True, 0),      # a sampled integrator, 1 + L: z
    # 2/(s + 1) beside a growing mode the loop neither drives nor sees (a helper's unwired 1/(s - 0.5))
    (control.ss([[-1.0, 0.0], [0.0, 0.5]], [[1.0], [0.0]], [[2.0, 0.0]], 0.0), 0, True, 0),
    # ... that the loop drives (a branch it feeds, or a cancellation: the margins do not cover it)
    (control.ss([[-1.0, 0.0], [0.0, 0.5]], [[1.0], [1.0]], [[2.0, 0.0]], 0.0), 0, True, 1),
    (control.ss([[-1.0, 0.0], [0.0, 0.5]], [[1.0], [1.0]], [[2.0, 1.0]], 0.0), 1, False, 0),  # 2/(s+1) + 1/(s-0.5), closed: s = 0.137
    # closing on the unit circle or the imaginary axis is not stable (both said True): L = 2/(z - 1), 4/s^2
    (control.tf([2.0], [1.0, -1.0], 0.1), 0, False, 0),     # 1 + L: z + 1
    (control.tf([4.0], [1.0, 0.0, 0.0]), 0, False, 0),      # 1 + L: s^2 + 4
    # an unstable pole the controller's zero cancels: 2/(s - 1) then (4s - 4)/(s^2 + 3s) (a helper's)
    (control.ss(control.tf([2.0], [1.0, -1.0])) * control.ss(control.tf([4.0, -4.0], [1.0, 3.0, 0.0])), 0, True, 1),
])
def test_loop_stability_says_what_margins_do_not(L, open_unstable, closed_stable, hidden):
    from hybridsim.analysis.stability import loop_stability

    assert loop_stability(L) == {"open_loop_unstable_poles": open_unstable, "closed_loop_stable": closed_stable,
                                 "hidden_unstable_modes": hidden}


@pytest.mark.slow
def test_margins_of_a_loop_that_closes_unstable_say_so(fig9_analysis):
    """Fig 9's force loop, opened at dF: |L| > 1.58 up to just below Nyquist, where it falls to 0 (phase
    margin 90 deg there, no usable gain margin), and the whole loop is not stable (|z| 6.44): the
    margins come with the verdict of 1/(1 + L), and the opened position loop's own unstable poles."""
    from hybridsim.analysis import stability as an

    res = fig9_analysis
    assert res["stable"] is False
    assert res["loops"]["force"]["closed_loop_stable"] is False
    assert res["loops"]["position"]["closed_loop_stable"] is False
    assert res["loops"]["position"]["open_loop_unstable_poles"] == 2  # the force loop's pair at |z| 6.44
    text = "\n".join(an.summary_lines(res))
    assert text.count("closed through this opening the loop is NOT STABLE") == 2


def test_a_continuous_loop_matches_python_control():
    """Nothing sampled: a continuous PI around a second-order plant; the closed loop's poles and the
    loop opened at the controller's output are python-control's feedback(C P) and C P."""
    C = control.tf([2.0, 3.0], [1.0, 0.0])          # PI: 2 + 3/s
    P = control.tf([1.0], [1.0, 0.4, 4.0])
    d = hs.Diagram("continuous_pi")
    d.add(Constant("r", value=0.0))
    d.add(Sum("e", signs="+-"))
    d.add(hs.from_control(C, name="C"))
    d.add(hs.from_control(P, name="P"))
    for a, b in [("r.y", "e.u1"), ("P.y", "e.u2"), ("e.y", "C.u"), ("C.y", "P.u")]:
        d.connect(a, b)
    lin = Linearization(d.build())
    assert not lin.sampled
    cl = lin.closed_loop()
    assert cl.domain == "continuous" and cl.period is None
    ref = control.feedback(C * P, 1).poles()
    assert np.sort_complex(cl.poles) == pytest.approx(np.sort_complex(ref), abs=1e-6)
    assert cl.stable == bool(np.all(ref.real < 0))
    L = lin.loop("C.y[0]")
    assert L.dt == 0
    for w in (0.1, 1.0, 2.0, 10.0):
        assert complex(L(1j * w)) == pytest.approx(complex((C * P)(1j * w)), rel=1e-6)
    T = lin.io("r.y[0]", "P.y[0]")  # an additive input at the command
    assert complex(T(1j)) == pytest.approx(complex(control.feedback(C * P, 1)(1j)), rel=1e-6)


def test_the_hand_oscillation_is_linearized_as_a_continuous_system():
    """Eq 18's diagram samples nothing: its poles are the hand's modes, (1/2 pi) sqrt((Kr + Kw)/M3)
    along C-X (against the surface) and sqrt(Kw/M3) along C-Y (the wrist alone), undamped; closing
    the contact loop opened at the surface's force gives the same closed-loop modes."""
    from hybridsim.analysis import stability as an

    Kw, M3 = 8.0e5, 0.58
    for Kr in (9.0e5, 1.0e6):
        sysm, _, _ = hs.build(DIAGRAMS / "eq18_hand_oscillation.yaml", Kr=Kr)
        lin = Linearization(sysm)
        cl = lin.closed_loop()
        f = sorted({round(r["freq_hz"], 3) for r in cl.pole_table() if r["freq_hz"] and abs(r["pole"].imag) > 1})
        assert f == pytest.approx([np.sqrt(Kw / M3) / (2 * np.pi), np.sqrt((Kr + Kw) / M3) / (2 * np.pi)], rel=1e-4)
        assert not cl.stable  # undamped modes: not asymptotically stable
        L = lin.loop("surface.fx[0]")
        closed = control.feedback(L, 1).poles()
        hand = [p for p in cl.poles if abs(p.imag) > 1500]
        assert all(np.min(np.abs(closed - p)) < 1e-3 * abs(p) for p in hand)
    res = an.analyze(DIAGRAMS / "eq18_hand_oscillation.yaml", sweeps=False)
    assert res["domain"] == "continuous" and res["hand_mode_hz"] == pytest.approx(272.5, abs=0.1)
    assert res["loops"]["contact"]["phase_margin_deg"] == pytest.approx(0.0, abs=0.5)  # undamped: on -1


def test_a_double_integrator_is_not_stable():
    """The bouncing ball in free fall (x' = v, v' = -g): both poles at s = 0, one Jordan block - it drifts."""
    sysm, _, _ = hs.build(DIAGRAMS / "bouncing_ball.yaml")
    cl = Linearization(sysm).closed_loop()
    assert cl.integrator_modes == 2 and cl.growth == 0.0 and not cl.stable


@pytest.mark.slow
def test_a_co_simulation_fmu_is_refused_with_its_reason(tmp_path):
    """A Co-Simulation FMU's states live inside it: linearizing around them would leave the plant out."""
    from hybridsim.analysis import stability as analysis
    from hybridsim.app.cli import main
    from hybridsim.fmus.build import build_plant_fmu

    fmu = build_plant_fmu(tmp_path / "plant.fmu")
    with pytest.raises(LinearizationError, match="'plant' keep their state inside"):
        analysis.analyze(DIAGRAMS / "fig9_fmu_cs.yaml", sweeps=False, fmu=str(fmu))
    assert main(["analyze", str(DIAGRAMS / "fig9_fmu_cs.yaml"), "--set", f"fmu={fmu}"]) == 2


DELAYED = """name: delayed
blocks:
  r: {type: step}
  pi: {type: discrete_pid, Kp: 4.0, Ki: 2.0, rate: 10}
  dly: {type: transport_delay, delay: 0.2}
  plant: {type: transfer_function, num: [1.0], den: [1.0, 2.0, 0.0]}
wires: [r.y -> pi.r, plant.y -> pi.y, pi.u -> dly.u, dly.y -> plant.u]
simulation: {t_end: 5.0, solver: rk4, step: 1.0e-3}
log: [plant.y]
analysis:
  points: {u: "pi.u[0]"}
"""


def test_a_transport_delay_is_linearized_as_its_pade_approximation(tmp_path):
    # its buffer changes only at events: analysis saw it as constants, the loop as open (margins inf,
    # "stable" at Kp = 8 too). Now its Pade approximation stands in: the 10 Hz loop equals
    # python-control's c2d(zoh) of the plant times z^-2 (0.2 s is two periods; order 5 is exact to
    # 1e-6 in the phase there)
    from hybridsim.analysis.stability import analyze, linearization

    p = tmp_path / "delayed.yaml"
    p.write_text(DELAYED)
    P = control.c2d(control.tf([1.0], [1.0, 2.0, 0.0]), 0.1) * control.tf([1.0], [1.0, 0.0, 0.0], 0.1)
    for kp in (4.0, 8.0):
        C = control.tf([kp + 2.0 * 0.1, -kp], [1.0, -1.0], 0.1)  # Kp + Ki T z / (z - 1) (forward Euler)
        cl = linearization(p, **{"pi.Kp": kp}).closed_loop()
        ref = np.max(np.abs(control.feedback(C * P, 1).poles()))
        assert cl.growth == pytest.approx(ref, abs=2e-4)
        assert cl.stable == (kp == 4.0)
    res = analyze(p)
    m = res["loops"]["u"]
    gm, pm, _, _ = control.margin(control.tf([4.2, -4.0], [1.0, -1.0], 0.1) * P)  # at Kp = 4
    assert m["gain_margin_db"] == pytest.approx(20 * np.log10(gm), abs=0.05)
    assert m["phase_margin_deg"] == pytest.approx(pm, abs=0.2)


@pytest.mark.slow
def test_a_conditionally_stable_gain_reports_its_lower_boundary(tmp_path):
    # PI 4 + 2/s around 1/(s (s + 2)): s^3 + 2 s^2 + Kp s + Ki is stable for 2 Kp > Ki, i.e. Kp above
    # x0.25 of 4; the boundary search walked up only ("no stability boundary found")
    from hybridsim.analysis.stability import analyze, summary_lines

    p = tmp_path / "cond.yaml"
    p.write_text("name: cond\nblocks:\n  r: {type: step}\n  pi: {type: pid, Kp: 4.0, Ki: 2.0}\n"
                 "  plant: {type: transfer_function, num: [1.0], den: [1.0, 2.0, 0.0]}\n"
                 "wires: [r.y -> pi.r, plant.y -> pi.y, pi.u -> plant.u]\nlog: [plant.y]\n"
                 "analysis:\n  points: {u: \"pi.u[0]\"}\n  gains: {Kp: pi.Kp, Ki: pi.Ki}\n")
    res = analyze(p)
    assert res["gains"]["Kp"]["lower_scale"] == pytest.approx(0.25, rel=0.01)
    assert res["gains"]["Kp"]["critical_scale"] is None
    assert res["gains"]["Ki"]["critical_scale"] == pytest.approx(4.0, rel=0.01)
    assert res["gains"]["Ki"]["lower_scale"] is None
    assert any("unstable below x0.25" in line for line in summary_lines(res))
    # unstable at x1 (Kp = 0.5): the boundary above it (x2) was not searched
    p.write_text(p.read_text().replace("Kp: 4.0", "Kp: 0.5"))
    res = analyze(p)
    assert not res["stable"] and res["gains"]["Kp"]["lower_scale"] == pytest.approx(2.0, rel=0.01)
    assert [b["unstable_above"] for b in res["gains"]["Kp"]["boundaries"]] == [False]
    # unstable at every scale of its sweep (Kp = 0.1, x0.5 .. x2): the boundary at x10 lies beyond it
    p.write_text(p.read_text().replace("Kp: 0.5", "Kp: 0.1").replace("gains:", "scales: [0.5, 1, 2]\n  gains:"))
    res = analyze(p)
    assert res["gains"]["Kp"]["lower_scale"] == pytest.approx(10.0, rel=0.01)


@pytest.mark.slow  # about twenty 30 s runs
def test_a_gain_sweep_about_a_later_state_takes_a_diverging_scale_as_unstable(tmp_path):
    # analyze --at 30 of a stable 10 Hz PI loop: the boundary search ran each scaled Kp for 30 s, and
    # one that diverged ended the analysis (exit 3, "simulation diverged")
    from hybridsim.analysis.stability import analyze

    p = tmp_path / "later.yaml"
    p.write_text("name: later\nblocks:\n  r: {type: step}\n  pi: {type: discrete_pid, Kp: 4.0, Ki: 2.0, rate: 10}\n"
                 "  plant: {type: transfer_function, num: [1.0], den: [1.0, 2.0, 0.0]}\n"
                 "wires: [r.y -> pi.r, plant.y -> pi.y, pi.u -> plant.u]\nlog: [plant.y]\n"
                 "simulation: {t_end: 40.0, solver: rk4, step: 0.01}\n"
                 "analysis:\n  points: {u: \"pi.u[0]\"}\n  gains: {Kp: pi.Kp}\n")
    res = analyze(p, at=30.0)
    assert res["stable"] and res["gains"]["Kp"]["critical_scale"] == pytest.approx(10.1, rel=0.02)


@pytest.mark.slow
def test_a_delays_stand_in_gives_the_delays_output_at_the_operating_point(tmp_path):
    # x' = 1 - x d with d a ramp delayed 1 s (initial 5 before): about t = 3 the Jacobian is -d(3) = -2,
    # about t = 0 it is -5. The stand-in was started at the steady state for its input (-3, and 0:
    # counted as an undriven integrator)
    from hybridsim.analysis.stability import linearization

    p = tmp_path / "prod.yaml"
    p.write_text("blocks:\n  rp: {type: ramp}\n  dly: {type: transport_delay, delay: 1.0, pade: 2, initial: 5.0}\n"
                 "  prod: {type: product}\n  neg: {type: gain, K: -1.0}\n"
                 "  x: {type: transfer_function, num: [1.0], den: [1.0, 0.0]}\n  one: {type: constant}\n"
                 "  s: {type: sum}\nwires: [rp.y -> dly.u, dly.y -> prod.u2, x.y -> prod.u1, prod.y -> neg.u,\n"
                 "        neg.y -> s.u1, one.y -> s.u2, s.y -> x.u]\nlog: [x.y]\n"
                 "simulation: {t_end: 4.0, solver: rk4, step: 1.0e-3}\n")
    pade = control.tf(*control.pade(1.0, 2)).poles()  # the stand-in's own poles
    for at, pole in ((None, -5.0), (3.0, -2.0)):
        poles = linearization(p, at=at).closed_loop().poles
        assert np.sort_complex(poles) == pytest.approx(np.sort_complex(np.append(pade, pole)), abs=1e-6), at


def test_a_gain_crossover_python_control_misses_is_found_on_the_response():
    # K (z - 0.8)/(z - 1) around c2d(4/(s^2 + 2 s + 4), 50 ms), K = 0.0195: |L| crosses 1 at 0.0124 Hz
    # (the integrator), which control.stability_margins misses: "phase margin inf" for a stable loop
    from hybridsim.analysis.stability import margins

    P = control.c2d(control.tf([4.0], [1.0, 2.0, 4.0]), 0.05)
    L = 0.0195 * control.tf([1.0, -0.8], [1.0, -1.0], 0.05) * P
    w = np.linspace(1e-4, 1.0, 200001)  # rad/s: the crossing, by a dense look of our own
    mag = np.abs(np.ravel(L(np.exp(1j * w * 0.05))))
    wc = w[np.argmin(np.abs(mag - 1.0))]
    pm = 180.0 + np.degrees(np.angle(complex(np.ravel(L(np.exp(1j * wc * 0.05)))[0])))
    m = margins(L)
    assert m["phase_margin_deg"] == pytest.approx(pm, abs=0.01)
    assert m["gain_crossover_hz"] == pytest.approx(wc / (2 * np.pi), rel=1e-3)


def test_a_gain_that_names_no_block_parameter_is_refused_as_the_table_says(tmp_path, capsys):
    # the table (and docs/settings.md) offered 'name' (a params name) for a gain, which check refused
    from hybridsim.app.cli import main

    row = next(line for line in (ROOT / "docs" / "settings.md").read_text().splitlines() if line.startswith("| `gains`"))
    assert "'name'" not in row and "'block.param'" in row
    p = tmp_path / "g.yaml"
    p.write_text("params: {K: 2.0}\nblocks:\n  g: {type: gain, K: $K}\n  i: {type: integrator}\n"
                 "wires: [g.y -> i.u, i.y -> g.u]\nanalysis:\n  gains: {K: K}\n")
    assert main(["check", str(p)]) == 2
    assert "g.yaml:7: analysis setting 'gains': 'K': 'K' is not a block's parameter" in capsys.readouterr().err


def test_the_step_figure_takes_a_whole_port_of_one_element(tmp_path):
    # analysis.step with output 'plant.y' (check accepts a whole port) stopped the report with exit 70
    from hybridsim.report.stability_figures import step_figure

    p = tmp_path / "msd.yaml"
    p.write_text("blocks:\n  setpoint: {type: step, final: 1.0}\n"
                 "  pid: {type: discrete_pid, Kp: 20.0, Ki: 15.0, Kd: 4.0, N: 40.0, rate: 100}\n"
                 "  plant: {type: transfer_function, num: [1.0], den: [1.0, 0.4, 4.0]}\n"
                 "wires: [setpoint.y -> pid.r, plant.y -> pid.y, pid.u -> plant.u]\n"
                 "simulation: {t_end: 0.2, step: 1.0e-3}\nlog: [plant.y]\n")
    figs = [step_figure(p, {}, {"step": {"input": "setpoint.y", "output": out, "size": 1.0, "set": {}}})[0]
            for out in ("plant.y", "plant.y[0]")]
    a, b = (f.axes[0].lines[-1].get_ydata() for f in figs)
    assert np.array_equal(a, b) and np.max(np.abs(a)) > 0.01
    _, stable = step_figure(p, {}, {"step": {"input": "setpoint.y", "output": "plant.y", "size": 1.0, "set": {}}})
    _, unstable = step_figure(p, {"pid.Kd": 400.0}, {"step": {"input": "setpoint.y", "output": "plant.y", "size": 1.0,
                                                               "ticks": 8, "set": {}}})
    assert stable["linear_unstable_poles"] == 0 and unstable["linear_unstable_poles"] > 0  # the report says so


DISTURBED = """\
name: disturbed
blocks:
  r: {type: constant, value: 0.0}
  dist: {type: step, initial: 0.0, final: 1.0, time: 0.0}
  e: {type: sum, signs: "+-"}
  C: {type: discrete_transfer_function, num: [0.5, -0.4], den: [1.0, -0.5], rate: 10}
  u: {type: sum, signs: "++"}
  P: {type: transfer_function, num: [1.0], den: [1.0, 2.0, 1.0]}
wires: [r.y -> e.u1, P.y -> e.u2, e.y -> C.u, C.y -> u.u1, dist.y -> u.u2, u.y -> P.u]
simulation: {t_end: 1.0}
"""


def test_an_input_the_plant_reads_continuously_enters_the_sampled_model(tmp_path):
    """A disturbance added after the hold, read by the plant between hits: the model from it is
    python-control's feedback(c2d(P), C) (it was the zero model: the input entered only at hits)."""
    p = tmp_path / "d.yaml"
    p.write_text(DISTURBED)
    lin = Linearization(hs.build(p)[0])
    C = control.tf([0.5, -0.4], [1.0, -0.5], 0.1)
    ref = control.feedback(control.c2d(control.tf([1.0], [1.0, 2.0, 1.0]), 0.1, "zoh"), C)
    t = np.arange(30) * 0.1
    for signal in ("dist.y[0]", "u.y[0]", "C.y[0]"):
        G = lin.io(signal, "P.y[0]")
        assert control.dcgain(G) == pytest.approx(5 / 6, rel=1e-7), signal
        assert control.step_response(G, t).outputs == pytest.approx(control.step_response(ref, t).outputs, abs=1e-9)


def test_a_large_held_input_does_not_swamp_the_differences():
    """msd_pid's plant is linear: its A is the same at every setpoint (a 1000 m step held a force of
    1.3e5 N, about which a step of 1e-11 m was lost in rounding: A came out 0)."""
    from hybridsim.runs.experiment import Experiment

    for final in (1.0, 1000.0):
        lin = Experiment(DIAGRAMS / "examples" / "msd_pid.yaml", **{"setpoint.final": final}).linearization()
        A, _ = lin.continuous()
        assert A == pytest.approx(np.array([[-0.4, -4.0], [1.0, 0.0]]), abs=1e-6), final
        assert lin.closed_loop().growth == pytest.approx(0.993018, abs=1e-6) and lin.fd_error < 1e-6


def test_bad_signals_and_times_from_python_are_named(tmp_path):
    """From the API, as a file's analysis section gets: an element past the port's width was an
    IndexError, `at="x"` a ValueError and `at=-1` the simulator's end-time message."""
    from hybridsim.analysis.stability import analyze
    from hybridsim.errors import InputError

    p = tmp_path / "d.yaml"
    p.write_text(DISTURBED)
    lin = Linearization(hs.build(p)[0])
    with pytest.raises(LinearizationError, match=r"input 'r.y\[3\]': r.y has 1 element\(s\)"):
        lin.io("r.y[3]", "P.y[0]")
    with pytest.raises(LinearizationError, match=r"output 'P.y\[7\]'"):
        lin.plant(["P.y[7]"])
    for at in ("x", -1, float("nan"), [0.5]):  # a list was a TypeError (unhashable)
        with pytest.raises(InputError, match="analysis setting 'at' must be a time in seconds >= 0"):
            analyze(p, at=at, sweeps=False)
    assert analyze(p, at=np.int64(0), sweeps=False)["stable"] is not None  # numpy's numbers are numbers


@pytest.mark.slow
def test_linearizing_on_the_contact_kink_says_so(capsys):
    """Fig 7 starts at first touch (0 N): the contact force's slopes are Kr and 0 there, the central
    difference their mean (the hand mode at 231.7 Hz instead of 270 Hz); analyze notes it."""
    import warnings

    from hybridsim.analysis import stability as an

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = an.analyze(DIAGRAMS / "fig7_force_steps.yaml", sweeps=False)
    assert res["plant_modes_hz"][0] == pytest.approx(231.66, abs=0.05)
    assert res["fd_error"] > 0.1
    assert any("kink or switch at the operating point" in line for line in an.summary_lines(res))


INTEGRATOR_LOOP = """
name: cascade
blocks:
  ref:   {type: step, initial: 0.0, final: 1.0, time: 0.05}
  outer: {type: discrete_pid, Kp: 8.0, Ki: 2.0, Kd: 0.5, N: 50.0, rate: 100}
  motor: {type: transfer_function, num: [1.0], den: [0.01, 0.1]}
  pos:   %s
wires: [ref.y -> outer.r, pos.y -> outer.y, outer.u -> motor.u, motor.y -> pos.u]
simulation: {t_end: 1.0}
"""


def test_an_integrators_mode_is_no_pole(tmp_path):
    """An integrator's mode (free, at a limit) is a state only events change: the loop closed through
    `integrator` has the poles of the same loop through the transfer function 1/s, none at z = 1 more
    (a helper found an 'undriven integrator pole' there), and check counts the blocks the file has."""
    from hybridsim.analysis import stability as an
    from hybridsim.format.build import check

    res = {}
    for kind, block in (("integrator", "{type: integrator}"), ("tf", "{type: transfer_function, num: [1.0], den: [1.0, 0.0]}")):
        p = tmp_path / f"{kind}.yaml"
        p.write_text(INTEGRATOR_LOOP % block)
        res[kind] = an.analyze(p, sweeps=False)
    assert res["integrator"]["integrator_modes"] == 0 == res["tf"]["integrator_modes"]
    poles = [np.sort_complex([complex(q["re"], q["im"]) for q in r["poles"]]) for r in res.values()]
    assert len(poles[0]) == len(poles[1]) and poles[0] == pytest.approx(poles[1], abs=1e-7)
    info = check(tmp_path / "integrator.yaml")
    assert info["blocks"] == 4 and info["states"] == 3 and info["held_states"] == 1


def test_a_gain_margin_at_dc_and_none_at_rounding():
    """A P controller, Kp = 2, around 1/(s - 1) sampled at 10 Hz: L(1) = -2, a phase crossover at DC, gain
    margin 0.5 (-6.02 dB) as python-control says (the grid started above DC and said none); and the loop of
    K / (s (s + 1)) has no phase crossover, where python-control's polynomial method finds |L| = 2e-16 at
    15 MHz (a gain margin of 313 dB was printed)."""
    from hybridsim.analysis.stability import margins

    L = 2.0 * control.sample_system(control.tf([1.0], [1.0, -1.0]), 0.1, "zoh")
    L = control.ss(control.tf([1.0, 0.0], [1.0, -1.0], 0.1)) * 0 + control.ss(L)  # a cancelled pole at z = 1
    m = margins(L)
    assert m["gain_margin"] == pytest.approx(0.5, rel=1e-4) and m["phase_crossover_hz"] == 0.0
    assert m["gain_margin"] == pytest.approx(control.stability_margins(L)[0], rel=1e-4)
    c = control.ss(control.tf([2.0], [1.0, 1.0, 0.0]))
    assert margins(c)["gain_margin"] is None and margins(c)["phase_margin_deg"] == pytest.approx(
        control.stability_margins(c)[1], rel=1e-6)


def test_a_count_is_no_pole(tmp_path):
    """A counter's count and a noise source's sample number grow by one at each hit whatever happens: as
    states of the loop they were poles at z = 1 ('undriven integrators'); they are held, as a mode is."""
    from hybridsim.analysis import stability as an

    p = tmp_path / "count.yaml"
    p.write_text(INTEGRATOR_LOOP.replace("wires:", "  n: {type: counter, rate: 100}\n"
                                          "  w: {type: noise, sigma: 0.0, rate: 100}\nwires:")
                 % "{type: transfer_function, num: [1.0], den: [1.0, 0.0]}")
    q = tmp_path / "plain.yaml"
    q.write_text(INTEGRATOR_LOOP % "{type: transfer_function, num: [1.0], den: [1.0, 0.0]}")
    a, b = (an.analyze(x, sweeps=False) for x in (p, q))
    assert a["integrator_modes"] == b["integrator_modes"] == 0 and len(a["poles"]) == len(b["poles"])


def test_a_relays_position_is_no_pole(tmp_path):
    """A relay's state is its position (on/off), which only its switches change: it was a pole at s = 0
    beside the plant's -1; held, the loop through the relay (on, nowhere near a switch) is the plant."""
    from hybridsim.analysis import stability as an

    p = tmp_path / "relay.yaml"
    p.write_text("blocks:\n  r: {type: constant, value: 0.3}\n  e: {type: sum, signs: '+-'}\n"
                 "  rel: {type: relay, switch_on: 0.1, switch_off: -0.1, y_on: 1.0, y_off: -1.0}\n"
                 "  plant: {type: transfer_function, num: [0.2], den: [1.0, 1.0]}\n"
                 "wires: [r.y -> e.u1, plant.y -> e.u2, e.y -> rel.u, rel.y -> plant.u]\n")
    res = an.analyze(p, sweeps=False)
    assert res["integrator_modes"] == 0 and [complex(q["re"], q["im"]) for q in res["poles"]] == pytest.approx([-1.0])


def test_margins_of_a_loop_with_a_pole_and_zero_at_z_1():
    # a discrete PID with Ki = 0 (its integrator unused) over a sampled integrator: L = 1/(z - 1) realized
    # with a pole and a zero more at z = 1; python-control's crossover at 0 Hz, where L is 0/0, gave a
    # gain margin of -111.7 dB. |L(-1)| = 1/2: 6.02 dB at Nyquist (5 Hz); |L| = 1 at pi/3: PM 60 deg
    from hybridsim.analysis.margins import margins

    L = control.ss(control.tf([1.0, -1.0], [1.0, -2.0, 1.0], 0.1))
    m = margins(L)
    assert m["gain_margin_db"] == pytest.approx(20 * np.log10(2.0), abs=1e-6)
    assert m["phase_crossover_hz"] == pytest.approx(5.0) and m["phase_margin_deg"] == pytest.approx(60.0, abs=1e-6)
    assert m["gain_crossover_hz"] == pytest.approx(10.0 / 6.0, rel=1e-6)


def test_a_loop_point_nothing_comes_back_to_is_said_so(tmp_path):
    # a source's output as a loop point, or a loop through a relay (slope 0): gain and phase margin
    # 'inf', read as very robust
    p = tmp_path / "d.yaml"
    p.write_text("blocks:\n  r: {type: step, final: 1.0}\n  e: {type: sum, signs: '+-'}\n"
                 "  C: {type: gain, K: 2.0}\n  P: {type: transfer_function, num: [1.0], den: [1.0, 1.0]}\n"
                 "wires: [r.y -> e.u1, P.y -> e.u2, e.y -> C.u, C.y -> P.u]\n"
                 "analysis: {points: {src: 'r.y[0]', u: 'C.y[0]'}}\n")
    res = hs.analyze(p, sweeps=False)
    assert res["loops"]["src"]["no_return"] and not res["loops"]["u"]["no_return"]
    assert res["loops"]["u"]["gain_margin"] is None and res["loops"]["u"]["phase_margin_deg"] is not None
    from hybridsim.analysis.stability import summary_lines

    said = "\n".join(summary_lines(res))
    assert "loop src (r.y[0]): opened here nothing comes back (L = 0)" in said and "loop u (C.y[0]): gain margin" in said


def test_an_analysis_about_a_later_state_says_which_in_its_header(caplog):
    # --at 10 printed the header of the initial state's analysis, and nothing for the minutes it ran
    import logging

    from hybridsim.analysis.stability import summary_lines
    from conftest import DIAGRAMS

    with caplog.at_level(logging.INFO, logger="hybridsim"):
        res = hs.analyze(DIAGRAMS / "examples" / "msd_pid.yaml", at=3.5, sweeps=False)
    assert res["at"] == 3.5 and "about the state at t = 3.5 s)" in summary_lines(res)[0]
    assert "at t = 3.5 s (past the diagram's t_end, 3 s): every rate and gain point" in caplog.text
    assert hs.analyze(DIAGRAMS / "examples" / "msd_pid.yaml", sweeps=False)["at"] is None
