"""Rigid-body algorithms for a tree of revolute and prismatic joints, on arrays from a Pinocchio model.

:func:`tree` takes from a Pinocchio model what the algorithms need: each joint's parent, placement
in its parent, kind and axis, each body's spatial inertia, the armature and gravity, and one frame
(the tool's). The algorithms are Featherstone's (*Rigid Body Dynamics Algorithms*, Springer 2008):
forward kinematics, the frame Jacobian, the recursive Newton-Euler algorithm (RNEA, table 5.1), the
composite-rigid-body algorithm (CRBA, table 6.2) and the articulated-body algorithm (ABA, table
7.1), each body in its own joint frame. Conventions are Pinocchio's: a motion is (linear,
angular), a force is (force, moment), both at a frame's origin in its axes; the Jacobian is the
tool frame's, in world axes at the frame's origin (``LOCAL_WORLD_ALIGNED``).

They keep to numba's nopython subset: the compiled path compiles them into its loop (the fused
path calls Pinocchio itself). Run in plain Python they give the same numbers, slowly. Tested
against Pinocchio's ABA, RNEA, CRBA and frame Jacobian to 1e-12 (tests/blocks/test_robot_rigid.py).
"""
import math
from typing import NamedTuple

import numpy as np

from hybridsim.engine.kernels import kernel
from hybridsim.errors import ParameterError

from hybridsim.blocks.robot.spatial import (add_force_to_parent, add_inertia_to_parent, cross_force, cross_motion,
                                            dot6, motion_to_child, times)

#: Pinocchio's joint types these algorithms take: (prismatic?, axis, None: the joint's own axis)
JOINTS = {"JointModelRX": (0, (1.0, 0.0, 0.0)), "JointModelRY": (0, (0.0, 1.0, 0.0)),
          "JointModelRZ": (0, (0.0, 0.0, 1.0)), "JointModelRevoluteUnaligned": (0, None),
          "JointModelPX": (1, (1.0, 0.0, 0.0)), "JointModelPY": (1, (0.0, 1.0, 0.0)),
          "JointModelPZ": (1, (0.0, 0.0, 1.0)), "JointModelPrismaticUnaligned": (1, None)}


class Tree(NamedTuple):
    """A kinematic tree as arrays (joint j of these arrays is Pinocchio's joint j + 1, velocity j)."""

    model: int              # the Pinocchio model's number in this process (hybridsim.blocks.robot.kernels)
    parent: np.ndarray      # (n,) int64: the parent joint, -1 for the base
    prismatic: np.ndarray   # (n,) int64: 1 prismatic, 0 revolute
    axis: np.ndarray        # (n, 3): the joint's unit axis in its own frame
    rotation: np.ndarray    # (n, 3, 3): the joint frame's rotation in its parent's at q = 0
    translation: np.ndarray  # (n, 3): its origin in its parent's frame, m
    inertia: np.ndarray     # (n, 6, 6): the body's spatial inertia at the joint frame's origin
    armature: np.ndarray    # (n,): rotor inertia added to M's diagonal, kg m^2 or kg
    gravity: np.ndarray     # (3,): m/s^2, base axes
    frame: int              # the tool frame's joint (-1: the base)
    frame_rotation: np.ndarray     # (3, 3): the tool frame in its joint's frame
    frame_translation: np.ndarray  # (3,), m


def tree(model, frame_id, number=-1):
    """The :class:`Tree` of a Pinocchio ``model`` (revolute and prismatic joints only, one velocity
    each) with the tool frame ``frame_id``; ``number``: the model's number for the fused path."""
    n = model.njoints - 1
    if model.nv != n or model.nq != n:
        raise ParameterError("urdf", f"the robot blocks take revolute and prismatic joints only (nq = {model.nq}, "
                                     f"nv = {model.nv} for {n} joints)")
    kind, axis = np.zeros(n, dtype=np.int64), np.zeros((n, 3))
    for j in range(n):
        joint = model.joints[j + 1]
        name = joint.shortname()
        if name not in JOINTS or joint.idx_v != j:
            raise ParameterError("urdf", f"joint {model.names[j + 1]!r} is a {name}: the robot blocks take "
                                         "revolute and prismatic joints only")
        kind[j], fixed = JOINTS[name]
        axis[j] = fixed if fixed is not None else np.asarray(joint.extract().axis, float)
    place = [model.jointPlacements[j + 1] for j in range(n)]
    frame = model.frames[frame_id]
    return Tree(int(number), np.array([model.parents[j + 1] - 1 for j in range(n)], dtype=np.int64), kind,
                axis / np.linalg.norm(axis, axis=1)[:, None],
                np.ascontiguousarray([m.rotation for m in place], dtype=float).reshape(n, 3, 3),
                np.ascontiguousarray([m.translation for m in place], dtype=float).reshape(n, 3),
                np.ascontiguousarray([model.inertias[j + 1].matrix() for j in range(n)], dtype=float),
                np.array(model.armature, dtype=float), np.array(model.gravity.linear, dtype=float),
                int(frame.parentJoint) - 1, np.ascontiguousarray(frame.placement.rotation, dtype=float),
                np.array(frame.placement.translation, dtype=float))


