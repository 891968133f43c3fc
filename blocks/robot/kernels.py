"""Kernels of the robot's plant blocks: robot_arm, robot_kinematics, gravity_torque, ft_sensor, plane_contact.

The blocks' methods (:mod:`hybridsim.blocks.robot.arm`, ...) stay the generic path's reference;
these are the same laws as pure functions ``f(p, t, x, u)`` (:mod:`hybridsim.engine.kernels`).

The rigid-body kernels have two bodies. Called from Python (the fused path) they call Pinocchio,
each algorithm once per right-hand side: the tool frame's placement and Jacobian are computed
once for given joint positions, by ``robot_kinematics``, and reused by ``robot_arm`` for J^T w;
the forward dynamics is one call of the articulated-body algorithm. Compiled by numba (the
compiled path), a call of them is the twin ``*_compiled`` instead (numba's ``overload``), which
runs :mod:`hybridsim.blocks.robot.rigid` on the arrays of the block's :class:`~.rigid.Tree`.
``block.params`` holds numbers and arrays only: the Pinocchio model is found by its number
(:func:`pinocchio_model`); a process without it (params sent to another process) runs the twin.
The sensor's and the plane's kernels are plain float arithmetic, the same code on every path.
"""
import math
from typing import NamedTuple

import numpy as np

from hybridsim.engine.kernels import Kernels, kernel

from hybridsim.blocks.robot import rigid

try:
    from numba.extending import overload
except ImportError:  # pragma: no cover - numba is optional (the fast extra); then nothing compiles these
    def overload(fn, **kw):
        return lambda typer: typer

#: the Pinocchio models of this process by number, (model, data); the numbers by key; Pinocchio
_MODELS, _NUMBERS, _PIN = {}, {}, []
#: per tool frame (robot file and frame): its last joint positions (a tuple), p and R (lists),
#: J (6xN), J row by row and J^T, computed by Pinocchio
_TOOLS = {}


def pinocchio_model(model, key):
    """The number under which ``model`` (with its ``data``) is kept for the fused path; ``key``
    names what makes it (robot file, its time, gravity): one model per key, however many blocks."""
    number = _NUMBERS.get(key)
    if number is None:
        import pinocchio

        _PIN[:] = [pinocchio]
        number = _NUMBERS[key] = len(_MODELS)
        _MODELS[number] = (model, model.createData())
    return number


def pinocchio_model_of(number):
    """The Pinocchio model kept under ``number`` (never modify it: blocks share it)."""
    return _MODELS[number][0]


def tool_frame(model, data, tool, q):
    """``(q, p, R, J, J row by row, J^T)`` of the tool frame ``tool`` (robot file number, frame id)
    at the joint positions ``q`` (a tuple) by Pinocchio: computed once for given ``q``, whichever
    block asks first (p and R row by row as lists, J in world axes at the frame's origin)."""
    got = _TOOLS.get(tool)
    if got is None or got[0] != q:
        pin = _PIN[0]
        J = pin.computeFrameJacobian(model, data, np.array(q), tool[1], pin.LOCAL_WORLD_ALIGNED)
        pose = pin.updateFramePlacement(model, data, tool[1])  # the joints' placements are those at q
        got = _TOOLS[tool] = (q, pose.translation.tolist(), pose.rotation.ravel().tolist(), J, J.ravel(), J.T.copy())
    return got


# -- robot_kinematics ------------------------------------------------------------------
class KinematicsParams(NamedTuple):
    tree: rigid.Tree
    tool: tuple   # (robot file number, frame id): the key of the tool frame's pose and Jacobian


def kinematics_output(p, t, x, u):
    """p, R (row by row), twist = J q' and J (row by row) of the tool frame."""
    got = _MODELS.get(p.tree.model)
    if got is None:  # no Pinocchio model here: the twin
        return kinematics_output_compiled(p, t, x, u)
    _, pos, R, J, flat, _ = tool_frame(got[0], got[1], p.tool, tuple(u[0]))
    return pos, R, (J @ np.array(u[1])).tolist(), flat


@kernel
def kinematics_output_compiled(p, t, x, u):
    """:func:`kinematics_output` on :mod:`~hybridsim.blocks.robot.rigid`'s arrays."""
    n = p.tree.parent.shape[0]
    q, qd = np.empty(n), np.empty(n)
    for i in range(n):
        q[i], qd[i] = u[0][i], u[1][i]
    R, pos, J = rigid.tool(p.tree, q)
    return pos, R.ravel(), J @ qd, J.ravel()


