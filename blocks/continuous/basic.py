"""Continuous-time control blocks: integrator, filtered derivative, transfer function, relay.

Each block works element-wise on a vector of ``width`` signals. Limits,
resets and relay switches are state events: the solver locates them and the
event action sets the state, on every path.
"""
import math
import warnings
from typing import NamedTuple

import numpy as np

from hybridsim.engine.block import Block
from hybridsim.errors import ParameterError
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.engine.registry import register

from hybridsim.blocks._util import count, flag, scalar, vector
from hybridsim.blocks.continuous.linear import abcd_output, abcd_step

GROUP = "control"  # where `hybridsim blocks` lists this module's blocks

_BIG = 1e300  # an infinite limit, kept finite so that event functions stay numbers


@register("integrator")
class Integrator(Block):
    """y = x, x' = K u, held within [lower, upper]; a rising ``reset`` sets x = initial.

    Parameters
    ----------
    K : float or list          gain (1/s)
    initial : float or list    x(0), also the value a reset restores
    lower, upper : float or list   limits of x (default unlimited)
    width : int                number of signals

    Notes
    -----
    A mode state m (0 free, +1 at the upper limit, -1 at the lower) has
    explicit enter and leave conditions, each a located event: a free
    integrator enters a limit when x reaches it (x set to the limit, then
    x' = 0); a held one leaves when K u changes sign to point back inside
    (one event, whatever the step). An integrator that starts at a limit
    starts held there unless K u(0) points inside, and so does one reset to a limit. Only the functions of the current mode
    are armed (the others read a constant that never fires). Ports: in ``u``, ``reset`` (optional: unwired it is 0;
    x resets when it rises through 0.5); out ``y``. Example: K = 2, u = 1
    from x(0) = 0 gives y(1 s) = 2; with upper = 1.5 it stops at 1.5 at
    t = 0.75 s.
    """

    def __init__(self, name="integrator", K=1.0, initial=0.0, lower=-math.inf, upper=math.inf, width=1):
        super().__init__(name)
        n = count(width, "width")
        lo = vector(lower, "lower", n, inf_ok=True)
        hi = vector(upper, "upper", n, inf_ok=True)
        x0 = vector(initial, "initial", n)
        if np.any(lo >= hi):  # equal limits: a constant, whose modes would only chatter at every reversal
            raise ParameterError("lower", f"must be below upper ({lower!r} >= {upper!r}); for a constant "
                                 "state use a constant block")
        if np.any((x0 < lo) | (x0 > hi)):
            raise ParameterError("initial", f"must lie within [lower, upper], got {initial!r}")
        self.params = IntegratorParams(vector(K, "K", n), x0, np.clip(lo, -_BIG, _BIG), np.clip(hi, -_BIG, _BIG), n)
        # reset; reach upper, reach lower; leave upper, leave lower
        self.event_directions = (1,) * n + (1,) * n + (-1,) * n + (-1,) * n + (1,) * n
        self.declare_input("u", n)
        self.declare_input("reset", n, default=[0.0] * n, optional=True)
        self.declare_output("y", n, depends_on=())
        self.declare_continuous_state(2 * n, held=[False] * n + [True] * n)  # x, then the mode m
        # starting at a limit, it starts held there unless its input points inside (read at t = 0)
        self.init_needs_inputs = bool(np.any((x0 <= lo) | (x0 >= hi)))

    def initial_state(self, u=None):
        p = self.params
        m = np.zeros(p.n)
        if u is not None:
            du = p.K * np.asarray(u[0], float)
            m = np.where((p.x0 >= p.upper) & (du >= 0), 1.0, np.where((p.x0 <= p.lower) & (du <= 0), -1.0, 0.0))
        return np.concatenate((p.x0, m))


class IntegratorParams(NamedTuple):
    K: np.ndarray      # gain, 1/s
    x0: np.ndarray     # initial state
    lower: np.ndarray  # lower limit
    upper: np.ndarray  # upper limit
    n: int             # width


@kernel
def integrator_output(p, t, x, u):
    xa = np.asarray(x)[:p.n]
    return (np.minimum(np.maximum(xa, p.lower), p.upper),)


@kernel
def integrator_derivatives(p, t, x, u):
    n = p.n
    dx = np.zeros(2 * n)
    for i in range(n):
        if abs(x[n + i]) < 0.5:  # free; held at a limit: x' = 0
            dx[i] = p.K[i] * u[0][i]
    return dx


@kernel
def integrator_crossings(p, t, x, u):
    # reset; enter upper (rising), enter lower (falling); leave upper (K u falls below 0),
    # leave lower (K u rises above 0); a function of another mode reads -1 / +1: never fires
    n = p.n
    g = np.empty(5 * n)
    for i in range(n):
        m, du = x[n + i], p.K[i] * u[0][i]
        free = abs(m) < 0.5
        g[i] = u[1][i] - 0.5
        g[n + i] = x[i] - p.upper[i] if free else -1.0
        g[2 * n + i] = x[i] - p.lower[i] if free else 1.0
        g[3 * n + i] = du if m > 0.5 else 1.0
        g[4 * n + i] = du if m < -0.5 else -1.0
    return g


