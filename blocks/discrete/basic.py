"""Sampled control blocks: discrete integrator (limits, reset), transfer function, state space, N-sample delay, PID, rate limiter.

Every block here runs at its own ``rate`` (Hz) or ``period`` (s); hit k is at
t = k T. At a hit the output is computed from the state and the current
input, then the state is updated (the engine's order). From zero state each
block equals the z-domain transfer function it names, which is how the tests
check them (against python-control).
"""
import math
from typing import NamedTuple

import numpy as np

from hybridsim.engine.block import Block
from hybridsim.errors import ParameterError
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.engine.registry import register

from hybridsim.blocks._util import count, finite_matrix, one_rate, pid_gains, vector
from hybridsim.blocks.continuous.basic import tf_to_ss
from hybridsim.blocks.continuous.linear import abcd_output, abcd_step


GROUP = "control"  # where `hybridsim blocks` lists this module's blocks

class _Sampled(Block):
    def __init__(self, name, rate, period):
        super().__init__(name)
        one_rate(rate, period)
        self.declare_rate(period=period, rate=rate)
        self.T = float(self.period)


_METHODS = ("forward", "backward", "trapezoidal")


@register("discrete_integrator")
class DiscreteIntegrator(_Sampled):
    """y[k] = sat(x[k] + c K T u[k]), x[k+1] = sat(y[k] + (1 - c) K T u[k]); a rising ``reset`` restarts it.

    ``method``: forward Euler (c = 0: K T / (z - 1)), backward Euler (c = 1:
    K T z / (z - 1), the paper's rectangle rule) or trapezoidal (c = 1/2:
    K T (z + 1) / (2 (z - 1))); K in 1/s. Starts at x[0] = ``initial``;
    sat clips to [``lower``, ``upper``] (default unlimited: the plain
    z-domain integrator). Ports: in ``u``, ``reset`` (optional; at a hit where
    it has risen through 0.5 since the last hit, x is set to ``initial``
    before y is computed, as Simulink's rising external reset); out ``y``.
    """

    def __init__(self, name="dintegrator", K=1.0, method="forward", initial=0.0, rate=None, period=None,
                 width=1, lower=-math.inf, upper=math.inf):
        super().__init__(name, rate, period)
        if method not in _METHODS:
            raise ParameterError("method", f"must be one of {', '.join(_METHODS)}; got {method!r}")
        n = count(width, "width")
        c = {"forward": 0.0, "backward": 1.0, "trapezoidal": 0.5}[method]
        lo, hi = vector(lower, "lower", n, inf_ok=True), vector(upper, "upper", n, inf_ok=True)
        if np.any(lo > hi):
            raise ParameterError("lower", f"must not exceed upper ({lower!r} > {upper!r})")
        self.x0 = vector(initial, "initial", n)
        if np.any((self.x0 < lo) | (self.x0 > hi)):
            raise ParameterError("initial", f"must lie within [lower, upper], got {initial!r}")
        self.params = DIntegratorParams(vector(K, "K", n) * self.T, c, lo, hi, self.x0.copy(), n)
        self.declare_discrete_state(2 * n, held=[False] * n + [True] * n)  # x, and the reset input at the last hit
        self.declare_input("u", n)
        self.declare_input("reset", n, default=[0.0] * n, optional=True)
        self.declare_output("y", n, depends_on=("reset",) if c == 0.0 else None)

    def initial_state(self, u=None):
        return np.concatenate((self.x0, np.zeros(self.params.n)))


class DIntegratorParams(NamedTuple):
    KT: np.ndarray     # gain times period
    c: float           # weight of u[k] in y[k]
    lower: np.ndarray  # limits of y and x
    upper: np.ndarray
    x0: np.ndarray     # initial state, also what a reset restores
    n: int             # width


@kernel
def dintegrator_state(p, x, u):
    """x[k] after a reset at this hit (if the reset input rose through 0.5 since the last hit)."""
    xa, r = np.asarray(x), np.asarray(u[1])
    rose = (r > 0.5) & (xa[p.n:] <= 0.5)
    return np.where(rose, p.x0, xa[:p.n])


@kernel
def dintegrator_output(p, t, x, u):
    xk = dintegrator_state(p, x, u)
    return (np.minimum(np.maximum(xk + p.c * p.KT * np.asarray(u[0]), p.lower), p.upper),)


