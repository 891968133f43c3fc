"""Signal routing and arithmetic: sum, gain, selection, mux, demux."""

import numpy as np

from hybridsim.engine.block import Block
from hybridsim.errors import ParameterError
from hybridsim.engine.kernels import Kernels, kernel, unroll
from hybridsim.engine.registry import register

from hybridsim.blocks._util import count, finite_matrix, flag, matrix, zero_one


GROUP = "math"  # where `hybridsim blocks` lists this module's blocks


@register("sum")
class Sum(Block):
    """y = sum of inputs u1, u2, ... each with the sign in ``signs`` ('+-' : u1 - u2)."""

    def __init__(self, name="sum", signs="+-", width=1):
        super().__init__(name)
        if not isinstance(signs, str) or not signs or set(signs) - {"+", "-"}:
            raise ValueError(f"signs must be a string of + and -, got {signs!r}")
        self.params = (tuple(1.0 if c == "+" else -1.0 for c in signs),)
        for k in range(len(signs)):
            self.declare_input(f"u{k + 1}", width)
        self.declare_output("y", width)


@kernel
def sum_output(p, t, x, u, out):
    signs = p[0]
    n = len(u[0])
    y = out[0]  # summed into element by element (compiled: no temporaries)
    first = u[0]
    for i in range(n):
        y[i] = signs[0] * first[i]
    k = 0
    for v in unroll(u):  # the inputs may mix arrays and tuples (compiled: unrolled)
        if k > 0:
            for i in range(n):
                y[i] = y[i] + signs[k] * v[i]
        k += 1
    return out


@register("gain")
class Gain(Block):
    """y = K u; K scalar, diagonal list or full matrix.

    A scalar or a list (the diagonal) keeps the width (``width``, or the list's length); a
    matrix of m rows and n columns takes u of n elements to y of m (``width``, when given, is n).
    Example: K = [[1, 2], [3, 4], [5, 6]], u = [1, 1] gives y = [3, 7, 11].
    """

    def __init__(self, name="gain", K=1.0, width=1):
        super().__init__(name)
        width = count(width, "width")
        shape = np.shape(np.asarray(K, dtype=object))
        if len(shape) == 2 and width in (1, shape[1]):  # a matrix sets the widths
            self.params = (finite_matrix(K, "K"),)
        else:  # a scalar, or a list (the diagonal) at its own length
            self.params = (matrix(K, "K", shape[0] if len(shape) == 1 and width == 1 else width),)
        self.declare_input("u", self.params[0].shape[1])
        self.declare_output("y", self.params[0].shape[0])


@kernel
def gain_output(p, t, x, u):
    return (np.dot(p[0], np.asarray(u[0])),)


@register("selection")
class Selection(Block):
    """Compliance selection, eq 13: y = S u, or (I - S) u with ``complement``.

    S = diag(s), s_j = 1 for force-controlled directions of {C}.
    """

    group = "paper"

    def __init__(self, name="sel", S=(1, 0), complement=False):
        super().__init__(name)
        s = zero_one(S, "S", meaning="0 (position) or 1 (force)")
        complement = flag(complement, "complement")
        self.params = (1.0 - s if complement else s,)  # the diagonal of S or I - S
        self.declare_input("u", s.size)
        self.declare_output("y", s.size)


@kernel
def selection_output(p, t, x, u, out):
    s, v, y = p[0], u[0], out[0]
    for i in range(s.size):
        y[i] = s[i] * v[i]  # eq 13
    return out


@register("mux")
class Mux(Block):
    """Stack inputs u1 (widths[0]), u2 (widths[1]), ... into one vector y = [u1; u2; ...]."""

    def __init__(self, name="mux", widths=(1, 1)):
        super().__init__(name)
        widths = _widths(widths)
        for k, w in enumerate(widths):
            self.declare_input(f"u{k + 1}", w)
        self.declare_output("y", sum(widths))
        self.params = (sum(widths),)


@kernel
def mux_output(p, t, x, u):
    y = np.empty(p[0])
    k = 0
    for v in unroll(u):  # the inputs may mix arrays and tuples (compiled: unrolled)
        for e in v:
            y[k] = e
            k += 1
    return (y,)


@register("demux")
class Demux(Block):
    """Split u into y1 (widths[0]), y2 (widths[1]), ... (kernels for up to 8 outputs)."""

    def __init__(self, name="demux", widths=(1, 1)):
        super().__init__(name)
        widths = _widths(widths)
        self.cuts = np.cumsum([0] + widths)
        self.declare_input("u", int(self.cuts[-1]))
        for k, w in enumerate(widths):
            self.declare_output(f"y{k + 1}", int(w))
        self.params = (tuple(int(c) for c in self.cuts),)
        self.kernels = _DEMUX[len(widths)] if len(widths) in _DEMUX else None

    def output(self, t, x, u):
        return tuple(u[0][a:b] for a, b in zip(self.cuts[:-1], self.cuts[1:]))


@kernel
def demux_piece(p, u, k):
    """Output k of a demux: the slice cuts[k]:cuts[k + 1] of its input."""
    c = p[0]
    return np.asarray(u[0])[c[k]:c[k + 1]].copy()


@kernel
def demux1_output(p, t, x, u):
    """The output of a demux with one output."""
    return (demux_piece(p, u, 0),)


@kernel
def demux2_output(p, t, x, u):
    """The 2 outputs of a demux with 2 outputs."""
    return demux_piece(p, u, 0), demux_piece(p, u, 1)


@kernel
def demux3_output(p, t, x, u):
    """The 3 outputs of a demux with 3 outputs."""
    return demux_piece(p, u, 0), demux_piece(p, u, 1), demux_piece(p, u, 2)


@kernel
def demux4_output(p, t, x, u):
    """The 4 outputs of a demux with 4 outputs."""
    return demux_piece(p, u, 0), demux_piece(p, u, 1), demux_piece(p, u, 2), demux_piece(p, u, 3)


@kernel
def demux5_output(p, t, x, u):
    """The 5 outputs of a demux with 5 outputs."""
    return demux4_output(p, t, x, u) + (demux_piece(p, u, 4),)


@kernel
def demux6_output(p, t, x, u):
    """The 6 outputs of a demux with 6 outputs."""
    return demux4_output(p, t, x, u) + (demux_piece(p, u, 4), demux_piece(p, u, 5))


@kernel
def demux7_output(p, t, x, u):
    """The 7 outputs of a demux with 7 outputs."""
    return demux4_output(p, t, x, u) + (demux_piece(p, u, 4), demux_piece(p, u, 5), demux_piece(p, u, 6))


@kernel
def demux8_output(p, t, x, u):
    """The 8 outputs of a demux with 8 outputs."""
    return demux4_output(p, t, x, u) + demux4_output((p[0][4:],), t, x, u)


_DEMUX = {k + 1: Kernels(output=f) for k, f in enumerate(
    (demux1_output, demux2_output, demux3_output, demux4_output, demux5_output, demux6_output,
     demux7_output, demux8_output))}


def _widths(widths):
    if not isinstance(widths, (list, tuple)) or not widths:
        raise ParameterError("widths", f"must be a list of port widths, got {widths!r}")
    return [count(w, "widths") for w in widths]


Sum.kernels = Kernels(output_into=sum_output)
Mux.kernels = Kernels(output=mux_output)
Gain.kernels = Kernels(output=gain_output)
Selection.kernels = Kernels(output_into=selection_output)