# -- joints ---------------------------------------------------------------------------
@kernel
def placements(tr, q):
    """Each joint frame's placement in its parent's at ``q``: rotations (n, 3, 3), origins (n, 3)."""
    n = tr.parent.shape[0]
    R, p = np.empty((n, 3, 3)), np.empty((n, 3))
    for j in range(n):
        P, a, t = tr.rotation[j], tr.axis[j], tr.translation[j]
        if tr.prismatic[j]:
            for r in range(3):
                p[j, r] = t[r] + q[j] * (P[r, 0] * a[0] + P[r, 1] * a[1] + P[r, 2] * a[2])
                R[j, r, 0], R[j, r, 1], R[j, r, 2] = P[r, 0], P[r, 1], P[r, 2]
            continue
        c, s = math.cos(q[j]), math.sin(q[j])  # Rodrigues: E = c I + s [a]x + (1 - c) a a^T
        C = 1.0 - c
        e00, e01, e02 = c + a[0] * a[0] * C, a[0] * a[1] * C - a[2] * s, a[0] * a[2] * C + a[1] * s
        e10, e11, e12 = a[1] * a[0] * C + a[2] * s, c + a[1] * a[1] * C, a[1] * a[2] * C - a[0] * s
        e20, e21, e22 = a[2] * a[0] * C - a[1] * s, a[2] * a[1] * C + a[0] * s, c + a[2] * a[2] * C
        for r in range(3):
            p[j, r] = t[r]
            R[j, r, 0] = P[r, 0] * e00 + P[r, 1] * e10 + P[r, 2] * e20
            R[j, r, 1] = P[r, 0] * e01 + P[r, 1] * e11 + P[r, 2] * e21
            R[j, r, 2] = P[r, 0] * e02 + P[r, 1] * e12 + P[r, 2] * e22
    return R, p


@kernel
def along_axis(tr, j, f):
    """S^T f: the component along joint ``j``'s motion subspace S of a force ``f`` (its own frame)."""
    a, o = tr.axis[j], 0 if tr.prismatic[j] else 3
    return a[0] * f[o] + a[1] * f[o + 1] + a[2] * f[o + 2]


@kernel
def add_motion(tr, j, scale, out):
    """``out`` += S scale: joint ``j``'s motion at rate ``scale``."""
    a, o = tr.axis[j], 0 if tr.prismatic[j] else 3
    out[o] += a[0] * scale
    out[o + 1] += a[1] * scale
    out[o + 2] += a[2] * scale


@kernel
def velocities(tr, R, p, v, vel, c, vJ):
    """Each body's velocity ``vel`` (own frame) and its bias acceleration ``c`` = v x S q'
    (``vJ``: a 6-vector of scratch)."""
    for j in range(tr.parent.shape[0]):
        i = tr.parent[j]
        if i >= 0:
            motion_to_child(R[j], p[j], vel[i], vel[j])
        else:
            vel[j, :] = 0.0
        add_motion(tr, j, v[j], vel[j])
        vJ[:] = 0.0
        add_motion(tr, j, v[j], vJ)
        cross_motion(vel[j], vJ, c[j])


@kernel
def base_acceleration(tr):
    """The base's acceleration that stands for gravity: (-g, 0)."""
    a = np.zeros(6)
    a[0], a[1], a[2] = -tr.gravity[0], -tr.gravity[1], -tr.gravity[2]
    return a


# -- kinematics ------------------------------------------------------------------------
@kernel
def world_placements(tr, R, p):
    """Each joint frame's placement in the base from the local ones (:func:`placements`)."""
    n = tr.parent.shape[0]
    oR, op = np.empty((n, 3, 3)), np.empty((n, 3))
    for j in range(n):
        i = tr.parent[j]
        if i < 0:
            oR[j], op[j] = R[j], p[j]
            continue
        for r in range(3):
            op[j, r] = op[i, r] + oR[i, r, 0] * p[j, 0] + oR[i, r, 1] * p[j, 1] + oR[i, r, 2] * p[j, 2]
            for k in range(3):
                oR[j, r, k] = oR[i, r, 0] * R[j, 0, k] + oR[i, r, 1] * R[j, 1, k] + oR[i, r, 2] * R[j, 2, k]
    return oR, op


