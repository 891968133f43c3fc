"""Integrators for the continuous states between sample hits.

Both solvers share one method::

    x1, xs_out = solver.advance(f, t0, t1, x0, t_out, events=None, check=None)

``f(t, x)`` is the diagram's fused right-hand side; ``t_out`` are times in
``(t0, t1)`` at which states are wanted (logging); ``check(t, x)`` the
divergence check. ``advance_to_event`` also stops at the first located event
of given event functions (see docs/events-and-solvers.md).

* :class:`RK4` (and :class:`Heun`, any :class:`ExplicitRK` tableau) -
  fixed-step explicit Runge-Kutta. Each interval between sample hits is cut
  into equal steps no longer than ``step``; log times inside a step are read
  from the method's dense output, so logging never changes the answer. RK4 is
  cheap per step and, with a step well below the ~3.7 ms period of the hand
  mode, neither damps nor amplifies it noticeably (the default 1e-4 s gives
  < 1e-4 relative amplitude error per period). Discontinuities are stepped
  over; their effect is checked by the step-convergence tests.
* :class:`ScipySolver` - scipy's ``OdeSolver`` classes (Radau, BDF, LSODA,
  RK45, RK23, DOP853) stepped one accepted step at a time, with relative and
  per-state absolute tolerances; the event functions are compared between
  accepted steps and bisected on the step's dense output, and the
  integration restarts at each event, so a stiff method never steps across a
  friction or contact switch.
"""
import math

import numpy as np
from scipy.integrate import BDF, DOP853, LSODA, RK23, RK45, Radau

