"""CVODE as the stepping core's stepper (:class:`~hybridsim.engine.stepping.Ops`).

Between two stops one CVODE integration runs (a sample hit or an event
restarts it, at order 1). Its accepted steps, as the core sees them, are the
points CVODE returns: the log times ahead (from its own interpolant, so
logging does not change the steps it takes), a crossing of a located event
function (found by SUNDIALS' root finding, reported to the core with the
functions that fired) and the stop. Without blocks that want every step
(``after_step``) a whole stretch is one scikit-sundae ``solve`` call, with no
Python between its log times.
"""
import contextlib
import io
import os
import re
import sys

import numpy as np

from hybridsim.engine import stepping
from hybridsim.engine.finite import all_finite
from hybridsim.engine.solvers import NotFinite

#: internal steps CVODE may take between two returned points
MAX_STEPS = 1_000_000
#: the same where a located switch has no action: a state sliding along it (a sliding mode) makes
#: CVODE crawl at steps of nanoseconds, and the run fails in a second rather than a minute
SWITCH_STEPS = 20_000
#: restarts at a switch's surface reached but not crossed, each within REACHED_GAP s (relative past
#: t = 1 s) of the one before, after which the switch is muted for the rest of the interval
REACHED_RESTARTS = 20
REACHED_GAP = 1e-9


class CVodeStepper:
    """Where a :class:`~hybridsim.engine.cvode.CVode` is: the current integration and what it
    returned that the core has not taken yet. ``message``: why it failed; ``seen``: the first
    (t, x) where the right-hand side was not finite."""

    def __init__(self, solver):
        self.solver, self.num = solver, np.zeros(8)
        self.cv = None
        self.queue = []
        self.failed, self.message, self.seen = [], None, None
        self.event_at = self.event_x = None  # the last crossing CVODE returned, and the state there
        self.event_fired = self.before_fired = None  # the functions that fired there; and for ``before``
        self.moved = None  # the event functions off 0 at some point since the integration started
        self.extra = np.zeros(0, np.int64)  # the functions on 0 at the start searched as g -+ OFF_ZERO

    def start(self, w, gl, y, z, pf, pi):
        """A fresh CVODE for (t0, x0) with the glue's right-hand side and event functions."""
        from sksundae.cvode import CVODE

        s, e = self.solver, w.g.size
        failed, seen = self.failed, []
        muting = bool(w.muted.any())  # switches are muted at events, and each event starts a new CVODE
        # a function exactly on 0 here that is not there after its own event (a dead zone's output):
        # CVODE leaves it out of its search till it is off 0, and would not report it leaving; g - eps
        # (rising) and g + eps (falling), never 0, are searched in its place to find where it leaves
        g0 = _zc(self.t0, self.x0, np.empty(e), w, gl, y, z, pf, pi) if e else np.ones(0)
        flat = (g0 == 0.0) & ~(np.zeros(e, bool) if self.before_fired is None else np.asarray(self.before_fired, bool))
        up, down = np.flatnonzero(flat & (w.dirs >= 0)), np.flatnonzero(flat & (w.dirs <= 0))
        self.extra = np.concatenate((up, down))
        shift = np.concatenate((np.full(up.size, -OFF_ZERO), np.full(down.size, OFF_ZERO)))

        def rhs(t, xx, dx):
            if failed:
                dx.fill(np.nan)
                return
            try:
                gl.rhs(t, xx, dx, 0, y, z, pf, pi)
            except Exception as exc:  # noqa: BLE001 - raised again after CVODE returns
                failed.append(exc)
                dx.fill(np.nan)
                return
            if not all_finite(dx):  # ends the run, as on scipy's solvers (NotFinite)
                seen.append((t, np.array(xx, float)))
                failed.append(NotFinite(t))

        def roots(t, xx, out):
            if failed:
                out.fill(np.nan)
                return
            g = out[:e]
            try:
                gl.zc(t, xx, g, y, z, pf, pi)
            except Exception as exc:  # noqa: BLE001 - as in rhs
                failed.append(exc)
                out.fill(np.nan)
                return
            if muting:
                stepping.mute(g, w.muted)
            if shift.size:
                out[e:] = g[self.extra] + shift

        longest = min(s.max_step, s.scan) if e else s.max_step  # roots are looked for at step ends only
        # a step that cannot move t (a few of its float spacings) fails at once, as scipy's solvers do,
        # instead of crawling to max_num_steps (a singularity: 1/(t - 0.5) took 77 s to fail)
        tiny = 4.0 * np.spacing(max(abs(self.t0), abs(self.t1), 1.0))
        opts = dict(method=s.method, rtol=s.rtol, atol=s.atol,
                    max_step=longest if np.isfinite(longest) else np.finfo(float).max,  # (0 is refused with a min)
                    max_num_steps=SWITCH_STEPS if w.switch.any() else MAX_STEPS, min_step=tiny)
        if e:
            n = e + shift.size
            roots.terminal = [True] * n
            roots.direction = [int(d) for d in w.dirs] + [1] * up.size + [-1] * down.size
            opts.update(eventsfn=roots, num_events=n)
        self.seen = seen
        self.cv = CVODE(rhs, **opts)

    def fired(self, res, e):
        """The ``e`` functions whose root ``res`` reports (one searched in a function's place for it)."""
        found = np.asarray(res.i_events, float).reshape(-1, e + self.extra.size)[-1] != 0
        root = found[:e].copy()
        root[self.extra[found[e:]]] = True
        return root

    def result(self, res, t_start):
        """Whether ``res`` failed (then ``message`` says why); a callback's exception is raised."""
        if self.failed and isinstance(self.failed[0], NotFinite):
            self.message = f"solver cvode failed at t={self.seen[0][0]:.9g} s: {self.failed.pop(0)}"
            return False
        if self.failed:
            raise self.failed.pop(0)
        if res.status < 0:
            self.message = (f"solver cvode failed after t={t_start:.6g} s: {res.message}"
                            + (f" (SUNDIALS: {self.said})" if self.said else "")
                            + (f" (the right-hand side is not finite at t={self.seen[0][0]:.9g} s)"
                               if self.seen else ""))
            return False
        return True


