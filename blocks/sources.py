"""Signal sources. Each has outputs ``y`` and its time derivative ``dy``.

Widths follow the parameters: a scalar gives width 1, a list of n numbers
width n (scalars broadcast against lists).
"""
import math

import numpy as np

from hybridsim.block import Block
from hybridsim.registry import register

from ._util import vector


class _Source(Block):
    time_varying = True
    tuple_kernels = True  # no state, no inputs: runs as is in the fused path

    def __init__(self, name, width):
        super().__init__(name)
        self.declare_output("y", width)
        self.declare_output("dy", width)


def _widths(**params):
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
        self.value = vector(value, "value")
        super().__init__(name, self.value.size)
        self.zero = np.zeros(self.value.size)

    def output(self, t, x, u):
        return self.value, self.zero


@register("step")
class Step(_Source):
    """y = initial for t < time, final from t = time on (the unit step U of eq 17a)."""

    def __init__(self, name="step", initial=0.0, final=1.0, time=0.0):
        n = _widths(initial=initial, final=final)
        self.initial, self.final = vector(initial, "initial", n), vector(final, "final", n)
        self.time = float(time)
        super().__init__(name, n)
        self.zero = np.zeros(n)

    def output(self, t, x, u):
        return (self.final if t >= self.time else self.initial), self.zero


@register("ramp")
class Ramp(_Source):
    """y = initial + slope * (min(t, stop) - start) for t >= start (held before/after)."""

    def __init__(self, name="ramp", initial=0.0, slope=1.0, start=0.0, stop=math.inf):
        n = _widths(initial=initial, slope=slope)
        self.initial, self.slope = vector(initial, "initial", n), vector(slope, "slope", n)
        self.start, self.stop = float(start), float(stop)
        if self.stop < self.start:
            raise ValueError("ramp stop must not be before start")
        super().__init__(name, n)
        self.zero = np.zeros(n)

    def output(self, t, x, u):
        if t < self.start:
            return self.initial, self.zero
        moving = t < self.stop
        return self.initial + self.slope * (min(t, self.stop) - self.start), (self.slope if moving else self.zero)


@register("cosine")
class Cosine(_Source):
    """y = offset + amplitude cos(2 pi frequency t + phase) (eq 17b: 0.30 - 0.30 cos(0.75 pi t) m)."""

    def __init__(self, name="cosine", offset=0.0, amplitude=1.0, frequency=1.0, phase=0.0):
        n = _widths(offset=offset, amplitude=amplitude)
        self.offset, self.amp = vector(offset, "offset", n), vector(amplitude, "amplitude", n)
        self.w, self.phase = 2 * math.pi * float(frequency), float(phase)
        super().__init__(name, n)

    def output(self, t, x, u):
        a = self.w * t + self.phase
        return self.offset + self.amp * math.cos(a), -self.amp * self.w * math.sin(a)


@register("table")
class Table(_Source):
    """Piecewise-linear y(t) through (times[k], values[k]); held beyond the ends."""

    def __init__(self, name="table", times=(0.0, 1.0), values=(0.0, 1.0)):
        self.times = vector(times, "times")
        vals = np.asarray(values, float)
        self.values = vals[:, None] if vals.ndim == 1 else vals
        if self.values.shape[0] != self.times.size or self.times.size < 2:
            raise ValueError("table needs at least 2 times and one row of values per time")
        if np.any(np.diff(self.times) <= 0):
            raise ValueError("table times must increase strictly")
        super().__init__(name, self.values.shape[1])

    def output(self, t, x, u):
        k = int(np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, self.times.size - 2))
        t0, t1 = self.times[k], self.times[k + 1]
        slope = (self.values[k + 1] - self.values[k]) / (t1 - t0)
        if t < self.times[0] or t >= self.times[-1]:
            return (self.values[0] if t < t0 else self.values[-1]), np.zeros_like(slope)
        return self.values[k] + slope * (t - t0), slope
