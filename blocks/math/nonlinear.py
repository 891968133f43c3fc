"""Static nonlinearities and math: saturation, dead zone, switch, product, functions, quantizer, lookup tables.

All are memoryless (no state, direct feedthrough) and work element-wise on
``width`` signals. Nothing is evaluated from text: a math function is one of
a fixed set of names.
"""
import math

import numpy as np

from hybridsim.engine.block import Block
from hybridsim.errors import ParameterError
from hybridsim.engine.kernels import Kernels, kernel, unroll
from hybridsim.engine.registry import register

from hybridsim.blocks._util import WHOLE, as_floats, choice, count, vector
from hybridsim.blocks.math.lookup import lookup_1d_output, table_params


GROUP = "math"  # where `hybridsim blocks` lists this module's blocks

class _Band(Block):
    """A memoryless block of ``width`` signals with a band [lower, upper] (its params)."""

    def __init__(self, name, lower, upper, width):
        super().__init__(name)
        n = count(width, "width")
        lo, hi = vector(lower, "lower", n, inf_ok=True), vector(upper, "upper", n, inf_ok=True)
        if np.any(lo > hi):
            raise ParameterError("lower", f"must not exceed upper ({lower!r} > {upper!r})")
        self.params = (lo, hi)
        self.declare_input("u", n)
        self.declare_output("y", n)


@register("saturation")
class Saturation(_Band):
    """y = u clipped to [lower, upper]. Example: lower -1, upper 2: u = 3 gives 2, u = -5 gives -1."""

    def __init__(self, name="saturation", lower=-1.0, upper=1.0, width=1):
        super().__init__(name, lower, upper, width)


@kernel
def saturation_output(p, t, x, u):
    return (np.minimum(np.maximum(np.asarray(u[0]), p[0]), p[1]),)


@register("dead_zone")
class DeadZone(_Band):
    """y = 0 for lower <= u <= upper, else u minus the nearer edge. Example: [-1, 1]: u = 3 gives 2."""

    def __init__(self, name="dead_zone", lower=-1.0, upper=1.0, width=1):
        super().__init__(name, lower, upper, width)


@kernel
def dead_zone_output(p, t, x, u):
    ua = np.asarray(u[0])
    return (np.where(ua > p[1], ua - p[1], np.where(ua < p[0], ua - p[0], 0.0)),)


@register("switch")
class Switch(Block):
    """y = u1 where ``control`` >= threshold, else u2 (element-wise).

    Ports: in ``u1``, ``control``, ``u2``; out ``y``. ``control`` = threshold
    is a zero crossing (direction either), as in Simulink's Switch: the
    variable-step solvers locate it and restart there, and so do the
    fixed-step methods with ``simulation.locate_switches: true`` (otherwise
    they step over it, with an error of the order of one step).
    """

    def __init__(self, name="switch", threshold=0.0, width=1):
        super().__init__(name)
        n = count(width, "width")
        self.params = (vector(threshold, "threshold", n),)
        self.event_directions = (0,) * n
        self.declare_input("u1", n)
        self.declare_input("control", n)
        self.declare_input("u2", n)
        self.declare_output("y", n)


@kernel
def switch_output(p, t, x, u):
    return (np.where(np.asarray(u[1]) >= p[0], np.asarray(u[0]), np.asarray(u[2])),)


@kernel
def switch_crossings(p, t, x, u):
    """control - threshold, never zero: at the threshold it is past zero, on u1's side (a function
    fires on leaving zero, and a stage at the threshold already passes u1)."""
    d = np.asarray(u[1]) - p[0]
    return np.where(d == 0.0, 1e-300, d)


@register("product")
class Product(Block):
    """y = u1 * u2 / u3 ... element-wise, by ``ops`` (``'**/'``: u1 u2 / u3).

    A division by exactly zero is a run-time error (the run stops on the
    non-finite value), never a silent inf.
    """

    def __init__(self, name="product", ops="**", width=1):
        super().__init__(name)
        if not isinstance(ops, str) or not ops or set(ops) - {"*", "/"}:
            raise ParameterError("ops", f"must be a string of * and /, got {ops!r}")
        n = count(width, "width")
        self.params = (tuple(1.0 if c == "*" else -1.0 for c in ops),)
        for k in range(len(ops)):
            self.declare_input(f"u{k + 1}", n)
        self.declare_output("y", n)