@kernel
def dintegrator_update(p, t, x, u):
    xk = dintegrator_state(p, x, u)
    ua = np.asarray(u[0])
    y = np.minimum(np.maximum(xk + p.c * p.KT * ua, p.lower), p.upper)
    nxt = np.minimum(np.maximum(y + (1.0 - p.c) * p.KT * ua, p.lower), p.upper)
    return np.concatenate((nxt, np.asarray(u[1]) * 1.0))


class _LTI(_Sampled):
    def initial_state(self, u=None):
        return self.x0.copy()


@register("discrete_state_space")
class DiscreteStateSpace(_LTI):
    """x[k+1] = A x[k] + B u[k], y[k] = C x[k] + D u[k], sampled at ``rate``; x[0] = ``x0`` (default 0)."""

    def __init__(self, name="dss", A=((0.0,),), B=((1.0,),), C=((1.0,),), D=None, x0=None, rate=None,
                 period=None):
        super().__init__(name, rate, period)
        A, B, C = (finite_matrix(M, k) for M, k in ((A, "A"), (B, "B"), (C, "C")))
        n, m, q = A.shape[0], B.shape[1], C.shape[0]
        if A.shape != (n, n) or B.shape[0] != n or C.shape[1] != n:
            raise ParameterError("A", f"B and C have inconsistent shapes: A {A.shape}, B {B.shape}, C {C.shape}")
        D = np.zeros((q, m)) if D is None else finite_matrix(D, "D")
        if D.shape != (q, m):
            raise ParameterError("D", f"must be {q}x{m}, got {D.shape}")
        _setup_dss(self, A, B, C, D, x0)


def _setup_dss(block, A, B, C, D, x0=None):
    n, m, q = A.shape[0], B.shape[1], C.shape[0]
    block.params = tuple(np.ascontiguousarray(M, dtype=float) for M in (A, B, C, D))
    block.x0 = np.zeros(n) if x0 is None else vector(x0, "x0", n)
    block.declare_discrete_state(n)
    block.declare_input("u", m)
    block.declare_output("y", q, depends_on=None if np.any(D) else ())


@register("discrete_transfer_function")
class DiscreteTransferFunction(_LTI):
    """y = num(z) / den(z) u, coefficients in descending powers of z, from rest.

    Example: ``num: [0.5], den: [1, -0.5]`` at 10 Hz is y[k] = 0.5 y[k-1] +
    0.5 u[k-1]: a unit step gives 0, 0.5, 0.75, 0.875, ...
    """

    def __init__(self, name="dtf", num=(1.0,), den=(1.0, 0.0), rate=None, period=None):
        super().__init__(name, rate, period)
        _setup_dss(self, *tf_to_ss(num, den))


@register("delay_n")
class DelayN(_Sampled):
    """y[k] = u[k - N]: ``N`` samples of delay (the first N outputs are ``initial``).

    Without ``initial`` the delay starts in balance: its first N outputs are
    its input at t = 0 (in a loop back to its own input, the balance y = u:
    u = 1 + 0.5 y gives y = 2). N = 0 passes each sample through (no state): a delay
    option that is off changes no number (e.g. a controller's computation
    delay of N ticks).
    """

    init_needs_inputs = True

    def __init__(self, name="delay_n", N=1, initial=None, rate=None, period=None, width=1):
        super().__init__(name, rate, period)
        n, N = count(width, "width"), count(N, "N", minimum=0)
        self.params = (n, N)
        self.x0 = None if initial is None else np.tile(vector(initial, "initial", n), N)
        self.init_needs_inputs = initial is None and N > 0
        self.declare_input("u", n)
        if N == 0:
            self.kernels = Kernels(output=sample_output)
            self.declare_output("y", n)
        else:
            self.declare_discrete_state(n * N)
            self.declare_output("y", n, depends_on=())

    def initial_state(self, u=None):
        if self.x0 is not None:
            return self.x0.copy()
        n, N = self.params
        return np.tile(np.asarray(u[0], float) if u is not None else np.zeros(n), N)


@kernel
def sample_output(p, t, x, u):
    """y[k] = u[k]: a delay_n block with N = 0 (the input itself)."""
    return (u[0],)


@kernel
def delay_n_output(p, t, x, u):
    return (np.asarray(x)[: p[0]],)


@kernel
def delay_n_update(p, t, x, u):
    return np.concatenate((np.asarray(x)[p[0]:], np.asarray(u[0]) * 1.0))


