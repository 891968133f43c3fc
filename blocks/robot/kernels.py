"""Kernels of the rigid-body blocks: robot_arm, robot_kinematics, gravity_torque.

The blocks' methods (:mod:`hybridsim.blocks.robot.arm`, ...) stay the generic path's reference;
these are the same laws as pure functions ``f(p, t, x, u)`` (:mod:`hybridsim.engine.kernels`).

The rigid-body kernels have two bodies. Called from Python (the fused path) they call Pinocchio,
each algorithm once per right-hand side: the tool frame's placement and Jacobian are computed
once for given joint positions, by ``robot_kinematics``, and reused by ``robot_arm`` for J^T w;
the forward dynamics is one call of the articulated-body algorithm. Compiled by numba (the
compiled path), a call of them is their twin instead (``kernel.compiled``, ``*_compiled``, made
so by :func:`compiled_as`), which runs :mod:`hybridsim.blocks.robot.rigid` on the arrays of the
block's :class:`~.rigid.Tree`.
``block.params`` holds numbers and arrays only: the Pinocchio model is found by its number
(:func:`pinocchio_model`); a process without it (params sent to another process) runs the twin.
"""
from typing import NamedTuple

import numpy as np

from hybridsim.engine.kernels import Kernels, kernel

from hybridsim.blocks.robot import rigid
from hybridsim.blocks.robot.rigid import aba_at, crba, gravity, placements, rnea, tool, tool_at



def compiled_as(twin):
    """Mark a kernel whose Python body calls Pinocchio (the fused path's) as compiling to ``twin``
    (the same law in numba's subset): numba's ``overload`` makes a call of the kernel in compiled
    code a call of ``twin``; ``kernel.compiled`` names it."""
    def mark(fn):
        try:
            from numba.extending import overload
        except ImportError:  # pragma: no cover - numba is optional (the fast extra): nothing compiles then
            pass
        else:
            overload(fn)(lambda p, t, x, u: twin)
        fn.compiled = twin
        return fn

    return mark

#: the Pinocchio models of this process by number, (model, data); the numbers by key; Pinocchio
_MODELS, _NUMBERS, _PIN = {}, {}, []
#: per tool frame (robot file and frame): its last joint positions (a tuple), p and R (lists),
#: J (6xN), J row by row and J^T, computed by Pinocchio
_TOOLS = {}


def pinocchio_model(model, key):
    """The number under which ``model`` (with its ``data``) is kept for the fused path; ``key``
    names what makes it (robot file, its time, gravity): one model per key, however many blocks.
    The number is the key's hash, so params that reach another process find the same model there
    or none (then the kernels run their twins), never another one."""
    number = _NUMBERS.get(key)
    if number is None:
        import hashlib

        import pinocchio

        _PIN[:] = [pinocchio]
        number = _NUMBERS[key] = int.from_bytes(hashlib.sha256(repr(key).encode()).digest()[:7], "big")
        _MODELS[number] = (model, model.createData())
    return number


def pinocchio_model_of(number):
    """The Pinocchio model kept under ``number`` (never modify it: blocks share it)."""
    return _MODELS[number][0]


def frame_jacobian(pin, model, data, q, frame_id):
    """The 6xN Jacobian of frame ``frame_id`` at ``q`` (world axes at its origin): Pinocchio gives a
    one-joint robot's as a vector of 6."""
    return np.reshape(pin.computeFrameJacobian(model, data, q, frame_id, pin.LOCAL_WORLD_ALIGNED), (6, model.nv))


def tool_frame(model, data, tool, q):
    """``(q, p, R, J, J row by row, J^T)`` of the tool frame ``tool`` (robot file number, frame id)
    at the joint positions ``q`` (a tuple) by Pinocchio: computed once for given ``q``, whichever
    block asks first (p and R row by row as lists, J in world axes at the frame's origin)."""
    got = _TOOLS.get(tool)
    if got is None or got[0] != q:
        pin = _PIN[0]
        J = frame_jacobian(pin, model, data, np.array(q), tool[1])
        pose = pin.updateFramePlacement(model, data, tool[1])  # the joints' placements are those at q
        got = _TOOLS[tool] = (q, pose.translation.tolist(), pose.rotation.ravel().tolist(), J, J.ravel(), J.T)
    return got


# -- robot_kinematics ------------------------------------------------------------------
class KinematicsParams(NamedTuple):
    tree: rigid.Tree
    tool: tuple   # (robot file number, frame id): the key of the tool frame's pose and Jacobian


@kernel
def kinematics_output_compiled(p, t, x, u):
    """:func:`kinematics_output` on :mod:`~hybridsim.blocks.robot.rigid`'s arrays."""
    n = p.tree.parent.shape[0]
    q, qd = np.empty(n), np.empty(n)
    for i in range(n):
        q[i], qd[i] = u[0][i], u[1][i]
    R, pos, J = tool(p.tree, q)
    return pos, R.ravel(), J @ qd, J.ravel()