@kernel
def product_output(p, t, x, u):
    ops = p[0]
    y = np.asarray(u[0]) * 1.0 if ops[0] > 0 else 1.0 / np.asarray(u[0])
    k = 0
    for v in unroll(u):  # the inputs may mix arrays and tuples (compiled: unrolled)
        if k > 0:
            y = y * np.asarray(v) if ops[k] > 0 else y / np.asarray(v)
        k += 1
    return (y,)


#: the functions ``math_function`` offers, by name (each element-wise)
FUNCTIONS = ("sin", "cos", "tan", "asin", "acos", "atan", "exp", "log", "log10", "sqrt", "abs", "sign",
             "square", "reciprocal", "tanh", "sinh", "cosh", "floor", "ceil", "round")


@register("math_function")
class MathFunction(Block):
    """y = f(u) element-wise, ``function`` one of a fixed set (see FUNCTIONS).

    sin, cos, tan, asin, acos, atan, exp, log (natural), log10, sqrt, abs,
    sign, square (u^2), reciprocal (1/u), tanh, sinh, cosh, floor, ceil,
    round (halves to even). A value outside the domain (log of 0, sqrt of
    -1) gives a non-finite value, which stops the run with an error.
    """

    def __init__(self, name="f", function="sin", width=1):
        super().__init__(name)
        if function not in FUNCTIONS:
            raise ParameterError("function", f"must be one of {', '.join(FUNCTIONS)}; got {function!r}")
        n = count(width, "width")
        self.params = (float(FUNCTIONS.index(function)),)
        self.declare_input("u", n)
        self.declare_output("y", n)


#: the largest arguments of exp and of sinh / cosh whose results are finite (math.exp raises above)
EXP_MAX = 709.782712893384       # log(float max)
SINH_MAX = 710.4758600739439     # log(2 float max)


@kernel
def apply_function(code, v):
    """FUNCTIONS[code] of the float v (the C library's, so every path gives the same bits). NaN gives
    NaN (never a number a later block passes on as if it were one: the run stops at this block)."""
    c = int(code)
    if v != v:
        return v
    if math.isinf(v) and (c <= 2 or c >= 17):  # sin, cos, tan of +-inf: NaN; floor, ceil, round: itself
        return math.nan if c <= 2 else v
    if c == 0:
        return math.sin(v)
    if c == 1:
        return math.cos(v)
    if c == 2:
        return math.tan(v)
    if c == 3:
        return math.asin(v) if -1.0 <= v <= 1.0 else math.nan
    if c == 4:
        return math.acos(v) if -1.0 <= v <= 1.0 else math.nan
    if c == 5:
        return math.atan(v)
    if c == 6:
        return math.exp(v) if v <= EXP_MAX else math.inf
    if c == 7:
        return math.log(v) if v > 0.0 else (-math.inf if v == 0.0 else math.nan)
    if c == 8:
        return math.log10(v) if v > 0.0 else (-math.inf if v == 0.0 else math.nan)
    if c == 9:
        return math.sqrt(v) if v >= 0.0 else math.nan
    if c == 10:
        return abs(v)
    if c == 11:
        return 1.0 if v > 0.0 else (-1.0 if v < 0.0 else 0.0)
    if c == 12:
        return v * v
    if c == 13:
        return 1.0 / v if v != 0.0 else math.inf
    if c == 14:
        return math.tanh(v)
    if c == 15:
        return math.sinh(v) if abs(v) <= SINH_MAX else math.copysign(math.inf, v)
    if c == 16:
        return math.cosh(v) if abs(v) <= SINH_MAX else math.inf
    if not abs(v) < WHOLE:  # a whole number already
        return v
    if c == 17:
        return float(math.floor(v))
    if c == 18:
        return float(math.ceil(v))
    return float(round(v))


@kernel
def math_function_output(p, t, x, u):
    ua = np.asarray(u[0])
    y = np.empty(ua.size)
    for i in range(ua.size):
        y[i] = apply_function(p[0], ua[i])
    return (y,)