@overload(kinematics_output)
def _kinematics_output_numba(p, t, x, u):
    return kinematics_output_compiled


KINEMATICS = Kernels(output=kinematics_output)


# -- gravity_torque --------------------------------------------------------------------
class GravityParams(NamedTuple):
    tree: rigid.Tree


def gravity_output(p, t, x, u):
    """g(q), N m or N."""
    got = _MODELS.get(p.tree.model)
    if got is None:
        return gravity_output_compiled(p, t, x, u)
    return (_PIN[0].computeGeneralizedGravity(got[0], got[1], np.array(u[0], float)).copy(),)


@kernel
def gravity_output_compiled(p, t, x, u):
    """:func:`gravity_output` on :mod:`~hybridsim.blocks.robot.rigid`'s arrays."""
    return (rigid.gravity(p.tree, np.asarray(u[0])),)


@overload(gravity_output)
def _gravity_output_numba(p, t, x, u):
    return gravity_output_compiled


GRAVITY = Kernels(output=gravity_output)


# -- robot_arm -----------------------------------------------------------------------
class ArmParams(NamedTuple):
    tree: rigid.Tree    # with the arm's gravity
    tool: tuple         # the key of the tool frame the wrench acts on (see KinematicsParams)
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
    if p.tree.model not in _MODELS:
        return arm_output_compiled(p, t, x, u)
    return (x[:p.n], x[p.n:2 * p.n])


@kernel
def arm_output_compiled(p, t, x, u):
    """:func:`arm_output` as arrays."""
    xa = np.asarray(x)
    return (xa[:p.n].copy(), xa[p.n:2 * p.n].copy())


@overload(arm_output)
def _arm_output_numba(p, t, x, u):
    return arm_output_compiled


@kernel
def sliding_level(p, v):
    """g(v) per joint: Coulomb's level, or Stribeck's falling from the static one."""
    if not (p.stribeck or p.lugre):
        return p.tau_c.copy()
    return p.tau_c + (p.tau_s - p.tau_c) * np.exp(-(v / p.v_s) ** 2)


@kernel
def bristle_rate(p, v, z):
    """LuGre's z' = v - sigma0 |v| z / g(v) per joint (0 where g(v) = 0)."""
    g = sliding_level(p, v)
    zd = v.copy()
    for i in range(v.shape[0]):
        if g[i] > 0.0:
            zd[i] -= p.sigma0[i] * abs(v[i]) * z[i] / g[i]
    return zd


@kernel
def joint_friction(p, v, f, bias, m):
    """B of eq 11 per joint under the non-friction force ``f``, with ``bias`` = C q' + g and ``m`` = diag M."""
    level = sliding_level(p, v)
    B = np.empty(v.shape[0])
    for i in range(v.shape[0]):
        if abs(v[i]) >= p.band:
            B[i] = -np.sign(v[i]) * level[i]
        else:
            B[i] = min(max(-(f[i] - bias[i]) - m[i] * v[i] / p.t_stick, -p.tau_s[i]), p.tau_s[i])
    return B


def _applied(p, model, data, q, v, u):
    """tau + J^T w - b q' (N m or N) by Pinocchio (``q`` a tuple, ``v`` an array)."""
    f = np.array(u[0]) - p.b * v
    if any(u[1]):
        f += tool_frame(model, data, p.tool, q)[5] @ np.array(u[1])
    return f


def arm_derivatives(p, t, x, u):
    """(q', q''): ABA under tau + J^T w - b q' (no joint friction)."""
    got = _MODELS.get(p.tree.model)
    if got is None:
        return arm_derivatives_compiled(p, t, x, u)
    model, data = got
    q, v = x[:p.n], x[p.n:2 * p.n]
    va = np.array(v)
    return v + tuple(_PIN[0].aba(model, data, np.array(q), va, _applied(p, model, data, q, va, u)).tolist())


