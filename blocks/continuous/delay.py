"""Continuous-time memory: a transport delay with a buffer, and a triggered memory (sample and hold).

Both keep their memory in continuous states that change only at located
events (their derivatives are 0), so they run on every solver and path.
"""
from typing import NamedTuple

import numpy as np

from hybridsim.engine.block import Block
from hybridsim.errors import ParameterError
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.engine.registry import register

from hybridsim.blocks._sides import side_function
from hybridsim.blocks._util import count, scalar, vector

GROUP = "control"  # where `hybridsim blocks` lists this module's blocks


@register("transport_delay")
class TransportDelay(Block):
    """y(t) = u(t - delay) for t >= delay, ``initial`` before: a dead time, e^(-s delay).

    Parameters
    ----------
    delay : float            the dead time tau (s), > 0
    buffer : int             samples of u kept per delay, N (default 64)
    initial : float or list  y before t = tau (units of u; Simulink's initial output)
    width : int

    Notes
    -----
    u is stored every Ts = tau / N s (a located event at each t = j Ts, the
    buffer a ring of N + 2 samples per element) and y is the linear
    interpolation between the two samples around t - tau, as Simulink's
    Transport Delay interpolates its buffer. The error is at most
    Ts^2 / 8 max abs(u''); y does not depend on u(t) itself, so the block breaks
    algebraic loops. Example: tau = 0.1 s, u = t: y(0.35 s) = 0.25. An edge of u
    (a step) is spread over one Ts, starting up to Ts before t_edge + tau: its
    integral is off by up to Ts/2 times the step (raise ``buffer`` for edges).

    Why 64 samples: the error bound is then (tau/64)^2/8 max abs(u''), a tenth
    of that of 20 samples (3e-5 of the amplitude for a sine at omega tau = 1),
    while the block stays small: 64 located events per delay time and 66
    states per element. A run's time grows with N squared (N / tau events per
    simulated second, each over N + 2 states: N = 1000 for tau = 0.1 s takes
    minutes per simulated second; on the compiled path the compile time grows
    with the states too), so raise ``buffer`` only for inputs with much content
    above 1/tau.
    Simulink's Transport Delay stores the input at its solver's steps, so its
    initial buffer of 1024 points is a memory allocation, not a resolution.

    ``pade`` (int, default 5) is the order of the Pade approximation of
    e^(-s tau) that analysis (linearize, margins, Bode) puts in the block's
    place, as Simulink's "Pade order (for linearization)": order 5 holds the
    phase of the dead time to 1e-6 rad up to omega tau = 2 (control.pade).
    """

    init_needs_inputs = True

    def __init__(self, name="dead_time", delay=0.1, buffer=64, initial=0.0, width=1, pade=5):
        super().__init__(name)
        n, N = count(width, "width"), count(buffer, "buffer")
        tau = scalar(delay, "delay", "positive")
        if not tau / N >= 1e-9:  # its samples are events, located to 1e-12 s: 1e-16 s ran without any
            raise ParameterError("delay", f"{tau:g} s over {N} samples puts them {tau / N:.3g} s apart: "
                                 "they are events, which need at least 1e-9 s between them (a longer delay "
                                 "or a smaller buffer)")
        self.params = DelayParams(tau, tau / N, N + 2, vector(initial, "initial", n), n)
        self.event_spacing = tau / N
        self.pade = count(pade, "pade")
        self.event_directions = (1,)
        self.declare_input("u", n)
        self.declare_output("y", n, depends_on=())
        # the ring of samples (slot-major), then the time of the next sample (s), which grows by design
        self.declare_continuous_state((N + 2) * n + 1, bounded=[True] * ((N + 2) * n) + [False], held=True)

    def linear_standin(self):
        """Its (pade, pade) Pade approximation, which analysis linearizes in its place (the buffer's
        samples change only at events, which a linearization does not see)."""
        return PadeDelay(self.name, self.params.tau, self.pade, self.params.n, self.params.initial)

    def initial_state(self, u=None):
        p = self.params
        x = np.zeros(p.slots * p.n + 1)
        x[:p.n] = np.asarray(u[0], float) if u is not None else 0.0  # sample 0: u(0)
        x[-1] = p.Ts
        return x


class DelayParams(NamedTuple):
    tau: float            # delay, s
    Ts: float             # buffer period, s
    slots: int            # samples in the ring
    initial: np.ndarray   # output before tau
    n: int                # width


@kernel
def transport_delay_output(p, t, x, u):
    xa = np.asarray(x)
    s = t - p.tau
    if s < 0.0:
        return (p.initial.copy(),)
    stored = int(round(xa[-1] / p.Ts))  # samples 0 .. stored - 1, at times j Ts
    j = min(max(int(np.floor(s / p.Ts)), stored - p.slots), stored - 2)
    f = s / p.Ts - j
    a, b = (j % p.slots) * p.n, ((j + 1) % p.slots) * p.n
    return (xa[a:a + p.n] + f * (xa[b:b + p.n] - xa[a:a + p.n]),)


@kernel
def transport_delay_derivatives(p, t, x, u):
    return np.zeros(p.slots * p.n + 1)


@kernel
def transport_delay_crossings(p, t, x, u):
    return (t - x[-1],)  # rises through 0 at the next sample time