from hybridsim.errors import SimulationError



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
    triangle), ``b`` and ``dense``; :mod:`hybridsim.engine.rk_code` turns them into
    the step every path runs. Discontinuities inside a step are stepped over.
    """

    name = None
    c = A = b = dense = ()

    def __init__(self, step=1e-4):
        if not step > 0:
            raise ValueError(f"{self.name} step must be positive, got {step!r}")
        self.step = float(step)
        from hybridsim.engine.rk_code import vector_functions

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

    def advance(self, f, t0, t1, x, t_out=(), events=None, check=None):
        """Integrate ``x`` from ``t0`` to ``t1``; also return the states at ``t_out``
        (``events``, zero crossings without resets, are stepped over)."""
        _, x, _, outs = self.advance_to_event(f, t0, t1, x, t_out, None, None, check=check)
        return x, outs

    def advance_to_event(self, f, t0, t1, x, t_out, g, directions, steps_with=None, check=None, step=None):
        """Like :meth:`advance`, stopping at the first located event of ``g``.

        Returns ``(t_stop, x_stop, fired, outs)``: ``fired`` (a mask over the
        functions of ``g``) is None when no event occurred and ``t_stop`` is
        ``t1``. Without an event the steps are exactly those of :meth:`advance`.
        An event is located by bisecting the step's dense output, and its state
        comes from re-stepping to it (one step of ``theta h``: the method's order)
        when that state is past the surface too. ``steps_with``: what takes the
        steps (:class:`Steps` by default; the fused path gives its generated ones).
        ``check(t, x)``: the divergence check (it raises); its ``ok(x)`` is asked about the
        last state of the stretch, and when that fails the steps are taken again (the same
        numbers) and ``check`` called after each, so it raises at the first bad step.
        ``step(t, x)``: called after every step (checked first) and at a located event; when it
        returns True the stretch ends there with ``fired`` a mask of no functions (a step event).
        """
        from hybridsim.engine.events import bisect, crossed

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
                t_ev = t + theta * h if theta < 1.0 else t0 + (k + 1) * h
                if check is not None:
                    self._check_steps(st, t0, h, k, x, X, check)
                    check(t_ev, x_ev)
                if step is not None:
                    step(t_ev, x_ev)  # its request joins the event's actions
                return t_ev, x_ev, fired, outs
            X = X_next
            if step is not None:
                t_k, x_k = t0 + (k + 1) * h, st.array(X)
                if check is not None:
                    check(t_k, x_k)
                if step(t_k, x_k):
                    return (t_k, x_k, np.zeros(len(directions) if directions is not None else 0, bool),
                            outs)
        if check is not None:
            self._check_steps(st, t0, h, n, x, X, check)
        return t1, st.array(X), None, outs

    @staticmethod
    def _check_steps(st, t0, h, n, x, X, check):
        """``check`` the state after each of the first ``n`` steps from ``x`` at ``t0`` (``X``
        after the last): when ``X`` fails ``check.ok``, the steps are taken again (the same
        numbers) so that ``check`` raises at the first bad one."""
        ok = getattr(check, "ok", lambda x: bool(np.all(np.isfinite(x))))
        if n and not ok(st.array(X)):
            X = st.first(x)
            for k in range(n):
                X = st.step(t0, h, k, X)[0]
                check(t0 + (k + 1) * h, st.array(X))

    def __repr__(self):
        return f"{type(self).__name__}(step={self.step:g})"


class Steps:
    """The steps of an :class:`ExplicitRK` on numpy vectors (the generic path), as
    :meth:`ExplicitRK.advance_to_event` takes them; the fused path gives the same
    interface over its generated functions (:class:`hybridsim.engine.fused.FusedStepper`)."""

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
    """A scipy ``OdeSolver`` (Radau, BDF, LSODA, RK45, RK23, DOP853) stepped one accepted step at
    a time, with the event functions checked between steps.

    Each interval between stops starts a fresh solver (a sample hit or an
    event restarts the integration cleanly: no step straddles it). After each
    accepted step the event functions are compared, by
    :func:`~hybridsim.engine.events.crossed`, at the step's ends and at points of its
    dense output no more than ``scan`` s apart; the first sign change is
    bisected on the dense output to :data:`~hybridsim.engine.events.TIME_TOL`. A
    change and change back between two such points is not seen.

    Parameters
    ----------
    method : str
        ``solve_ivp``'s name of the method.
    rtol, atol : float or array
        Relative and (per state) absolute tolerance.
    max_step : float
        Longest step, s (default unlimited).
    scan : float
        Longest stretch, s, between two checks of the event functions inside
        one step (default 1 ms): event functions driven by time rather than by
        the states (a relay on a sine source) do not shorten the solver's steps.
    """

    def __init__(self, method="Radau", rtol=1e-8, atol=1e-10, max_step=np.inf, scan=1e-3):
        if method not in METHODS:
            raise ValueError(f"unknown scipy method {method!r}; one of {', '.join(METHODS)}")
        if not scan > 0:
            raise ValueError(f"scan must be positive, got {scan!r}")
        self.method, self.rtol, self.max_step = method, float(rtol), float(max_step)
        self.atol, self.scan = atol, float(scan)
        self.name = method.lower()

    def advance(self, f, t0, t1, x, t_out=(), events=None, check=None):
        """Integrate from ``t0`` to ``t1``; returns ``(x, states at t_out)``. (``events``: not
        used; the simulator locates every zero crossing on these solvers.)"""
        return self.advance_to_event(f, t0, t1, x, t_out, None, None, check=check)[1::2]

    def advance_to_event(self, f, t0, t1, x, t_out, g, directions, check=None, step=None):
        """Like :meth:`ExplicitRK.advance_to_event`: ``(t_stop, x_stop, fired, outs)``.

        ``check(t, x)``: called with the state after every accepted step (it
        raises on divergence); then ``step(t, x)``, when given (True: a step event
        there, ``fired`` a mask of no functions), also at a located event.
        """
        from hybridsim.engine.events import bisect, crossed

        pending = sorted(t_out)
        outs = []
        x = np.array(x, float)
        while pending and pending[0] <= t0:  # a log time at the start (after an event): its state
            pending.pop(0)
            outs.append(x.copy())
        if t1 <= t0:
            return t1, x, None, outs
        seen = []  # the first (t, x) where the right-hand side was not finite

        def fun(t, y):
            dx = f(t, y)
            if not seen and not np.isfinite(dx).all():
                seen.append((t, np.array(y, float)))
            return dx

        # the first step at most ``scan``: scipy's starting-step heuristic reads f at t0 only, and
        # where f is zero there (a held state, an input crossing zero) it can take one step over a
        # whole half-period that its error estimate, zero at both ends, then accepts
        solver = METHODS[self.method](fun, t0, x, t1, rtol=self.rtol, atol=self.atol, max_step=self.max_step,
                                      first_step=min(self.scan, self.max_step, t1 - t0))
        g_a = np.asarray(g(t0, x), float) if g is not None else None
        while solver.status == "running":
            try:
                message = solver.step()
            except (ValueError, np.linalg.LinAlgError) as exc:  # scipy's linear algebra on NaN
                if not seen:
                    raise
                solver.status, message = "failed", str(exc)
            if solver.status == "failed":
                if seen and hasattr(check, "blame"):
                    check.blame(*seen[0])  # the block whose output was not finite, when one was
                why = f" (the right-hand side is not finite at t={seen[0][0]:.9g} s)" if seen else ""
                raise SimulationError(f"solver {self.method} failed at t={solver.t:.9g} s: {message}{why}")
            ta, tb, xb = solver.t_old, solver.t, solver.y.copy()
            dense = solver.dense_output() if (pending and pending[0] <= tb) or g is not None else None
            if g is not None:
                m = max(1, math.ceil((tb - ta) / self.scan - 1e-9))
                ts = [ta + j * (tb - ta) / m for j in range(1, m)] + [tb]
                xs = np.column_stack([dense(np.array(ts[:-1])), xb]) if m > 1 else xb[:, None]
                sa = ta
                for j, sb in enumerate(ts):
                    g_b = np.asarray(g(sb, xs[:, j]), float)
                    if crossed(g_a, g_b, directions).any():
                        h = sb - sa
                        theta, x_ev, fired = bisect(g, directions, sa, h, lambda th: dense(sa + th * h),
                                                    g_a, xs[:, j], g_b)
                        t_ev = float(sb if theta >= 1.0 else sa + theta * h)
                        self._observe(pending, outs, dense, t_ev, None, inclusive=False)
                        if check is not None:
                            check(t_ev, x_ev)
                        if step is not None:
                            step(t_ev, np.array(x_ev, float))  # its request joins the event's actions
                        return t_ev, np.array(x_ev, float), fired, outs
                    g_a, sa = g_b, sb
            if check is not None:
                check(tb, xb)
            self._observe(pending, outs, dense, tb, xb)
            if step is not None and step(tb, xb):
                return tb, xb, np.zeros(len(directions) if directions is not None else 0, bool), outs
        return t1, solver.y.copy(), None, outs

    @staticmethod
    def _observe(pending, outs, dense, t, x, inclusive=True):
        """Move the log times up to ``t`` (and at ``t`` when ``inclusive``: the state ``x``) from
        ``pending`` to ``outs``, their states from one call of the step's dense output."""
        k = 0
        while k < len(pending) and (pending[k] < t or inclusive and pending[k] == t):
            k += 1
        if not k:
            return
        times, pending[:k] = pending[:k], []
        at_end = inclusive and times[-1] == t
        inner = times[:-1] if at_end else times
        if inner:
            outs += list(dense(np.array(inner)).T)
        if at_end:
            outs.append(x.copy())

    def __repr__(self):
        return f"ScipySolver({self.method}, rtol={self.rtol:g})"


#: scipy's solvers by the name ``solve_ivp`` gives them
METHODS = {"Radau": Radau, "BDF": BDF, "LSODA": LSODA, "RK45": RK45, "RK23": RK23, "DOP853": DOP853}
