"""Kernels of the task-space blocks: hybrid_control_6d, task_phases, wrench_transform, the Jacobian blocks.

The same laws as the blocks' methods (the generic path's reference, :mod:`hybridsim.blocks.robot.hybrid6d`
and its neighbours) written as pure functions ``f(p, t, x, u)`` in numba's nopython subset
(:mod:`hybridsim.engine.kernels`), with rotations by :func:`exp3` and :func:`log3` (Pinocchio's
exp3 and log3, written out). Conventions: positions in metres, rotations as rotation vectors (rad),
wrenches as (force N, moment N m), matrices row by row on the wires.
"""
import math
from typing import NamedTuple

import numpy as np

from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.errors import SimulationError


class SingularJacobian(SimulationError):
    """A square task Jacobian with condition number above 1e8 (a singular pose), at time ``t`` (s)."""

    def __init__(self, t):
        super().__init__(f"a task Jacobian (hybrid_control_6d or task_jacobian_inverse) is singular at "
                         f"t = {t:.6g} s (condition number above 1e8): give dls_damping > 0 or avoid that pose")


class NotARotation(SimulationError):
    """A task frame's rotation (``hybrid_control_6d``'s input ``C``) that is not one, at time ``t`` (s)."""

    def __init__(self, t):
        super().__init__(f"hybrid_control_6d's input C at t = {t:.6g} s: its rotation (elements 3..11, row by "
                         "row) is not a rotation matrix (R^T R differs from I by more than 1e-6, or det R < 0)")


# -- rotations and the task inverse ---------------------------------------------------------
@kernel
def check_rotation(R, t):
    """Raise :class:`NotARotation` unless the 3x3 ``R`` is a rotation to 1e-6 (orthonormal, det +1)."""
    worst = 0.0
    for i in range(3):
        for j in range(3):
            d = R[0, i] * R[0, j] + R[1, i] * R[1, j] + R[2, i] * R[2, j] - (1.0 if i == j else 0.0)
            worst = max(worst, abs(d))
    det = (R[0, 0] * (R[1, 1] * R[2, 2] - R[1, 2] * R[2, 1]) - R[0, 1] * (R[1, 0] * R[2, 2] - R[1, 2] * R[2, 0])
           + R[0, 2] * (R[1, 0] * R[2, 1] - R[1, 1] * R[2, 0]))
    if not (worst <= 1e-6 and det > 0.0):
        raise NotARotation(t)



@kernel
def exp3(w):
    """The rotation matrix of the rotation vector ``w`` (rad): Rodrigues' formula."""
    th2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2]
    if th2 < 1e-8:  # series of sin(th)/th and (1 - cos th)/th^2
        a, b = 1.0 - th2 / 6.0 * (1.0 - th2 / 20.0), 0.5 - th2 / 24.0 * (1.0 - th2 / 30.0)
    else:
        th = math.sqrt(th2)
        a, b = math.sin(th) / th, (1.0 - math.cos(th)) / th2
    R = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            R[i, j] = b * w[i] * w[j]
        R[i, i] += 1.0 - b * th2
    R[0, 1] -= a * w[2]
    R[1, 0] += a * w[2]
    R[0, 2] += a * w[1]
    R[2, 0] -= a * w[1]
    R[1, 2] -= a * w[0]
    R[2, 1] += a * w[0]
    return R


@kernel
def log3(R):
    """The rotation vector (rad, angle in [0, pi]) of the rotation matrix ``R`` (3x3)."""
    c = 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0)
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])  # 2 sin(th) axis
    s = 0.5 * math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
    th = math.atan2(s, min(max(c, -1.0), 1.0))
    if c > -0.5:  # th below 120 degrees: the skew part gives the axis well
        f = 0.5 * (1.0 + s * s / 6.0) if s < 1e-5 else 0.5 * th / s
        return w * f
    B = np.empty((3, 3))  # near a half turn: the axis from the symmetric part, (1 - c) a a^T
    for i in range(3):
        for j in range(3):
            B[i, j] = 0.5 * (R[i, j] + R[j, i]) - (c if i == j else 0.0)
    k = 0
    for i in range(1, 3):
        if B[i, i] > B[k, k]:
            k = i
    a = B[k] / math.sqrt(B[k, k] * (1.0 - c))
    if a[0] * w[0] + a[1] * w[1] + a[2] * w[2] < 0.0:
        a = -a
    return a * th


@kernel
def matrix3(v, start):
    """The 3x3 matrix written row by row in ``v[start:start + 9]``."""
    R = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            R[i, j] = v[start + 3 * i + j]
    return R


@kernel
def rotate6(R, v):
    """Both halves of the six-vector ``v`` rotated by ``R``."""
    out = np.empty(6)
    for h in range(0, 6, 3):
        for i in range(3):
            out[h + i] = R[i, 0] * v[h] + R[i, 1] * v[h + 1] + R[i, 2] * v[h + 2]
    return out


