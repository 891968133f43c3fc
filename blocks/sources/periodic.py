"""Periodic and swept sources and a clock: sine, square, pulse, sawtooth, chirp, clock.

Each has outputs ``y`` and its time derivative ``dy`` (units of y per s), like
the sources of :mod:`hybridsim.blocks.sources.basic`. The edges of square, pulse and
sawtooth are zero crossings of a smooth function, so the adaptive solvers (and
fixed-step ones with ``locate_switches``) stop exactly on them. At an edge's
instant the output is the new level, also where the phase rounds a hair short
of it (a 0.4 s pulse at 0.6 s: 0.6 / 0.4 = 1.4999999999999998).
"""
import math
from typing import NamedTuple

import numpy as np

from hybridsim.errors import ParameterError
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.engine.registry import register

from hybridsim.blocks._util import WHOLE, choice, scalar, vector
from hybridsim.blocks.sources.basic import _Source, _widths

GROUP = "sources"  # where `hybridsim blocks` lists this module's blocks


class WaveParams(NamedTuple):
    bias: np.ndarray   # offset, units of y
    amp: np.ndarray    # amplitude, units of y
    f: float           # frequency, Hz
    phase: float       # phase, rad
    n: int             # width


def _wave(bias, amplitude, frequency, phase):
    n = _widths(bias=bias, amplitude=amplitude)
    return WaveParams(vector(bias, "bias", n), vector(amplitude, "amplitude", n),
                      scalar(frequency, "frequency", "positive"), scalar(phase, "phase"), n)


@register("sine")
class Sine(_Source):
    """y = bias + amplitude sin(2 pi frequency t + phase).

    Parameters
    ----------
    bias, amplitude : float or list   units of y
    frequency : float                 Hz
    phase : float                     rad

    Example: frequency 0.25 Hz, amplitude 2 gives y(1 s) = 2.
    """

    def __init__(self, name="sine", bias=0.0, amplitude=1.0, frequency=1.0, phase=0.0):
        p = _wave(bias, amplitude, frequency, phase)
        super().__init__(name, p.n)
        self.params = p


@kernel
def sine_output(p, t, x, u):
    a = 2.0 * math.pi * p.f * t + p.phase
    return p.bias + p.amp * math.sin(a), p.amp * (2.0 * math.pi * p.f) * math.cos(a)


@register("square")
class Square(_Source):
    """y = bias + amplitude sgn(sin(2 pi frequency t + phase)), sgn(0) = +1: a square wave of 50 % duty.

    Parameters as :class:`Sine`; dy = 0 between the edges. Example: frequency 1 Hz gives
    +amplitude on [0, 0.5) s and -amplitude on [0.5, 1) s.
    """

    def __init__(self, name="square", bias=0.0, amplitude=1.0, frequency=1.0, phase=0.0):
        p = _wave(bias, amplitude, frequency, phase)
        super().__init__(name, p.n)
        self.params = p
        self.event_directions = (0,)


@kernel
def fraction(c):
    """The fraction in [0, 1) of the cycle reached at ``c`` cycles; a ``c`` within round-off below a
    whole number counts as that number (0.6 s / 0.4 s is 1.4999999999999998: the edge at 1.5 is
    reached)."""
    s = c + round_off(c)
    if not abs(s) < WHOLE:  # a whole number of cycles
        return 0.0
    k = math.floor(s)
    return max(c - k, 0.0)


@kernel
def round_off(c):
    """How far ``c`` (cycles, or a fraction of one) may be off an exact edge from rounding alone."""
    return 64.0 * 2.220446049250313e-16 * max(1.0, abs(c))


@kernel
def cycle_fraction(f, phase, t):
    """The fraction in [0, 1) of the period reached at t (s) by a wave of f Hz and phase (rad)."""
    return fraction(f * t + phase / (2.0 * math.pi))


@kernel
def square_output(p, t, x, u):
    c = p.f * t + p.phase / (2.0 * math.pi)
    high = fraction(c) < 0.5 - round_off(c)
    return p.bias + (p.amp if high else -p.amp), p.amp * 0.0


@kernel
def edge_function(size, high):
    """A wave's event function: ``size`` (how far the edges are, zero at each), signed by the
    output's level (+ high, - low), never 0: past zero from an edge on, where the output has
    switched (a function fires on leaving zero: an edge at t = 0 is none)."""
    g = max(abs(size), 1e-300)
    return g if high else -g


@kernel
def square_crossings(p, t, x, u):
    c = p.f * t + p.phase / (2.0 * math.pi)
    return (edge_function(math.sin(2.0 * math.pi * c), fraction(c) < 0.5 - round_off(c)),)


@register("sawtooth")
class Sawtooth(_Source):
    """y = bias + amplitude (2 c - 1), c = frac(frequency t + phase / 2 pi): rises from -amplitude to amplitude each period.

    dy = 2 amplitude frequency (units of y per s). Example: 1 Hz, amplitude 1: y(0.25 s) = -0.5.
    """

    def __init__(self, name="sawtooth", bias=0.0, amplitude=1.0, frequency=1.0, phase=0.0):
        p = _wave(bias, amplitude, frequency, phase)
        super().__init__(name, p.n)
        self.params = p
        self.event_directions = (0,)


