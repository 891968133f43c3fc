"""Finite differences and the matrices a linearization is made of.

Central-difference Jacobians with an error estimate, the zero-order-hold
discretization of a continuous part, and the states a lifted model can drop.
"""
import numpy as np
from scipy.linalg import expm


def zoh(A, B, tau):
    """(Phi, Gamma) of x' = A x + B u with u held over ``tau`` seconds."""
    n, m = A.shape[0], B.shape[1]
    aug = np.zeros((n + m, n + m))
    aug[:n, :n], aug[:n, n:] = A * tau, B * tau
    E = expm(aug)
    return E[:n, :n], E[:n, n:]


def _column(fun, x0, j, step, size=0.0, f0=None):
    """Column ``j`` of the central difference, its rounding error bound (eps times the larger of |f|
    and ``size``, the magnitude of the terms f sums, over the step) and, given f0 = f(x0), the
    difference of the one-sided slopes (forward - backward)."""
    e = np.zeros_like(x0)
    e[j] = step
    hi, lo = fun(x0 + e), fun(x0 - e)
    big = max(np.max(np.abs(hi) + np.abs(lo), initial=0.0), 2.0 * size)
    bend = None if f0 is None else (hi - 2.0 * f0 + lo) / step
    return (hi - lo) / (2 * step), np.finfo(float).eps * big / (2 * step), bend


def _columns(fun, x0, steps, size):
    f0 = fun(x0)
    J, noise, bend = np.zeros((f0.size, x0.size)), np.zeros(x0.size), np.zeros((f0.size, x0.size))
    for j in range(x0.size):
        J[:, j], noise[j], bend[:, j] = _column(fun, x0, j, steps[j], size, f0)
    return J, noise, bend


def checked_jacobian(fun, x0, steps, tol=1e-8, tries=8, size=0.0):
    """Jacobian and an estimate of its relative error: the difference to steps / 4 and the
    rounding error bound, relative to the largest entry.

    A column whose estimate exceeds ``tol`` is taken again with steps 10, 100, ... times larger,
    up to ``tries`` times, while that lowers it: a step small against a large right-hand side (a
    held input of 1e5 about a state at 0) loses the difference in rounding, a larger one keeps it
    (where rounding hid every entry, each column rounding could hide one in is taken again).
    ``size``: the magnitude of the values f's terms reach (its signals), where they cancel in f.

    A kink at x0 (a one-sided spring engaging there, a saturation at its limit) has one-sided slopes
    that differ by as much at steps / 4 as at steps (smooth: 4 times less); the central difference
    is then their mean, half their difference from either: relative to the larger slope, that is
    the estimate's floor for that entry, whatever the other entries' sizes. A jump at x0 (a floor,
    a sign) has no slope: a central difference 4 times larger at steps / 4; its estimate is 1.
    """
    J1, _, bend1 = _columns(fun, x0, steps, size)
    J2, noise, bend2 = _columns(fun, x0, steps / 4, size)
    if not J2.size:
        return J2, 0.0
    a1, a2 = np.abs(J1), np.abs(J2)
    seen = 1e3 * noise  # above what rounding could make
    # bend2 / bend1: 1/4 smooth, 1 a kink, 4 a jump or a value at x0 alone (an equality test, whose
    # neighbours agree: its central difference stays small)
    kink = ((np.abs(bend2) > 0.5 * np.abs(bend1)) & (np.abs(bend2) < 2.0 * np.abs(bend1))
            & (np.abs(bend2) > seen))
    jump = (a2 > 2.0 * a1) & (a2 < 8.0 * a1) & (a2 > seen)
    # at a kink the entry is the mean of its one-sided slopes J2 +- bend2 / 2: half their difference,
    # relative to the larger, is how far it is from either (0.5 for a saturation at its limit, 1 for |x|)
    sides = np.maximum(np.abs(J2 + bend2 / 2), np.abs(J2 - bend2 / 2))
    half = np.where(kink, np.abs(bend2) / 2, 0.0)
    bent = np.max(np.divide(half, sides, out=np.zeros_like(half), where=sides > 0), axis=0)
    bent = np.where(jump.any(axis=0), 1.0, bent)
    absolute = np.max(np.abs(J2 - J1), axis=0) + noise
    scale = np.max(a2)
    retake = absolute > tol * scale if scale > 0 else noise > 0
    for j in np.flatnonzero(retake & ~jump.any(axis=0)):
        step = steps[j]
        for _ in range(tries):
            step *= 10
            c1, _, _ = _column(fun, x0, j, step, size)
            c2, n2, _ = _column(fun, x0, j, step / 4, size)
            e = np.max(np.abs(c2 - c1)) + n2
            if not e < absolute[j]:
                break
            J2[:, j], absolute[j] = c2, e
            if e <= tol * max(scale, np.max(np.abs(c2))):
                break
    scale = np.max(np.abs(J2))
    if scale == 0:  # nothing depends on x0, at any step tried
        return J2, 0.0
    return J2, float(np.max(np.maximum(absolute / scale, bent)))


def nonzero_columns(M, drop=None):
    """States to keep: drop, repeatedly, those whose column is zero (and those in ``drop``).

    ``M`` has one column per state and one row per state, possibly followed by
    output rows. A state whose column vanishes (in the rows of the states kept
    and the outputs) influences nothing; dropping it removes a zero eigenvalue.
    """
    n = M.shape[1]
    extra = np.ones(M.shape[0] - n, bool)
    keep = np.ones(n, bool) if drop is None else ~np.asarray(drop, bool)
    while True:
        rows = np.concatenate([keep, extra])
        zero = keep & ~np.any(M[rows] != 0, axis=0)
        if not zero.any():
            return keep
        keep &= ~zero
