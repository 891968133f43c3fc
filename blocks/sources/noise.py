"""Seeded band-limited white noise from the Philox4x64-10 counter-based generator.

Sample k of channel i is the Philox4x64-10 block of counter (k, i, 0, 0)
under key (seed, 0): the very bits of numpy's ``numpy.random.Philox`` (the
tests compare them word for word), turned into N(0, 1) by the Box-Muller
transform (as cuRAND and Random123 do for Philox). Nothing depends on how
many samples came before, on the path or on the process.
"""
import math
from typing import NamedTuple

import numpy as np

from hybridsim.engine.block import Block
from hybridsim.errors import ParameterError
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.engine.registry import register

from hybridsim.blocks._util import count, one_rate, vector

GROUP = "sources"  # where `hybridsim blocks` lists this module's blocks

_SEED_MAX = 2**64 - 1
_M32 = np.uint64(0xFFFFFFFF)
_S32 = np.uint64(32)
_S11 = np.uint64(11)
_PHILOX_M0 = np.uint64(0xD2E7470EE14C6C93)  # Salmon et al. 2011, Philox4x64 multipliers
_PHILOX_M1 = np.uint64(0xCA5A826395121157)
_WEYL = (0x9E3779B97F4A7C15, 0xBB67AE8584CAA73B)  # key increments per round
_ROUNDS = 10


def philox_keys(seed):
    """The 10 round keys of Philox4x64-10 for key (seed, 0), as a flat uint64 array (k0, k1 per round)."""
    k0, k1, out = int(seed), 0, []
    for _ in range(_ROUNDS):
        out += [k0, k1]
        k0, k1 = (k0 + _WEYL[0]) % 2**64, (k1 + _WEYL[1]) % 2**64
    return np.array(out, dtype=np.uint64)


@kernel
def mulhilo64(a, b):
    """(high, low) 64-bit words of the 128-bit product a b, from 32-bit limbs (no overflow)."""
    al, ah, bl, bh = a & _M32, a >> _S32, b & _M32, b >> _S32
    ll, lh, hl, hh = al * bl, al * bh, ah * bl, ah * bh
    mid = (ll >> _S32) + (lh & _M32) + (hl & _M32)
    return hh + (lh >> _S32) + (hl >> _S32) + (mid >> _S32), ((mid & _M32) << _S32) | (ll & _M32)


@kernel
def philox4x64(c0, c1, c2, c3, keys):
    """The Philox4x64-10 block of counter (c0, c1, c2, c3) under the round keys ``keys``."""
    for r in range(10):
        hi0, lo0 = mulhilo64(_PHILOX_M0, c0)
        hi1, lo1 = mulhilo64(_PHILOX_M1, c2)
        c0, c1, c2, c3 = hi1 ^ c1 ^ keys[2 * r], lo1, hi0 ^ c3 ^ keys[2 * r + 1], lo0
    return c0, c1, c2, c3


@kernel
def philox_normal(keys, k, channel):
    """N(0, 1) sample ``k`` of ``channel``: Box-Muller on two 53-bit uniforms of one Philox block."""
    w0, w1, w2, w3 = philox4x64(np.uint64(k), np.uint64(channel), np.uint64(0), np.uint64(0), keys)
    u1 = 1.0 - float(w0 >> _S11) * 2.0**-53  # (0, 1]: the logarithm stays finite
    u2 = float(w1 >> _S11) * 2.0**-53
    return math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)


@register("noise")
class Noise(Block):
    """Gaussian white noise held over each period: y = mean + sigma n_k, n_k ~ N(0, 1).

    Parameters
    ----------
    sigma : float or list   standard deviation of each sample (units of y); default 1
    psd : float or list     instead of sigma: the two-sided power spectral density
                            of the band-limited white noise it approximates (units^2/Hz,
                            Simulink's "noise power"): sigma = sqrt(psd / T)
    mean : float or list    offset (units of y)
    seed : int              0 .. 2^64 - 1; the same seed gives the same sequence
                            on every path and in every process (a Monte Carlo
                            sweep varies it)
    rate, period            sample rate (Hz) or period T (s): the noise bandwidth

    Notes
    -----
    n_k of channel i is the Box-Muller transform of the Philox4x64-10 block of
    counter (k, i, 0, 0) under key (seed, 0) (numpy's ``Philox`` bit for bit),
    so sample k never depends on the samples before it or on global state.
    Example: ``psd: 0.01`` at 100 Hz has sigma = 1.
    """

    def __init__(self, name="noise", sigma=None, mean=0.0, seed=0, rate=None, period=None, width=1, psd=None):
        super().__init__(name)
        one_rate(rate, period)
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed <= _SEED_MAX:
            raise ParameterError("seed", f"must be a whole number from 0 to 2^64 - 1, got {seed!r}")
        if sigma is not None and psd is not None:
            raise ParameterError("psd", "or sigma: give one of them, not both")
        n = count(width, "width")
        self.declare_rate(period=period, rate=rate)
        if psd is not None:
            sd = np.sqrt(vector(psd, "psd", n, "nonnegative") / float(self.period))
        else:
            sd = vector(1.0 if sigma is None else sigma, "sigma", n, "nonnegative")
        self.params = NoiseParams(sd, vector(mean, "mean", n), philox_keys(seed), n)
        self.declare_discrete_state(1, bounded=False, held=True)  # k, the samples so far
        self.declare_output("y", n)


class NoiseParams(NamedTuple):
    sigma: np.ndarray  # standard deviation, units of y
    mean: np.ndarray   # offset, units of y
    keys: np.ndarray   # Philox round keys (uint64) of the seed
    n: int             # width


@kernel
def noise_output(p, t, x, u):
    y = np.empty(p.n)
    for i in range(p.n):
        y[i] = p.mean[i] + p.sigma[i] * philox_normal(p.keys, x[0], i)
    return (y,)


@kernel
def noise_update(p, t, x, u):
    return (x[0] + 1.0,)


Noise.kernels = Kernels(output=noise_output, update=noise_update)