@kernel
def sawtooth_output(p, t, x, u):
    c = cycle_fraction(p.f, p.phase, t)
    return p.bias + p.amp * (2.0 * c - 1.0), 2.0 * p.amp * p.f


@kernel
def sawtooth_crossings(p, t, x, u):
    return (math.sin(math.pi * (p.f * t + p.phase / (2.0 * math.pi))),)  # 0 at every wrap


@register("pulse")
class Pulse(_Source):
    """A pulse train: y = amplitude for delay + k period <= t < delay + (k + duty) period, else 0.

    Parameters
    ----------
    amplitude : float or list   units of y
    period : float              s
    duty : float                fraction of the period that is high, 0 < duty < 1
    delay : float               s; y = 0 before it (Simulink's phase delay)

    Example: period 1 s, duty 0.25, delay 0.5 s: high on [0.5, 0.75), [1.5, 1.75), ...
    """

    def __init__(self, name="pulse", amplitude=1.0, period=1.0, duty=0.5, delay=0.0):
        amp = vector(amplitude, "amplitude")
        super().__init__(name, amp.size)
        duty = scalar(duty, "duty")
        if not 0.0 < duty < 1.0:
            raise ParameterError("duty", f"must lie strictly between 0 and 1, got {duty!r}")
        self.params = PulseParams(amp, scalar(period, "period", "positive"), duty, scalar(delay, "delay"))
        self.event_directions = (0,)


class PulseParams(NamedTuple):
    amp: np.ndarray  # amplitude, units of y
    period: float    # s
    duty: float      # fraction high
    delay: float     # s


@kernel
def pulse_high(p, t):
    s = (t - p.delay) / p.period
    return s >= -round_off(s) and fraction(s) < p.duty - round_off(s)


@kernel
def pulse_output(p, t, x, u):
    return (p.amp if pulse_high(p, t) else p.amp * 0.0), p.amp * 0.0


@kernel
def pulse_crossings(p, t, x, u):
    s = (t - p.delay) / p.period
    if s < 0.0:  # before the delay: no edge; down to 0 at the first rise with the same slope as after
        size = math.pi * s * math.sin(math.pi * p.duty)
    else:  # zero at each edge
        size = math.sin(math.pi * s) * math.sin(math.pi * (s - p.duty))
    return (edge_function(size, pulse_high(p, t)),)


@register("chirp")
class Chirp(_Source):
    """A swept cosine, as ``scipy.signal.chirp``: y = amplitude cos(phi(t) + phase).

    Parameters
    ----------
    f0, f1 : float     Hz at t = 0 and at t = t1
    t1 : float         s
    method : str       ``linear``: phi = 2 pi (f0 t + (f1 - f0) t^2 / (2 t1));
                       ``logarithmic``: phi = 2 pi f0 t1 / ln(f1 / f0) ((f1 / f0)^(t / t1) - 1)
    amplitude : float  units of y
    phase : float      rad

    The sweep continues past t1 by the same law. dy is its exact derivative.
    """

    def __init__(self, name="chirp", f0=1.0, f1=10.0, t1=1.0, method="linear", amplitude=1.0, phase=0.0):
        amp = vector(amplitude, "amplitude")
        super().__init__(name, amp.size)
        method = choice(method, "method", ("linear", "logarithmic"))
        f0, f1 = scalar(f0, "f0", "positive"), scalar(f1, "f1", "positive")
        if method == "logarithmic" and f0 == f1:
            raise ParameterError("f1", "must differ from f0 for a logarithmic sweep")
        self.params = ChirpParams(amp, f0, f1, scalar(t1, "t1", "positive"), float(method == "logarithmic"),
                                  scalar(phase, "phase"))


class ChirpParams(NamedTuple):
    amp: np.ndarray  # amplitude, units of y
    f0: float        # Hz
    f1: float        # Hz
    t1: float        # s
    log: float       # 1: logarithmic sweep, 0: linear
    phase: float     # rad


@kernel
def chirp_output(p, t, x, u):
    if p.log == 1.0:
        r = math.log(p.f1 / p.f0)
        g = math.exp(r * t / p.t1)
        phi = 2.0 * math.pi * p.f0 * p.t1 / r * (g - 1.0)
        f = p.f0 * g
    else:
        phi = 2.0 * math.pi * (p.f0 * t + 0.5 * (p.f1 - p.f0) * t * t / p.t1)
        f = p.f0 + (p.f1 - p.f0) * t / p.t1
    return p.amp * math.cos(phi + p.phase), -p.amp * (2.0 * math.pi * f) * math.sin(phi + p.phase)


@register("clock")
class Clock(_Source):
    """y = t (s), dy = 1: the simulation time as a signal (Simulink's Clock)."""

    def __init__(self, name="clock"):
        super().__init__(name, 1)
        self.params = ()


@kernel
def clock_output(p, t, x, u):
    return (t,), (1.0,)


Sine.kernels = Kernels(output=sine_output)
Square.kernels = Kernels(output=square_output, zero_crossings=square_crossings)
Sawtooth.kernels = Kernels(output=sawtooth_output, zero_crossings=sawtooth_crossings)
Pulse.kernels = Kernels(output=pulse_output, zero_crossings=pulse_crossings)
Chirp.kernels = Kernels(output=chirp_output)
Clock.kernels = Kernels(output=clock_output)
