"""discrete_pid's conventions (integrator and filter methods, sign-aware clamping) and the continuous pid."""
import numpy as np
import pytest

import hybridsim as hs
from hybridsim.blocks.discrete.basic import DiscretePID

from test_discrete import sequence  # noqa: E402 (the sibling module)
from paths import PATHS  # noqa: E402



@pytest.mark.parametrize("imethod, fmethod", [("forward", "forward"), ("backward", "trapezoidal"),
                                              ("trapezoidal", "backward"), ("trapezoidal", "trapezoidal")])
def test_discrete_pid_methods_equal_their_z_transfer_functions(imethod, fmethod):
    import control as ct

    T, Kp, Ki, Kd, N = 0.01, 2.0, 5.0, 0.3, 40.0
    z = ct.tf([1, 0], [1], T)
    integ = {"forward": T / (z - 1), "backward": T * z / (z - 1), "trapezoidal": T * (z + 1) / (2 * (z - 1))}
    s = {"forward": (z - 1) / T, "backward": (z - 1) / (T * z), "trapezoidal": 2 * (z - 1) / (T * (z + 1))}
    C = Kp + Ki * integ[imethod] + Kd * N * s[fmethod] / (s[fmethod] + N)
    e = np.sin(0.3 * np.arange(60)) + 0.2
    ref = ct.forced_response(ct.minreal(C, verbose=False), T=np.arange(60) * T, U=e).outputs
    pid = DiscretePID(Kp=Kp, Ki=Ki, Kd=Kd, N=N, rate=1 / T, integrator_method=imethod, filter_method=fmethod)
    ours = sequence(pid, [[ek, 0.0] for ek in e])[:, 0]
    assert np.max(np.abs(ours - ref)) < 1e-11


def _loop(sign, anti_windup="clamping", path=()):
    """A saturating PI loop around 1/(s (s + 1)); sign -1 mirrors controller and plant."""
    d = hs.Diagram("mirror")
    d.add(hs.registry.lookup("step")("r", final=1.0))
    d.add(DiscretePID("c", Kp=sign * 3.0, Ki=sign * 4.0, lower=-1.5, upper=1.5, anti_windup=anti_windup,
                      rate=100))
    d.add(hs.registry.lookup("transfer_function")("p", num=[sign * 1.0], den=[1.0, 1.0, 0.0]))
    for a, b in (("r.y", "c.r"), ("p.y", "c.y"), ("c.u", "p.u")):
        d.connect(a, b)
    return hs.Simulator(d.build(), hs.RK4(1e-3), log=["p.y", "c.u"], log_period=0.01, **dict(path)).run(8.0)


def test_a_mirrored_loop_clamps_as_its_original_does():
    plain, mirror = _loop(1.0), _loop(-1.0)
    assert np.max(np.abs(plain["p.y[0]"] - mirror["p.y[0]"])) < 1e-12  # (-C)(-P) = C P
    assert np.max(np.abs(plain["c.u[0]"] + mirror["c.u[0]"])) < 1e-12
    wound = _loop(1.0, "none")
    over = lambda r: r["p.y[0]"].max() - 1.0  # noqa: E731
    assert over(mirror) < 0.8 * over(wound)  # clamping cuts the overshoot in both


def _cloop(path, sign=1.0, limits=None, anti_windup="clamping", step=5e-4, **sim):
    """A continuous PID around m x'' + c x' + k x = u (1 kg, 0.4 N s/m, 4 N/m), a unit setpoint step."""
    from paths import block, run

    lim = dict(lower=-limits, upper=limits) if limits else {}
    blocks = [block("step", "r", final=1.0),
              block("pid", "c", Kp=sign * 20.0, Ki=sign * 15.0, Kd=sign * 4.0, N=20.0, anti_windup=anti_windup, **lim),
              block("transfer_function", "p", num=[sign * 1.0], den=[1.0, 0.4, 4.0])]
    return run(path, blocks, [("r.y", "c.r"), ("p.y", "c.y"), ("c.u", "p.u")], 3.0, ["p.y", "c.u"], step=step,
               **sim)


@pytest.mark.slow
@pytest.mark.parametrize("path", PATHS)
def test_continuous_pid_equals_python_controls_closed_loop(path):
    import control as ct
    from paths import check

    res = _cloop(path)
    s = ct.tf("s")
    C = 20.0 + 15.0 / s + 4.0 * 20.0 * s / (s + 20.0)
    ref = ct.forced_response(ct.feedback(C / (s * s + 0.4 * s + 4.0), 1), T=res.t, U=np.ones(res.t.size)).outputs
    check("pid", path, res["p.y[0]"], ref, 1e-8)


@pytest.mark.slow  # 0.1 ms steps with located switches
@pytest.mark.parametrize("path", PATHS)
def test_continuous_pid_clamps_on_the_sign_of_ki_e(path):
    from scipy.integrate import solve_ivp
    from paths import check

    res = _cloop(path, limits=3.0, locate_switches=True, step=1e-4)
    mirror = _cloop(path, sign=-1.0, limits=3.0, locate_switches=True, step=1e-4)
    check("pid", path, mirror["p.y[0]"], res["p.y[0]"], 1e-12)  # (-C)(-P) = C P

    def f(t, z):  # the same loop written out: x, x', I, F
        x, v, i, fs = z
        e = 1.0 - x
        u = 20.0 * e + i + 4.0 * 20.0 * (e - fs)
        di = 0.0 if (u > 3.0 and 15.0 * e > 0) or (u < -3.0 and 15.0 * e < 0) else 15.0 * e
        return [v, np.clip(u, -3.0, 3.0) - 0.4 * v - 4.0 * x, di, 20.0 * (e - fs)]

    ref = solve_ivp(f, (0, 3.0), [0, 0, 0, 0], t_eval=res.t, method="LSODA", rtol=1e-10, atol=1e-12, max_step=1e-3)
    check("pid", path, res["p.y[0]"], ref.y[0], 5e-7)
    assert res["c.u[0]"].max() == 3.0 and res["c.u[0]"].min() >= -3.0


T5 = """\
name: t5
blocks:
  r:   {type: step, initial: 1.0, final: -1.0, time: 3.0}
  pid: {type: pid, Kp: 2.0, Ki: 5.0, upper: 1.5, lower: -1.5, anti_windup: clamping}
  y:   {type: first_order, tau: 1.0, initial: 0.0}
wires: [r.y -> pid.r, y.y -> pid.y, pid.u -> y.u]
simulation: {t_end: 1.0, solver: rk45, step: 1.0e-2, log_period: 0.01}
log: [pid.u]
"""


def test_a_pid_sliding_along_its_clamp_is_named_with_what_to_do(tmp_path):
    """Held at 1.5 while y rises to r = 1: clamped, the output leaves the limit, integrating, it
    returns (a Filippov sliding mode); the error said to give a relay hysteresis. The advice works:
    back-calculation has no such edge."""
    p = tmp_path / "t5.yaml"
    p.write_text(T5)
    with pytest.raises(hs.SimulationError, match=r"block 'pid'.*use anti_windup: back_calculation"):
        hs.simulate(p)
    res = hs.simulate(p, **{"pid.anti_windup": "back_calculation"})
    assert res["pid.u[0]"].max() == pytest.approx(1.5)