@kernel
def transport_delay_event(p, t, x, u, fired):
    out = np.asarray(x).copy()
    if fired[0]:
        k = int(round(out[-1] / p.Ts))
        a = (k % p.slots) * p.n
        out[a:a + p.n] = np.asarray(u[0])
        out[-1] = (k + 1) * p.Ts
    return out


class PadeDelay(Block):
    """The linear stand-in of a transport delay for analysis: per element, the (order, order) Pade
    approximant of e^(-s tau) (``control.pade``) as a state-space model, started where its output is
    the delay's (``initial`` at t = 0; see :meth:`state_for`). Not a block of the library:
    :meth:`TransportDelay.linear_standin` makes it."""

    init_needs_inputs = True

    def __init__(self, name, tau, order, width, initial=None):
        import control
        from scipy.signal import tf2ss

        super().__init__(name)
        num, den = control.pade(tau, order)
        A, B, C, D = (np.atleast_2d(np.asarray(m, float)) for m in tf2ss(num, den))
        self.params = PadeParams(A, B.ravel(), C.ravel(), float(D[0, 0]), order, width)
        self.y0 = None if initial is None else np.asarray(initial, float)
        self.declare_input("u", width)
        self.declare_output("y", width, depends_on=("u",) if D[0, 0] != 0.0 else ())
        self.declare_continuous_state(order * width)  # element-major

    def initial_state(self, u=None):
        u0 = np.asarray(u[0], float) if u is not None else np.zeros(self.params.n)
        return self.state_for(u0, u0 if self.y0 is None else self.y0)

    def state_for(self, u, y):
        """A state whose output is ``y`` for input ``u`` (per element): the steady state for ``u``
        (output u) moved along C to ``y`` (the delay's output where the operating point has it)."""
        p = self.params
        x1 = -np.linalg.solve(p.A, p.B)  # the steady state for u = 1: output C x1 + D = 1
        u, y = np.broadcast_to(np.asarray(u, float), (p.n,)), np.broadcast_to(np.asarray(y, float), (p.n,))
        return np.concatenate([x1 * a + p.C * (b - a) / (p.C @ p.C) for a, b in zip(u, y)])


class PadeParams(NamedTuple):
    A: np.ndarray  # (order, order) state matrix of one element
    B: np.ndarray  # (order,)
    C: np.ndarray  # (order,)
    D: float
    order: int
    n: int         # width


@kernel
def pade_output(p, t, x, u):
    xa, ua = np.asarray(x).reshape(p.n, p.order), np.asarray(u[0])
    return (xa @ p.C + p.D * ua,)


@kernel
def pade_derivatives(p, t, x, u):
    xa, ua = np.asarray(x).reshape(p.n, p.order), np.asarray(u[0])
    return (xa @ p.A.T + np.outer(ua, p.B)).ravel()


@register("memory")
class Memory(Block):
    """y holds the value u had at the last rising edge of ``trigger`` (through 0.5): a sample and hold.

    Parameters
    ----------
    initial : float or list   y before the first edge, per element (units of u)
    width : int

    Ports: in ``u``, ``trigger``; out ``y``. The edges are located events, so y
    is u at the exact edge time on every solver. An edge goes from below 0.5 to
    above: a trigger starting at 0.5 and rising is not one. Example: u = t, a
    pulse of period 1 s on trigger: y = 0, 1, 2, ... held for a second each.
    """

    init_needs_inputs = True
    not_linearizable = ("(memory) holds its output between trigger edges, events a linearization does not "
                        "see (the loop would look open there)")

    def __init__(self, name="memory", initial=0.0, width=1):
        super().__init__(name)
        n = count(width, "width")
        self.params = (n,)
        self.x0 = vector(initial, "initial", n)
        self.event_directions = (-1,)  # side * (trigger - 0.5) falls at an edge either way (blocks/_sides.py)
        self.declare_input("u", n)
        self.declare_input("trigger", 1)
        self.declare_output("y", n, depends_on=())
        # y, then the trigger's side of 0.5 (-1, 0 at the start on it, +1)
        self.declare_continuous_state(n + 1, held=True)

    def initial_state(self, u=None):
        side = np.sign(float(np.asarray(u[1], float)[0]) - 0.5) if u is not None else 0.0
        return np.concatenate((self.x0, [side]))


@kernel
def memory_output(p, t, x, u):
    return (np.asarray(x)[:p[0]] * 1.0,)


@kernel
def memory_derivatives(p, t, x, u):
    return np.zeros(p[0] + 1)


@kernel
def memory_crossings(p, t, x, u):
    return (side_function(np.asarray(x)[p[0]], u[1][0] - 0.5),)


@kernel
def memory_event(p, t, x, u, fired):
    out = np.asarray(x) * 1.0
    if fired[0]:  # the side of 0.5 the trigger is on now: from below to above is a rising edge
        side, new = out[p[0]], float(np.sign(u[1][0] - 0.5))
        if side < 0.0 and new > 0.0:
            out[:p[0]] = np.asarray(u[0])
        if new != 0.0:
            out[p[0]] = new
    return out


TransportDelay.kernels = Kernels(output=transport_delay_output, derivatives=transport_delay_derivatives,
                                 zero_crossings=transport_delay_crossings, event_action=transport_delay_event)
PadeDelay.kernels = Kernels(output=pade_output, derivatives=pade_derivatives)
Memory.kernels = Kernels(output=memory_output, derivatives=memory_derivatives, zero_crossings=memory_crossings,
                         event_action=memory_event)