_ANTI_WINDUP = ("none", "clamping", "back_calculation")


@register("discrete_pid")
class DiscretePID(_Sampled):
    """A sampled PID in parallel form with setpoint weights, a derivative filter and anti-windup.

    u = Kp (b r - y) + I + D, output clipped to [lower, upper] (units of u; r, y in
    units of the measurement; Ki in 1/s, Kd in s, N in rad/s):

    * I[k] = I[k-1] + Ki T (a e[k] + (1 - a) e[k-1]), e = r - y;
      ``integrator_method``: backward Euler (a = 1: Ki T z / (z - 1), the default),
      forward Euler (a = 0: Ki T / (z - 1), Simulink's default) or trapezoidal
      (a = 1/2: Ki T (z + 1) / (2 (z - 1)));
    * D: Kd N s / (s + N) on e_d = c r - y, with s replaced as ``filter_method``
      says: backward (s = (z - 1) / (T z)): D[k] = (D[k-1] + Kd N de) / (1 + N T);
      forward (s = (z - 1) / T): D[k] = (1 - N T) D[k-1] + Kd N de; trapezoidal
      (s = 2 (z - 1) / (T (z + 1))): D[k] = ((2 - N T) D[k-1] + 2 Kd N de) / (2 + N T),
      de = e_d[k] - e_d[k-1]; with N = inf (no filter) D[k] = Kd de / T;
    * anti-windup: ``clamping`` holds the integrator while the output is
      saturated and the integrator's input Ki e pushes it further out (the sign of
      Ki e, so a reverse-acting loop with negative gains clamps as its mirror
      does); ``back_calculation`` feeds Kb (u_sat - u) back into the
      integrator (Kb, 1/s, default Ki / Kp).

    Ports: in ``r`` (setpoint), ``y`` (measurement); out ``u``. From rest it
    equals python-control's C(z) = Kp + Ki T z/(z-1) + Kd N (z-1)/((1+NT) z - 1)
    (b = c = 1, no saturation, backward Euler).
    """

    def __init__(self, name="pid", Kp=1.0, Ki=0.0, Kd=0.0, N=math.inf, b=1.0, c=1.0, lower=-math.inf,
                 upper=math.inf, anti_windup="clamping", Kb=None, rate=None, period=None, width=1,
                 integrator_method="backward", filter_method="backward"):
        super().__init__(name, rate, period)
        n = count(width, "width")
        if anti_windup not in _ANTI_WINDUP:
            raise ParameterError("anti_windup", f"must be one of {', '.join(_ANTI_WINDUP)}; got {anti_windup!r}")
        for key, m in (("integrator_method", integrator_method), ("filter_method", filter_method)):
            if m not in _METHODS:
                raise ParameterError(key, f"must be one of {', '.join(_METHODS)}; got {m!r}")
        Kp_, Ki_, Kd_, lo, hi, Kb_ = pid_gains(Kp, Ki, Kd, lower, upper, Kb, n)
        Nf = vector(N, "N", n, "positive", inf_ok=True)
        a = {"forward": 0.0, "backward": 1.0, "trapezoidal": 0.5}[integrator_method]
        nt = np.where(np.isfinite(Nf), Nf, 0.0) * self.T
        one = np.ones(n)
        fa, fb, fg = {"forward": (1.0 - nt, one, one), "backward": (one, one, 1.0 + nt),
                      "trapezoidal": (2.0 - nt, 2.0 * one, 2.0 + nt)}[filter_method]
        self.params = PIDParams(Kp_, Ki_, Kd_, Nf, vector(b, "b", n), vector(c, "c", n), lo, hi,
                                float(_ANTI_WINDUP.index(anti_windup)), Kb_, self.T, n, a, fa, fb, fg)
        self.declare_discrete_state(4 * n)  # I, D, e_d and e of the last hit
        self.declare_input("r", n)
        self.declare_input("y", n)
        self.declare_output("u", n)

    def initial_state(self, u=None):
        return np.zeros(4 * self.params.n)


