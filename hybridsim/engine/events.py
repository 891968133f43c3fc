"""State events with resets and time events, between two sample hits.

A block with ``event_action`` (see :mod:`hybridsim.engine.block`) has its events
located by every solver, to :data:`TIME_TOL`: the fixed-step methods check the
sign of the event functions after each step of their grid, bisect the step's
dense output and re-step to the root; the scipy solvers check them after each
accepted step (and at scan points inside it) and bisect its dense output
(docs/events-and-solvers.md). At
the event the actions run (x+ = h(x-, u)), then again while an action makes
another event function cross (event iteration, at most
:data:`MAX_ITERATIONS` times at one instant), and the integration restarts
there on a fresh step grid. A block's time events (``next_event_time``) are
stops like sample hits, hit exactly. More than :data:`MAX_EVENTS` events
between two hits, or an iteration that does not settle, is Zeno or
chattering behaviour: a :class:`~hybridsim.errors.SimulationError` that names
the blocks.

A function fires *falling* (direction -1) when it goes from >= 0 to < 0 and
*rising* (+1) from <= 0 to > 0; direction 0 fires on either.
"""
import numpy as np

from hybridsim.errors import SimulationError, StopRequest

#: events are located to this many seconds
TIME_TOL = 1e-12
#: actions at one instant before the iteration counts as chattering
MAX_ITERATIONS = 100
#: events between two sample hits before the run counts as Zeno
MAX_EVENTS = 100_000
#: events in a row, each within 10 TIME_TOL of the one before, before the run counts as Zeno
MAX_STALLS = 50
#: a switch without an action (stick/slip, contact) located more often than this between two
#: hits slides along its surface: it is stepped over for the rest of that interval
MAX_REPEATS = 20


def crossed(g0, g1, directions):
    """Boolean mask: which functions crossed zero from ``g0`` to ``g1`` in their direction."""
    g0, g1 = np.asarray(g0, float), np.asarray(g1, float)
    rising = (g0 <= 0) & (g1 > 0) & (directions >= 0)
    return rising | ((g0 >= 0) & (g1 < 0) & (directions <= 0))


def bisect(g, directions, t, h, state_at, g_lo, x_hi, g_hi, restep=None):
    """The first crossing of ``g`` inside ``[t, t + h]``, to :data:`TIME_TOL`.

    ``state_at(theta)`` is the state at ``t + theta h`` (a dense output);
    ``g_lo`` the functions at ``t``, ``x_hi`` / ``g_hi`` the state and functions
    at ``t + h``. With ``restep(theta h)`` the state at the crossing is taken from
    it when that state is past the surface too (else the dense one). Returns
    ``(theta, x there, fired)``.
    """
    lo, hi = 0.0, 1.0
    while (hi - lo) * h > TIME_TOL:
        mid = 0.5 * (lo + hi)
        xm = state_at(mid)
        gm = g(t + mid * h, xm)
        if crossed(g_lo, gm, directions).any():
            hi, x_hi, g_hi = mid, xm, gm
        else:
            lo, g_lo = mid, gm
    if restep is not None and hi < 1.0:
        x_re = restep(hi * h)
        if crossed(g_lo, g(t + hi * h, x_re), directions).any():
            x_hi = x_re
    return hi, x_hi, crossed(g_lo, g_hi, directions)