def start_crossing(s, w, gl, y, z, pf, pi):
    """A function exactly on its surface where an integration starts that leaves to its firing
    side crosses there: the core's rule (leaving zero fires), which the RK and scipy paths
    locate about 1e-12 s on. CVODE skips such a root (a relay whose input starts at its
    threshold would never switch), so it is reported here: ``(t, x, fired)`` of the point one
    ``START_STEP`` on, or None. A function that crossed just now and goes on as it did, untouched
    by the event's action (a ``hit_crossing`` after its own event), is not crossing again; one
    whose motion the action changed (a ball that the bounce left at rest on the floor, gravity
    pulling it through) is."""
    g0 = w.g
    on = g0 == 0.0
    if not on.any():
        return None
    change, t1, x1 = _rates(s.t0, s.x0, g0, w, gl, y, z, pf, pi, START_STEP)
    # the core's rule over the step, for every function: one just short of its surface that crosses
    # within it (a timer at 0.5 - 3e-16 when a clock's relay fires at 0.5) would be past it at the
    # next start, where CVODE would not see it
    fired = np.zeros(g0.size, np.bool_)
    stepping.crossed_any(g0, g0 + change, w.dirs, fired)
    if not (fired & on).any():
        return None
    if s.before is not None:  # on its surface, crossed just now, going on as it did: not again (only
        # a function that fired in that event: another one reaching its surface at the same instant
        # crosses now)
        before = _rates(s.t0, s.before, None, w, gl, y, z, pf, pi, START_STEP)[0]
        fired &= ~(on & s.before_fired & np.isclose(before, change, rtol=1e-9, atol=0.0))
    return (t1, x1, fired) if fired.any() else None


def leaving_sides(s, xn, w, gl, y, z, pf, pi):
    """Before the core checks the first point from a start: each event function that sits on its
    surface at the start gets, in ``w.g``, the side it leaves to, from its rate there. One that
    leaves to one side and is on the other at the point crossed back inside the step,
    unreported (CVODE skips roots where a function starts on zero), so the core stops; so did one
    flat at the start (zero rate: a dead zone's output) and off its surface at the point, unless it
    sits there after its own event (an FMU's indicator)."""
    g0, gn = w.g, np.empty_like(w.g)
    on = np.flatnonzero(np.abs(g0) <= 1e-9 * np.abs(_zc(s.ta, xn, gn, w, gl, y, z, pf, pi)))
    if not on.size:
        return
    after = np.sign(_rates(s.t0, s.x0, g0, w, gl, y, z, pf, pi)[0])
    own = _own(s, g0.size)
    for i in on:
        if after[i] == 0.0 and gn[i] != 0.0 and not own[i]:  # flat at the start (a dead zone's output),
            g0[i] = -gn[i]  # off its surface by the point: it left unreported, which the core stops at
        else:
            g0[i] = gn[i] if after[i] == 0.0 or gn[i] == 0.0 else after[i] * abs(gn[i])


