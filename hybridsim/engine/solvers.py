"""Integrators for the continuous states between sample hits: each one small class.

A solver says how steps are taken; the stepping core (:mod:`.stepping`) does
the rest the same way for all of them: event location on the step's dense
output, log points from it, divergence checks, restarts at hits and events.
``solver.stepper()`` gives the core its :class:`~.stepping.Ops` and state.

* :class:`RK4` (and :class:`Heun`, any :class:`ExplicitRK` tableau) -
  fixed-step explicit Runge-Kutta. Each interval between stops is cut into
  equal steps no longer than ``step``; log times inside a step are read from
  the method's dense output, so logging never changes the answer. With a step
  well below the period of a plant's fastest mode RK4 neither damps nor
  amplifies it noticeably (a step of 1/37 of the period gives < 1e-4 relative
  amplitude error per period). Runs on every path; the compiled path compiles
  its steps.
* :class:`ScipySolver` - scipy's ``OdeSolver`` classes (Radau, BDF, LSODA,
  RK45, RK23, DOP853) one accepted step at a time, with relative and
  per-state absolute tolerances; each interval starts a fresh solver (a hit
  or an event restarts the integration: no step straddles it).
* :class:`~hybridsim.engine.cvode.CVode` - SUNDIALS' BDF, for stiff plants
  and Model Exchange FMUs.

``solver.advance(f, t0, t1, x, t_out)`` integrates ``x' = f(t, x)`` alone
with the same core (a system of one block).
"""
import math

import warnings

import numpy as np
from scipy.integrate import BDF, DOP853, LSODA, RK23, RK45, Radau
from scipy.linalg.lapack import dgetrf, dgetrs, zgetrf, zgetrs
from scipy.sparse import issparse

from hybridsim.engine import rk, stepping
from hybridsim.engine.finite import all_finite
from hybridsim.errors import ParameterError


def steps(t0, t1, step):
    """Number of equal steps no longer than ``step`` from ``t0`` to ``t1``."""
    return max(1, math.ceil((t1 - t0) / step - 1e-9))


class Solver:
    """What every solver shares: the standalone :meth:`advance`."""

    def stepper(self):
        """``(ops, state)`` for the stepping core (:class:`~.stepping.Ops` of plain functions)."""
        raise NotImplementedError

    def advance(self, f, t0, t1, x, t_out=(), events=None):
        """Integrate ``x' = f(t, x)`` from ``t0`` to ``t1``; returns ``(x(t1), [x at t_out])``.

        ``f`` returns the derivatives as a sequence; ``t_out`` are times in
        ``[t0, t1)`` (s). ``events(t, x)``, when given, are switch functions: each
        sign change is located and the integration restarts there (no step straddles
        it). A state that is not finite, or a failing solver, raises
        :class:`~hybridsim.errors.SimulationError`.
        """
        from hybridsim.engine.events import MAX_REPEATS
        from hybridsim.engine.timeline import build
        from hybridsim.errors import SimulationError

        t_out = sorted(float(t) for t in t_out)
        tl = build([t0] + t_out, [True] + [False] * len(t_out), np.zeros((1 + len(t_out), 0), bool),
                   [False] + [True] * len(t_out), t1)
        x = np.array(x, float)
        seen = []

        def rhs(t, xx, dx, at, y, z, pf, pi):
            dx[at:at + xx.size] = f(t, xx)

        def zc(t, xx, g, y, z, pf, pi):
            g[:] = events(t, xx)

        def act(t, xx, xn, fired, y, z, pf, pi):
            xn[:] = xx  # a switch: the integration restarts, the state is kept
            return stepping.GO

        def observe(t, xx, y, z, pf, pi):
            seen.append(np.array(xx, float))
            return -1

        nothing = lambda *a: -1  # noqa: E731
        glue = stepping.Glue(nothing, nothing, rhs, zc, act, observe, None, None, None)
        ops, s = self.stepper()
        e = np.atleast_1d(events(t0, x)).size if events is not None else 0
        w = work(x.size, getattr(s, "c", np.zeros(1)).size, e, switch=np.ones(e, bool))
        w.x[:] = x
        out = outputs(0, 0, 1000 if e else 0, 1)
        fixed = isinstance(self, ExplicitRK)
        lim = limits(np.inf, stepped=False, timed=False, scan=getattr(self, "scan", 1e-3),
                     batch=(fixed and not e) or getattr(self, "returns_points", False),
                     max_repeats=0 if fixed else MAX_REPEATS,
                     crawl=not fixed and not getattr(self, "returns_points", False))
        code = stepping.run(tl, 0, len(tl.t), glue, ops, s, lim, w, out, np.zeros(0), np.zeros(0), np.zeros(0),
                            np.zeros(0, np.int64))
        if code == stepping.DIVERGED:
            raise SimulationError(f"the state is not finite at t={out.tfail[0]:.9g} s")
        if code in (stepping.CRAWLING, stepping.SLIDING):
            raise SimulationError(f"the {self.name} steps shrank to nothing at t={out.tfail[0]:.9g} s: the system "
                                  "is stiff there, or its right-hand side jumps (a sliding mode)")
        if code != stepping.OK:
            raise SimulationError(getattr(s, "message", None) or f"integration failed (status {code})")
        return w.x.copy(), seen