def arm_friction_derivatives(p, t, x, u):
    """(q', q''): ABA under tau + J^T w - b q' + B, B the Karnopp law (eq 11), or Stribeck's, per joint."""
    got = _MODELS.get(p.tree.model)
    if got is None:
        return arm_friction_derivatives_compiled(p, t, x, u)
    pin, (model, data) = _PIN[0], got
    q, v = x[:p.n], x[p.n:2 * p.n]
    qa, va = np.array(q), np.array(v)
    f = _applied(p, model, data, q, va, u)
    bias = pin.rnea(model, data, qa, va, np.zeros(p.n))  # C(q, q') q' + g(q)
    f = f + joint_friction(p, va, f, bias, np.diag(pin.crba(model, data, qa)))
    return v + tuple(pin.aba(model, data, qa, va, f).tolist())


def arm_lugre_derivatives(p, t, x, u):
    """(q', q'', z'): ABA under tau + J^T w - b q' - (sigma0 z + sigma1 z'), LuGre's bristles per joint."""
    got = _MODELS.get(p.tree.model)
    if got is None:
        return arm_lugre_derivatives_compiled(p, t, x, u)
    model, data = got
    n = p.n
    q, v = x[:n], x[n:2 * n]
    va, z = np.array(v), np.array(x[2 * n:])
    zd = bristle_rate(p, va, z)
    f = _applied(p, model, data, q, va, u) - (p.sigma0 * z + p.sigma1 * zd)
    return v + tuple(_PIN[0].aba(model, data, np.array(q), va, f).tolist()) + tuple(zd.tolist())


@kernel
def applied_compiled(p, R, pos, x, u):
    """(q', tau + J^T w - b q') at the joint placements (R, pos) of the state ``x``, as arrays."""
    n = p.n
    v, f = np.empty(n), np.empty(n)
    for i in range(n):
        v[i] = x[n + i]
        f[i] = u[0][i] - p.b[i] * v[i]
    w = np.asarray(u[1])
    if np.any(w != 0.0):
        J = rigid.tool_at(p.tree, R, pos)[2]
        for i in range(n):
            for k in range(6):
                f[i] += J[k, i] * w[k]
    return v, f


@kernel
def joints(p, x):
    """q of the state ``x`` as an array."""
    q = np.empty(p.n)
    for i in range(p.n):
        q[i] = x[i]
    return q


@kernel
def arm_derivatives_compiled(p, t, x, u):
    """:func:`arm_derivatives` on :mod:`~hybridsim.blocks.robot.rigid`'s arrays."""
    R, pos = rigid.placements(p.tree, joints(p, x))  # once, for J^T w and the dynamics
    v, f = applied_compiled(p, R, pos, x, u)
    return np.concatenate((v, rigid.aba_at(p.tree, R, pos, v, f)))


@kernel
def arm_friction_derivatives_compiled(p, t, x, u):
    """:func:`arm_friction_derivatives` on :mod:`~hybridsim.blocks.robot.rigid`'s arrays."""
    q = joints(p, x)
    R, pos = rigid.placements(p.tree, q)
    v, f = applied_compiled(p, R, pos, x, u)
    bias = rigid.rnea(p.tree, q, v, np.zeros(p.n))
    f = f + joint_friction(p, v, f, bias, np.diag(rigid.crba(p.tree, q)).copy())
    return np.concatenate((v, rigid.aba_at(p.tree, R, pos, v, f)))


@kernel
def arm_lugre_derivatives_compiled(p, t, x, u):
    """:func:`arm_lugre_derivatives` on :mod:`~hybridsim.blocks.robot.rigid`'s arrays."""
    n = p.n
    R, pos = rigid.placements(p.tree, joints(p, x))
    v, f = applied_compiled(p, R, pos, x, u)
    z = np.empty(n)
    for i in range(n):
        z[i] = x[2 * n + i]
    zd = bristle_rate(p, v, z)
    return np.concatenate((v, rigid.aba_at(p.tree, R, pos, v, f - (p.sigma0 * z + p.sigma1 * zd)), zd))


@overload(arm_derivatives)
def _arm_derivatives_numba(p, t, x, u):
    return arm_derivatives_compiled


@overload(arm_friction_derivatives)
def _arm_friction_derivatives_numba(p, t, x, u):
    return arm_friction_derivatives_compiled


@overload(arm_lugre_derivatives)
def _arm_lugre_derivatives_numba(p, t, x, u):
    return arm_lugre_derivatives_compiled


#: the arm's kernels without joint friction, with Karnopp's or Stribeck's, and with LuGre's
ARM = Kernels(output=arm_output, derivatives=arm_derivatives)
ARM_FRICTION = Kernels(output=arm_output, derivatives=arm_friction_derivatives)
ARM_LUGRE = Kernels(output=arm_output, derivatives=arm_lugre_derivatives)