@register("quantizer")
class Quantizer(Block):
    """y = q round(u / q): a converter of resolution ``q`` (e.g. a force sensor's ADC step, N).

    ``rounding``: ``even`` (halves to even, numpy's and IEEE's default) or
    ``away`` (halves away from zero, as Simulink's Quantizer). Example: q = 0.1,
    u = 0.26 gives 0.3; u = 0.25 gives 0.2 (even) or 0.3 (away).
    """

    def __init__(self, name="quantizer", q=0.01, width=1, rounding="even"):
        super().__init__(name)
        rounding = choice(rounding, "rounding", ("even", "away"))
        n = count(width, "width")
        self.params = (vector(q, "q", n, "positive"), float(rounding == "away"))
        self.declare_input("u", n)
        self.declare_output("y", n)


@kernel
def quantizer_output(p, t, x, u):
    v = np.asarray(u[0]) / p[0]
    if p[1] == 1.0:  # v - trunc(v) is exact (floor(abs(v) + 0.5) took 0.49999999999999994 to 1)
        w = np.trunc(v)
        return (p[0] * (w + np.where(np.abs(v - w) >= 0.5, np.sign(v), 0.0)),)
    return (p[0] * np.round(v),)


def _breakpoints(values, name):
    bp = vector(values, name)
    if bp.size < 2 or np.any(np.diff(bp) <= 0):
        raise ParameterError(name, f"must be at least 2 strictly increasing numbers, got {values!r}")
    return bp


@register("lookup_1d")
class Lookup1D(Block):
    """y = table(u), linear between breakpoints ``x``; beyond them held (default) or extrapolated.

    ``extrapolation``: ``hold`` (the end values) or ``linear`` (the end
    segments continued, Simulink's default); ``width`` elements, each looked up
    in the same table. Example: x [0, 1, 2], y [0, 10, 0]: u = 0.5 gives 5,
    u = 3 gives 0 (hold) or -10 (linear).
    """

    def __init__(self, name="lookup", x=(0.0, 1.0), y=(0.0, 1.0), extrapolation="hold", width=1):
        super().__init__(name)
        bx = _breakpoints(x, "x")
        n = count(width, "width")
        self.params = table_params([bx], vector(y, "y", bx.size), extrapolation, n)
        self.declare_input("u", n)
        self.declare_output("y", n)


@register("lookup_2d")
class Lookup2D(Block):
    """y = table(u1, u2), bilinear on the grid ``x1`` x ``x2`` (table[i][j] at x1[i], x2[j]); ends held."""

    def __init__(self, name="lookup2", x1=(0.0, 1.0), x2=(0.0, 1.0), table=((0.0, 0.0), (0.0, 0.0))):
        super().__init__(name)
        b1, b2 = _breakpoints(x1, "x1"), _breakpoints(x2, "x2")
        tab = as_floats(table, "table", "a matrix of numbers")
        if tab.shape != (b1.size, b2.size) or not np.all(np.isfinite(tab)):
            raise ParameterError("table", f"must be {b1.size}x{b2.size} finite numbers, got shape {tab.shape}")
        self.params = (b1, b2, tab)
        self.declare_input("u1", 1)
        self.declare_input("u2", 1)
        self.declare_output("y", 1)


@kernel
def cell(bp, v):
    """(index i, weight w) with v = (1 - w) bp[i] + w bp[i + 1], clamped to the table (NaN: weight NaN)."""
    if v != v:
        return 0, v
    if v <= bp[0]:
        return 0, 0.0
    if v >= bp[-1]:
        return bp.size - 2, 1.0
    i = np.searchsorted(bp, v) - 1
    return i, (v - bp[i]) / (bp[i + 1] - bp[i])


@kernel
def lookup_2d_output(p, t, x, u):
    b1, b2, tab = p
    i, w = cell(b1, u[0][0])
    j, v = cell(b2, u[1][0])
    y = ((1 - w) * ((1 - v) * tab[i, j] + v * tab[i, j + 1])
         + w * ((1 - v) * tab[i + 1, j] + v * tab[i + 1, j + 1]))
    return (np.array([y]),)


Saturation.kernels = Kernels(output=saturation_output)
DeadZone.kernels = Kernels(output=dead_zone_output)
Switch.kernels = Kernels(output=switch_output, zero_crossings=switch_crossings)
Product.kernels = Kernels(output=product_output)
MathFunction.kernels = Kernels(output=math_function_output)
Quantizer.kernels = Kernels(output=quantizer_output)
Lookup2D.kernels = Kernels(output=lookup_2d_output)

Lookup1D.kernels = Kernels(output=lookup_1d_output)
