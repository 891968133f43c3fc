"""The stepping core: how every path advances a system, written once.

A run walks the stops of a :class:`Timeline` (sample hits, log points
between hits, the end). At a hit the diagram's glue (:class:`Glue`) computes
the outputs of every block that is not discrete and of the discrete blocks
due (the others hold theirs: zero-order hold), the log row is recorded, and
the due blocks update. Between two hits the continuous states are
integrated by a stepper (:class:`Ops`) one accepted step at a time; after
each step

1. the state is checked: not finite or beyond ``max_state`` is DIVERGED;
2. the located event functions are compared with the step's start (and at
   scan points no more than ``scan`` s apart inside a long step); the first
   sign change is bisected on the step's dense output to ``time_tol``;
3. log points inside the step are observed from the dense output, in time
   order, before an event's actions;
4. at an event the actions run, again while they make another function
   cross (at most ``max_iterations``), and the integration restarts there.

Time events (a block's ``next_event_time``) are stops hit exactly; blocks
told of every accepted step (``after_step``) may ask for a step event or
stop the run. More than ``max_events`` events averaging under 1000 ``time_tol``
apart, or events piling up at one instant, is Zeno behaviour. A crossing within ``time_tol`` of the next
hit fires just after it (the hit samples the value before; its log row is
logged again after the event); one at the run's end is not acted on. A
variable-step run whose steps shrink to nothing (sliding along a muted
switch, or any ``crawl_steps`` steps averaging under ``slide_step``) stops.

Everything here keeps to the subset of Python that numba compiles. The
compiled path compiles these very functions once per machine
(:mod:`hybridsim.engine.compiled`), the diagram's glue and the Runge-Kutta
stepper passed in as first-class functions; the generic and fused paths run
them as plain Python with their own glue and steppers. Failures are status
codes in ``Out.status`` (``code, index, row``) and ``Out.tfail``, turned into
messages by :mod:`hybridsim.engine.simulator`.
"""
import math

from hybridsim.engine.locating import copy_into, crossed_any, first_sign_change, locate, mute  # noqa: F401
from hybridsim.engine.records import Glue, Limits, Ops, Out, Timeline, Work  # noqa: F401 (the core's records)
from hybridsim.engine.records import (BAD_OUTPUT, BAD_UPDATE, BIG_UPDATE, CHATTER, CRAWLING, DIVERGED, END,  # noqa: F401
                                      END_LOG, FAILED, GO, HIT, LOG, MISSED, OK, ROOT, SLIDING, STALLED, STEP_EVENT,
                                      STOP, STOPPED, ZENO)

# -- small helpers -----------------------------------------------------------------
def counted(count, stalls, since, t, lim, out, j):
    """After an event at ``t``, the ``count``-th since ``since`` and the ``stalls``-th in a row within 10
    time_tol: ``(status, count, since)``. ZENO when more than ``max_events`` average under 1000
    time_tol (1e-9 s) apart, STALLED when more than ``max_stalls`` pile up (failed in ``out``); else
    OK, the count started again after ``max_events`` spread out (a delay's buffer sampled for minutes,
    every 0.8 us for a 50 us delay)."""
    if count > lim.max_events:
        if t - since < count * 1000.0 * lim.time_tol:
            fail(out, ZENO, count, j, t)
            return ZENO, count, since
        count, since = 0, t
    if stalls > lim.max_stalls:
        fail(out, STALLED, stalls, j, t)
        return STALLED, count, since
    return OK, count, since


def first_bad(x, bounded, max_state):
    """The index of the first element of ``x`` not finite, or ``bounded`` and beyond ``max_state``;
    -1 if none."""
    for i in range(x.size):
        if not (abs(x[i]) <= max_state or (not bounded[i] and abs(x[i]) < math.inf)):
            return i
    return -1


def fail(out, code, index, row, t):
    out.status[0] = code
    out.status[1] = index
    out.status[2] = row
    out.tfail[0] = t


