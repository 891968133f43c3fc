import numpy as np
import pytest

from hybridsim.blocks.manipulator import Manipulator


def test_eq5_eq6_without_friction_hand_checked():
    arm = Manipulator(friction=False, q0=(0.3, 0.5))
    x = np.array([0.3, 0.5, 0.0, 0.0])
    d = arm.derivatives(0, x, [np.array([1.0, 2.0]), np.array([3.0, 4.0])])
    # I1(0.5) = 3.98 - 2.625 + 1.6175 = 2.9725; F1 = 1 + 0.5*4 + 0.153*3 = 3.459
    assert d[2] == pytest.approx(3.459 / 2.9725, rel=1e-12)
    # (M2 + M3) = 7.26; F2 = 2 + 3
    assert d[3] == pytest.approx(5.0 / 7.26, rel=1e-12)
    assert list(d[:2]) == [0.0, 0.0]


def test_sliding_friction_opposes_velocity():
    arm = Manipulator(q0=(0.3, 0.5))
    x = np.array([0.3, 0.5, 0.1, -0.1])
    d = arm.derivatives(0, x, [np.zeros(2), np.zeros(2)])
    assert d[2] == pytest.approx(-5.0 / 2.9725)
    assert d[3] == pytest.approx(3.5 / 7.26)


def test_sticking_holds_below_static_limit_and_breaks_above():
    arm = Manipulator(q0=(0.3, 0.5))
    x = np.array([0.3, 0.5, 0.0, 0.0])
    held = arm.derivatives(0, x, [np.array([5.7, 4.5]), np.zeros(2)])
    assert held[2] == 0.0 and held[3] == 0.0
    moving = arm.derivatives(0, x, [np.array([0.0, 6.0]), np.zeros(2)])
    assert moving[3] == pytest.approx((6.0 - 4.6) / 7.26)


def test_stick_band_brings_velocity_to_rest():
    arm = Manipulator(q0=(0.3, 0.5), stick_band=1e-4, stick_time=1e-3)
    x = np.array([0.3, 0.5, 0.0, 5e-5])
    d = arm.derivatives(0, x, [np.zeros(2), np.zeros(2)])
    assert d[3] == pytest.approx(-5e-5 / 1e-3)


def test_endpoint0_uses_inverse_kinematics():
    arm = Manipulator(endpoint0=(0.5, 0.0))
    q = arm.initial_state()[:2]
    assert q[1] == pytest.approx(np.sqrt(0.5**2 - 0.153**2))
    assert q[0] == pytest.approx(np.arctan2(0.153, q[1]))


def test_zero_crossings_mark_stick_slip():
    arm = Manipulator()
    z = arm.zero_crossings(0, np.array([0, 0.5, 2e-4, -5e-5]), None)
    assert z[0] > 0 > z[1]