@kernel
def frame_pose(tr, oR, op):
    """The tool frame's rotation (3, 3) and origin (3,) in the base."""
    j, F, t = tr.frame, tr.frame_rotation, tr.frame_translation
    if j < 0:
        return F.copy(), t.copy()
    Rf, pf = np.empty((3, 3)), np.empty(3)
    for r in range(3):
        pf[r] = op[j, r] + oR[j, r, 0] * t[0] + oR[j, r, 1] * t[1] + oR[j, r, 2] * t[2]
        for k in range(3):
            Rf[r, k] = oR[j, r, 0] * F[0, k] + oR[j, r, 1] * F[1, k] + oR[j, r, 2] * F[2, k]
    return Rf, pf


@kernel
def frame_jacobian(tr, oR, op, pf):
    """The tool frame's 6xN Jacobian (world axes, at its origin ``pf``): twist = J q'."""
    J = np.zeros((6, tr.parent.shape[0]))
    j = tr.frame
    while j >= 0:  # the joints that move the frame: its joint and that joint's ancestors
        a = tr.axis[j]
        w0 = oR[j, 0, 0] * a[0] + oR[j, 0, 1] * a[1] + oR[j, 0, 2] * a[2]
        w1 = oR[j, 1, 0] * a[0] + oR[j, 1, 1] * a[1] + oR[j, 1, 2] * a[2]
        w2 = oR[j, 2, 0] * a[0] + oR[j, 2, 1] * a[1] + oR[j, 2, 2] * a[2]
        if tr.prismatic[j]:
            J[0, j], J[1, j], J[2, j] = w0, w1, w2
        else:
            d0, d1, d2 = pf[0] - op[j, 0], pf[1] - op[j, 1], pf[2] - op[j, 2]
            J[0, j], J[1, j], J[2, j] = w1 * d2 - w2 * d1, w2 * d0 - w0 * d2, w0 * d1 - w1 * d0
            J[3, j], J[4, j], J[5, j] = w0, w1, w2
        j = tr.parent[j]
    return J


@kernel
def tool_at(tr, R, p):
    """The tool frame for the joint placements (R, p) of :func:`placements`: rotation (3, 3), origin (3,)
    and Jacobian (6, N)."""
    oR, op = world_placements(tr, R, p)
    Rf, pf = frame_pose(tr, oR, op)
    return Rf, pf, frame_jacobian(tr, oR, op, pf)


@kernel
def tool(tr, q):
    """The tool frame at ``q``: rotation (3, 3), origin (3,) and Jacobian (6, N)."""
    R, p = placements(tr, q)
    return tool_at(tr, R, p)


# -- dynamics ------------------------------------------------------------------------
@kernel
def rnea(tr, q, v, a):
    """Inverse dynamics: tau = M(q) a + C(q, v) v + g(q) (RNEA; armature included)."""
    n = tr.parent.shape[0]
    R, p = placements(tr, q)
    W = np.empty((4, n, 6))  # velocities, bias accelerations, accelerations, forces
    vel, c, acc, f = W[0], W[1], W[2], W[3]
    w = np.empty((3, 6))
    Iv, tmp = w[0], w[1]
    velocities(tr, R, p, v, vel, c, tmp)
    base = base_acceleration(tr)
    for j in range(n):
        i = tr.parent[j]
        motion_to_child(R[j], p[j], acc[i] if i >= 0 else base, acc[j])
        add_motion(tr, j, a[j], acc[j])
        for k in range(6):
            acc[j, k] += c[j, k]
        times(tr.inertia[j], acc[j], f[j])
        times(tr.inertia[j], vel[j], Iv)
        cross_force(vel[j], Iv, tmp)
        for k in range(6):
            f[j, k] += tmp[k]
    tau = np.empty(n)
    for j in range(n - 1, -1, -1):
        tau[j] = along_axis(tr, j, f[j]) + tr.armature[j] * a[j]
        i = tr.parent[j]
        if i >= 0:
            add_force_to_parent(R[j], p[j], f[j], f[i])
    return tau


