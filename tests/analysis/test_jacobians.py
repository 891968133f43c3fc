"""Finite-difference Jacobians: the error estimate, hand-checked."""
import numpy as np
import pytest

from hybridsim.analysis.jacobians import checked_jacobian

STEPS = np.array([1e-6, 1e-6])


def test_a_smooth_function_is_differenced_to_its_derivative():
    J, err = checked_jacobian(lambda x: np.array([np.sin(x[0]) * x[1], x[1] ** 3]), np.array([0.3, 2.0]), STEPS)
    assert J == pytest.approx(np.array([[2 * np.cos(0.3), np.sin(0.3)], [0.0, 12.0]]), rel=1e-8)
    assert err < 1e-8


def test_a_kink_at_the_point_is_half_its_jump_in_the_error_estimate():
    """max(0, 3 x) at x = 0: slopes 3 and 0, the central difference their mean 1.5; the estimate says
    the entry is 1.5 from either side, relative to the larger slope: 0.5, however large the other
    entries are (a fast mode elsewhere in a helper's diagram hid the kink)."""
    J, err = checked_jacobian(lambda x: np.array([max(0.0, 3 * x[0]) + 2 * x[1], np.sin(x[0])]),
                              np.array([0.0, 1.0]), STEPS)
    assert J[0, 0] == pytest.approx(1.5) and err == pytest.approx(0.5, rel=1e-6)
    _, err = checked_jacobian(lambda x: np.array([max(0.0, 3 * x[0]) + 2e6 * x[1], abs(x[0])]),
                              np.array([0.0, 1.0]), STEPS)
    assert err == pytest.approx(1.0, rel=1e-6)  # |x| at 0: slopes -1 and 1, their mean 0
    _, err = checked_jacobian(lambda x: np.array([max(0.0, 3 * x[0]) + 2 * x[1]]), np.array([0.1, 1.0]), STEPS)
    assert err < 1e-8  # off the kink


def test_a_value_at_the_point_alone_is_not_a_kink():
    """An equality test (1 at x = 0 exactly, 0 around it): both sides agree on slope 0."""
    J, err = checked_jacobian(lambda x: np.array([float(x[0] == 0.0) + x[1]]), np.array([0.0, 1.0]), STEPS)
    assert J[0, 0] == 0.0 and err < 1e-8



def test_a_column_rounding_hid_entirely_is_taken_again():
    """x' = 1e5 - 3 x about x = 0 with a step of 1e-12: the difference (6e-12) is below the rounding of 1e5,
    every entry came out 0 and the pole vanished (a helper's constant bias); a larger step finds -3."""
    J, err = checked_jacobian(lambda x: np.array([1e5 - 3.0 * x[0]]), np.array([0.0]), np.array([1e-12]))
    assert J[0, 0] == pytest.approx(-3.0, rel=1e-6) and err < 1e-6


def test_a_jump_at_the_point_has_no_slope():
    """floor(x) at x = 1: the central difference grows as 1/step; its estimate is 1 (it was 7.5e-9 beside a
    pole of -4001)."""
    J, err = checked_jacobian(lambda x: np.array([np.floor(x[0]) + x[1]]), np.array([1.0, 0.5]), STEPS)
    assert err == 1.0
