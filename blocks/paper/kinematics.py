"""Kinematics of the two-joint arm (revolute q1, prismatic q2) and its blocks.

Eq 3a: C_X = Lambda(q); eq 12b: C_Xdot = J(q) qdot; eqs 14a-b: q_e = J^-1 X_e,
tau_e = J^T F_e. docs/model.md gives the corrected Jacobian.
"""
import math

import numpy as np

from hybridsim.engine.block import Block
from hybridsim.errors import ParameterError
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.engine.registry import register

from hybridsim.blocks._util import finite_matrix, scalar, vector

GROUP = "paper"  # where `hybridsim blocks` lists this module's blocks

L_OFFSET = 0.153  # link offset l, m (Appendix A)


@kernel
def endpoint_xy(q, l):
    """Lambda(q), eq 3a: arm endpoint (X, Y) in {C}, m."""
    c, s = math.cos(q[0]), math.sin(q[0])
    return (q[1] * c + l * s, q[1] * s - l * c)


def endpoint(q, l=L_OFFSET):
    """Lambda(q) as an array."""
    return np.array(endpoint_xy(q, l))


@kernel
def jacobian_rows(q, l):
    """J(q) = d Lambda / dq (docs/model.md's corrected form) as ((J11, J12), (J21, J22))."""
    c, s = math.cos(q[0]), math.sin(q[0])
    return (-q[1] * s + l * c, c), (q[1] * c + l * s, s)


def jacobian(q, l=L_OFFSET):
    """J(q) as a 2x2 array."""
    return np.array(jacobian_rows(q, l))


def inverse_kinematics(X, Y, l=L_OFFSET):
    """Joint position (q1 rad, q2 m) that puts the endpoint at (X, Y)."""
    r2 = X * X + Y * Y - l * l
    if r2 <= 0:
        raise ValueError(f"endpoint ({X}, {Y}) is within the link offset {l} m of the base")
    q2 = math.sqrt(r2)
    return np.array([math.atan2(Y, X) + math.atan2(l, q2), q2])


def rotation(q1):
    """C_H R(q1): rotates a vector from the hand frame {H} into {C}."""
    c, s = math.cos(q1), math.sin(q1)
    return np.array([[c, -s], [s, c]])


class _ArmMap(Block):
    """A map of a 2-vector that depends on the arm configuration q."""

    def __init__(self, name, arg, out, l):
        super().__init__(name)
        self.params = (scalar(l, "l"),)
        self.declare_input("q", 2)
        if arg:
            self.declare_input(arg, 2)
        self.declare_output(out, 2)


@register("forward_kinematics")
class ForwardKinematics(_ArmMap):
    """C_X = Lambda(q) (eq 3a). In: q [rad, m]. Out: X [m]."""

    def __init__(self, name="fk", l=L_OFFSET):
        super().__init__(name, None, "X", l)


@kernel
def fk_output(p, t, x, u):
    return (endpoint_xy(u[0], p[0]),)  # eq 3a


@register("jacobian")
class Jacobian(_ArmMap):
    """C_Xdot = J(q) qdot (eq 12b). In: q, qd. Out: Xd [m/s]."""

    def __init__(self, name="jac", l=L_OFFSET):
        super().__init__(name, "qd", "Xd", l)


@kernel
def jacobian_output(p, t, x, u):
    (a, b), (c, d) = jacobian_rows(u[0], p[0])
    qd = u[1]
    return ((a * qd[0] + b * qd[1], c * qd[0] + d * qd[1]),)  # eq 12b


@register("inverse_jacobian")
class InverseJacobian(_ArmMap):
    """q_e = J(q)^-1 X_e (eq 14a). In: q, X. Out: q."""

    def __init__(self, name="jinv", l=L_OFFSET):
        super().__init__(name, "X", "qe", l)


@kernel
def inverse_jacobian_output(p, t, x, u):
    (a, b), (c, d) = jacobian_rows(u[0], p[0])
    X = u[1]
    det = a * d - b * c  # = -q2: J is singular only at q2 = 0
    return (((d * X[0] - b * X[1]) / det, (a * X[1] - c * X[0]) / det),)  # eq 14a


@register("jacobian_transpose")
class JacobianTranspose(_ArmMap):
    """tau = J(q)^T F (eq 14b). In: q, F [N]. Out: tau [N m, N]."""

    def __init__(self, name="jt", l=L_OFFSET):
        super().__init__(name, "F", "tau", l)


@kernel
def jacobian_transpose_output(p, t, x, u):
    (a, b), (c, d) = jacobian_rows(u[0], p[0])
    F = u[1]
    return ((a * F[0] + c * F[1], b * F[0] + d * F[1]),)  # eq 14b


@register("force_transform")
class ForceTransform(_ArmMap):
    """C_F = C_H T H_F (eq 3b), planar: C_H T = R(q1). In: q, F. Out: F in {C}."""

    def __init__(self, name="ft"):
        super().__init__(name, "F", "CF", L_OFFSET)


@kernel
def force_transform_output(p, t, x, u):
    c, s = math.cos(u[0][0]), math.sin(u[0][0])
    f1, f2 = u[1][0], u[1][1]
    return ((c * f1 - s * f2, s * f1 + c * f2),)  # eq 3b


def force_transform_6d(R, V):
    """The 6x6 C_H T of eq 3b: [[R, 0], [V x R, R]] for a hand-to-{C} offset V."""
    R = np.asarray(R, float)
    vx = np.array([[0, -V[2], V[1]], [V[2], 0, -V[0]], [-V[1], V[0], 0]], float)
    T = np.zeros((6, 6))
    T[:3, :3] = R
    T[3:, :3] = vx @ R
    T[3:, 3:] = R
    return T


@register("force_transform_6d")
class ForceTransform6D(Block):
    """C_F = C_H T H_F (eq 3b), general form for a fixed rotation and offset.

    Parameters: ``rotation`` (3x3, {H} to {C}), ``offset`` V (m, origin of
    {H} seen from {C}). In: F (6: forces N, torques N m). Out: CF (6).
    """

    def __init__(self, name="ft6", rotation=((1, 0, 0), (0, 1, 0), (0, 0, 1)), offset=(0, 0, 0)):
        super().__init__(name)
        R = finite_matrix(rotation, "rotation")
        if R.shape != (3, 3):
            raise ParameterError("rotation", f"must be 3x3, got shape {R.shape}")
        self.params = (force_transform_6d(R, vector(offset, "offset", 3)),)
        self.declare_input("F", 6)
        self.declare_output("CF", 6)


@kernel
def force_transform_6d_output(p, t, x, u):
    return (np.dot(p[0], np.asarray(u[0])),)  # eq 3b


ForwardKinematics.kernels = Kernels(output=fk_output)
Jacobian.kernels = Kernels(output=jacobian_output)
InverseJacobian.kernels = Kernels(output=inverse_jacobian_output)
JacobianTranspose.kernels = Kernels(output=jacobian_transpose_output)
ForceTransform.kernels = Kernels(output=force_transform_output)
ForceTransform6D.kernels = Kernels(output=force_transform_6d_output)
