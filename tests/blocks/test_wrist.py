import math

import numpy as np
import pytest

from hybridsim.blocks.paper.wrist import Wrist


def test_eq7_eq8_hand_checked():
    w = Wrist(Kw=8e5, M3=0.58)
    q1 = 0.3
    x = np.array([1e-6, -2e-6, 0.0, 0.0])
    d = w.derivatives(0, x, [np.array([q1, 0.5]), np.zeros(2), np.array([4.0])])
    assert d[2] == pytest.approx((-0.8 - 4.0 * math.cos(q1)) / 0.58)
    assert d[3] == pytest.approx((1.6 + 4.0 * math.sin(q1)) / 0.58)


def test_sensor_reads_minus_Kw_w_and_hand_position():
    w = Wrist(Kw=8e5)
    q = np.array([0.0, 0.5])
    F, f_arm, x, v = w.output(0, np.array([1e-5, 2e-5, 0, 0]), [q, np.zeros(2), np.zeros(1)])
    assert F == pytest.approx((-8.0, -16.0))
    assert f_arm == pytest.approx((8.0, 16.0))
    # q1 = 0: Lambda = (0.5, -0.153), R = I
    assert x == pytest.approx((0.5 + 1e-5, -0.153 + 2e-5))


def test_preload_is_in_static_balance():
    w = Wrist(Kw=8e5, preload=5.0)
    q = np.array([0.31, 0.476])
    x0 = w.initial_state([q, np.zeros(2), np.zeros(1)])
    d = w.derivatives(0, x0, [q, np.zeros(2), np.array([5.0])])
    assert np.allclose(d, 0, atol=1e-9)
    # the sensed force rotated into {C} is (5, 0)
    F = w.output(0, x0, [q, np.zeros(2), np.zeros(1)])[0]
    c, s = math.cos(q[0]), math.sin(q[0])
    assert (c * F[0] - s * F[1], s * F[0] + c * F[1]) == pytest.approx((5.0, 0.0))


def test_hand_velocity_is_the_time_derivative_of_hand_position():
    w = Wrist(Kw=8e5)
    q, qd = np.array([0.3, 0.48]), np.array([0.7, -0.2])
    x, xd = np.array([1e-5, -2e-5]), np.array([0.01, 0.03])
    h = 1e-7

    def hand(t):
        return np.array(w.output(0, np.concatenate([x + t * xd, xd]), [q + t * qd, qd, np.zeros(1)])[2])

    v = w.output(0, np.concatenate([x, xd]), [q, qd, np.zeros(1)])[3]
    assert v == pytest.approx((hand(h) - hand(-h)) / (2 * h), rel=1e-7)