@kernel
def crba(tr, q):
    """The joint-space inertia matrix M(q) (CRBA; armature on the diagonal), both triangles."""
    n = tr.parent.shape[0]
    R, p = placements(tr, q)
    Ic = tr.inertia.copy()
    w = np.empty((2, 6, 6))
    for j in range(n - 1, -1, -1):
        i = tr.parent[j]
        if i >= 0:
            add_inertia_to_parent(R[j], p[j], Ic[j], Ic[i], w[0], w[1])
    M = np.zeros((n, n))
    g = np.empty((2, 6))
    F, G = g[0], g[1]
    for j in range(n):
        a, o = tr.axis[j], 0 if tr.prismatic[j] else 3
        for r in range(6):  # F = Ic S
            F[r] = Ic[j, r, o] * a[0] + Ic[j, r, o + 1] * a[1] + Ic[j, r, o + 2] * a[2]
        M[j, j] = along_axis(tr, j, F) + tr.armature[j]
        k = j
        while tr.parent[k] >= 0:
            G[:] = 0.0
            add_force_to_parent(R[k], p[k], F, G)
            F[:] = G
            k = tr.parent[k]
            M[j, k] = M[k, j] = along_axis(tr, k, F)
    return M


@kernel
def aba_at(tr, R, p, v, tau):
    """Forward dynamics at the joint placements (R, p) of :func:`placements`: q'' with
    M(q) q'' + C(q, v) v + g(q) = tau (ABA; armature included)."""
    n = tr.parent.shape[0]
    W = np.empty((5, n, 6))  # velocities, bias accelerations, bias forces, I^A S, accelerations
    vel, c, pA, U, acc = W[0], W[1], W[2], W[3], W[4]
    w = np.empty((4, 6))
    Iv, pa, base = w[0], w[1], w[2]
    velocities(tr, R, p, v, vel, c, w[3])
    IA = tr.inertia.copy()
    for j in range(n):
        times(IA[j], vel[j], Iv)
        cross_force(vel[j], Iv, pA[j])
    s = np.empty((3, n))
    D, u, qdd = s[0], s[1], s[2]
    m = np.empty((3, 6, 6))
    Ia = m[0]
    for j in range(n - 1, -1, -1):
        a, o = tr.axis[j], 0 if tr.prismatic[j] else 3
        for r in range(6):  # U = I^A S
            U[j, r] = IA[j, r, o] * a[0] + IA[j, r, o + 1] * a[1] + IA[j, r, o + 2] * a[2]
        D[j] = along_axis(tr, j, U[j]) + tr.armature[j]
        u[j] = tau[j] - along_axis(tr, j, pA[j])
        i = tr.parent[j]
        if i >= 0:
            for r in range(6):
                for k in range(6):
                    Ia[r, k] = IA[j, r, k] - U[j, r] * U[j, k] / D[j]
            times(Ia, c[j], pa)
            for r in range(6):
                pa[r] += pA[j, r] + U[j, r] * u[j] / D[j]
            add_inertia_to_parent(R[j], p[j], Ia, IA[i], m[1], m[2])
            add_force_to_parent(R[j], p[j], pa, pA[i])
    base[:] = 0.0
    base[0], base[1], base[2] = -tr.gravity[0], -tr.gravity[1], -tr.gravity[2]  # gravity as the base's rise
    for j in range(n):
        i = tr.parent[j]
        motion_to_child(R[j], p[j], acc[i] if i >= 0 else base, acc[j])
        for k in range(6):
            acc[j, k] += c[j, k]
        qdd[j] = (u[j] - dot6(U[j], acc[j])) / D[j]
        add_motion(tr, j, qdd[j], acc[j])
    return qdd


@kernel
def aba(tr, q, v, tau):
    """Forward dynamics: q'' with M(q) q'' + C(q, v) v + g(q) = tau (ABA; armature included)."""
    R, p = placements(tr, q)
    return aba_at(tr, R, p, v, tau)


@kernel
def gravity(tr, q):
    """g(q): the joint forces that hold the tree still against gravity (RNEA at rest)."""
    n = tr.parent.shape[0]
    R, p = placements(tr, q)
    W = np.empty((2, n, 6))  # accelerations (gravity's, as the base's rise), forces
    acc, f = W[0], W[1]
    base = np.zeros(6)
    base[0], base[1], base[2] = -tr.gravity[0], -tr.gravity[1], -tr.gravity[2]
    for j in range(n):
        i = tr.parent[j]
        motion_to_child(R[j], p[j], acc[i] if i >= 0 else base, acc[j])
        times(tr.inertia[j], acc[j], f[j])
    tau = np.empty(n)
    for j in range(n - 1, -1, -1):
        tau[j] = along_axis(tr, j, f[j])
        i = tr.parent[j]
        if i >= 0:
            add_force_to_parent(R[j], p[j], f[j], f[i])
    return tau