def positive(name, value, inf=False):
    """``value`` as a float > 0 (and finite unless ``inf``); ParameterError naming the setting ``name``."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if isinstance(value, (bool, np.bool_)) or not (v > 0 and (inf or math.isfinite(v))):
        raise ParameterError(name, f"must be a positive{'' if inf else ', finite'} number of the solver, "
                                   f"got {value!r}")
    return v


def tolerance(name, value):
    """An absolute tolerance: one positive number, or one per state (an array of them)."""
    try:
        a = np.asarray(value, float)
    except (TypeError, ValueError):
        a = np.array([math.nan])
    if a.ndim > 1 or not a.size or isinstance(value, (bool, str)) or not np.all((a > 0) & np.isfinite(a)):
        raise ParameterError(name, f"must be a positive number or a list of them (one per state), got {value!r}")
    return value


class ExplicitRK(Solver):
    """A fixed-step explicit Runge-Kutta method given by its Butcher tableau.

    A subclass gives ``name``, ``c``, ``A`` (rows of the strictly lower
    triangle), ``b`` and ``dense`` (per stage, the coefficients of
    ``b_j(theta)`` in powers ``theta, theta^2, ...``); :mod:`hybridsim.engine.rk`
    takes the steps on arrays and :mod:`hybridsim.engine.rk_code` writes them out
    for the fused path, the same arithmetic. Discontinuities inside a step are
    stepped over unless located as events. ``step`` (s); ``scan`` (s): the longest
    stretch between two checks of the event functions inside one step.
    """

    name = None
    c = A = b = dense = ()
    #: a fixed step grid: switches without actions are stepped over unless asked to be located
    fixed_step = True

    def __init__(self, step=1e-4, scan=1e-3):
        self.step, self.scan = positive("step", step), positive("scan", scan)

    def dense_weights(self, theta):
        """Dense-output weights ``(b_1(theta), ..., b_s(theta))``; ``theta`` a number or an array
        (then one column per stage); the same arithmetic as the core's."""
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

    def stepper(self):
        """The Runge-Kutta steps on arrays (:mod:`hybridsim.engine.rk`), as plain functions."""
        return rk.ops(type(self)), rk.rk_state(self)

    def __repr__(self):
        return f"{type(self).__name__}(step={self.step:g})"


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


class ScipySolver(Solver):
    """A scipy ``OdeSolver`` (Radau, BDF, LSODA, RK45, RK23, DOP853), one accepted step at a time.

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
        Each integration's first step is at most this long too: scipy's
        starting-step heuristic reads f at the start only, and where f is zero
        there (a held state) it could step over a whole half-period.
    """

    def __init__(self, method="Radau", rtol=1e-8, atol=1e-10, max_step=np.inf, scan=1e-3):
        if method not in METHODS:
            raise ValueError(f"unknown scipy method {method!r}; one of {', '.join(METHODS)}")
        self.method, self.rtol, self.max_step = method, positive("rtol", rtol), positive("max_step", max_step, inf=True)
        self.atol, self.scan = tolerance("atol", atol), positive("scan", scan)
        self.name = method.lower()

    def stepper(self):
        """A fresh scipy solver per integration, stepped by the core."""
        return scipy_ops(), ScipyStepper(self)

    def __repr__(self):
        return f"ScipySolver({self.method}, rtol={self.rtol:g})"


#: the multistep methods whose integrations restart at order 1 (a first step of the size the last
#: integration reached at a higher order would be too long for them)
RESTART_AT_ORDER_1 = ("BDF", "LSODA")

#: scipy's solvers by the name ``solve_ivp`` gives them
METHODS = {"Radau": Radau, "BDF": BDF, "LSODA": LSODA, "RK45": RK45, "RK23": RK23, "DOP853": DOP853}


class NotFinite(ArithmeticError):
    """A right-hand side that is not finite: it ends the integration (a solver's step fails)."""

    def __init__(self, t):
        super().__init__(f"the right-hand side is not finite at t={t:.9g} s")


