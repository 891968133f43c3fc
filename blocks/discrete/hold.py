"""Sampled holds and delays: zero-order hold, unit delay, a hit counter."""

import numpy as np

from hybridsim.engine.block import Block
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.engine.registry import register

from hybridsim.blocks._util import count, vector


GROUP = "math"  # where `hybridsim blocks` lists this module's blocks

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


@register("counter")
class Counter(Block):
    """Counts its own sample hits (y = hits so far); for checking schedules."""

    group = "sources"

    def __init__(self, name="counter", rate=None, period=None, offset=0):
        super().__init__(name)
        self.declare_rate(period=period, rate=rate, offset=offset)
        self.declare_discrete_state(1, bounded=False, held=True)  # a count
        self.declare_output("y", 1)


@kernel
def counter_output(p, t, x, u):
    return ((x[0] + 1.0,),)


@kernel
def counter_update(p, t, x, u):
    return (x[0] + 1.0,)


ZeroOrderHold.kernels = Kernels(output=zoh_output)
UnitDelay.kernels = Kernels(output=delay_output, update=delay_update)
Counter.kernels = Kernels(output=counter_output, update=counter_update)