def left_zero(s, t, xn, w, gl, y, z, pf, pi):
    """A function without a direction that sat exactly on 0 (not after its own event, as an FMU's
    indicator does) and is off it at point ``t``: it crossed there (the core's rule: leaving 0
    fires), which CVODE, skipping a root that starts on zero, did not report. In ``w.g`` it reads
    as having come from the other side, so the core stops at the crossing it cannot locate."""
    here = _zc(t, xn, np.empty(w.g.size), w, gl, y, z, pf, pi)
    left = (w.g == 0.0) & (w.dirs == 0) & (here != 0.0) & ~_own(s, w.g.size)
    w.g[left] = -here[left]


def left_with(s, t, xn, here, root, w, gl, y, z, pf, pi):
    """At a root CVODE reported at ``t``: the functions that sat exactly on 0 at the last point and
    are off it to their firing side at ``t`` (``here``). One still on 0 just before ``t`` left at
    ``t`` (a dead zone's output leaving its zone at the instant another function crosses): it fires
    with the root, returned. One that left earlier in the step (CVODE skips roots that start on
    zero) makes it None: the core, looking, stops at a crossing it cannot locate (:func:`left_zero`)."""
    fires = np.zeros(root.size, np.bool_)
    stepping.crossed_any(np.zeros(root.size), here, w.dirs, fires)
    left = fires & (w.g == 0.0) & ~root & ~_own(s, root.size)
    if not left.any():
        return root
    before = here + _rates(t, xn, here, w, gl, y, z, pf, pi, -LEAVE_STEP)[0]
    if (before[left] == 0.0).all():
        return root | left
    w.g[left] = -here[left]
    return None


def _own(s, n):
    """The functions that fired in the event this integration started from and sat exactly on 0
    there (an FMU's indicator after its own event); not one that has left 0 and come back since."""
    if s.before_fired is None or s.moved is None:
        return np.zeros(n, np.bool_)
    return np.asarray(s.before_fired, bool) & ~s.moved


def _rates(t, x, g, w, gl, y, z, pf, pi, step=None):
    """``(changes, t + dt, x(t + dt))``: how the event functions change over a step ``dt``
    (``step``, default ``LEAVE_STEP``, relative past t = 1 s) from (t, x), by the midpoint rule
    (second order: a function with zero rate still shows where its curvature takes it, as a ball
    at rest on the floor with gravity pulling it through); ``g``: their values at (t, x) when
    known. NaN changes read as 0."""
    if g is None:
        g = _zc(t, x, np.empty(w.g.size), w, gl, y, z, pf, pi)
    dt = (LEAVE_STEP if step is None else step) * max(1.0, abs(t))
    dx = np.empty(x.size)
    gl.rhs(t, x, dx, 0, y, z, pf, pi)
    gl.rhs(t + 0.5 * dt, x + 0.5 * dt * dx, dx, 0, y, z, pf, pi)
    x1 = x + dt * dx
    return np.nan_to_num(_zc(t + dt, x1, np.empty_like(g), w, gl, y, z, pf, pi) - g), t + dt, x1


def _zc(t, x, g, w, gl, y, z, pf, pi):
    gl.zc(t, x, g, y, z, pf, pi)
    stepping.mute(g, w.muted)
    return g


#: how far off 0 the functions searched in place of one on 0 are (see CVodeStepper.start)
OFF_ZERO = 1e-300
#: the time step (s, relative past t = 1 s) over which a function's rate at a start is taken
LEAVE_STEP = 1e-9
#: where a crossing at a start is reported (s after it, relative past t = 1 s): the RK and scipy
#: paths bisect such a crossing to within 1e-15 s of the start
START_STEP = 1e-15


