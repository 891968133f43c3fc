"""The two example diagrams built from the new blocks, each against a computation of its own written here."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import hybridsim as hs
from conftest import DIAGRAMS
from paths import check
from test_noise import block_normals


def motor_reference(t_end=2.0, dt=2e-5):
    """The motor loop by RK4 at dt: play operator on the motor angle, the dead time as an exact history lookup."""
    tau_d, h, n_delay = 0.02, 0.01, round(0.02 / dt)
    steps = round(t_end / dt)
    hist = np.zeros(steps + 1)  # load angle at k dt

    def delayed(t):
        s = t - tau_d
        if s < 0:
            return 0.0
        k = min(int(s / dt), steps - 1)
        return hist[k] + (s / dt - k) * (hist[k + 1] - hist[k])

    def f(t, z):
        th, w, i, fs = z
        e = 1.0 - delayed(t)
        v = 2.0 * e + i + 0.1 * 100.0 * (e - fs)
        u = min(max(v, -1.0), 1.0)
        di = 0.0 if (v > 1.0 and e > 0) or (v < -1.0 and e < 0) else 1.0 * e
        return np.array([w, 100.0 * u - 10.0 * w, di, 100.0 * (e - fs)]), u

    z, y, out = np.zeros(4), 0.0, [(0.0, 0.0, 0.0)]
    for k in range(steps):
        t = k * dt
        k1, u = f(t, z)
        k2, _ = f(t + dt / 2, z + dt / 2 * k1)
        k3, _ = f(t + dt / 2, z + dt / 2 * k2)
        k4, _ = f(t + dt, z + dt * k3)
        z = z + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        y = min(max(y, z[0] - h), z[0] + h)  # the play operator
        hist[k + 1] = y
        out.append((y, z[0], f((k + 1) * dt, z)[1]))
    return np.array(out)[:: round(0.01 / dt)]


@pytest.mark.slow  # 2000 located buffer samples
def test_motor_with_backlash_and_a_dead_time_under_a_continuous_pid():
    res = hs.simulate(DIAGRAMS / "examples" / "motor_backlash_delay.yaml")
    ref = motor_reference()
    check("example motor: load angle", "generic", res["gear.y[0]"], ref[:, 0], 2e-5)
    check("example motor: motor angle", "generic", res["split.y1[0]"], ref[:, 1], 2e-5)
    # the torque limit binds at the start; the load settles at the setpoint within the play
    assert res["pid.u[0]"][:10].tolist() == [1.0] * 10
    assert abs(res["gear.y[0]"][-1] - 1.0) < 0.01


def thermostat_reference(t_end=600):
    """Room and sensor by solve_ivp, second by second (the noise sample constant over each), the relay's
    thresholds as terminal events: on when the measurement falls through 19.5, off when it rises through
    20.5, only the threshold of the relay's current position watched (a relay that is off does not see
    the measurement rise through 20.5 again). The relay starts on: the measurement, 15, is below 19.5."""
    noise = 0.2 * block_normals(2026, t_end, 0)
    tout = lambda t: np.interp(t, [0.0, 200.0, 400.0, 600.0], [5.0, 0.0, 8.0, 12.0])  # noqa: E731
    z, on, switches, rows = np.array([15.0, 15.0]), True, [], [[15.0, 15.0, 1.0]]

    def off(t, s):  # rises through 20.5 while on: off
        return s[1] - 20.5

    def on_(t, s):  # falls through 19.5 while off: on
        return s[1] - 19.5

    off.terminal, off.direction, on_.terminal, on_.direction = True, 1, True, -1
    for k in range(t_end):
        t0 = float(k)

        def f(t, s):
            return [(tout(t) - s[0]) / 60.0 + 0.5 * on, (s[0] + noise[k] - s[1]) / 2.0]

        while True:
            sol = solve_ivp(f, (t0, k + 1.0), z, events=[off if on else on_], rtol=1e-11, atol=1e-11,
                            method="DOP853")
            z = sol.y[:, -1]
            if sol.status != 1:
                break
            t0, on = sol.t[-1], not on
            switches.append(t0)
            # step 1 us past the root without events, so that the root itself is not found again
            sol = solve_ivp(f, (t0, t0 + 1e-6), z, rtol=1e-11, atol=1e-11, method="DOP853")
            t0, z = t0 + 1e-6, sol.y[:, -1]
        rows.append([z[0], z[1], float(on)])
    return np.array(rows), switches


@pytest.mark.slow  # 30 000 steps
def test_thermostat_with_relay_noise_and_a_lookup():
    # the first 300 s of the example's 600 (36 switches; the whole run took 25 s of the suite)
    res = hs.simulate(DIAGRAMS / "examples" / "thermostat.yaml", t_end=300.0)
    ref, switches = thermostat_reference(300)
    check("example thermostat: room", "generic", res["room.y[0]"][::10], ref[:, 0], 1e-6)  # each second
    check("example thermostat: sensor", "generic", res["sensor.y[0]"][::10], ref[:, 1], 1e-6)
    check("example thermostat: switch times", "generic", [t for t, _ in res.meta["events"]], switches, 1e-6)
    assert len(switches) > 30 and 19.0 < res["room.y[0]"][300:].mean() < 21.0