@compiled_as(kinematics_output_compiled)
def kinematics_output(p, t, x, u):
    """p, R (row by row), twist = J q' and J (row by row) of the tool frame."""
    got = _MODELS.get(p.tree.model)
    if got is None:  # no Pinocchio model here: the twin
        return kinematics_output_compiled(p, t, x, u)
    _, pos, R, J, flat, _ = tool_frame(got[0], got[1], p.tool, tuple(u[0]))
    return pos, R, (J @ np.array(u[1])).tolist(), flat


KINEMATICS = Kernels(output=kinematics_output)


# -- gravity_torque --------------------------------------------------------------------
class GravityParams(NamedTuple):
    tree: rigid.Tree


@kernel
def gravity_output_compiled(p, t, x, u):
    """:func:`gravity_output` on :mod:`~hybridsim.blocks.robot.rigid`'s arrays."""
    return (gravity(p.tree, np.asarray(u[0])),)


@compiled_as(gravity_output_compiled)
def gravity_output(p, t, x, u):
    """g(q), N m or N."""
    got = _MODELS.get(p.tree.model)
    if got is None:
        return gravity_output_compiled(p, t, x, u)
    return (_PIN[0].computeGeneralizedGravity(got[0], got[1], np.array(u[0], float)).copy(),)


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


@kernel
def arm_output_compiled(p, t, x, u):
    """:func:`arm_output` as arrays."""
    xa = np.asarray(x)
    return (xa[:p.n].copy(), xa[p.n:2 * p.n].copy())


@compiled_as(arm_output_compiled)
def arm_output(p, t, x, u):
    """q and q'."""
    if p.tree.model not in _MODELS:
        return arm_output_compiled(p, t, x, u)
    return (x[:p.n], x[p.n:2 * p.n])


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
        J = tool_at(p.tree, R, pos)[2]
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
    R, pos = placements(p.tree, joints(p, x))  # once, for J^T w and the dynamics
    v, f = applied_compiled(p, R, pos, x, u)
    return np.concatenate((v, aba_at(p.tree, R, pos, v, f)))


@kernel
def arm_friction_derivatives_compiled(p, t, x, u):
    """:func:`arm_friction_derivatives` on :mod:`~hybridsim.blocks.robot.rigid`'s arrays."""
    q = joints(p, x)
    R, pos = placements(p.tree, q)
    v, f = applied_compiled(p, R, pos, x, u)
    bias = rnea(p.tree, q, v, np.zeros(p.n))
    f = f + joint_friction(p, v, f, bias, np.diag(crba(p.tree, q)).copy())
    return np.concatenate((v, aba_at(p.tree, R, pos, v, f)))


@kernel
def arm_lugre_derivatives_compiled(p, t, x, u):
    """:func:`arm_lugre_derivatives` on :mod:`~hybridsim.blocks.robot.rigid`'s arrays."""
    n = p.n
    R, pos = placements(p.tree, joints(p, x))
    v, f = applied_compiled(p, R, pos, x, u)
    z = np.empty(n)
    for i in range(n):
        z[i] = x[2 * n + i]
    zd = bristle_rate(p, v, z)
    return np.concatenate((v, aba_at(p.tree, R, pos, v, f - (p.sigma0 * z + p.sigma1 * zd)), zd))


def _applied(p, model, data, q, v, u):
    """tau + J^T w - b q' (N m or N) by Pinocchio (``q`` a tuple, ``v`` an array)."""
    f = np.array(u[0]) - p.b * v
    if any(u[1]):
        f += tool_frame(model, data, p.tool, q)[5] @ np.array(u[1])
    return f


@compiled_as(arm_derivatives_compiled)
def arm_derivatives(p, t, x, u):
    """(q', q''): ABA under tau + J^T w - b q' (no joint friction)."""
    got = _MODELS.get(p.tree.model)
    if got is None:
        return arm_derivatives_compiled(p, t, x, u)
    model, data = got
    q, v = x[:p.n], x[p.n:2 * p.n]
    va = np.array(v)
    f = _applied(p, model, data, q, va, u)
    return v + tuple(_PIN[0].aba(model, data, np.array(q), va, f).tolist())


@compiled_as(arm_friction_derivatives_compiled)
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


@compiled_as(arm_lugre_derivatives_compiled)
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
def arm_friction_crossings(p, t, x, u):
    """|q_i'| - stick_band per joint (rad/s or m/s): the edges of the Karnopp band, located."""
    return np.abs(np.asarray(x)[p.n:2 * p.n]) - p.band


#: the arm's kernels without joint friction, with Karnopp's or Stribeck's, and with LuGre's
ARM = Kernels(output=arm_output, derivatives=arm_derivatives)
ARM_FRICTION = Kernels(output=arm_output, derivatives=arm_friction_derivatives, zero_crossings=arm_friction_crossings)
ARM_LUGRE = Kernels(output=arm_output, derivatives=arm_lugre_derivatives)
