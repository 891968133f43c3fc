import numpy as np
import pytest

from hybridsim.blocks.paper.kinematics import (ForceTransform, ForceTransform6D, InverseJacobian,
                               endpoint, inverse_kinematics, jacobian)


def test_endpoint_hand_checked():
    assert endpoint([0.0, 0.5]) == pytest.approx((0.5, -0.153))
    assert endpoint([np.pi / 2, 0.5]) == pytest.approx((0.153, 0.5))


def test_jacobian_matches_finite_differences():
    q = np.array([0.4, 0.6])
    h = 1e-7
    num = np.column_stack([(endpoint(q + h * e) - endpoint(q - h * e)) / (2 * h) for e in np.eye(2)])
    assert jacobian(q) == pytest.approx(num, abs=1e-8)


def test_inverse_kinematics_round_trip():
    q = inverse_kinematics(0.5, 0.3)
    assert endpoint(q) == pytest.approx((0.5, 0.3), abs=1e-14)


def test_inverse_jacobian_solves():
    q = np.array([0.3, 0.5])
    dq = InverseJacobian().output(0, None, [q, np.array([1e-3, 2e-3])])[0]
    assert jacobian(q) @ dq == pytest.approx((1e-3, 2e-3))


def test_force_transform_rotates_hand_to_constraint_frame():
    cf = ForceTransform().output(0, None, [np.array([np.pi / 2, 0.5]), np.array([1.0, 0.0])])[0]
    assert cf == pytest.approx((0.0, 1.0), abs=1e-15)


def test_force_transform_6d_adds_moment_of_offset():
    ft = ForceTransform6D(offset=(0.0, 0.0, 0.1))
    out = ft.output(0, None, [np.array([1.0, 0, 0, 0, 0, 0])])[0]
    # torque = V x f = (0, 0, 0.1) x (1, 0, 0) = (0, 0.1, 0)
    assert out == pytest.approx((1, 0, 0, 0, 0.1, 0))