def record(out, y, row):
    """Copy the logged elements of ``y`` into log row ``row``."""
    if row < 0:
        return
    for c in range(out.cols.size):
        out.log[row, c] = y[out.cols[c]]
    if row + 1 > out.nrow[0]:
        out.nrow[0] = row + 1


def observe_to(gl, out, tl, j, ja, x, y, z, pf, pi):
    """Log rows ``j .. ja - 1`` of ``tl`` from the state ``x``; the next row, or -1 on a bad output
    (status set)."""
    while j < ja:
        if not observe(gl, out, tl.t[j], x, y, z, pf, pi, tl.rec[j], j):
            return -1
        j += 1
    return j


def log_event(out, t, fired, owner):
    """Append an event at ``t``: the located blocks whose functions ``fired``."""
    n = out.nev[0]
    if n < out.evt.size:
        out.evt[n] = t
        for b in range(out.evb.shape[1]):
            out.evb[n, b] = False
        for i in range(fired.size):
            if fired[i]:
                out.evb[n, owner[i]] = True
    out.nev[0] = n + 1


def observe(gl, out, t, x, y, z, pf, pi, row, k):
    """Evaluate the log path at (t, x) and record row ``row``; False (status set) on a bad output."""
    bad = gl.observe(t, x, y, z, pf, pi)
    if bad >= 0:
        fail(out, BAD_OUTPUT, bad, k, t)
        return False
    record(out, y, row)
    return True


# -- the run ------------------------------------------------------------------
def run(tl, k0, k1, gl, ops, s, lim, w, out, y, z, pf, pi):
    """Walk the stops ``k0 .. k1 - 1`` of ``tl`` (``k0`` a hit or the end); ``w.x`` holds the state
    and is left holding the state at the last stop. Returns the status code (0: done)."""
    k = k0
    n_x = w.x.size
    while k < k1:
        kind = tl.kind[k]
        t = tl.t[k]
        if kind == HIT:
            bad = gl.outputs(t, w.x, y, z, pf, pi, tl.due, k)
            if bad >= 0:
                fail(out, BAD_OUTPUT, bad, k, t)
                return BAD_OUTPUT
            record(out, y, tl.rec[k])
            bad = gl.update(t, w.x, y, z, pf, pi, tl.due, k)
            if bad >= 0:
                fail(out, BAD_UPDATE, bad, k, t)
                return BAD_UPDATE
            for i in range(w.zb.size):
                if w.zb[i] and not abs(z[i]) <= lim.max_state:
                    fail(out, BIG_UPDATE, i, k, t)
                    return BIG_UPDATE
            nxt = tl.next[k]
            if n_x > 0:
                code = interval(t, tl.t[nxt], k + 1, nxt, tl, gl, ops, s, lim, w, out, y, z, pf, pi)
                if code != OK:
                    return code
            else:
                for j in range(k + 1, nxt):
                    if not observe(gl, out, tl.t[j], w.x, y, z, pf, pi, tl.rec[j], j):
                        return BAD_OUTPUT
            k = nxt
        else:  # the end (a row of its own after the last hit)
            if kind == END_LOG:
                if not observe(gl, out, t, w.x, y, z, pf, pi, tl.rec[k], k):
                    return BAD_OUTPUT
            k += 1
    return OK