# -- ft_sensor -----------------------------------------------------------------------
class SensorParams(NamedTuple):
    m: float
    K: tuple
    B: tuple
    g: tuple
    compensate: bool


@kernel
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


@kernel
def sensor_output(p, t, x, u):
    """wrench on the flange, the tool's p and twist, the reading F (tare subtracted)."""
    f = _spring(p, x, u)
    tw, g = u[2], p.g
    c = p.m if p.compensate else 0.0
    return ((-f[0], -f[1], -f[2], 0.0, 0.0, 0.0), (x[0], x[1], x[2]), (x[3], x[4], x[5], tw[3], tw[4], tw[5]),
            (f[0] + c * g[0] - x[6], f[1] + c * g[1] - x[7], f[2] + c * g[2] - x[8], 0.0, 0.0, 0.0))


@kernel
def sensor_derivatives(p, t, x, u):
    """The tool's p' and p'' (m p'' = spring + m g + f_env); the tare is constant."""
    f, fe = _spring(p, x, u), u[3]
    return (x[3], x[4], x[5], (f[0] + p.m * p.g[0] + fe[0]) / p.m, (f[1] + p.m * p.g[1] + fe[1]) / p.m,
            (f[2] + p.m * p.g[2] + fe[2]) / p.m, 0.0, 0.0, 0.0)


@kernel
def sensor_zero_crossings(p, t, x, u):
    """The tare input's crossing of 0.5 (a rising edge tares)."""
    return (u[4][0] - 0.5,)


@kernel
def sensor_event_action(p, t, x, u, fired):
    """A tare: the reading now (before taring) is stored, so the reading becomes zero."""
    f = _spring(p, x, u)
    c = p.m if p.compensate else 0.0
    return (x[0], x[1], x[2], x[3], x[4], x[5], f[0] + c * p.g[0], f[1] + c * p.g[1], f[2] + c * p.g[2])


#: the sensor's kernels with a tare input (its event) and without
SENSOR = Kernels(output=sensor_output, derivatives=sensor_derivatives, zero_crossings=sensor_zero_crossings,
                 event_action=sensor_event_action)
SENSOR_UNTARED = Kernels(output=sensor_output, derivatives=sensor_derivatives)


# -- plane_contact ---------------------------------------------------------------------
class PlaneParams(NamedTuple):
    point: tuple
    n: tuple
    K: float
    B: float
    mu: float
    v_s: float
    unilateral: bool


@kernel
def plane_depth(p, pt):
    """Penetration (m) of the point ``pt`` into the plane: positive inside."""
    n, c = p.n, p.point
    return n[0] * (c[0] - pt[0]) + n[1] * (c[1] - pt[1]) + n[2] * (c[2] - pt[2])


@kernel
def plane_output(p, t, x, u):
    """wrench on the tool, F on the plane, contact, depth (the method's law in floats)."""
    n, c, pt, tw = p.n, p.point, u[0], u[1]
    d = n[0] * (c[0] - pt[0]) + n[1] * (c[1] - pt[1]) + n[2] * (c[2] - pt[2])  # as plane_depth
    vn = tw[0] * n[0] + tw[1] * n[1] + tw[2] * n[2]
    fn = p.K * d - p.B * vn
    inside = d > 0.0 or not p.unilateral
    fn = (max(fn, 0.0) if p.unilateral else fn) if inside else 0.0
    vt = (tw[0] - vn * n[0], tw[1] - vn * n[1], tw[2] - vn * n[2])
    k = -p.mu * abs(fn) / math.sqrt(vt[0] ** 2 + vt[1] ** 2 + vt[2] ** 2 + p.v_s ** 2)
    w = (fn * n[0] + k * vt[0], fn * n[1] + k * vt[1], fn * n[2] + k * vt[2])
    return ((w[0], w[1], w[2], 0.0, 0.0, 0.0), (-w[0], -w[1], -w[2], 0.0, 0.0, 0.0),
            (1.0 if fn > 0.0 else 0.0,), (d,))


@kernel
def plane_zero_crossings(p, t, x, u):
    """First touch and lift-off: the depth's sign."""
    return (plane_depth(p, u[0]),)


PLANE = Kernels(output=plane_output, zero_crossings=plane_zero_crossings)