@kernel
def integrator_event(p, t, x, u, fired):
    n = p.n
    out = np.empty(2 * n)
    for i in range(2 * n):
        out[i] = x[i]
    for i in range(n):
        if fired[3 * n + i] or fired[4 * n + i]:  # left a limit: integrate again
            out[n + i] = 0.0
        if fired[n + i]:  # reached the upper limit
            out[i], out[n + i] = p.upper[i], 1.0
        if fired[2 * n + i]:  # reached the lower limit
            out[i], out[n + i] = p.lower[i], -1.0
        if fired[i]:  # reset: held at once when the initial value is a limit the input pushes against
            du = p.K[i] * u[0][i]
            held = 1.0 if p.x0[i] >= p.upper[i] and du >= 0 else -1.0 if p.x0[i] <= p.lower[i] and du <= 0 else 0.0
            out[i], out[n + i] = p.x0[i], held
    return out


@register("derivative")
class FilteredDerivative(Block):
    """y = s / (tau s + 1) u: a derivative filtered with time constant ``tau`` (s).

    State x with x' = (u - x) / tau and y = (u - x) / tau; starts at x(0) =
    ``initial`` (set it to u(0) to avoid a kick). Example: u = t gives
    y = 1 - exp(-t / tau).
    """

    def __init__(self, name="derivative", tau=0.01, initial=0.0, width=1):
        super().__init__(name)
        n = count(width, "width")
        self.params = (scalar(tau, "tau", "positive"),)
        self.x0 = vector(initial, "initial", n)
        self.declare_input("u", n)
        self.declare_output("y", n)
        self.declare_continuous_state(n)

    def initial_state(self, u=None):
        return self.x0.copy()


@kernel
def derivative_output(p, t, x, u):
    return ((np.asarray(u[0]) - np.asarray(x)) / p[0],)


@kernel
def derivative_derivatives(p, t, x, u):
    return (np.asarray(u[0]) - np.asarray(x)) / p[0]


def tf_to_ss(num, den, name="num"):
    """Controllable-form (A, B, C, D) of num(s)/den(s) (or of z), coefficients in descending powers.

    Parameters
    ----------
    num, den : list of float
        Numerator and denominator; the transfer function must be proper.
    name : str
        The parameter named in errors.

    Returns
    -------
    tuple of numpy.ndarray
        A (n x n), B (n x 1), C (1 x n), D (1 x 1), n = the order of ``den``.
    """
    from scipy.signal import BadCoefficients, tf2ss

    num = np.atleast_1d(vector(num, name))
    den = np.atleast_1d(vector(den, "den"))
    den = np.trim_zeros(den, "f")
    num = np.trim_zeros(num, "f") if np.any(num) else np.zeros(1)
    if den.size == 0:
        raise ParameterError("den", "must not be all zeros")
    if num.size > den.size:
        raise ParameterError(name, f"the transfer function must be proper: numerator of degree "
                                   f"{num.size - 1} over denominator of degree {den.size - 1}")
    n = den.size - 1
    if n == 0:  # a pure gain num/den: no state (tf2ss gives a 1x1 zero A for it)
        return np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.array([[num[-1] / den[0]]])
    with warnings.catch_warnings():  # a zero numerator is a zero system, not "badly conditioned"
        warnings.simplefilter("ignore", BadCoefficients)
        A, B, C, D = tf2ss(num, den)
    return (np.asarray(A, float).reshape(n, n), np.asarray(B, float).reshape(n, 1),
            np.asarray(C, float).reshape(1, n), np.asarray(D, float).reshape(1, 1))


@register("transfer_function")
class TransferFunction(Block):
    """y = num(s) / den(s) u: a proper SISO transfer function, from rest.

    Coefficients in descending powers of s: ``num: [1], den: [1, 2, 1]`` is
    1 / (s + 1)^2. Realized in controllable canonical form; direct
    feedthrough only when num and den have the same degree.
    """

    def __init__(self, name="tf", num=(1.0,), den=(1.0, 1.0)):
        super().__init__(name)
        A, B, C, D = tf_to_ss(num, den)
        self.params = (A, B, C, D)
        self.declare_input("u", 1)
        self.declare_output("y", 1, depends_on=None if np.any(D) else ())
        self.declare_continuous_state(A.shape[0])

    def initial_state(self, u=None):
        return np.zeros(self.params[0].shape[0])


