"""General-purpose blocks: sums, gains, selection, mux, delays, filters, recorder."""
import math

import numpy as np

from hybridsim.block import Block
from hybridsim.errors import ParameterError
from hybridsim.kernels import Kernels, kernel, unroll
from hybridsim.registry import register

from ._util import count, finite_matrix, flag, matrix, scalar, vector


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
def sum_output(p, t, x, u):
    signs = p[0]
    y = signs[0] * np.asarray(u[0])
    k = 0
    for v in unroll(u):  # the inputs may mix arrays and tuples (compiled: unrolled)
        if k > 0:
            y = y + signs[k] * np.asarray(v)
        k += 1
    return (y,)


@register("gain")
class Gain(Block):
    """y = K u; K scalar, diagonal list or full matrix."""

    def __init__(self, name="gain", K=1.0, width=1):
        super().__init__(name)
        self.params = (matrix(K, "K", width),)
        self.declare_input("u", width)
        self.declare_output("y", width)


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
        s = vector(S, "S")
        if set(np.unique(s)) - {0.0, 1.0}:
            raise ParameterError("S", f"must hold only 0 and 1, got {S!r}")
        complement = flag(complement, "complement")
        self.params = (1.0 - s if complement else s,)  # the diagonal of S or I - S
        self.declare_input("u", s.size)
        self.declare_output("y", s.size)


@kernel
def selection_output(p, t, x, u):
    return (p[0] * np.asarray(u[0]),)  # eq 13


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


@register("zoh")
class ZeroOrderHold(Block):
    """Sample u at the block's rate and hold it (a rate transition)."""

    group = "control"

    def __init__(self, name="zoh", rate=None, period=None, width=1):
        super().__init__(name)
        self.declare_rate(period=period, rate=rate)
        self.declare_input("u", width)
        self.declare_output("y", width)


@kernel
def zoh_output(p, t, x, u):
    return (u[0],)


@register("delay")
class UnitDelay(Block):
    """y[k] = u[k-1]: one sample of delay; breaks algebraic loops.

    ``initial``: y[0], one number or one per element (then ``width`` defaults to its length).
    """

    group = "control"

    def __init__(self, name="delay", rate=None, period=None, width=None, initial=0.0):
        super().__init__(name)
        self.declare_rate(period=period, rate=rate)
        width = count(width, "width") if width is not None else max(np.size(initial), 1)
        self.declare_discrete_state(width)
        self.x0 = vector(initial, "initial", width)
        self.declare_input("u", width)
        self.declare_output("y", width, depends_on=())

    def initial_state(self, u=None):
        return self.x0.copy()


@kernel
def delay_output(p, t, x, u):
    return (x,)


@kernel
def delay_update(p, t, x, u):
    return u[0]


@register("lowpass")
class LowPass(Block):
    """Second-order Butterworth low-pass, continuous: the paper's 12 Hz display filter.

    y'' + sqrt(2) wc y' + wc^2 y = wc^2 u, wc = 2 pi cutoff; unity DC gain,
    starts at rest at ``initial``.
    """

    group = "control"

    def __init__(self, name="filter", cutoff=12.0, width=1, initial=0.0):
        super().__init__(name)
        wc = 2 * math.pi * scalar(cutoff, "cutoff", "positive")
        self.n = count(width, "width")
        self.params = (wc, self.n)
        self.y0 = vector(initial, "initial", self.n)
        self.declare_input("u", self.n)
        self.declare_output("y", self.n, depends_on=())
        self.declare_continuous_state(2 * self.n, atol=1e-9)

    def initial_state(self, u=None):
        return np.concatenate([self.y0, np.zeros(self.n)])


@kernel
def lowpass_output(p, t, x, u):
    return (np.asarray(x)[: p[1]],)


@kernel
def lowpass_derivatives(p, t, x, u):
    wc, n = p
    xa = np.asarray(x)
    y, yd = xa[:n], xa[n:]
    return np.concatenate((yd, wc * wc * (np.asarray(u[0]) - y) - math.sqrt(2) * wc * yd))


@register("recorder")
class Recorder(Block):
    """A sink whose inputs are all logged; ``inputs`` maps names to widths."""

    group = "sinks"

    log_inputs = True

    def __init__(self, name="scope", inputs=None):
        super().__init__(name)
        if inputs is not None and not isinstance(inputs, dict):
            raise ParameterError("inputs", f"must map input names to widths, got {inputs!r}")
        for k, w in (inputs or {"u": 1}).items():
            self.declare_input(str(k), count(w, "inputs"))


@register("counter")
class Counter(Block):
    """Counts its own sample hits (y = hits so far); for checking schedules."""

    group = "sources"

    def __init__(self, name="counter", rate=None, period=None, offset=0):
        super().__init__(name)
        self.declare_rate(period=period, rate=rate, offset=offset)
        self.declare_discrete_state(1)
        self.declare_output("y", 1)


@kernel
def counter_output(p, t, x, u):
    return ((x[0] + 1.0,),)


@kernel
def counter_update(p, t, x, u):
    return (x[0] + 1.0,)


@register("state_space")
class StateSpace(Block):
    """Continuous LTI system x' = A x + B u, y = C x + D u (any plant or filter).

    ``D`` defaults to zero (then y has no direct feedthrough); ``x0`` the initial state.
    """

    group = "control"

    def __init__(self, name="ss", A=((0.0,),), B=((1.0,),), C=((1.0,),), D=None, x0=None):
        super().__init__(name)
        A, B, C = (finite_matrix(M, k) for M, k in ((A, "A"), (B, "B"), (C, "C")))
        n, m, p = A.shape[0], B.shape[1], C.shape[0]
        if A.shape != (n, n) or B.shape[0] != n or C.shape[1] != n:
            raise ParameterError("A", f"B and C have inconsistent shapes: A {A.shape}, B {B.shape}, C {C.shape}")
        D = np.zeros((p, m)) if D is None else finite_matrix(D, "D")
        if D.shape != (p, m):
            raise ParameterError("D", f"must be {p}x{m}, got {D.shape}")
        self.params = tuple(np.ascontiguousarray(M) for M in (A, B, C, D))
        self.x0 = np.zeros(n) if x0 is None else vector(x0, "x0", n)
        self.declare_input("u", m)
        self.declare_output("y", p, depends_on=None if np.any(D) else ())
        self.declare_continuous_state(n)

    def initial_state(self, u=None):
        return self.x0.copy()


@kernel
def state_space_output(p, t, x, u):
    A, B, C, D = p
    return (np.dot(C, np.asarray(x)) + np.dot(D, np.asarray(u[0])),)


@kernel
def state_space_derivatives(p, t, x, u):
    A, B, C, D = p
    return np.dot(A, np.asarray(x)) + np.dot(B, np.asarray(u[0]))


Sum.kernels = Kernels(output=sum_output)
Mux.kernels = Kernels(output=mux_output)
Gain.kernels = Kernels(output=gain_output)
Selection.kernels = Kernels(output=selection_output)
ZeroOrderHold.kernels = Kernels(output=zoh_output)
UnitDelay.kernels = Kernels(output=delay_output, update=delay_update)
LowPass.kernels = Kernels(output=lowpass_output, derivatives=lowpass_derivatives)
Counter.kernels = Kernels(output=counter_output, update=counter_update)
StateSpace.kernels = Kernels(output=state_space_output, derivatives=state_space_derivatives)
