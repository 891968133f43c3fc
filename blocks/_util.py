"""Small helpers shared by the block library (parameter shaping)."""
import numpy as np


def vector(value, name, width=None):
    """A parameter as a 1-D float array (a scalar broadcasts to ``width``)."""
    try:
        arr = np.atleast_1d(np.asarray(value, dtype=float))
    except (TypeError, ValueError):
        raise ValueError(f"parameter {name!r} must be a number or a list of numbers, got {value!r}") from None
    if arr.ndim != 1:
        raise ValueError(f"parameter {name!r} must be a flat list, got shape {arr.shape}")
    if width is not None:
        if arr.size == 1:
            arr = np.full(width, arr[0])
        elif arr.size != width:
            raise ValueError(f"parameter {name!r} must have {width} elements, got {arr.size}")
    return arr


def floats(value, name, width=None):
    """A parameter as a tuple of floats (what kernels read; see :func:`vector`)."""
    return tuple(float(v) for v in vector(value, name, width))


def matrix(value, name, n):
    """A gain as an n x n matrix: a scalar, a diagonal list, or a full matrix."""
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        return np.eye(n) * float(arr)
    if arr.ndim == 1:
        return np.diag(vector(arr, name, n))
    if arr.shape != (n, n):
        raise ValueError(f"parameter {name!r} must be {n}x{n}, got shape {arr.shape}")
    return arr