def interval(t0, t1, j, j1, tl, gl, ops, s, lim, w, out, y, z, pf, pi):
    """Integrate ``w.x`` from the hit at ``t0`` to the next stop ``t1`` (rows ``j .. j1 - 1`` of ``tl``
    are the log points between), locating events and acting on them. Returns the status code."""
    x, xn = w.x, w.xn
    located = w.g.size > 0
    for i in range(w.muted.size):
        w.muted[i] = False
        w.repeats[i] = 0
    count = 0
    since = t0  # when the count of events began (a new count starts after max_events spaced out)
    stalls = 0
    tol = lim.time_tol
    at_hit = located
    t_end = tl.t[tl.t.size - 1]
    deferred = False  # a crossing found at the next hit, fired after it (w.gp holds the functions before it)
    t_hit, j_hit = t0, j - 1  # the hit this interval starts from, and its row
    slid = -1        # the first switch muted in this interval (sliding along its surface)
    slid_t = t0      # since when
    slid_n = 0       # steps since
    crawl_t = t0     # the start of the current count of steps, and the count
    crawl_n = 0
    while True:
        # -- one integration from t0 to the next stop (a time event or t1) ----------------------
        stop = t1
        timed = False
        if lim.timed:
            te = gl.next_time(t0, x, y, z, pf, pi)
            if te <= t0 + tol:  # due now (an event just before it brought the run to it): act at once
                code, count, since = counted(count + 1, stalls + 1, since, t0, lim, out, j)
                stalls += 1
                if code != OK:
                    return code
                code = time_event(t0, gl, lim, w, out, y, z, pf, pi, j)
                if code != OK:
                    return code
                continue
            if te <= t1 + tol:  # before the next stop, or at it: acted on there, before its hit
                stop, timed = min(te, t1), True
        ops.begin(s, t0, stop, x, tl.t, j, j1)
        if located:
            gl.zc(t0, x, w.g, y, z, pf, pi)
            mute(w.g, w.muted)
            if at_hit:  # the hit changed held outputs: a function they carried across its surface fires now
                at_hit = False
                if crossed_any(w.gp, w.g, w.dirs, w.fired):
                    count += 1
                    log_event(out, t0, w.fired, w.owner)
                    copy_into(w.xe, x)
                    code = settle(t0, gl, lim, w, out, y, z, pf, pi)
                    if code != OK:
                        fail(out, code, out.status[1] if code == DIVERGED else 0, j, t0)
                        return code
                    # the hit's log row, row j - 1 (a log point at an event is logged after it)
                    if not observe(gl, out, t0, x, y, z, pf, pi, tl.rec[j - 1], j - 1):
                        return BAD_OUTPUT
                    continue  # integrate from the state after the actions
        ta = t0
        event = False
        asked = GO
        t_ev = t0
        while True:
            # log points at the step's start (the state itself) are logged once the step is known: one
            # within tol before an event is logged after it, unless the step starts the integration
            at = ta + 1e-9 * (s.num[1] if s.num[1] > 0.0 else tol)
            ja = j
            while ja < j1 and tl.t[ja] <= at:
                ja += 1
            t_lim = tl.t[ja] if ja < j1 else stop
            if lim.batch:
                tb = ops.steps(s, t_lim, x, xn, w, gl, y, z, pf, pi)
                if tb == tb and first_bad(xn, w.xb, lim.max_state) >= 0:
                    tb = restep_to_failure(ta, tb, ops, s, w, gl, y, z, pf, pi, lim)
            else:
                tb = ops.step(s, x, xn, w, gl, y, z, pf, pi)
            if tb != tb:
                j = observe_to(gl, out, tl, j, ja, x, y, z, pf, pi)
                if j < 0:
                    return BAD_OUTPUT
                fail(out, FAILED, 0, j, ta)
                return FAILED
            bad = first_bad(xn, w.xb, lim.max_state)
            if bad >= 0:
                j = observe_to(gl, out, tl, j, ja, x, y, z, pf, pi)
                if j < 0:
                    return BAD_OUTPUT
                copy_into(w.xo, x)  # the step's start: where its stages can be looked at again
                copy_into(x, xn)
                fail(out, DIVERGED, bad, j, tb)
                return DIVERGED
            # -- events: the first sign change inside the step --------------------------------
            if located and s.num[ROOT] > -1.5:
                gl.zc(tb, xn, w.gn, y, z, pf, pi)
                mute(w.gn, w.muted)
                if s.num[ROOT] > 0.0:  # the stepper found the crossing itself (CVODE): at tb
                    event, t_ev = True, tb
                    copy_into(w.xe, xn)
                elif s.num[ROOT] < 0.0:  # it looked, and none lies in the step
                    miss = first_sign_change(w.g, w.gn, w.dirs)
                    if miss >= 0:  # yet one changed sign: without dense output it cannot be located
                        j = observe_to(gl, out, tl, j, ja, x, y, z, pf, pi)
                        if j < 0:
                            return BAD_OUTPUT
                        copy_into(x, xn)
                        fail(out, MISSED, miss, j, tb)
                        return MISSED
                    copy_into(w.g, w.gn)
                else:  # bisected on the step's dense output
                    event, t_ev = locate(ta, tb, gl, ops, s, lim, w, y, z, pf, pi)
                # a crossing at the run's end or at the next hit is not acted on before it; the stop's
                # state is the crossing's (a fresh step's to just before a jump, where one was taken:
                # the step's own last stage saw the value after it)
                if event and t_ev >= t_end - tol:  # at the run's end: not acted on (the last row arrives)
                    event = False
                    copy_into(w.g, w.gn)
                    copy_into(xn, w.xe)
                elif event and not timed and t_ev >= t1 - tol:  # at the next hit: fired just after it, as
                    event = False  # a function fires on leaving its surface (the hit samples the value before)
                    if not deferred:  # the functions before the first such crossing (a second one, as
                        # close to the hit, must not take the first's function past its surface)
                        copy_into(w.gp, w.glo if s.num[ROOT] == 0.0 else w.g)
                    deferred = True
                    copy_into(w.g, w.gn)
                    copy_into(xn, w.xe)
            # -- log points at the step's start and inside it, before the event ------------------
            t_in = t_ev - tol if event else tb  # one within tol of the event: logged after it
            while j < ja and (tl.t[j] < t_in or ta == t0):  # (an integration's start is after its event)
                if not observe(gl, out, tl.t[j], x, y, z, pf, pi, tl.rec[j], j):
                    return BAD_OUTPUT
                j += 1
            h = tb - ta
            while j < j1 and tl.t[j] < t_in and tl.t[j] < tb - 1e-9 * h:
                ops.dense(s, tl.t[j], x, w, w.xo)
                if not observe(gl, out, tl.t[j], w.xo, y, z, pf, pi, tl.rec[j], j):
                    return BAD_OUTPUT
                j += 1
            if event:
                break
            copy_into(x, xn)
            ta = tb
            if lim.crawl_steps > 0:  # any run whose steps shrank to nothing
                crawl_n += 1
                if crawl_n >= lim.crawl_steps:
                    if tb - crawl_t < crawl_n * lim.slide_step:
                        fail(out, CRAWLING, 0, j, tb)
                        return CRAWLING
                    crawl_t, crawl_n = tb, 0
            if slid >= 0:  # a solver that shrinks its steps to nothing on a switching right-hand side
                slid_n += 1
                if slid_n >= lim.slide_steps and tb - slid_t < slid_n * lim.slide_step:
                    fail(out, SLIDING, slid, j, tb)
                    return SLIDING
            if lim.stepped:
                asked = gl.stepped(tb, x, y, z, pf, pi)
                if asked == STOP:
                    fail(out, STOPPED, 0, j, tb)
                    return STOPPED
                if asked == STEP_EVENT:
                    for i in range(w.fired.size):
                        w.fired[i] = False
                    event = True
                    t_ev = tb
                    copy_into(w.xe, x)
                    break
            if tb >= stop:
                break
        if event:
            stalls = stalls + 1 if t_ev - t0 <= 10.0 * tol else 0
            log_event(out, t_ev, w.fired, w.owner)
            code, count, since = counted(count + 1, stalls, since, t_ev, lim, out, j)
            if code != OK:
                return code
            if lim.stepped and asked != STEP_EVENT:  # a located event ends a step too: its request joins
                if gl.stepped(t_ev, w.xe, y, z, pf, pi) == STOP:
                    copy_into(x, w.xe)
                    fail(out, STOPPED, 0, j, t_ev)
                    return STOPPED
            if lim.max_repeats > 0:  # a switch located too often slides along its surface: muted
                for i in range(w.fired.size):
                    if w.switch[i] and w.fired[i]:
                        w.repeats[i] += 1
                        if w.repeats[i] > lim.max_repeats:
                            w.muted[i] = True
                            if slid < 0:
                                slid, slid_t, slid_n = i, t_ev, 0
            code = settle(t_ev, gl, lim, w, out, y, z, pf, pi)
            if code != OK:
                fail(out, code, out.status[1] if code == DIVERGED else 0, j, t_ev)
                return code
            if t_ev - t_hit <= tol:  # at the hit's instant: its log row is logged again, after the event
                if not observe(gl, out, t_hit, x, y, z, pf, pi, tl.rec[j_hit], j_hit):
                    return BAD_OUTPUT
            t0 = t_ev
        elif timed:  # a time event
            count += 1
            code = time_event(stop, gl, lim, w, out, y, z, pf, pi, j)
            if code != OK:
                return code
            t0 = stop
        else:
            break
        if t1 - t0 <= tol:  # an event at the next stop itself
            break
    # log points left (within round-off of the stop, or after an event at it): the state there
    while j < j1:
        if not observe(gl, out, tl.t[j], x, y, z, pf, pi, tl.rec[j], j):
            return BAD_OUTPUT
        j += 1
    if located and not deferred:  # the functions at the stop, before its hit: compared after it
        gl.zc(t1, x, w.gp, y, z, pf, pi)
    return OK


