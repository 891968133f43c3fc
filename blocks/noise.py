"""Seeded band-limited white noise: the same numbers on every path, in every process."""
import math
from typing import NamedTuple

import numpy as np

from hybridsim.block import Block
from hybridsim.errors import ParameterError
from hybridsim.kernels import Kernels, kernel
from hybridsim.registry import register

from ._util import count, vector

GROUP = "sources"  # where `hybridsim blocks` lists this module's blocks

_MASK = 0xFFFFFFFF


@register("noise")
class Noise(Block):
    """Gaussian white noise held over each period: y = mean + sigma n_k, n_k ~ N(0, 1).

    Parameters
    ----------
    sigma : float or list   standard deviation of each sample (units of y)
    mean : float or list    offset
    seed : int              0 .. 2^32 - 1; the same seed gives the same sequence
                            on every path and in every process (a Monte Carlo
                            sweep varies it)
    rate, period            sample rate (Hz) or period (s): the noise bandwidth

    n_k is a counter-based hash of (seed, k, channel) through the Box-Muller
    transform, so sample k never depends on how many samples came before it
    or on any global random state.
    """

    def __init__(self, name="noise", sigma=1.0, mean=0.0, seed=0, rate=None, period=None, width=1):
        super().__init__(name)
        if (rate is None) == (period is None):
            raise ParameterError("rate", "or period: give exactly one of rate (Hz) or period (s)")
        if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= _MASK:
            raise ParameterError("seed", f"must be a whole number from 0 to {_MASK}, got {seed!r}")
        n = count(width, "width")
        self.declare_rate(period=period, rate=rate)
        self.params = NoiseParams(vector(sigma, "sigma", n, "nonnegative"), vector(mean, "mean", n),
                                  float(seed), n)
        self.declare_discrete_state(1)  # k, the samples so far
        self.declare_output("y", n)


class NoiseParams(NamedTuple):
    sigma: np.ndarray  # standard deviation
    mean: np.ndarray   # offset
    seed: float        # the seed (a whole number)
    n: int             # width


@kernel
def hash32(a):
    """A 32-bit integer hash (Wang's), in 64-bit integer arithmetic that never overflows."""
    a = (a ^ 61) ^ (a >> 16)
    a = (a * 9) & 0xFFFFFFFF
    a = a ^ (a >> 4)
    a = (a * 0x27D4EB2D) & 0xFFFFFFFF
    return a ^ (a >> 15)


@kernel
def uniform(seed, k, channel, which):
    """A number in (0, 1) from the hash of (seed, k, channel, which)."""
    a = hash32(int(seed) & 0xFFFFFFFF)
    a = hash32(a ^ (int(k) & 0xFFFFFFFF))
    a = hash32(a ^ ((2 * channel + which) & 0xFFFFFFFF))
    return (a + 0.5) / 4294967296.0


@kernel
def noise_output(p, t, x, u):
    y = np.empty(p.n)
    for i in range(p.n):
        u1, u2 = uniform(p.seed, x[0], i, 0), uniform(p.seed, x[0], i, 1)
        y[i] = p.mean[i] + p.sigma[i] * math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)
    return (y,)


@kernel
def noise_update(p, t, x, u):
    return (x[0] + 1.0,)


Noise.kernels = Kernels(output=noise_output, update=noise_update)
