"""Kernels of the robot blocks for the fused path: plain floats, one Pinocchio call per use.

The blocks' methods (:mod:`hybridsim.blocks.robot`) stay the generic path's
reference; these are the same laws written for :mod:`hybridsim.engine.fused`, which
calls them with tuples of floats and no buffers between blocks. The rigid-body
algorithms stay Pinocchio's: the tool frame's Jacobian is computed once per
right-hand side by ``robot_kinematics`` and reused by ``robot_arm`` for J^T w
when both name the same robot and frame at the same joint positions
(:data:`_JACOBIANS`), the forward dynamics is one call of the articulated-body
algorithm. They are marked ``python_only``: numba cannot compile Pinocchio.
"""
import math
from typing import NamedTuple

import numpy as np

from hybridsim.engine.kernels import Kernels

#: the last tool-frame Jacobian per (robot file, frame): (joint positions as bytes, 6xN array)
_JACOBIANS = {}


def _pin():
    import pinocchio

    return pinocchio


def frame_jacobian(model, data, key, q):
    """The tool frame's 6xN Jacobian (world axes at the frame's origin) at ``q`` (array).
    Reuses the one computed last for ``key`` at the same ``q``; returns ``(J, fresh)``:
    ``fresh`` when this call computed it (then ``data`` holds the frame placements at ``q``)."""
    tag = q.tobytes()
    got = _JACOBIANS.get(key)
    if got is not None and got[0] == tag:
        return got[1], False
    pin = _pin()
    J = pin.computeFrameJacobian(model, data, q, key[1], pin.LOCAL_WORLD_ALIGNED)
    _JACOBIANS[key] = (tag, J)
    return J, True


# -- robot_kinematics ------------------------------------------------------------------
class KinematicsParams(NamedTuple):
    model: object
    data: object
    key: tuple  # (robot file, frame id)


def kinematics_output(p, t, x, u):
    """p, R (row by row), twist = J q' and J (row by row) of the tool frame."""
    q = np.array(u[0], float)
    J, fresh = frame_jacobian(p.model, p.data, p.key, q)
    pin = _pin()
    if not fresh:  # the placements in data may be of another q
        pin.forwardKinematics(p.model, p.data, q)
    pose = pin.updateFramePlacement(p.model, p.data, p.key[1])
    return (pose.translation.tolist(), pose.rotation.ravel().tolist(), (J @ np.array(u[1], float)).tolist(),
            J.ravel().copy())


KINEMATICS = Kernels(output=kinematics_output, python_only=True)


# -- robot_arm -----------------------------------------------------------------------
class ArmParams(NamedTuple):
    model: object       # with the arm's gravity
    data: object
    key: tuple          # (robot file, frame id) of the tool frame the wrench acts on
    n: int
    b: np.ndarray       # viscous damping per joint
    friction: bool
    stribeck: bool
    lugre: bool
    tau_c: np.ndarray
    tau_s: np.ndarray
    v_s: np.ndarray
    sigma0: np.ndarray
    sigma1: np.ndarray
    band: float
    t_stick: float


def arm_output(p, t, x, u):
    """q and q'."""
    return (x[:p.n], x[p.n:2 * p.n])


def _sliding_level(p, v):
    if not (p.stribeck or p.lugre):
        return p.tau_c
    return p.tau_c + (p.tau_s - p.tau_c) * np.exp(-(v / p.v_s) ** 2)


def arm_derivatives(p, t, x, u):
    """(q', q'', z'): ABA under tau + J^T w - b q' + B (Karnopp, Stribeck or LuGre friction)."""
    pin = _pin()
    n = p.n
    x = np.array(x, float)
    q, v = x[:n], x[n:2 * n]
    f = np.array(u[0], float) - p.b * v
    if any(u[1]):
        J, _ = frame_jacobian(p.model, p.data, p.key, q)
        f = f + J.T @ np.array(u[1], float)
    if p.lugre:
        z = x[2 * n:]
        g = _sliding_level(p, v)
        zd = v - np.divide(p.sigma0 * np.abs(v) * z, g, out=np.zeros(n), where=g > 0)
        acc = pin.aba(p.model, p.data, q, v, f - (p.sigma0 * z + p.sigma1 * zd))
        return np.concatenate([v, acc, zd]).tolist()
    if p.friction:
        bias = pin.rnea(p.model, p.data, q, v, np.zeros(n))  # C(q, q') q' + g(q)
        m = np.diag(pin.crba(p.model, p.data, q))
        stuck = np.clip(-(f - bias) - m * v / p.t_stick, -p.tau_s, p.tau_s)
        f = f + np.where(np.abs(v) >= p.band, -np.sign(v) * _sliding_level(p, v), stuck)
    return np.concatenate([v, pin.aba(p.model, p.data, q, v, f)]).tolist()