class ScipyStepper:
    """Where a :class:`ScipySolver` is: its ``OdeSolver`` of the current integration."""

    def __init__(self, solver):
        self.solver, self.num = solver, np.zeros(8)
        self.h_next = np.inf  # the step the last integration would have taken next, s
        self.ode = self.interp = self.logged = None
        self.times = np.zeros(0)
        self.message = self.seen = self.raised = None

    def start(self, rhs, y, z, pf, pi):
        s = self.solver
        n = self.x0.size
        seen = []

        def fun(t, xx):
            dx = np.empty(n)
            try:
                rhs(t, xx, dx, 0, y, z, pf, pi)
            except Exception as exc:  # a block's own error: raised as it is, not taken for the solver's
                self.raised = exc
                raise
            if not all_finite(dx):  # ends the run: the solvers shrink their steps to nothing
                seen.append((t, np.array(xx, float)))  # on it, or integrate infinities, or hang (LSODA)
                raise NotFinite(t)
            return dx

        self.seen = seen
        self.ode = METHODS[s.method](fun, self.t0, self.x0, self.t1, rtol=s.rtol, atol=s.atol,
                                     max_step=s.max_step,
                                     first_step=min(s.scan, s.max_step, self.h_next, self.t1 - self.t0))
        if hasattr(self.ode, "solve_lu") and not issparse(self.ode.J):
            direct_lu(self.ode)


def fresh_jacobian(ode):
    """Radau's or BDF's Jacobian evaluated again where the integration is. While a switch is muted
    the right-hand side jumps across it; a Jacobian differenced across the jump (a state resting on
    it) is huge and makes the Newton increments vanish, so that step after step is accepted on the
    predictor alone, and scipy re-evaluates a Jacobian only when Newton fails."""
    if hasattr(ode, "LU_real"):  # Radau (its differencing takes the right-hand side there)
        ode.J = ode.jac(ode.t, ode.y, ode.f)
        ode.LU_real = ode.LU_complex = None
        ode.current_jac = True
    else:
        ode.J = ode.jac(ode.t, ode.y)
        ode.LU = None


def direct_lu(ode):
    """Radau's and BDF's dense LU factorisation and solve as LAPACK's getrf / getrs themselves:
    ``scipy.linalg.lu_solve`` checks its arguments' array namespace and device on every call,
    which for a plant of a few states costs more than the solve, at every Newton iteration.
    A matrix that is not finite fails the step as ``lu_factor`` does (ValueError). Not kept:
    scipy's warning for a singular matrix and its check of the right-hand side (a solve that is
    not finite makes the next right-hand side evaluation fail the run, as before)."""
    def lu(a):
        ode.nlu += 1
        if not np.isfinite(a).all():
            raise ValueError("array must not contain infs or NaNs")
        complex_ = a.dtype.kind == "c"
        lu_, piv, _ = (zgetrf if complex_ else dgetrf)(a, overwrite_a=True)
        return lu_, piv, zgetrs if complex_ else dgetrs

    def solve_lu(factors, b):
        lu_, piv, getrs = factors
        return getrs(lu_, piv, b, overwrite_b=True)[0]

    ode.lu, ode.solve_lu = lu, solve_lu


