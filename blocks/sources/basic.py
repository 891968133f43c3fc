"""Signal sources. Each has outputs ``y`` and its time derivative ``dy``.

Widths follow the parameters: a scalar gives width 1, a list of n numbers
width n (scalars broadcast against lists).
"""
import math

import numpy as np

from hybridsim.engine.block import Block
from hybridsim.errors import ParameterError
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.engine.registry import register

from hybridsim.blocks._util import finite_matrix, floats, scalar, vector


GROUP = "sources"  # where `hybridsim blocks` lists this module's blocks

class _Source(Block):
    time_varying = True

    def __init__(self, name, width):
        super().__init__(name)
        self.declare_output("y", width)
        self.declare_output("dy", width)


def _widths(**params):
    for name, v in params.items():
        vector(v, name)  # numbers, finite, flat
    sizes = {np.size(v) for v in params.values()}
    n = max(sizes)
    bad = sizes - {1, n}
    if bad:
        raise ValueError(f"parameters {sorted(params)} have inconsistent lengths {sorted(sizes)}")
    return n


@register("constant")
class Constant(_Source):
    """y = value."""

    time_varying = False

    def __init__(self, name="const", value=0.0):
        value = floats(value, "value")
        super().__init__(name, len(value))
        self.params = (value, (0.0,) * len(value))


@kernel
def constant_output(p, t, x, u):
    return p[0], p[1]


@register("step")
class Step(_Source):
    """y = initial for t < time, final from t = time on (the unit step U of eq 17a).

    Its jump is a zero crossing (``t - time``), located where switches are (variable-step
    solvers, ``locate_switches``) when it can change a derivative; otherwise a fixed step steps
    over it (its last stage at the jump sees ``final``: an O(h) error in an integral of y).
    """

    def __init__(self, name="step", initial=0.0, final=1.0, time=0.0):
        n = _widths(initial=initial, final=final)
        super().__init__(name, n)
        self.params = (floats(initial, "initial", n), floats(final, "final", n),
                       scalar(time, "time"), (0.0,) * n)
        self.event_directions = (1,)  # its jump, located where switches are (a step from 0 has none)


@kernel
def step_output(p, t, x, u):
    initial, final, time, zero = p
    return (final if t >= time else initial), zero


@kernel
def step_crossings(p, t, x, u):
    """t - time, past zero from t = time on, where the output is ``final`` (a function fires on
    leaving zero: at t = time itself it is already past)."""
    time = p[2]
    if time <= 0.0:
        return (1.0,)
    return ((t - time) if t < time else max(t - time, 1e-300),)


@register("ramp")
class Ramp(_Source):
    """y = initial + slope * (min(t, stop) - start) for t >= start (held before/after)."""

    def __init__(self, name="ramp", initial=0.0, slope=1.0, start=0.0, stop=math.inf):
        n = _widths(initial=initial, slope=slope)
        start, stop = scalar(start, "start"), scalar(stop, "stop", inf_ok=True)
        if stop < start:
            raise ParameterError("stop", "must not be before start")
        super().__init__(name, n)
        self.params = (vector(initial, "initial", n), vector(slope, "slope", n), start, stop,
                       np.zeros(n))


@kernel
def ramp_output(p, t, x, u):
    initial, slope, start, stop, zero = p
    if t < start:
        return initial, zero
    moving = t < stop
    return initial + slope * (min(t, stop) - start), (slope if moving else zero)


@register("cosine")
class Cosine(_Source):
    """y = offset + amplitude cos(2 pi frequency t + phase) (eq 17b: 0.30 - 0.30 cos(0.75 pi t) m)."""

    def __init__(self, name="cosine", offset=0.0, amplitude=1.0, frequency=1.0, phase=0.0):
        n = _widths(offset=offset, amplitude=amplitude)
        super().__init__(name, n)
        self.params = (vector(offset, "offset", n), vector(amplitude, "amplitude", n),
                       2 * math.pi * scalar(frequency, "frequency"), scalar(phase, "phase"))


@kernel
def cosine_output(p, t, x, u, out):
    offset, amp, w, phase = p
    a = w * t + phase
    c, s = math.cos(a), math.sin(a)
    y, yd = out
    for i in range(offset.size):  # element by element, into the arrays given (compiled: no allocation)
        y[i] = offset[i] + amp[i] * c
        yd[i] = -amp[i] * w * s
    return out


@register("table")
class Table(_Source):
    """Piecewise-linear y(t) through (times[k], values[k]); held beyond the ends.

    A time given twice is a jump (as in Simulink's From Workspace): the first of its rows holds
    up to it, the second from it on; the jump is a zero crossing like a ``step``'s.
    Example: times [0, 1, 1, 2], values [0, 0, 5, 5] steps from 0 to 5 at t = 1 s.
    """

    def __init__(self, name="table", times=(0.0, 1.0), values=(0.0, 1.0)):
        times = vector(times, "times")
        vals = finite_matrix(values, "values")
        values = vals.T if np.ndim(values) == 1 else vals
        if values.shape[0] != times.size or times.size < 2:
            raise ParameterError("values", "needs at least 2 times and one row of values per time")
        gaps = np.diff(times)
        if np.any(gaps < 0):
            raise ParameterError("times", "must not decrease (a time given twice is a jump)")
        if np.any((gaps[:-1] == 0) & (gaps[1:] == 0)):
            raise ParameterError("times", "gives one time three times; a jump is a time given twice")
        super().__init__(name, values.shape[1])
        jumps = times[1:][gaps == 0]
        self.params = (times, np.ascontiguousarray(values), jumps)
        if jumps.size:
            self.event_directions = (1,) * jumps.size
            self.kernels = Kernels(output=table_output, zero_crossings=table_crossings)


@kernel
def table_output(p, t, x, u):
    times, values, jumps = p
    n = times.size
    if t < times[0]:
        return values[0].copy(), np.zeros_like(values[0])
    if t >= times[n - 1]:
        return values[n - 1].copy(), np.zeros_like(values[0])
    k = np.searchsorted(times, t, side="right") - 1  # times[k] <= t < times[k + 1]: never a jump's gap
    t0, t1 = times[k], times[k + 1]
    slope = (values[k + 1] - values[k]) / (t1 - t0)
    return values[k] + slope * (t - t0), slope


@kernel
def table_crossings(p, t, x, u):
    """t - each jump's time, past zero from the jump on, where the output has jumped (as a step's)."""
    d = t - p[2]
    return np.where(d == 0.0, 1e-300, d)


Constant.kernels = Kernels(output=constant_output)
Step.kernels = Kernels(output=step_output, zero_crossings=step_crossings)
Ramp.kernels = Kernels(output=ramp_output)
Cosine.kernels = Kernels(output_into=cosine_output)
Table.kernels = Kernels(output=table_output)