@kernel
def task_inverse(J, V, lam, t):
    """J^-1 V (eq 14): exact for a square J, else damped least squares J^T (J J^T + lam^2 I)^-1 V;
    a square J with condition number above 1e8 raises :class:`SingularJacobian`."""
    if lam > 0.0:
        return J.T @ np.linalg.solve(J @ J.T + lam ** 2 * np.eye(J.shape[0]), V)
    if np.linalg.cond(J) > 1e8:
        raise SingularJacobian(t)
    return np.linalg.solve(J, V)


# -- hybrid_control_6d ---------------------------------------------------------------
class HybridParams(NamedTuple):
    n: int
    T: float             # the sample period, s
    rows: np.ndarray     # the controlled axes of {C} (int64)
    Kpp: np.ndarray
    Kpi: np.ndarray
    Kpd: np.ndarray
    Kfp: np.ndarray
    Kfi: np.ndarray
    tau_max: np.ndarray
    lam: float


@kernel
def hybrid_law(p, t, z, u, S):
    """(tau, new integrators, F in {C}) of eqs 12-16 with the selection ``S`` (six 0/1)."""
    n, rows = p.n, p.rows
    pos, C = u[0], u[9]
    RCt = matrix3(C, 3).T.copy()
    check_rotation(RCt, t)
    d = np.array([pos[0] - C[0], pos[1] - C[1], pos[2] - C[2]])
    Xd, Xdd, Fd = np.asarray(u[5]), np.asarray(u[6]), np.asarray(u[7])
    dX = np.empty(6)  # eq 12
    dX[:3] = Xd[:3] - RCt @ d
    dX[3:] = log3(exp3(Xd[3:]) @ (RCt @ matrix3(u[1], 0)).T)
    dXd = Xdd - rotate6(RCt, u[2])
    FC = rotate6(RCt, u[4])
    Xe, Xed, Fe = (1.0 - S) * dX, (1.0 - S) * dXd, S * (Fd - FC)  # eq 13
    J = np.asarray(u[3]).reshape(6, n)
    JC = np.empty((6, n))
    JC[:3], JC[3:] = RCt @ J[:3], RCt @ J[3:]
    JC = JC[rows]
    V = np.empty((rows.shape[0], 2))
    V[:, 0], V[:, 1] = Xe[rows], Xed[rows]
    Q = task_inverse(JC, V, p.lam, t)  # eq 14, one factorization
    qe, qed = Q[:, 0].copy(), Q[:, 1].copy()
    tau_e = JC.T @ Fe[rows]
    z = np.asarray(z)
    zq = z[:n] + qe * p.T
    zf = z[n:2 * n] + np.minimum(np.maximum(tau_e, -p.tau_max), p.tau_max) * p.T
    tau_p = p.Kpp * qe + p.Kpi * zq + p.Kpd * qed  # eq 15a
    tau_f = JC.T @ (S * Fd)[rows] + p.Kfp * tau_e + p.Kfi * zf  # eq 15b
    return tau_p + tau_f + np.asarray(u[10]), zq, zf, FC  # eq 16


@kernel
def hybrid_tick(p, t, z, u):
    """(tau, ∫q_e, ∫tau'_e, S, F in {C}) of one tick, bumpless when S changes (the force integrator
    takes the step S would make, where Kfi is not zero)."""
    n = p.n
    S = (np.asarray(u[8]) != 0.0) * 1.0
    tau, zq, zf, FC = hybrid_law(p, t, z, u, S)
    prev = np.asarray(z)[2 * n:].copy()
    if np.all(prev >= 0.0) and np.any(prev != S):
        before = hybrid_law(p, t, z, u, prev)[0]
        for i in range(n):
            if p.Kfi[i] != 0.0:
                zf[i] += (before[i] - tau[i]) / p.Kfi[i]
                tau[i] = before[i]
    return tau, zq, zf, S, FC


@kernel
def hybrid_arrays(z, u):
    """The state and the eleven inputs as arrays: compiled, :func:`hybrid_tick` then has the same
    argument types for every arm and is compiled once (numba's cache), not once per number of joints."""
    return np.asarray(z), (np.asarray(u[0]), np.asarray(u[1]), np.asarray(u[2]), np.asarray(u[3]),
                           np.asarray(u[4]), np.asarray(u[5]), np.asarray(u[6]), np.asarray(u[7]),
                           np.asarray(u[8]), np.asarray(u[9]), np.asarray(u[10]))


@kernel
def hybrid_output(p, t, z, u):
    """tau (held to the next tick) and F in {C}."""
    za, ua = hybrid_arrays(z, u)
    tau, zq, zf, S, FC = hybrid_tick(p, t, za, ua)
    return (tau, FC)


@kernel
def hybrid_update(p, t, z, u):
    """The integrators and this tick's S."""
    za, ua = hybrid_arrays(z, u)
    tau, zq, zf, S, FC = hybrid_tick(p, t, za, ua)
    return np.concatenate((zq, zf, S))


HYBRID = Kernels(output=hybrid_output, update=hybrid_update)