def time_event(t, gl, lim, w, out, y, z, pf, pi, j):
    """The time event at ``t`` on ``w.x`` (logged, acted on, ``w.x`` the state after); STOPPED
    when a block asked to end the run, DIVERGED when the actions left a state not finite (status
    set), else OK."""
    for i in range(w.fired.size):
        w.fired[i] = False
    log_event(out, t, w.fired, w.owner)
    if gl.timed(t, w.x, w.xe, y, z, pf, pi) == STOP:
        fail(out, STOPPED, 0, j, t)
        return STOPPED
    copy_into(w.x, w.xe)
    bad = first_bad(w.x, w.xb, lim.max_state)
    if bad >= 0:
        fail(out, DIVERGED, bad, j, t)
        return DIVERGED
    return OK


def restep_to_failure(ta, tb_batch, ops, s, w, gl, y, z, pf, pi, lim):
    """After a batch of steps from ``w.x`` whose last state failed the check: the same steps again,
    one at a time, up to the first state that fails (left in ``w.xn``); returns its end time."""
    if not ops.rewind(s):  # a stepper that cannot take its steps again: the batch's end it is
        return tb_batch
    tb = ta
    while tb < tb_batch:
        tb = ops.step(s, w.x, w.xn, w, gl, y, z, pf, pi)
        if first_bad(w.xn, w.xb, lim.max_state) >= 0:
            return tb
        copy_into(w.x, w.xn)
    return tb


