"""General-purpose blocks: sums, gains, selection, mux, delays, filters, recorder."""
import math

import numpy as np

from hybridsim.block import Block
from hybridsim.registry import register

from ._util import matrix, vector


@register("sum")
class Sum(Block):
    """y = sum of inputs u1, u2, ... each with the sign in ``signs`` ('+-' : u1 - u2)."""

    def __init__(self, name="sum", signs="+-", width=1):
        super().__init__(name)
        if not signs or set(signs) - {"+", "-"}:
            raise ValueError(f"signs must be a string of + and -, got {signs!r}")
        self.signs = [1.0 if c == "+" else -1.0 for c in signs]
        for k in range(len(self.signs)):
            self.declare_input(f"u{k + 1}", width)
        self.declare_output("y", width)

    def output(self, t, x, u):
        y = self.signs[0] * u[0]
        for s, v in zip(self.signs[1:], u[1:]):
            y = y + s * v
        return (y,)


@register("gain")
class Gain(Block):
    """y = K u; K scalar, diagonal list or full matrix."""

    def __init__(self, name="gain", K=1.0, width=1):
        super().__init__(name)
        self.K = matrix(K, "K", width)
        self.declare_input("u", width)
        self.declare_output("y", width)

    def output(self, t, x, u):
        return (self.K @ u[0],)


@register("selection")
class Selection(Block):
    """Compliance selection, eq 13: y = S u, or (I - S) u with ``complement``.

    S = diag(s), s_j = 1 for force-controlled directions of {C}.
    """

    def __init__(self, name="sel", S=(1, 0), complement=False):
        super().__init__(name)
        s = vector(S, "S")
        if set(np.unique(s)) - {0.0, 1.0}:
            raise ValueError(f"S must hold only 0 and 1, got {S!r}")
        self.mask = 1.0 - s if complement else s
        self.declare_input("u", s.size)
        self.declare_output("y", s.size)

    def output(self, t, x, u):
        return (self.mask * u[0],)


@register("mux")
class Mux(Block):
    """Stack inputs u1 (widths[0]), u2 (widths[1]), ... into one vector y."""

    def __init__(self, name="mux", widths=(1, 1)):
        super().__init__(name)
        for k, w in enumerate(widths):
            self.declare_input(f"u{k + 1}", int(w))
        self.declare_output("y", int(sum(widths)))

    def output(self, t, x, u):
        return (np.concatenate(u),)


@register("demux")
class Demux(Block):
    """Split u into y1 (widths[0]), y2 (widths[1]), ..."""

    def __init__(self, name="demux", widths=(1, 1)):
        super().__init__(name)
        self.cuts = np.cumsum([0] + [int(w) for w in widths])
        self.declare_input("u", int(self.cuts[-1]))
        for k, w in enumerate(widths):
            self.declare_output(f"y{k + 1}", int(w))

    def output(self, t, x, u):
        return tuple(u[0][a:b] for a, b in zip(self.cuts[:-1], self.cuts[1:]))


@register("zoh")
class ZeroOrderHold(Block):
    """Sample u at the block's rate and hold it (a rate transition)."""

    def __init__(self, name="zoh", rate=None, period=None, width=1):
        super().__init__(name)
        self.declare_rate(period=period, rate=rate)
        self.declare_input("u", width)
        self.declare_output("y", width)

    def output(self, t, x, u):
        return (u[0],)


@register("delay")
class UnitDelay(Block):
    """y[k] = u[k-1]: one sample of delay; breaks algebraic loops."""

    def __init__(self, name="delay", rate=None, period=None, width=1, initial=0.0):
        super().__init__(name)
        self.declare_rate(period=period, rate=rate)
        self.declare_discrete_state(width)
        self.x0 = vector(initial, "initial", width)
        self.declare_input("u", width)
        self.declare_output("y", width, depends_on=())

    def initial_state(self, u=None):
        return self.x0.copy()

    def output(self, t, x, u):
        return (x,)

    def update(self, t, x, u):
        return u[0].copy()


@register("lowpass")
class LowPass(Block):
    """Second-order Butterworth low-pass, continuous: the paper's 12 Hz display filter.

    y'' + sqrt(2) wc y' + wc^2 y = wc^2 u, wc = 2 pi cutoff; unity DC gain,
    starts at rest at ``initial``.
    """

    def __init__(self, name="filter", cutoff=12.0, width=1, initial=0.0):
        super().__init__(name)
        self.wc = 2 * math.pi * float(cutoff)
        if not self.wc > 0:
            raise ValueError("cutoff must be positive")
        self.n = int(width)
        self.y0 = vector(initial, "initial", self.n)
        self.declare_input("u", self.n)
        self.declare_output("y", self.n, depends_on=())
        self.declare_continuous_state(2 * self.n, atol=1e-9)

    def initial_state(self, u=None):
        return np.concatenate([self.y0, np.zeros(self.n)])

    def output(self, t, x, u):
        return (x[: self.n],)

    def derivatives(self, t, x, u):
        y, yd = x[: self.n], x[self.n:]
        wc = self.wc
        return np.concatenate([yd, wc * wc * (u[0] - y) - math.sqrt(2) * wc * yd])


@register("recorder")
class Recorder(Block):
    """A sink whose inputs are all logged; ``inputs`` maps names to widths."""

    log_inputs = True

    def __init__(self, name="scope", inputs=None):
        super().__init__(name)
        for k, w in (inputs or {"u": 1}).items():
            self.declare_input(str(k), int(w))


@register("counter")
class Counter(Block):
    """Counts its own sample hits (y = hits so far); for checking schedules."""

    def __init__(self, name="counter", rate=None, period=None, offset=0):
        super().__init__(name)
        self.declare_rate(period=period, rate=rate, offset=offset)
        self.declare_discrete_state(1)
        self.declare_output("y", 1)

    def output(self, t, x, u):
        return (x + 1,)

    def update(self, t, x, u):
        return x + 1





@register("state_space")
class StateSpace(Block):
    """Continuous LTI system x' = A x + B u, y = C x + D u (any plant or filter).

    ``D`` defaults to zero (then y has no direct feedthrough); ``x0`` the initial state.
    """

    def __init__(self, name="ss", A=((0.0,),), B=((1.0,),), C=((1.0,),), D=None, x0=None):
        super().__init__(name)
        self.A, self.B, self.C = (np.atleast_2d(np.asarray(m, float)) for m in (A, B, C))
        n, m, p = self.A.shape[0], self.B.shape[1], self.C.shape[0]
        if self.A.shape != (n, n) or self.B.shape[0] != n or self.C.shape[1] != n:
            raise ValueError(f"inconsistent shapes A {self.A.shape}, B {self.B.shape}, C {self.C.shape}")
        self.D = np.zeros((p, m)) if D is None else np.atleast_2d(np.asarray(D, float))
        if self.D.shape != (p, m):
            raise ValueError(f"D must be {p}x{m}, got {self.D.shape}")
        self.x0 = np.zeros(n) if x0 is None else vector(x0, "x0", n)
        self.declare_input("u", m)
        self.declare_output("y", p, depends_on=None if np.any(self.D) else ())
        self.declare_continuous_state(n)

    def initial_state(self, u=None):
        return self.x0.copy()

    def output(self, t, x, u):
        return (self.C @ x + self.D @ u[0],)

    def derivatives(self, t, x, u):
        return self.A @ x + self.B @ u[0]
