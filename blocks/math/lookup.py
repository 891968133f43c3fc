"""Lookup tables on a rectangular grid, linear interpolation: the n-D table and the kernels of lookup_1d.

Beyond the breakpoints a table either holds its end values (``extrapolation:
hold``, Simulink's "clip") or continues the end segments' slopes
(``extrapolation: linear``, Simulink's default "linear extrapolation"); both
are the same numbers as scipy's ``RegularGridInterpolator`` (method linear, at
the clipped input or with ``fill_value=None``).
"""
import itertools
from typing import NamedTuple

import numpy as np

from hybridsim.engine.block import Block
from hybridsim.errors import ParameterError
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.engine.registry import register

from hybridsim.blocks._util import as_floats, vector

GROUP = "math"  # where `hybridsim blocks` lists this module's blocks

_EXTRAPOLATION = ("hold", "linear")


def _breakpoints(values, name):
    b = vector(values, name)
    if b.size < 2 or np.any(np.diff(b) <= 0):
        raise ParameterError(name, f"needs at least 2 strictly increasing breakpoints, got {b.tolist()!r}")
    return b


def _extrapolation(value):
    if value not in _EXTRAPOLATION:
        raise ParameterError("extrapolation", f"must be hold or linear, got {value!r}")
    return float(value == "linear")


class LookupParams(NamedTuple):
    bps: np.ndarray      # every dimension's breakpoints, one after the other
    starts: np.ndarray   # where dimension d's breakpoints start in bps (d + 1 entries)
    table: np.ndarray    # the values, C order, flat
    strides: np.ndarray  # table index step per dimension
    linear: float        # 1: linear extrapolation, 0: hold
    corners: np.ndarray  # the 2^d corners of a cell, as 0/1 rows
    n: int               # elements looked up (1-D table: the width; n-D: 1)


@kernel
def lookup_at(p, q):
    """Multilinear interpolation of the table at the point q (one coordinate per dimension)."""
    d = p.starts.size - 1
    base = 0
    frac = np.empty(d)
    for j in range(d):
        b = p.bps[p.starts[j]:p.starts[j + 1]]
        k = min(max(np.searchsorted(b, q[j], side="right") - 1, 0), b.size - 2)
        f = (q[j] - b[k]) / (b[k + 1] - b[k])
        if p.linear == 0.0:
            f = min(max(f, 0.0), 1.0)
        frac[j] = f
        base += k * p.strides[j]
    y = 0.0
    for c in range(p.corners.shape[0]):
        w = 1.0
        idx = base
        for j in range(d):
            if p.corners[c, j] == 1:
                w *= frac[j]
                idx += p.strides[j]
            else:
                w *= 1.0 - frac[j]
        y += w * p.table[idx]
    return y


def _params(bps, table, linear, n):
    table = np.ascontiguousarray(table, float)
    strides = np.array(table.strides, dtype=np.int64) // table.itemsize
    corners = np.array(list(itertools.product((0, 1), repeat=len(bps))), dtype=np.int64)
    starts = np.cumsum([0] + [b.size for b in bps]).astype(np.int64)
    return LookupParams(np.concatenate(bps), starts, table.ravel(), strides, linear, corners, n)


@kernel
def lookup_1d_output(p, t, x, u):
    """lookup_1d (:mod:`hybridsim.blocks.math.nonlinear`): each element of u in the same 1-D table."""
    ua = np.asarray(u[0])
    y = np.empty(p.n)
    q = np.empty(1)
    for i in range(p.n):
        q[0] = ua[i]
        y[i] = lookup_at(p, q)
    return (y,)


def table_params(bps, table, extrapolation, n):
    """The kernels' numbers of a table on the grid ``bps`` (a list of breakpoint arrays)."""
    return _params(bps, table, _extrapolation(extrapolation), n)


@register("lookup_nd")
class LookupND(Block):
    """y = f(u[0], ..., u[d-1]): multilinear interpolation on a rectangular grid.

    Parameters
    ----------
    breakpoints : list of lists   one strictly increasing list per dimension (units of u[j])
    table : nested list           values of shape (len(breakpoints[0]), ..., len(breakpoints[d-1]))
    extrapolation : str           ``linear`` (default, as Simulink's n-D Lookup Table) or ``hold``

    Ports: in ``u`` of width d (one coordinate per dimension); out ``y`` (width 1).
    Example: breakpoints [[0, 1], [0, 1]], table [[0, 1], [2, 3]]: f(0.5, 0.5) = 1.5.
    """

    def __init__(self, name="lookup_nd", breakpoints=((0.0, 1.0), (0.0, 1.0)), table=((0.0, 1.0), (2.0, 3.0)),
                 extrapolation="linear"):
        super().__init__(name)
        if not isinstance(breakpoints, (list, tuple)) or not breakpoints or not all(
                isinstance(b, (list, tuple, np.ndarray)) for b in breakpoints):
            raise ParameterError("breakpoints", "must be a list of breakpoint lists, one per dimension")
        bps = [_breakpoints(b, "breakpoints") for b in breakpoints]
        tab = as_floats(table, "table", "a nested list of numbers (a rectangular grid)")
        shape = tuple(b.size for b in bps)
        if tab.shape != shape:
            raise ParameterError("table", f"must have shape {shape} (one value per grid point), got {tab.shape}")
        if not np.all(np.isfinite(tab)):
            raise ParameterError("table", "must be finite")
        self.params = _params(bps, tab, _extrapolation(extrapolation), 1)
        self.declare_input("u", len(bps))
        self.declare_output("y", 1)


@kernel
def lookup_nd_output(p, t, x, u):
    return (np.array([lookup_at(p, np.asarray(u[0]))]),)


LookupND.kernels = Kernels(output=lookup_nd_output)