def cvode_ops():
    """The :class:`~hybridsim.engine.stepping.Ops` of :class:`CVodeStepper`."""

    def begin(s, t0, t1, x, times, j, j1):
        s.t0, s.t1, s.x0 = t0, t1, np.array(x, float)
        s.times = [float(t) for t in times[j:j1] if t0 < t < t1]
        s.fresh = True  # at the first point from here, leaving_sides stands in for functions on
        # their surface at the start (after their own event): CVODE skips roots there
        s.before = s.event_x if s.event_at == t0 else None  # from an event: the state before its action
        s.before_fired = s.event_fired
        s.event_at, s.event_x, s.event_fired = None, None, None
        s.cv, s.queue, s.ta, s.started, s.looked = None, [], t0, False, False
        s.said = ""
        s.reached, s.reached_t = 0, -np.inf  # restarts at surfaces reached, not crossed, one on another
        s.stale = s.watch = False  # w.g (the core's) holds the functions at the last point; one sat on 0

    def solve(s, w, gl, y, z, pf, pi):
        """Every log time to the stop in one call: the returned points, queued (a failure after
        the points before it, which the core checks first)."""
        s.start(w, gl, y, z, pf, pi)
        times = np.array([s.t0, *s.times, s.t1])
        if np.any(np.diff(times) <= 0):  # repeated log times: one point at a time
            return False
        with _Words() as words:
            res = s.cv.solve(times, s.x0)
        s.said = words.said
        ts, ys = np.atleast_1d(res.t), np.atleast_2d(res.y)
        last = len(ts) - 1
        if res.status < 0 or s.failed:
            s.queue = [(float(ts[k]), ys[k], None) for k in range(1, last)] + [("failed", res, None)]
            return True
        root = s.fired(res, w.g.size) if res.status == 2 else None
        s.queue = [(float(ts[k]), ys[k], None) for k in range(1, last)]
        s.queue.append((float(ts[last]) if res.status == 2 else s.t1, ys[last], root))
        return True

    def one(s, w, gl, y, z, pf, pi):
        """The next returned point (one ``step`` call): a log time, a crossing or the stop."""
        if not s.started:
            s.start(w, gl, y, z, pf, pi)
            s.started = True
            with _Words() as words:
                res = s.cv.init_step(s.t0, s.x0)
            if not s.result(res, s.t0):
                return np.nan, None, None
        target = s.times.pop(0) if s.times else s.t1
        with _Words() as words:
            res = s.cv.step(target, tstop=s.t1)
        s.said = words.said
        if not s.result(res, s.ta):
            return np.nan, None, None
        t = float(np.atleast_1d(res.t)[-1])
        if res.status == 2:
            if target != s.t1 and t < target:
                s.times.insert(0, target)
            return t, res.y, s.fired(res, w.g.size)
        return (s.t1 if target == s.t1 else t), res.y, None

    def take(s, point, x, xn, w, gl, y, z, pf, pi):
        """The point ``point`` into ``xn`` (``x``: the state at the last one); its time, or NaN."""
        t, yy, root = point
        if t == "failed" or yy is None:
            refresh(s, x, w, gl, y, z, pf, pi)  # the failure's diagnosis reads the functions there
            if t == "failed":
                s.result(yy, s.ta)  # a callback's exception is raised here
            return np.nan
        t_last = s.ta
        xn[:] = np.asarray(yy, float).reshape(-1)
        s.num[1] = t - s.ta
        s.ta = t
        if s.fresh or s.watch:  # w.g: the functions at the (re)start, or at the last point, where the
            # core looked. CVODE leaves one exactly on 0 out of its search until a point where it is not
            s.watch = bool((w.g == 0.0).any())  # (leaving 0 unreported): the core looks till then
            s.moved = (w.g != 0.0) | (False if s.fresh else s.moved)  # off 0 since the start (see _own)
        reached = False
        reported = root
        if root is not None:  # the core's rule: a function fires once on its firing side, not on reaching 0
            past = np.zeros(root.size, np.bool_)
            here = _zc(t, xn, np.empty(root.size), w, gl, y, z, pf, pi)
            stepping.crossed_any(np.zeros(root.size), here, w.dirs, past)
            root = root & past
            refresh(s, x, w, gl, y, z, pf, pi, t_last)  # w.g at the last point
            if (w.g == 0.0).any():  # one sat on 0 there (or at the start)
                root = left_with(s, t, xn, here, root, w, gl, y, z, pf, pi)
            reached = root is not None and not root.any()
            root = None if reached else root
        # past an integration's first point, CVODE's root search has compared the functions on a grid
        # holding every point it returned (its step ends and the log times): the core need not look
        # again, unless one sat exactly on 0 at the last point
        s.num[stepping.ROOT] = 1.0 if root is not None else (-1.0 if s.fresh or s.watch else -2.0)
        if root is None and s.watch and not s.fresh and not reached:
            left_zero(s, t, xn, w, gl, y, z, pf, pi)
        if root is not None:  # the core reads w.g as the functions before the crossing
            refresh(s, x, w, gl, y, z, pf, pi, t_last)
        s.stale = s.stale or s.num[stepping.ROOT] < -1.5
        if s.fresh and root is None and w.g.size:
            leaving_sides(s, xn, w, gl, y, z, pf, pi)
        s.fresh = False
        if root is not None:
            w.fired[:] = root
            s.event_at, s.event_x, s.event_fired = t, xn.copy(), root.copy()
            # CVODE stops at the crossing; the core may go on from it (a crossing just before the next
            # hit fires after that hit): from here, as from the state before an event's action
            restart(s, t, xn, before=xn.copy())
            s.before_fired = root.copy()
        if reached:  # no event here: CVODE starts afresh, and leaving the surface is judged at that start
            if s.num[stepping.ROOT] < -1.5:  # the core keeps w.g only where it looks
                w.g[:] = here
                s.stale = False
            restart(s, t, xn, before=None)
            # a switch that reaches its surface again and again, never crossing (a PID held exactly at
            # its limit), slides along it: muted for the rest of the interval, as one located too often
            s.reached = s.reached + 1 if t - s.reached_t <= REACHED_GAP * max(1.0, abs(t)) else 1
            s.reached_t = t
            if s.reached > REACHED_RESTARTS:
                w.muted[reported & w.switch] = True
                s.reached = 0
        return t

    def refresh(s, x, w, gl, y, z, pf, pi, t_last=None):
        """w.g at the last point (state ``x``) when the core did not keep it there (ROOT = -2)."""
        if s.stale and w.g.size:
            _zc(s.ta if t_last is None else t_last, x, w.g, w, gl, y, z, pf, pi)
        s.stale = False

    def restart(s, t, xn, before):
        s.t0, s.x0, s.before = t, xn.copy(), before
        s.before_fired = None if before is None else s.before_fired  # no event here: none fired
        s.times = [tt for tt in s.times if tt > t]
        s.cv, s.queue, s.started, s.fresh, s.looked = None, [], False, True, False

    def at_start(s, xn, w, gl, y, z, pf, pi):
        """The crossing at the start (:func:`start_crossing`), taken, once per start; else None."""
        if s.looked or not w.g.size:
            return None
        s.looked = True
        point = start_crossing(s, w, gl, y, z, pf, pi)
        return None if point is None else take(s, point, s.x0, xn, w, gl, y, z, pf, pi)

    def step(s, x, xn, w, gl, y, z, pf, pi):
        t = at_start(s, xn, w, gl, y, z, pf, pi)
        return t if t is not None else take(s, one(s, w, gl, y, z, pf, pi), x, xn, w, gl, y, z, pf, pi)

    def steps(s, t_lim, x, xn, w, gl, y, z, pf, pi):
        t = at_start(s, xn, w, gl, y, z, pf, pi)
        if t is not None:
            return t
        if s.cv is None and not s.queue and not solve(s, w, gl, y, z, pf, pi):
            s.cv = None
        if not s.queue:
            return step(s, x, xn, w, gl, y, z, pf, pi)
        return take(s, s.queue.pop(0), x, xn, w, gl, y, z, pf, pi)

    def dense(s, t, x, w, xo):  # the core asks only inside a step; CVODE's points end at log times
        xo[:] = x

    def restep(s, hh, x, w, gl, y, z, pf, pi, xr):
        return False

    def rewind(s):
        return False

    return stepping.Ops(begin, step, steps, dense, restep, rewind)


