import numpy as np
import pytest

from hybridsim.blocks.paper.controllers import ForcePI, PositionPID


def test_pid_eq15a_first_tick_includes_current_sample():
    pid = PositionPID(Kp=(2.0, 3.0), Ki=(10.0, 20.0), Kd=(1.0, 1.0), rate=100)
    e, ed = np.array([0.1, -0.2]), np.array([0.5, 0.0])
    z = np.zeros(2)
    tau = pid.output(0, z, [e, ed])[0]
    # Kp e + Ki (0 + e T) + Kd ed, T = 0.01
    assert tau == pytest.approx((0.2 + 0.01 + 0.5, -0.6 - 0.04))
    z = pid.update(0, z, [e, ed])
    assert z == pytest.approx((0.001, -0.002))
    assert pid.T == 0.01


def test_force_pi_eq15b_limiter_clips_integrand_only():
    fpi = ForcePI(Kp=(0.4, 0.3), Ki=(240.0, 220.0), limit=(0.004, 0.1), rate=60)
    e, ff = np.array([1.0, -1.0]), np.array([2.0, 3.0])
    tau = fpi.output(0, np.zeros(2), [e, ff])[0]
    T = 1 / 60
    assert tau == pytest.approx((2.0 + 0.4 + 240 * 0.004 * T, 3.0 - 0.3 - 220 * 0.1 * T))
    assert fpi.update(0, np.zeros(2), [e, ff]) == pytest.approx((0.004 * T, -0.1 * T))


def test_rate_or_period_required():
    with pytest.raises(ValueError):
        PositionPID()
