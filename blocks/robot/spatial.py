"""Spatial algebra on 6-vectors and 6x6 matrices, for the rigid-body algorithms of :mod:`.rigid`.

Pinocchio's conventions: a motion is (linear, angular), a force is (force, moment), both at a
frame's origin in its axes; a child frame is placed at (R, p) in its parent (its rotation and
origin there). Featherstone, *Rigid Body Dynamics Algorithms* (2008), ch. 2. The functions write
into ``out`` and allocate nothing (they run on every right-hand side), in numba's nopython subset.
"""
from hybridsim.engine.kernels import kernel


@kernel
def motion_to_child(R, p, m, out):
    """``out`` = the motion ``m`` (parent frame) in the child frame placed at (R, p) in the parent."""
    w0, w1, w2 = m[3], m[4], m[5]
    v0, v1, v2 = m[0] + w1 * p[2] - w2 * p[1], m[1] + w2 * p[0] - w0 * p[2], m[2] + w0 * p[1] - w1 * p[0]
    for k in range(3):
        out[k] = R[0, k] * v0 + R[1, k] * v1 + R[2, k] * v2
        out[3 + k] = R[0, k] * w0 + R[1, k] * w1 + R[2, k] * w2


@kernel
def add_force_to_parent(R, p, f, out):
    """``out`` += the force ``f`` (child frame, placed at (R, p) in the parent) in the parent frame."""
    g0 = R[0, 0] * f[0] + R[0, 1] * f[1] + R[0, 2] * f[2]
    g1 = R[1, 0] * f[0] + R[1, 1] * f[1] + R[1, 2] * f[2]
    g2 = R[2, 0] * f[0] + R[2, 1] * f[1] + R[2, 2] * f[2]
    out[0] += g0
    out[1] += g1
    out[2] += g2
    out[3] += R[0, 0] * f[3] + R[0, 1] * f[4] + R[0, 2] * f[5] + p[1] * g2 - p[2] * g1
    out[4] += R[1, 0] * f[3] + R[1, 1] * f[4] + R[1, 2] * f[5] + p[2] * g0 - p[0] * g2
    out[5] += R[2, 0] * f[3] + R[2, 1] * f[4] + R[2, 2] * f[5] + p[0] * g1 - p[1] * g0


@kernel
def add_inertia_to_parent(R, p, M, out, X, T):
    """``out`` += X M X^T, X = [[R, 0], [[p]x R, R]]: the (articulated) inertia ``M`` of a child frame
    placed at (R, p), in the parent's frame. ``X``, ``T``: 6x6 scratch arrays."""
    for r in range(3):
        for k in range(3):
            X[r, k] = R[r, k]
            X[3 + r, 3 + k] = R[r, k]
        X[3, r] = p[1] * R[2, r] - p[2] * R[1, r]
        X[4, r] = p[2] * R[0, r] - p[0] * R[2, r]
        X[5, r] = p[0] * R[1, r] - p[1] * R[0, r]
    for r in range(6):  # T = X M (X's upper right block is zero)
        for k in range(6):
            acc = 0.0
            for m in range(6 if r >= 3 else 3):
                acc += X[r, m] * M[m, k]
            T[r, k] = acc
    for r in range(6):  # out += T X^T, symmetric: the upper triangle, mirrored
        for k in range(r, 6):
            acc = 0.0
            for m in range(6 if k >= 3 else 3):
                acc += T[r, m] * X[k, m]
            out[r, k] += acc
            if k != r:
                out[k, r] += acc


@kernel
def cross_motion(v, m, out):
    """``out`` = v x m (motion cross product)."""
    out[0] = v[4] * m[2] - v[5] * m[1] + v[1] * m[5] - v[2] * m[4]
    out[1] = v[5] * m[0] - v[3] * m[2] + v[2] * m[3] - v[0] * m[5]
    out[2] = v[3] * m[1] - v[4] * m[0] + v[0] * m[4] - v[1] * m[3]
    out[3] = v[4] * m[5] - v[5] * m[4]
    out[4] = v[5] * m[3] - v[3] * m[5]
    out[5] = v[3] * m[4] - v[4] * m[3]


@kernel
def cross_force(v, f, out):
    """``out`` = v x* f (force cross product)."""
    out[0] = v[4] * f[2] - v[5] * f[1]
    out[1] = v[5] * f[0] - v[3] * f[2]
    out[2] = v[3] * f[1] - v[4] * f[0]
    out[3] = v[4] * f[5] - v[5] * f[4] + v[1] * f[2] - v[2] * f[1]
    out[4] = v[5] * f[3] - v[3] * f[5] + v[2] * f[0] - v[0] * f[2]
    out[5] = v[3] * f[4] - v[4] * f[3] + v[0] * f[1] - v[1] * f[0]


@kernel
def times(M, v, out):
    """``out`` = M v for a 6x6 ``M``."""
    for r in range(6):
        out[r] = M[r, 0] * v[0] + M[r, 1] * v[1] + M[r, 2] * v[2] + M[r, 3] * v[3] + M[r, 4] * v[4] + M[r, 5] * v[5]


@kernel
def dot6(a, b):
    """a . b of two 6-vectors."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] + a[4] * b[4] + a[5] * b[5]
