"""Integrators for the continuous states between sample hits.

Both solvers share one method::

    x1, xs_out = solver.advance(f, t0, t1, x0, t_out, events=None)

``f(t, x)`` is the diagram's fused right-hand side; ``t_out`` are times in
``(t0, t1)`` at which states are wanted (logging); ``events(t, x)`` returns the
zero-crossing functions of the diagram (or is None).

* :class:`RK4` - classic fixed-step Runge-Kutta. Each interval is cut into
  equal steps no longer than ``step``. Cheap per step and, with a step well
  below the ~3.7 ms period of the hand mode, neither damps nor amplifies it
  noticeably (the default 1e-4 s gives < 1e-4 relative amplitude error per
  period). Discontinuities are stepped over; their effect is checked by the
  step-convergence tests.
* :class:`ScipySolver` - ``scipy.integrate.solve_ivp`` with any of its
  methods (Radau, BDF, LSODA, RK45, DOP853, ...), relative and per-state
  absolute tolerances, and event location: integration stops at each zero
  crossing and restarts there, so a stiff method never steps across a friction
  or contact switch.
"""
import math

import numpy as np
from scipy.integrate import solve_ivp

from .errors import SimulationError

#: restarts at zero crossings allowed within one interval between sample hits
MAX_RESTARTS = 10000
#: after a crossing, that switch is re-armed this fraction of the interval later,
#: once its function is at least REARM_LEVEL away from zero
REARM = 1e-4
REARM_LEVEL = 1e-12
#: a switch located more often than this in one interval is stepped over for the rest of it
MAX_REPEATS = 20


class RK4:
    """Fixed-step classic Runge-Kutta, step <= ``step`` seconds."""

    name = "rk4"

    def __init__(self, step=1e-4):
        if not step > 0:
            raise ValueError(f"RK4 step must be positive, got {step!r}")
        self.step = float(step)

    def _span(self, f, t0, t1, x):
        n = max(1, math.ceil((t1 - t0) / self.step - 1e-9))
        h = (t1 - t0) / n
        for k in range(n):
            t = t0 + k * h
            k1 = f(t, x)
            k2 = f(t + 0.5 * h, x + (0.5 * h) * k1)
            k3 = f(t + 0.5 * h, x + (0.5 * h) * k2)
            k4 = f(t + h, x + h * k3)
            x = x + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)
        return x

    def advance(self, f, t0, t1, x, t_out=(), events=None):
        outs = []
        for tb in t_out:
            x = self._span(f, t0, tb, x)
            outs.append(x)
            t0 = tb
        if t1 > t0:
            x = self._span(f, t0, t1, x)
        return x, outs

    def __repr__(self):
        return f"RK4(step={self.step:g})"


class ScipySolver:
    """``solve_ivp`` with restarts at sample hits and at zero crossings."""

    def __init__(self, method="Radau", rtol=1e-8, atol=1e-10, max_step=np.inf):
        self.method, self.rtol, self.max_step = method, float(rtol), float(max_step)
        self.atol = atol
        self.name = method.lower()

    def advance(self, f, t0, t1, x, t_out=(), events=None):
        pending = sorted(t for t in t_out if t0 < t < t1)
        outs = []
        skip = None  # the event just located is not armed again at its own root
        stretch = REARM * (t1 - t0)
        hits, muted = {}, set()  # a switch that fires over and over (sliding along it) is muted
        for _ in range(MAX_RESTARTS):
            off = muted | ({skip} if skip is not None else set())
            funs = _event_functions(events, t0, x, off) if events is not None else None
            # the event just located stays disarmed only until its function has left
            # zero, so a quick second crossing of the same switch is not stepped over
            t_end = t1 if skip is None else min(t1, t0 + stretch)
            sol = solve_ivp(
                f, (t0, t_end), x, method=self.method, rtol=self.rtol, atol=self.atol,
                max_step=self.max_step, dense_output=bool(pending), events=funs,
            )
            if sol.status == -1:
                raise SimulationError(
                    f"solver {self.method} failed at t={sol.t[-1]:.6g} s: {sol.message}"
                )
            if sol.status == 1:  # stopped at a zero crossing
                k = next(k for k, te in enumerate(sol.t_events) if len(te))
                t_stop, x_stop = sol.t_events[k][0], sol.y_events[k][0]
                skip, stretch = funs[k].j, REARM * (t1 - t0)
                hits[skip] = hits.get(skip, 0) + 1
                if hits[skip] > MAX_REPEATS:
                    muted.add(skip)  # stepped over from here to the next sample hit
            else:
                t_stop, x_stop = t_end, sol.y[:, -1]
                if skip is not None and abs(np.asarray(events(t_stop, x_stop))[skip]) < REARM_LEVEL:
                    stretch *= 2  # still at its root: keep it disarmed a while longer
                else:
                    skip = None
            while pending and pending[0] <= t_stop:
                outs.append(sol.sol(pending.pop(0)))
            if t_stop >= t1:
                return x_stop, outs
            t0, x = t_stop, x_stop
        raise SimulationError(
            f"more than {MAX_RESTARTS} zero crossings before t={t1:.6g} s "
            "(a switch is chattering)"
        )

    def __repr__(self):
        return f"ScipySolver({self.method}, rtol={self.rtol:g})"


def _event_functions(events, t0, x0, off):
    """One terminal scipy event function per zero-crossing component not in ``off``."""
    cache = {}

    def values(t, x):
        key = (t, x.tobytes())
        if cache.get("key") != key:
            cache["key"], cache["val"] = key, np.asarray(events(t, x), float)
        return cache["val"]

    m = values(t0, x0).size
    funs = []
    for j in range(m):
        if j in off:
            continue

        def g(t, x, j=j):
            return values(t, x)[j]

        g.terminal = True
        g.j = j
        funs.append(g)
    return funs