_SAYS = re.compile(r"\n\[(\w+), Error: (-?\d+)\] (.*?)\n\n", re.S)


class _Words(contextlib.redirect_stdout):
    """Around a scikit-sundae call: SUNDIALS' error messages (which it prints) go into
    ``said`` instead of the standard output; anything else printed there is passed on.
    SUNDIALS' warnings (its logger prints them on stderr; it reads where to from the environment
    when a call makes its context) go nowhere, unless the user chose a place: what they report
    (a root function that stays 0, a step too small) the core judges itself, and says in its
    errors."""

    WARNINGS = "SUNLOGGER_WARNING_FILENAME"

    def __init__(self):
        super().__init__(io.StringIO())
        self.said = ""
        self._quiet = False

    def __enter__(self):
        super().__enter__()
        if self.WARNINGS not in os.environ:
            os.environ[self.WARNINGS] = os.devnull
            self._quiet = True
        return self

    def __exit__(self, *exc):
        if self._quiet:
            os.environ.pop(self.WARNINGS, None)
        super().__exit__(*exc)
        text = self._new_target.getvalue()
        if text:
            self.said = "; ".join(m.group(3).strip() for m in _SAYS.finditer(text))
            rest = _SAYS.sub("", text)
            if rest:
                sys.stdout.write(rest)
        return False