class EventSet:
    """The located events and time events of one context: their functions and actions.

    Located: the blocks with actions, and with ``locate_switches`` every block
    with zero crossings (an event without an action only restarts the step grid).

    ``g(t, x)`` evaluates every action block's event functions (after the
    outputs at (t, x)); ``act(t, x, fired)`` applies the actions of the
    blocks whose functions ``fired`` (mask) or, with ``fired=None``, the time
    events due at ``t``; ``next_time(t, x)`` the earliest time event after t.
    """

    def __init__(self, system, ctx, outputs, located=None):
        self.system, self.ctx, self.outputs = system, ctx, outputs
        located = system.action_events if located is None else located
        self.blocks = [(i, system.xslices[i]) for i in located]
        self.timed = [(i, system.xslices[i]) for i in system.time_events]
        sizes, dirs = [], []
        for i, s in self.blocks:
            b = ctx.blocks[i]
            n = len(np.atleast_1d(b.zero_crossings(0.0, ctx.xc[s] if s is not None else ctx.xd[i], ctx.u[i])))
            d = b.event_directions if b.event_directions is not None else (0,) * n
            sizes.append(n)
            dirs += list(d)
        self.cuts = np.cumsum([0] + sizes)
        self.directions = np.array(dirs, float)
        #: functions of blocks without an action (switches that only restart the integration)
        self.switches = np.repeat([not ctx.blocks[i].has_event_action for i, _ in self.blocks], sizes).astype(bool)
        self.muted = np.zeros(len(dirs), dtype=bool)
        self.log = []  # (t, block names) of every event, in order
        stepped = [(i, system.xslices[i]) for i in getattr(system, "after_step", ())]
        #: the callback every solver calls after each accepted step (None: no block needs it)
        self.step = self._after_step if stepped else None
        self.stepped, self.requested, self.stop = stepped, [], None

    def _after_step(self, t, x):
        """Tell the blocks with ``after_step`` of an accepted step ending at (t, x); True when one
        asks for a step event there (or to stop: the request waits in ``stop`` until the solver
        has handed back its log states)."""
        self.outputs(t, x)
        blocks, u = self.ctx.blocks, self.ctx.u
        for i, s in self.stepped:
            try:
                if blocks[i].after_step(t, x[s], u[i]):
                    self.requested.append((i, s))
            except StopRequest as stop:
                stop.x = x
                self.stop = stop
                return True
        return bool(self.requested)

    def step_fired(self):
        """A mask of no fired functions: what a solver returns for a step event."""
        return np.zeros(len(self.directions), dtype=bool)

    def g(self, t, x):
        """Every located block's event functions at (t, x) (a muted switch reads +1: never fires)."""
        self.outputs(t, x)
        blocks, u = self.ctx.blocks, self.ctx.u
        xd = self.ctx.xd
        vals = [np.atleast_1d(np.asarray(blocks[i].zero_crossings(t, x[s] if s is not None else xd[i], u[i]), float))
                for i, s in self.blocks]
        out = np.concatenate(vals) if vals else np.zeros(0)
        return np.where(self.muted, 1.0, out) if self.muted.any() else out

    def next_time(self, t, x):
        """The earliest time event after ``t`` (inf: none); remembers which blocks ask for it."""
        blocks = self.ctx.blocks
        times = [(float(blocks[i].next_event_time(t, x[s])), i, s) for i, s in self.timed]
        te = min((tt for tt, _, _ in times), default=np.inf)
        self.due = [(i, s) for tt, i, s in times if tt == te]
        return te

    def act(self, t, x, fired):
        """The state after the actions at ``t``: of the blocks whose functions ``fired``, or
        (``fired`` None) of the blocks whose time event is due at ``t``. A block's
        :class:`~hybridsim.errors.StopRequest` leaves with the state at ``t``."""
        try:
            return self._act(t, x, fired)
        except StopRequest as stop:
            stop.x = x
            raise

    def _act(self, t, x, fired):
        self.outputs(t, x)
        x = x.copy()
        blocks, u = self.ctx.blocks, self.ctx.u
        if fired is None:
            for i, s in self.due:  # the blocks whose time event next_time found
                new = blocks[i].event_action(t, x[s].copy(), u[i], ())
                if new is not None:
                    x[s] = new
            return x
        done = set()
        for k, (i, s) in enumerate(self.blocks):
            mine = fired[self.cuts[k]:self.cuts[k + 1]]
            if mine.any() and s is not None:  # a stateless block's switch only restarts
                done.add(i)
                new = blocks[i].event_action(t, x[s].copy(), u[i], tuple(bool(f) for f in mine))
                if new is not None:
                    x[s] = new
        requested, self.requested = self.requested, []
        for i, s in requested:  # step events (after_step asked) at the same instant
            if i not in done:
                new = blocks[i].event_action(t, x[s].copy(), u[i], ())
                if new is not None:
                    x[s] = new
        return x

    def names(self, fired):
        """The blocks whose functions ``fired`` or that asked for a step event."""
        return sorted({self.system.blocks[i].name for k, (i, _) in enumerate(self.blocks)
                       if fired[self.cuts[k]:self.cuts[k + 1]].any()}
                      | {self.system.blocks[i].name for i, _ in self.requested})

    def settle(self, t, x_minus, g_minus, fired):
        """Apply the actions of ``fired`` at ``t`` and iterate while actions trigger events."""
        self.log.append((t, tuple(self.names(fired))))
        x = x_minus
        for _ in range(MAX_ITERATIONS):
            x = self.act(t, x, fired)
            g_plus = self.g(t, x)
            fired = crossed(g_minus, g_plus, self.directions)
            if not fired.any():
                return x
            g_minus = g_plus
        raise chatter_error(t, self.names(fired))