class PIDParams(NamedTuple):
    Kp: np.ndarray     # proportional gain
    Ki: np.ndarray     # integral gain, 1/s
    Kd: np.ndarray     # derivative gain, s
    N: np.ndarray      # derivative filter bandwidth, rad/s (inf: none)
    b: np.ndarray      # setpoint weight, proportional
    c: np.ndarray      # setpoint weight, derivative
    lower: np.ndarray  # output limits
    upper: np.ndarray
    mode: float        # anti-windup: 0 none, 1 clamping, 2 back-calculation
    Kb: np.ndarray     # back-calculation gain, 1/s
    T: float           # period, s
    n: int             # width
    a: float           # integrator: weight of e[k] (1 backward, 0 forward, 1/2 trapezoidal)
    fa: np.ndarray     # filter recurrence D[k] = (fa D[k-1] + fb Kd N de) / fg
    fb: np.ndarray
    fg: np.ndarray


@kernel
def pid_terms(p, x, u):
    """(unclipped u, clipped u, next I, next D, e_d, e) of one hit."""
    n = p.n
    xa, r, y = np.asarray(x), np.asarray(u[0]), np.asarray(u[1])
    i_prev, d_prev, ed_prev, e_prev = xa[:n], xa[n:2 * n], xa[2 * n:3 * n], xa[3 * n:]
    e = r - y
    ed = p.c * r - y
    filt = np.isfinite(p.N)
    nf = np.where(filt, p.N, 0.0)
    d = np.where(filt, (p.fa * d_prev + p.fb * p.Kd * nf * (ed - ed_prev)) / p.fg, p.Kd * (ed - ed_prev) / p.T)
    step = p.Ki * p.T * (p.a * e + (1.0 - p.a) * e_prev)  # the integrator's input over this period
    integ = i_prev + step
    v = p.Kp * (p.b * r - y) + integ + d
    sat = np.minimum(np.maximum(v, p.lower), p.upper)
    if p.mode == 1.0:  # clamping: no integration while saturated and Ki e pushes further out
        hold = ((v > p.upper) & (step > 0.0)) | ((v < p.lower) & (step < 0.0))
        integ = np.where(hold, i_prev, integ)
        v = p.Kp * (p.b * r - y) + integ + d
        sat = np.minimum(np.maximum(v, p.lower), p.upper)
    elif p.mode == 2.0:  # back-calculation
        integ = integ + p.Kb * p.T * (sat - v)
    return v, sat, integ, d, ed, e


@kernel
def discrete_pid_output(p, t, x, u):
    v, sat, integ, d, ed, e = pid_terms(p, x, u)
    return (sat,)


@kernel
def discrete_pid_update(p, t, x, u):
    v, sat, integ, d, ed, e = pid_terms(p, x, u)
    return np.concatenate((integ, d, ed, e))


@register("rate_limiter")
class RateLimiter(_Sampled):
    """y[k] = y[k-1] + clip(u[k] - y[k-1], -falling T, rising T): slew-rate limits in units/s.

    Starts from y[-1] = ``initial``. Example: rising 1/s at 10 Hz, u = 1 from
    0: y = 0.1, 0.2, ..., 1.
    """

    def __init__(self, name="rate_limiter", rising=1.0, falling=1.0, initial=0.0, rate=None, period=None,
                 width=1):
        super().__init__(name, rate, period)
        n = count(width, "width")
        self.params = (vector(rising, "rising", n, "positive", inf_ok=True) * self.T,
                       vector(falling, "falling", n, "positive", inf_ok=True) * self.T)
        self.x0 = vector(initial, "initial", n)
        self.declare_discrete_state(n)
        self.declare_input("u", n)
        self.declare_output("y", n)

    def initial_state(self, u=None):
        return self.x0.copy()


@kernel
def rate_limiter_output(p, t, x, u):
    xa = np.asarray(x)
    return (xa + np.minimum(np.maximum(np.asarray(u[0]) - xa, -p[1]), p[0]),)


@kernel
def rate_limiter_update(p, t, x, u):
    xa = np.asarray(x)
    return xa + np.minimum(np.maximum(np.asarray(u[0]) - xa, -p[1]), p[0])


DiscreteIntegrator.kernels = Kernels(output=dintegrator_output, update=dintegrator_update)
DiscreteStateSpace.kernels = Kernels(output=abcd_output, update=abcd_step)
DiscreteTransferFunction.kernels = Kernels(output=abcd_output, update=abcd_step)
DelayN.kernels = Kernels(output=delay_n_output, update=delay_n_update)
DiscretePID.kernels = Kernels(output=discrete_pid_output, update=discrete_pid_update)
RateLimiter.kernels = Kernels(output=rate_limiter_output, update=rate_limiter_update)