@register("first_order")
class FirstOrder(Block):
    """y' = (u - y) / tau, a first-order lag; starts in balance, y(0) = u(0), unless ``initial`` is given.

    A sensor filter, an actuator lag. ``tau`` (s) = 0 passes u through unchanged (no state): an option that is off
    costs nothing and changes no number. Starts in balance, y(0) = u(0), unless
    ``initial`` is given (in a loop back to its own input too: u = 3 (1 - y) starts at
    y = 0.75). Example: tau = 0.1 s, u = 1 from y(0) = 0 gives
    y(0.1 s) = 1 - 1/e.
    """

    init_needs_inputs = True

    def __init__(self, name="lag", tau=0.01, width=1, initial=None):
        super().__init__(name)
        n = count(width, "width")
        tau = scalar(tau, "tau", "nonnegative")
        self.params = (tau if tau > 0 else 1.0, n)
        self.x0 = None if initial is None else vector(initial, "initial", n)
        self.declare_input("u", n)
        if tau == 0.0:
            self.init_needs_inputs = False
            self.kernels = Kernels(output=pass_through_output)
            self.declare_output("y", n)
        else:
            self.declare_output("y", n, depends_on=())
            self.declare_continuous_state(n)

    def initial_state(self, u=None):
        if self.x0 is not None:
            return self.x0.copy()
        return np.array(u[0], dtype=float) if u is not None else np.zeros(self.params[1])


@kernel
def pass_through_output(p, t, x, u):
    """y = u: a first_order block with tau = 0 (the input itself: no copy in the compiled loop)."""
    return (u[0],)


@kernel
def first_order_output(p, t, x, u):
    return (x,)


@kernel
def first_order_derivatives(p, t, x, u):
    return (np.asarray(u[0]) - np.asarray(x)) / p[0]


@register("relay")
class Relay(Block):
    """A relay with hysteresis: switches on when u rises through ``switch_on``, off when it falls through ``switch_off``.

    y = ``y_on`` when on, ``y_off`` when off (``switch_off <= switch_on``). It starts on
    when u(0) > ``switch_on``, off when u(0) < ``switch_off``, else as ``initial`` says.
    The switches are located state events; the state is the relay's position (0 or 1),
    constant between them. Only the switch of the current position is armed: off, it
    waits for u to rise through ``switch_on``; on, for u to fall through ``switch_off``.
    """

    init_needs_inputs = True

    def __init__(self, name="relay", switch_on=0.0, switch_off=0.0, y_on=1.0, y_off=0.0, initial=False, width=1):
        super().__init__(name)
        n = count(width, "width")
        p = RelayParams(vector(switch_on, "switch_on", n), vector(switch_off, "switch_off", n),
                        vector(y_on, "y_on", n), vector(y_off, "y_off", n), n)
        if np.any(p.off > p.on):
            raise ParameterError("switch_off", f"must not exceed switch_on ({switch_off!r} > {switch_on!r})")
        self.params = p
        self.x0 = np.full(n, 1.0 if flag(initial, 'initial') else 0.0)
        self.event_directions = (1,) * n + (-1,) * n
        self.declare_input("u", n)
        self.declare_output("y", n, depends_on=())
        self.declare_continuous_state(n, held=True)  # the position, which only its switches change

    def initial_state(self, u=None):
        if u is None:
            return self.x0.copy()
        ua = np.asarray(u[0], float)
        return np.where(ua > self.params.on, 1.0, np.where(ua < self.params.off, 0.0, self.x0))


class RelayParams(NamedTuple):
    on: np.ndarray     # switch-on point
    off: np.ndarray    # switch-off point
    y_on: np.ndarray   # output when on
    y_off: np.ndarray  # output when off
    n: int             # width


@kernel
def relay_output(p, t, x, u):
    return (np.where(np.asarray(x) > 0.5, p.y_on, p.y_off),)


@kernel
def relay_derivatives(p, t, x, u):
    return np.zeros(p.n)


@kernel
def relay_crossings(p, t, x, u):
    # switch on (rising) while off, switch off (falling) while on; the other reads -1 / +1
    n = p.n
    g = np.empty(2 * n)
    for i in range(n):
        on = x[i] > 0.5
        g[i] = -1.0 if on else u[0][i] - p.on[i]
        g[n + i] = u[0][i] - p.off[i] if on else 1.0
    return g


@kernel
def relay_event(p, t, x, u, fired):
    out = np.asarray(x).copy()
    for i in range(p.n):
        if fired[i]:
            out[i] = 1.0
        if fired[p.n + i]:
            out[i] = 0.0
    return out


Integrator.kernels = Kernels(output=integrator_output, derivatives=integrator_derivatives,
                             zero_crossings=integrator_crossings, event_action=integrator_event)
FilteredDerivative.kernels = Kernels(output=derivative_output, derivatives=derivative_derivatives)
TransferFunction.kernels = Kernels(output=abcd_output, derivatives=abcd_step)
FirstOrder.kernels = Kernels(output=first_order_output, derivatives=first_order_derivatives)
Relay.kernels = Kernels(output=relay_output, derivatives=relay_derivatives,
                        zero_crossings=relay_crossings, event_action=relay_event)