def settle(t, gl, lim, w, out, y, z, pf, pi):
    """Apply the actions of ``w.fired`` to ``w.xe`` at ``t``, again while they make another function
    cross (each such block joins the event's entry); the state after, in ``w.x``. Returns the status
    code (CHATTER, STOPPED, DIVERGED: an action left a state not finite or beyond max_state, its
    index in ``out.status[1]``; or OK)."""
    gl.zc(t, w.xe, w.gm, y, z, pf, pi)  # the functions just before the actions
    mute(w.gm, w.muted)
    for _ in range(lim.max_iterations):
        if gl.act(t, w.xe, w.x, w.fired, y, z, pf, pi) == STOP:
            copy_into(w.x, w.xe)
            return STOPPED
        copy_into(w.xe, w.x)
        gl.zc(t, w.x, w.ghi, y, z, pf, pi)
        mute(w.ghi, w.muted)
        if not crossed_any(w.gm, w.ghi, w.dirs, w.fired):
            bad = first_bad(w.x, w.xb, lim.max_state)
            if bad >= 0:
                out.status[1] = bad
                return DIVERGED
            return OK
        n = out.nev[0] - 1
        if 0 <= n < out.evt.size:
            for i in range(w.fired.size):
                if w.fired[i]:
                    out.evb[n, w.owner[i]] = True
        copy_into(w.gm, w.ghi)
    return CHATTER
