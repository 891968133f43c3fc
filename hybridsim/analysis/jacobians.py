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


def jacobian(fun, x0, steps):
    """Central-difference Jacobian of ``fun`` at ``x0`` with per-entry steps."""
    f0 = fun(x0)
    J = np.zeros((f0.size, x0.size))
    for j in range(x0.size):
        e = np.zeros_like(x0)
        e[j] = steps[j]
        J[:, j] = (fun(x0 + e) - fun(x0 - e)) / (2 * steps[j])
    return J


def checked_jacobian(fun, x0, steps):
    """Jacobian and an estimate of its error (difference to steps / 4)."""
    J1 = jacobian(fun, x0, steps)
    J2 = jacobian(fun, x0, steps / 4)
    if not J2.size:  # no continuous state (or no input): nothing to difference
        return J2, 0.0
    return J2, float(np.max(np.abs(J2 - J1)) / max(np.max(np.abs(J2)), 1e-300))


def nonzero_columns(M):
    """States to keep: drop, repeatedly, those whose column is zero.

    ``M`` has one column per state and one row per state, possibly followed by
    output rows. A state whose column vanishes (in the rows of the states kept
    and the outputs) influences nothing; dropping it removes a zero eigenvalue.
    """
    n = M.shape[1]
    extra = np.ones(M.shape[0] - n, bool)
    keep = np.ones(n, bool)
    while True:
        rows = np.concatenate([keep, extra])
        zero = keep & ~np.any(M[rows] != 0, axis=0)
        if not zero.any():
            return keep
        keep &= ~zero