def scipy_ops():
    """The :class:`~.stepping.Ops` of :class:`ScipyStepper`."""

    def begin(s, t0, t1, x, times, j, j1):
        s.t0, s.t1, s.x0, s.ode = t0, t1, np.array(x, float), None
        s.times = times[j:j1]  # the log times ahead: dense output evaluates a step's at once

    def step(s, x, xn, w, gl, y, z, pf, pi):
        try:
            if s.ode is None:
                s.start(gl.rhs, y, z, pf, pi)
            ode = s.ode
            if w.muted.any() and getattr(ode, "jac", None) is not None and hasattr(ode, "J"):
                fresh_jacobian(ode)
            if s.solver.method == "LSODA":  # it says why it failed only as a warning: kept for the message
                with warnings.catch_warnings(record=True) as said:
                    warnings.simplefilter("always")
                    message = ode.step()
            else:  # (not around every step of the others: a per-step cost, and global state)
                said, message = None, ode.step()
            if said and ode.status == "failed":
                reasons = "; ".join(str(m.message).strip().rstrip(".") for m in said)
                message = f"{message} ({reasons})"
            failed = ode.status == "failed"
            if ode.status == "running" and not ode.t - ode.t_old > 10 * np.spacing(abs(ode.t_old)):
                # LSODA on tolerances float64 cannot meet takes steps of 0 s for ever
                failed, message = True, "required step size is less than spacing between numbers"
        except NotFinite as exc:
            failed, message = True, str(exc)
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:  # scipy's linear algebra on
            if exc is s.raised:  # NaN or on numbers that overflow in its Jacobian (a huge but finite rhs)
                raise
            failed, message = True, str(exc)
        if failed:
            t_at = s.seen[0][0] if s.seen else s.ode.t
            s.message = f"solver {s.solver.method} failed at t={t_at:.9g} s: {message}"
            if "spacing between numbers" in str(message):
                atol = ", ".join(f"{v:g}" for v in np.ravel(s.solver.atol))
                s.message += (f" (rtol {s.solver.rtol:g}, atol {atol}: float64 holds about 16 digits; "
                              "loosen them, or look for a discontinuity at that time)")
            return np.nan
        xn[:] = ode.y
        s.num[1] = ode.t - ode.t_old
        s.interp = s.logged = None
        # an integration restarted at a hit or an event goes on with the step it had (scipy's Radau
        # judges its first step by a weaker error estimate: a 1 ms first step after a PID left its
        # limit was accepted 5e-5 wrong); not BDF and LSODA, which restart at order 1. Only a step the
        # stop did not cut short says so (the last one, cut to end at a hit, may be 1e-15 s)
        if s.solver.method not in RESTART_AT_ORDER_1 and ode.t < ode.t_bound:
            h = getattr(ode, "h_abs", None)
            s.h_next = h if h is not None and h > 0.0 else np.inf
        return ode.t

    def steps(s, t_lim, x, xn, w, gl, y, z, pf, pi):
        return step(s, x, xn, w, gl, y, z, pf, pi)

    def dense(s, t, x, w, xo):
        if s.interp is None:
            s.interp = s.ode.dense_output()
            a, b = np.searchsorted(s.times, (s.ode.t_old, s.ode.t), side="right")
            ts = s.times[a:b][s.times[a:b] < s.ode.t]  # inside the step (a search: the run's may be long)
            # the step's log points in one call (one call per point cost a third of a run)
            s.logged = dict(zip(ts.tolist(), s.interp(ts).T)) if ts.size > 1 else {}
        got = s.logged.get(t)
        xo[:] = got if got is not None else s.interp(t)

    def restep(s, hh, x, w, gl, y, z, pf, pi, xr):
        return False

    def rewind(s):
        return False

    return stepping.Ops(begin, step, steps, dense, restep, rewind)


# -- the core's buffers ---------------------------------------------------------------------
def work(n, s, e, dirs=None, switch=None, owner=None, zb=None, xb=None):
    """The :class:`~.stepping.Work` buffers of a run: ``n`` states, ``s`` stages, ``e`` located
    event functions (their directions, which are switches, which located block owns each), and
    which discrete and continuous states ``max_state`` bounds (``zb``, ``xb``; default: all)."""
    f = lambda *shape: np.zeros(shape)  # noqa: E731
    s = max(s, 1)
    return stepping.Work(
        f(n), f(n), f(n), f(n), f(n), f(n), f(s * n), f(s * n), f(n), f(s), f(e), f(e), f(e), f(e), f(e),
        np.full(e, np.nan), np.zeros(e, np.bool_),
        np.zeros(e, np.int64) if dirs is None else np.asarray(dirs, np.int64),
        np.zeros(e, np.bool_) if switch is None else np.asarray(switch, np.bool_),
        np.zeros(e, np.bool_), np.zeros(e, np.int64),
        np.zeros(e, np.int64) if owner is None else np.asarray(owner, np.int64),
        np.zeros(0, np.bool_) if zb is None else np.asarray(zb, np.bool_),
        np.ones(n, np.bool_) if xb is None else np.asarray(xb, np.bool_))


def outputs(rows, cols, cap, blocks, columns=None):
    """The :class:`~.stepping.Out` of a run: ``rows`` x ``cols`` log (``columns``: the elements of
    the wire vector each copies), room for ``cap`` events over ``blocks`` located blocks."""
    return stepping.Out(np.zeros((rows, cols)),
                        np.zeros(cols, np.int64) if columns is None else np.asarray(columns, np.int64),
                        np.zeros(1, np.int64), np.zeros(cap), np.zeros((cap, max(blocks, 1)), np.bool_),
                        np.zeros(1, np.int64), np.zeros(3, np.int64), np.zeros(1))


def limits(max_state, time_tol=None, scan=1e-3, stepped=False, timed=False, batch=False, max_repeats=0,
           crawl=False):
    """The :class:`~.stepping.Limits` of a run (the event policies from :mod:`.events`); ``crawl``: stop a
    run whose steps shrink to nothing (a solver whose every step the core sees)."""
    from hybridsim.engine import events as ev

    return stepping.Limits(float(max_state), float(ev.TIME_TOL if time_tol is None else time_tol), float(scan),
                           int(ev.MAX_EVENTS), int(ev.MAX_STALLS), int(ev.MAX_ITERATIONS), int(max_repeats),
                           int(ev.SLIDE_STEPS), float(ev.SLIDE_STEP), int(ev.CRAWL_STEPS) if crawl else 0,
                           bool(timed), bool(stepped), bool(batch))
