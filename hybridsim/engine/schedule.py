"""Multi-rate sample hits on an integer tick grid.

Every sample period is an exact :class:`fractions.Fraction`. The base tick is
their greatest common divisor; a block with period ``p`` and offset ``o``
(both whole multiples of the base tick) is due at tick ``n`` when
``n >= o`` and ``(n - o) % p == 0``. Time is ``n * base`` computed from
integers, never accumulated, so coincident hits of different rates coincide
exactly however long the run.
"""
from fractions import Fraction
from math import gcd

import numpy as np

from hybridsim.errors import RateError

#: most base ticks the shortest period may span before rates count as incommensurate
MAX_TICKS_PER_PERIOD = 10**4


def fraction_gcd(a, b):
    """Greatest common divisor of two positive Fractions."""
    return Fraction(gcd(a.numerator * b.denominator, b.numerator * a.denominator),
                    a.denominator * b.denominator)


class Schedule:
    """Sample hits of a set of (period, offset) pairs on one tick grid."""

    def __init__(self, timings, names=None):
        self.timings = list(timings)
        names = names or [str(i) for i in range(len(self.timings))]
        base = None
        for period, offset in self.timings:
            for v in (period, offset):
                if v:
                    base = v if base is None else fraction_gcd(base, v)
        self.base = base if base is not None else Fraction(1)
        self.ticks = [(int(p / self.base), int(o / self.base)) for p, o in self.timings]
        if self.ticks:
            k = min(range(len(self.ticks)), key=lambda i: self.ticks[i][0])
            if self.ticks[k][0] > MAX_TICKS_PER_PERIOD:
                listing = ", ".join(f"{n} {float(1 / p):.6g} Hz" for (p, _), n in zip(self.timings, names))
                raise RateError(
                    f"sample rates are not commensurate ({listing}): their common base tick "
                    f"would be {float(self.base):.3g} s, {self.ticks[k][0]} ticks per period of "
                    f"{names[k]!r}; choose rates with a small common multiple (e.g. 60, 80, 120 Hz)"
                )

    def time(self, n):
        """Exact time of tick ``n`` as a float (one rounding); ``n`` may be an int array. A base tick
        whose numerator times ``n`` would pass int64 (a period of 1e300 s) costs one more rounding."""
        num, den = self.base.numerator, self.base.denominator
        top = int(np.max(np.abs(n))) if np.size(n) else 0
        if max(num, den, top * num) < 2**63:
            return n * num / den
        return np.asarray(n, float) * (num / den)

    def hits(self, n_last):
        """Every tick up to ``n_last`` at which anything is due (tick 0 always).

        Returns ``(n, due)``: the ticks (int64 array, increasing) and a
        boolean array ``due[k, i]``, timing ``i`` due at tick ``n[k]``.
        """
        # a period or offset beyond n_last acts as n_last + 1 (due at most once): int64 holds it
        cap = max(n_last, 0) + 1
        ticks = [(min(p, cap), min(o, cap)) for p, o in self.ticks]
        parts = [np.zeros(1, dtype=np.int64)]
        parts += [np.arange(o, n_last + 1, p, dtype=np.int64) for p, o in ticks if o <= n_last]
        n = np.unique(np.concatenate(parts))
        due = np.zeros((n.size, len(ticks)), dtype=bool)
        for i, (p, o) in enumerate(ticks):
            due[:, i] = (n >= o) & ((n - o) % p == 0)
        return n, due

    def due(self, n):
        """Indices of the timings due at tick ``n``."""
        return [i for i, (p, o) in enumerate(self.ticks) if n >= o and (n - o) % p == 0]

    def last_tick_before(self, t_end):
        """Largest n with ``time(n) < t_end``.

        An end time within 1e-9 of a tick (relative to the tick or the end time, the smaller)
        counts as that tick (so ``0.01`` s, which is not exactly 1/100 in binary, ends before the
        tick at 1/100).
        """
        t = Fraction(t_end)
        k = round(t / self.base)
        if abs(k * self.base - t) <= Fraction(1, 10**9) * min(self.base, t):
            return k - 1
        n = int(t / self.base)
        if n * self.base >= t:
            n -= 1
        return n