def zeno_error(t, names, too_many, stalls):
    """The error for events that accumulate (every path raises this one)."""
    what = (f"more than {MAX_EVENTS} events before the next hit" if too_many else
            f"{stalls} events within {10 * TIME_TOL:g} s of each other")
    return SimulationError(f"events accumulate at t={t:.9g} s in block(s) {', '.join(names)}: {what} "
                           "(Zeno behaviour, e.g. a bouncing ball coming to rest); stop the run before "
                           "that time or give the model a resting state")


def chatter_error(t, names):
    """The error for an event iteration that does not settle (every path raises this one)."""
    return SimulationError(f"event iteration at t={t:.9g} s does not settle after {MAX_ITERATIONS} "
                           f"actions (chattering) in block(s) {', '.join(names)}")


def integrate(solver, f, events, t0, t1, x, t_out, observe=None, check=None, mute=False):
    """Integrate from hit ``t0`` to hit ``t1`` stopping at time events and located state events.

    ``solver`` gives ``advance_to_event(f, t0, t1, x, t_out, g, directions, check=check)``
    returning ``(t_stop, x_stop, fired, outs)``; ``fired`` None means it
    reached ``t1``. ``observe(t, x)``: called for each log time as
    soon as its segment is integrated, before the next event's actions (a
    block with hidden discrete state, an FMU, then shows the value of that
    time); without it the states come back in ``outs``. ``check(t, x)``: the
    divergence check, after every accepted step. With blocks that define ``after_step``, the
    solver also gets ``step=events.step``, called after every accepted step; when it returns
    True the solver stops there with a mask of no fired functions (a step event: the actions
    of the blocks that asked run as at a state event). ``mute``: a switch without an
    action located more than :data:`MAX_REPEATS` times is stepped over until
    ``t1`` (the scipy solvers: a sliding friction surface). Returns ``(x, outs)``
    like ``solver.advance``.
    """
    outs, pending = [], list(t_out)
    count = stalls = 0
    events.muted[:] = False
    repeats = np.zeros(len(events.directions), dtype=np.int64)
    while True:
        te = events.next_time(t0, x)
        stop = min(t1, te) if te > t0 + TIME_TOL else t1
        here = [tb for tb in pending if tb < stop]
        g = events.g if events.blocks else None
        kw = {"check": check} if events.step is None else {"check": check, "step": events.step}
        t_stop, x_stop, fired, got = solver.advance_to_event(f, t0, stop, x, here, g, events.directions, **kw)
        if observe is not None:
            for tb, xb in zip(pending, got):
                observe(tb, xb)
        else:
            outs += got
        pending = pending[len(got):]
        if events.stop is not None:  # a block's after_step asked to stop: the states so far are out
            stop_request, events.stop = events.stop, None
            raise stop_request
        if fired is not None:
            count += 1
            stalls = stalls + 1 if t_stop - t0 <= 10 * TIME_TOL else 0
            if count > MAX_EVENTS or stalls > MAX_STALLS:
                raise zeno_error(t_stop, events.names(fired), count > MAX_EVENTS, stalls)
            x = events.settle(t_stop, x_stop, events.g(t_stop, x_stop), fired)
            if mute:
                repeats += fired & events.switches
                events.muted |= repeats > MAX_REPEATS
        elif stop < t1:
            events.log.append((stop, tuple(sorted(events.system.blocks[i].name for i, _ in events.due))))
            x = events.act(stop, x_stop, None)
            count += 1
        else:
            return x_stop, outs
        t0 = t_stop
        if t1 - t0 <= TIME_TOL:  # an event at the hit itself
            while pending:
                tb = pending.pop(0)
                observe(tb, x) if observe is not None else outs.append(x)
            return x, outs