# -- task_phases -----------------------------------------------------------------------
class PhasesParams(NamedTuple):
    o: np.ndarray        # {C}'s origin, m
    RC: np.ndarray       # {C}'s rotation (3x3)
    k: int               # the normal axis
    v: float             # approach speed, m/s
    f0: float            # contact force, N
    f1: float            # force, N
    t_ramp: float
    t_settle: float
    radius: float
    T: float             # circle period, s


@kernel
def phases_commands(p, t, z, u):
    """((S, X_d, X_d', F_d, phase), new state) of one tick (see :class:`~.phases.TaskPhases`)."""
    x = np.asarray(z).copy()
    RCt = p.RC.T.copy()
    if x[0] < 0:  # the first tick: the start pose in {C}
        d = np.array([u[0][0] - p.o[0], u[0][1] - p.o[1], u[0][2] - p.o[2]])
        x[0], x[1] = 0.0, t
        x[2:5] = RCt @ d
        x[5:8] = log3(RCt @ matrix3(u[1], 0))
    k = p.k
    FC = rotate6(RCt, u[2])
    S, Xd, Xdd, Fd = np.zeros(6), x[2:8].copy(), np.zeros(6), np.zeros(6)
    if x[0] == 0.0:
        if FC[k] >= p.f0:  # contact: hold where it was found, press from here on
            x[8:14] = x[2:8]
            x[8 + k] += p.v * (t - x[1])
            x[0], x[1] = 1.0, t
        else:
            Xd[k] += p.v * (t - x[1])
            Xdd[k] = p.v
    if x[0] >= 1.0:
        S[k] = 1.0
        Xd = x[8:14].copy()
        s = t - x[1]
        ramp = min(1.0, s / p.t_ramp) if p.t_ramp > 0 and x[0] == 1.0 else 1.0
        Fd[k] = p.f0 + (p.f1 - p.f0) * ramp
        if x[0] == 1.0 and s >= p.t_ramp + p.t_settle - 1e-9:  # a tick that lands on it, in floats
            x[0], x[1] = 2.0, t
        if x[0] == 2.0:
            a, b = (1 if k == 0 else 0), (1 if k == 2 else 2)  # the two other axes, in order
            s = min(t - x[1], p.T)  # one turn, from rest to rest: th = pi (1 - cos(pi s / T))
            th = np.pi * (1.0 - np.cos(np.pi * s / p.T))
            w = np.pi ** 2 / p.T * np.sin(np.pi * s / p.T)
            Xd[a] += p.radius * (np.cos(th) - 1.0)
            Xd[b] += p.radius * np.sin(th)
            Xdd[a], Xdd[b] = -p.radius * w * np.sin(th), p.radius * w * np.cos(th)
    return (S, Xd, Xdd, Fd, x[:1].copy()), x


@kernel
def phases_output(p, t, z, u):
    """S, X_d, X_d', F_d in {C} and the phase."""
    return phases_commands(p, t, z, u)[0]


@kernel
def phases_update(p, t, z, u):
    """The phase, when it began, the start pose and the pose where contact was found."""
    return phases_commands(p, t, z, u)[1]


PHASES = Kernels(output=phases_output, update=phases_update)


# -- wrench_transform and the Jacobian blocks ---------------------------------------------
@kernel
def wrench_output(p, t, x, u):
    """f_out = R f_in, m_out = R m_in + r x f_out."""
    w, R, r = u[0], u[1], u[2]
    f0 = R[0] * w[0] + R[1] * w[1] + R[2] * w[2]
    f1 = R[3] * w[0] + R[4] * w[1] + R[5] * w[2]
    f2 = R[6] * w[0] + R[7] * w[1] + R[8] * w[2]
    return ((f0, f1, f2,
             R[0] * w[3] + R[1] * w[4] + R[2] * w[5] + (r[1] * f2 - r[2] * f1),
             R[3] * w[3] + R[4] * w[4] + R[5] * w[5] + (r[2] * f0 - r[0] * f2),
             R[6] * w[3] + R[7] * w[4] + R[8] * w[5] + (r[0] * f1 - r[1] * f0)),)


WRENCH = Kernels(output=wrench_output)


class JacobianParams(NamedTuple):
    n: int
    rows: np.ndarray     # the rows of J kept (int64)
    lam: float           # damped least squares (the inverse's)


@kernel
def transpose_output(p, t, x, u):
    """tau = J^T F over the kept rows."""
    J = np.asarray(u[0]).reshape(6, p.n)[p.rows]
    return (J.T @ np.asarray(u[1])[p.rows],)


@kernel
def inverse_output(p, t, x, u):
    """q = J^-1 X over the kept rows."""
    J = np.asarray(u[0]).reshape(6, p.n)[p.rows]
    return (task_inverse(J, np.asarray(u[1])[p.rows].copy(), p.lam, t),)


TRANSPOSE = Kernels(output=transpose_output)
INVERSE = Kernels(output=inverse_output)
