"""Integrators for the continuous states between sample hits.

Both solvers share one method::

    x1, xs_out = solver.advance(f, t0, t1, x0, t_out, events=None)

``f(t, x)`` is the diagram's fused right-hand side; ``t_out`` are times in
``(t0, t1)`` at which states are wanted (logging); ``events(t, x)`` returns the
zero-crossing functions of the diagram (or is None).

* :class:`RK4` (and :class:`Heun`, any :class:`ExplicitRK` tableau) -
  fixed-step explicit Runge-Kutta. Each interval between sample hits is cut
  into equal steps no longer than ``step``; log times inside a step are read
  from the method's dense output, so logging never changes the answer. RK4 is
  cheap per step and, with a step well below the ~3.7 ms period of the hand
  mode, neither damps nor amplifies it noticeably (the default 1e-4 s gives
  < 1e-4 relative amplitude error per period). Discontinuities are stepped
  over; their effect is checked by the step-convergence tests.
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


def steps(t0, t1, step):
    """Number of equal steps no longer than ``step`` from ``t0`` to ``t1``."""
    return max(1, math.ceil((t1 - t0) / step - 1e-9))


def steps_between(times, step):
    """:func:`steps` from each of ``times`` to the next (an int64 array, one shorter)."""
    return np.maximum(1, np.ceil(np.diff(times) / step - 1e-9)).astype(np.int64)


def observations(t0, h, n, t):
    """Where log times ``t`` (array) in ``[t0, t0 + n h)`` lie on the step grid.

    Returns ``(k, theta)``: the step containing each time (int64 array) and
    the fraction of it in [0, 1). A time within 1e-9 steps of a step point is
    that point (``theta = 0``), so its logged state is the integrator's own,
    bit for bit. Every path uses this one function.
    """
    t = np.asarray(t, float)
    r = (t - t0) / h
    near = np.round(r)
    at_point = (np.abs(r - near) <= 1e-9) & (near < n)
    k = np.where(at_point, near, np.minimum(np.floor(r), n - 1)).astype(np.int64)
    theta = np.where(at_point, 0.0, (t - (t0 + k * h)) / h)
    return k, theta


def observation(t0, h, n, t):
    """:func:`observations` for one time: ``(k, theta)`` as Python numbers."""
    k, theta = observations(t0, h, n, [t])
    return int(k[0]), float(theta[0])


class ExplicitRK:
    """A fixed-step explicit Runge-Kutta method given by its Butcher tableau.

    Each interval between stops (sample hits) is cut into equal steps no
    longer than ``step``; the step grid depends on the stops and ``step``
    only. States at log times inside a step come from the method's dense
    output (``dense``: per stage, the coefficients of ``b_j(theta)`` in powers
    ``theta, theta^2, ...``), so logging never changes the integration.
    A subclass gives ``name``, ``c``, ``A`` (rows of the strictly lower
    triangle), ``b`` and ``dense``; :mod:`hybridsim.rk_code` turns them into
    the step every path runs. Discontinuities inside a step are stepped over.
    """

    name = None
    c = A = b = dense = ()

    def __init__(self, step=1e-4):
        if not step > 0:
            raise ValueError(f"{self.name} step must be positive, got {step!r}")
        self.step = float(step)
        from .rk_code import vector_functions

        self._step, self._dense = vector_functions(self)

    def dense_weights(self, theta):
        """Dense-output weights ``(b_1(theta), ..., b_s(theta))``; ``theta`` a number or an array
        (then one column per stage); the same arithmetic either way."""
        cols = []
        for poly in self.dense:
            power, w = theta, poly[0] * theta
            for p in poly[1:]:
                power = power * theta
                w = w + p * power
            cols.append(w)
        if np.ndim(theta):
            return np.stack(cols, axis=-1)
        return tuple(float(w) for w in cols)

    def advance(self, f, t0, t1, x, t_out=(), events=None):
        """Integrate ``x`` from ``t0`` to ``t1``; also return the states at ``t_out``
        (``events``, zero crossings without resets, are stepped over)."""
        _, x, _, outs = self.advance_to_event(f, t0, t1, x, t_out, None, None)
        return x, outs

    def advance_to_event(self, f, t0, t1, x, t_out, g, directions, steps_with=None):
        """Like :meth:`advance`, stopping at the first located event of ``g``.

        Returns ``(t_stop, x_stop, fired, outs)``: ``fired`` (a mask over the
        functions of ``g``) is None when no event occurred and ``t_stop`` is
        ``t1``. Without an event the steps are exactly those of :meth:`advance`.
        An event is located by bisecting the step's dense output, and its state
        comes from re-stepping to it (one step of ``theta h``: the method's order)
        when that state is past the surface too. ``steps_with``: what takes the
        steps (:class:`Steps` by default; the fused path gives its generated ones).
        """
        from .events import bisect, crossed

        st = steps_with or Steps(self, f)
        n = steps(t0, t1, self.step)
        h = (t1 - t0) / n
        ks, thetas = observations(t0, h, n, t_out)
        obs = list(zip(ks.tolist(), thetas.tolist()))
        outs, j, X = [], 0, st.first(x)
        g_k = g(t0, st.array(X)) if g is not None else None
        for k in range(n):
            t = t0 + k * h
            while j < len(obs) and obs[j] == (k, 0.0):
                outs.append(st.array(X))
                j += 1
            X_next, token = st.step(t0, h, k, X)
            event = None
            if g is not None:
                g_next = g(t0 + (k + 1) * h, st.array(X_next))
                if crossed(g_k, g_next, directions).any():
                    event = bisect(g, directions, t, h, lambda th: st.dense(t0, h, k, X, token, th),
                                   g_k, st.array(X_next), g_next,
                                   restep=lambda hh: st.array(st.restep(t, hh, X)))
                g_k = g_next
            theta_stop = event[0] if event else 1.0
            while j < len(obs) and obs[j][0] == k and obs[j][1] < theta_stop:
                outs.append(st.dense(t0, h, k, X, token, obs[j][1]))
                j += 1
            if event:
                theta, x_ev, fired = event
                return (t + theta * h if theta < 1.0 else t0 + (k + 1) * h), x_ev, fired, outs
            X = X_next
        return t1, st.array(X), None, outs

    def __repr__(self):
        return f"{type(self).__name__}(step={self.step:g})"


class Steps:
    """The steps of an :class:`ExplicitRK` on numpy vectors (the generic path), as
    :meth:`ExplicitRK.advance_to_event` takes them; the fused path gives the same
    interface over its generated functions (:class:`hybridsim.fused.FusedStepper`)."""

    def __init__(self, method, f):
        self.method, self.f = method, f

    def first(self, x):
        """The state in the form the steps take (here: itself)."""
        return x

    def array(self, x):
        """A state as a numpy array (here: itself)."""
        return x

    def step(self, t0, h, k, x):
        """Step ``k`` of size ``h`` from ``t0``: ``(x_next, stages)``."""
        return self.method._step(self.f, t0 + k * h, h, x)

    def dense(self, t0, h, k, x, stages, theta):
        """The state at ``theta`` inside step ``k`` (from its stages)."""
        m = self.method
        return m._dense(x, stages, h, m.dense_weights(theta))

    def restep(self, t, hh, x):
        """One step of size ``hh`` from ``(t, x)``."""
        return self.method._step(self.f, t, hh, x)[0]


class RK4(ExplicitRK):
    """Classic fourth-order Runge-Kutta; dense output of order 3 (Hairer, Norsett & Wanner II.6)."""

    name = "rk4"
    c = (0.0, 0.5, 0.5, 1.0)
    A = ((), (0.5,), (0.0, 0.5), (0.0, 0.0, 1.0))
    b = (1 / 6, 1 / 3, 1 / 3, 1 / 6)
    dense = ((1.0, -1.5, 2 / 3), (0.0, 1.0, -2 / 3), (0.0, 1.0, -2 / 3), (0.0, -0.5, 2 / 3))


class Heun(ExplicitRK):
    """Heun's method (explicit trapezoid rule), second order; dense output of order 2."""

    name = "heun"
    c = (0.0, 1.0)
    A = ((), (1.0,))
    b = (0.5, 0.5)
    dense = ((1.0, -0.5), (0.0, 0.5))


#: the fixed-step methods by name (what ``simulation.solver`` accepts)
FIXED_STEP = {cls.name: cls for cls in (RK4, Heun)}


class ScipySolver:
    """``solve_ivp`` with restarts at sample hits and at zero crossings."""

    def __init__(self, method="Radau", rtol=1e-8, atol=1e-10, max_step=np.inf):
        self.method, self.rtol, self.max_step = method, float(rtol), float(max_step)
        self.atol = atol
        self.name = method.lower()

    def advance(self, f, t0, t1, x, t_out=(), events=None):
        """Integrate from ``t0`` to ``t1`` restarting at every zero crossing of ``events``;
        returns ``(x, states at t_out)``."""
        return self.advance_to_event(f, t0, t1, x, t_out, None, None, events)[1::2]

    def advance_to_event(self, f, t0, t1, x, t_out, g, directions, events=None):
        """Like :meth:`advance`, stopping at the first event of ``g`` (located by solve_ivp).

        Returns ``(t_stop, x_stop, fired, outs)`` as :meth:`ExplicitRK.advance_to_event`;
        ``events`` (restart-only zero crossings) restart the solver without stopping.
        """
        pending = sorted(t_out)
        outs = []
        while pending and pending[0] <= t0:  # a log time at the start (after an event): its state
            pending.pop(0)
            outs.append(np.array(x, float))
        if g is not None:
            g0 = np.asarray(g(t0, x), float)
            if (np.abs(g0) <= REARM_LEVEL).any():  # a function on its surface (just reset to 0)
                got = self._leave_surface(f, t0, t1, x, pending, outs, g, g0, directions)
                if got is not None:
                    return got
        actions = _action_functions(g, directions) if g is not None else []
        skip = None  # the event just located is not armed again at its own root
        stretch = REARM * (t1 - t0)
        hits, muted = {}, set()  # a switch that fires over and over (sliding along it) is muted
        for _ in range(MAX_RESTARTS):
            off = muted | ({skip} if skip is not None else set())
            funs = (_event_functions(events, t0, x, off) if events is not None else []) + actions
            # the event just located stays disarmed only until its function has left
            # zero, so a quick second crossing of the same switch is not stepped over
            t_end = t1 if skip is None else min(t1, t0 + stretch)
            sol = solve_ivp(
                f, (t0, t_end), x, method=self.method, rtol=self.rtol, atol=self.atol,
                max_step=self.max_step, dense_output=bool(pending), events=funs or None,
            )
            if sol.status == -1:
                raise SimulationError(
                    f"solver {self.method} failed at t={sol.t[-1]:.6g} s: {sol.message}"
                )
            if sol.status == 1:  # stopped at a zero crossing
                k = next(k for k, te in enumerate(sol.t_events) if len(te))
                t_stop, x_stop = sol.t_events[k][0], sol.y_events[k][0]
                if hasattr(funs[k], "a"):  # an event with an action: the caller takes over here
                    while pending and pending[0] <= t_stop:
                        outs.append(sol.sol(pending.pop(0)))
                    fired = np.zeros(len(actions), dtype=bool)
                    fired[funs[k].a] = True
                    return t_stop, x_stop, fired, outs
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
                return t1, x_stop, None, outs
            t0, x = t_stop, x_stop
        raise SimulationError(
            f"more than {MAX_RESTARTS} zero crossings before t={t1:.6g} s "
            "(a switch is chattering)"
        )

    def _leave_surface(self, f, t0, t1, x, pending, outs, g, g0, directions):
        """The first stretch after a start on an event surface, as a fixed-step method sees it.

        solve_ivp would find a root at ``t0`` itself and stop there for ever; instead the
        solver runs a short stretch without events, compares the functions' signs at its
        ends (as :func:`~hybridsim.events.crossed` defines a crossing) and bisects its
        dense output for the first. Returns ``(t_stop, x_stop, fired, outs)`` for an
        event in the stretch, else None (then ``x``/``t0`` are not advanced: the caller
        integrates from the start, the function now armed once it has left zero).
        """
        from .events import bisect, crossed

        t_s = min(t1, t0 + REARM * (t1 - t0))
        sol = solve_ivp(f, (t0, t_s), x, method=self.method, rtol=self.rtol, atol=self.atol,
                        max_step=self.max_step, dense_output=True)
        if sol.status == -1:
            raise SimulationError(f"solver {self.method} failed at t={sol.t[-1]:.6g} s: {sol.message}")
        g_s = np.asarray(g(t_s, sol.y[:, -1]), float)
        if not crossed(g0, g_s, directions).any():
            return None
        h = t_s - t0
        theta, x_ev, fired = bisect(g, directions, t0, h, lambda th: sol.sol(t0 + th * h), g0, sol.y[:, -1], g_s)
        t_stop = t0 + theta * h
        while pending and pending[0] < t_stop:
            outs.append(sol.sol(pending.pop(0)))
        return t_stop, x_ev, fired, outs

    def __repr__(self):
        return f"ScipySolver({self.method}, rtol={self.rtol:g})"


def _last_value(fun):
    """``fun(t, x)`` as a float array, remembered for the last (t, x): scipy asks every event
    function at the same point, and one evaluation serves them all."""
    cache = {}

    def values(t, x):
        key = (t, x.tobytes())
        if cache.get("key") != key:
            cache["key"], cache["val"] = key, np.asarray(fun(t, x), float)
        return cache["val"]

    return values


def _action_functions(g, directions):
    """One terminal scipy event function, with its direction, per function of ``g``."""
    values = _last_value(g)
    funs = []
    for a, d in enumerate(directions):
        def fun(t, x, a=a):
            return values(t, x)[a]

        fun.terminal, fun.direction, fun.a = True, float(d), a
        funs.append(fun)
    return funs


def _event_functions(events, t0, x0, off):
    """One terminal scipy event function per zero-crossing component not in ``off``."""
    values = _last_value(events)
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