ARM = Kernels(output=arm_output, derivatives=arm_derivatives, python_only=True)


# -- ft_sensor -----------------------------------------------------------------------
class SensorParams(NamedTuple):
    m: float
    K: tuple
    B: tuple
    g: tuple
    compensate: bool


def _spring(p, x, u):
    """The spring-damper's force on the tool (base axes): -R (K R^T d + B R^T d')."""
    fp, R, tw = u[0], u[1], u[2]
    K, B = p.K, p.B
    d0, d1, d2 = x[0] - fp[0], x[1] - fp[1], x[2] - fp[2]
    e0, e1, e2 = x[3] - tw[0], x[4] - tw[1], x[5] - tw[2]
    a0 = K[0] * (R[0] * d0 + R[3] * d1 + R[6] * d2) + B[0] * (R[0] * e0 + R[3] * e1 + R[6] * e2)
    a1 = K[1] * (R[1] * d0 + R[4] * d1 + R[7] * d2) + B[1] * (R[1] * e0 + R[4] * e1 + R[7] * e2)
    a2 = K[2] * (R[2] * d0 + R[5] * d1 + R[8] * d2) + B[2] * (R[2] * e0 + R[5] * e1 + R[8] * e2)
    return (-(R[0] * a0 + R[1] * a1 + R[2] * a2), -(R[3] * a0 + R[4] * a1 + R[5] * a2),
            -(R[6] * a0 + R[7] * a1 + R[8] * a2))


def sensor_output(p, t, x, u):
    """wrench on the flange, the tool's p and twist, the reading F (tare subtracted)."""
    f = _spring(p, x, u)
    tw, g = u[2], p.g
    c = p.m if p.compensate else 0.0
    return ((-f[0], -f[1], -f[2], 0.0, 0.0, 0.0), (x[0], x[1], x[2]), (x[3], x[4], x[5], tw[3], tw[4], tw[5]),
            (f[0] + c * g[0] - x[6], f[1] + c * g[1] - x[7], f[2] + c * g[2] - x[8], 0.0, 0.0, 0.0))


def sensor_derivatives(p, t, x, u):
    """The tool's p' and p'' (m p'' = spring + m g + f_env); the tare is constant."""
    f, fe = _spring(p, x, u), u[3]
    return (x[3], x[4], x[5], (f[0] + p.m * p.g[0] + fe[0]) / p.m, (f[1] + p.m * p.g[1] + fe[1]) / p.m,
            (f[2] + p.m * p.g[2] + fe[2]) / p.m, 0.0, 0.0, 0.0)


def sensor_zero_crossings(p, t, x, u):
    """The tare input's crossing of 0.5 (a rising edge tares)."""
    return (u[4][0] - 0.5,)


def sensor_event_action(p, t, x, u, fired):
    """A tare: the reading now (before taring) is stored, so the reading becomes zero."""
    f = _spring(p, x, u)
    c = p.m if p.compensate else 0.0
    return tuple(x[:6]) + (f[0] + c * p.g[0], f[1] + c * p.g[1], f[2] + c * p.g[2])


SENSOR = Kernels(output=sensor_output, derivatives=sensor_derivatives, zero_crossings=sensor_zero_crossings,
                 event_action=sensor_event_action, python_only=True)  # python_only: not checked under numba


# -- plane_contact ---------------------------------------------------------------------
class PlaneParams(NamedTuple):
    point: tuple
    n: tuple
    K: float
    B: float
    mu: float
    v_s: float
    unilateral: bool


def plane_output(p, t, x, u):
    """wrench on the tool, F on the plane, contact, depth (the method's law in floats)."""
    n, c, pt, tw = p.n, p.point, u[0], u[1]
    d = n[0] * (c[0] - pt[0]) + n[1] * (c[1] - pt[1]) + n[2] * (c[2] - pt[2])
    vn = tw[0] * n[0] + tw[1] * n[1] + tw[2] * n[2]
    fn = p.K * d - p.B * vn
    inside = d > 0.0 or not p.unilateral
    fn = (max(fn, 0.0) if p.unilateral else fn) if inside else 0.0
    vt = (tw[0] - vn * n[0], tw[1] - vn * n[1], tw[2] - vn * n[2])
    k = -p.mu * abs(fn) / math.sqrt(vt[0] ** 2 + vt[1] ** 2 + vt[2] ** 2 + p.v_s ** 2)
    w = (fn * n[0] + k * vt[0], fn * n[1] + k * vt[1], fn * n[2] + k * vt[2])
    return ((w[0], w[1], w[2], 0.0, 0.0, 0.0), (-w[0], -w[1], -w[2], 0.0, 0.0, 0.0),
            (1.0 if fn > 0.0 else 0.0,), (d,))


PLANE = Kernels(output=plane_output, python_only=True)  # python_only: not checked under numba
