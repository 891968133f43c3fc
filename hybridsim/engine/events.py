"""Events: the located blocks of a run, their functions and actions, and the policies' limits.

A block with ``event_action`` (see :mod:`hybridsim.engine.block`) has its
events located by every solver to :data:`TIME_TOL` (the algorithm is the
stepping core's, :mod:`hybridsim.engine.stepping`): after each accepted step
the event functions are compared with the step's start, the first sign
change is bisected on the step's dense output, the actions run (x+ = h(x-,
u)) and run again while an action makes another function cross (at most
:data:`MAX_ITERATIONS` times at one instant), and the integration restarts
there. A block's time events (``next_event_time``) are stops hit exactly.
More than :data:`MAX_EVENTS` events on average under 1000 :data:`TIME_TOL`
apart, or an iteration that does not settle, is Zeno or chattering behaviour: a
:class:`~hybridsim.errors.SimulationError` that names the blocks.

A function fires *falling* (direction -1) when it goes from >= 0 to < 0 and
*rising* (+1) from <= 0 to > 0; direction 0 fires on either.

:class:`EventSet` gives the generic path's glue its event functions and
actions, calling the blocks' methods; the fused and compiled paths generate
the same from the blocks' kernels.
"""
import numpy as np

from hybridsim.errors import SimulationError, StopRequest

#: events are located to this many seconds
TIME_TOL = 1e-12
#: actions at one instant before the iteration counts as chattering
MAX_ITERATIONS = 100
#: events, on average under 1000 TIME_TOL apart, before the run counts as Zeno
MAX_EVENTS = 100_000
#: events in a row, each within 10 TIME_TOL of the one before, before the run counts as Zeno
MAX_STALLS = 50
#: a switch without an action (stick/slip, contact) located more often than this between two
#: hits slides along its surface: it is stepped over for the rest of that interval
MAX_REPEATS = 20
#: steps after such a switch is muted, and their mean length (s) below which the run is stuck
#: sliding along it (a variable-step solver shrinks its steps to nothing on a right-hand side
#: that switches at every step)
SLIDE_STEPS = 1000
SLIDE_STEP = 1e-6
#: steps of a variable-step solver over which a mean step below SLIDE_STEP stops any run: it crawls
#: (a state that bounces off a switch without crossing it, a stiff system on an explicit method)
CRAWL_STEPS = 5_000


def located_events(system, solver, locate_switches=False):
    """The blocks whose events ``solver`` locates: those with resets, and on the variable-step
    solvers (or with ``locate_switches``) every block with zero crossings whose switch can change
    a derivative (a block with continuous state, or one the right-hand side evaluates; a source
    stepping a sampled block's input changes nothing between hits, and is not an event)."""
    located = list(system.action_events)
    if locate_switches or not getattr(solver, "fixed_step", False):
        moves = set(system.rhs_path) | set(system.stateful)
        located += [i for i in system.events if i not in located and i in moves]
    return located


def layout(system, ctx, located):
    """``(sizes, directions, switches)`` of the located blocks' event functions (``sizes`` per
    block from one evaluation at the initial state; ``switches`` marks the functions of blocks
    without an action, which only restart the integration)."""
    sizes, dirs = [], []
    for i in located:
        b, s = ctx.blocks[i], system.xslices[i]
        n = len(np.atleast_1d(b.zero_crossings(0.0, ctx.xc[s] if s is not None else ctx.xd[i], ctx.u[i])))
        d = b.event_directions if b.event_directions is not None else (0,) * n
        sizes.append(n)
        dirs += list(d)
    switches = np.repeat([not ctx.blocks[i].has_event_action for i in located], sizes).astype(bool)
    return sizes, np.array(dirs, dtype=np.int64), switches


class EventSet:
    """The located events, time events and step hooks of one context, through the blocks' methods.

    ``outputs(t, x)`` evaluates the right-hand side's blocks (their outputs are the
    event functions' inputs). ``g`` gives every located block's event functions,
    ``act`` the state after the actions of the functions that fired,
    ``next_time`` / ``act_timed`` the time events, ``after_step`` tells the blocks
    that asked of an accepted step. Requests to end the run
    (:class:`~hybridsim.errors.StopRequest`) are kept in ``stop``.
    """

    def __init__(self, system, ctx, outputs, located):
        self.system, self.ctx, self.outputs = system, ctx, outputs
        self.blocks = [(i, system.xslices[i]) for i in located]
        self.timed = [(i, system.xslices[i]) for i in system.time_events]
        self.stepped = [(i, system.xslices[i]) for i in system.after_step]
        sizes, self.directions, self.switches = layout(system, ctx, located)
        self.cuts = np.cumsum([0] + sizes).tolist()
        self.requested, self.due, self.stop = [], [], None
        # per located block: its functions' method, x slice, inputs, index and place in g
        self._g = [(ctx.blocks[i].zero_crossings, s, ctx.u[i], i, slice(a, b))
                   for (i, s), a, b in zip(self.blocks, self.cuts[:-1], self.cuts[1:])]

    def g(self, t, x, out):
        """Every located block's event functions at (t, x), into ``out``."""
        if self.system.rhs_path:
            self.outputs(t, x)
        for zc, s, ui, i, where in self._g:
            out[where] = zc(t, x[s] if s is not None else self.ctx.xd[i], ui)

    def next_time(self, t, x):
        """The earliest time event after ``t`` (inf: none); remembers which blocks ask for it."""
        blocks = self.ctx.blocks
        times = [(float(blocks[i].next_event_time(t, x[s])), i, s) for i, s in self.timed]
        te = min((tt for tt, _, _ in times), default=np.inf)
        self.due = [(i, s) for tt, i, s in times if tt == te]
        return te

    def act(self, t, x, fired, xn):
        """The state after the actions at ``t`` into ``xn``: of the blocks whose functions
        ``fired``, and of those that asked for a step event. Returns the names acting."""
        self.outputs(t, x)
        xn[:] = x
        done = set()
        for k, (i, s) in enumerate(self.blocks):
            mine = fired[self.cuts[k]:self.cuts[k + 1]]
            if mine.any() and s is not None:  # a stateless block's switch only restarts
                done.add(i)
                self._apply(i, s, t, xn, tuple(bool(f) for f in mine))
        requested, self.requested = self.requested, []
        for i, s in requested:  # step events (after_step asked) at the same instant
            if i not in done:
                self._apply(i, s, t, xn, ())
        return [self.system.blocks[i].name for i, _ in requested]

    def act_timed(self, t, x, xn):
        """The state after the time events due at ``t`` (those :meth:`next_time` found) into ``xn``;
        returns the names acting."""
        self.outputs(t, x)
        xn[:] = x
        for i, s in self.due:
            self._apply(i, s, t, xn, ())
        return [self.system.blocks[i].name for i, _ in self.due]

    def _apply(self, i, s, t, xn, fired):
        new = self.ctx.blocks[i].event_action(t, xn[s].copy(), self.ctx.u[i], fired)
        if new is not None:
            xn[s] = new

    def after_step(self, t, x):
        """Tell the blocks with ``after_step`` of an accepted step ending at (t, x); True when one
        asks for a step event there (a :class:`StopRequest` propagates)."""
        self.outputs(t, x)
        blocks, u = self.ctx.blocks, self.ctx.u
        for i, s in self.stepped:
            if blocks[i].after_step(t, x[s], u[i]):
                self.requested.append((i, s))
        return bool(self.requested)


def zeno_error(t, names, too_many, stalls, advice=None):
    """The error for events that accumulate (every path raises this one); ``advice``: the blocks' own."""
    what = (f"more than {MAX_EVENTS} events on average under {1000 * TIME_TOL:g} s apart" if too_many else
            f"{stalls} events within {10 * TIME_TOL:g} s of each other")
    return SimulationError(f"events accumulate at t={t:.9g} s in block(s) {', '.join(names)}: {what} "
                           "(Zeno behaviour: a bouncing ball coming to rest, or a relay or switch that the "
                           "state keeps flipping, a sliding mode)" + (f". {advice}" if advice else
                           "; stop the run before that time, give the model a resting state, or give a relay "
                           "hysteresis (switch_on above switch_off)"))


def sliding_error(t, name, more, advice=None):
    """The error for a variable-step run stuck sliding along a switch (every path raises this one);
    ``advice``: the block's own (:attr:`~hybridsim.engine.block.Block.sliding_advice`)."""
    return SimulationError(
        f"block {name!r}{' (and others)' if more else ''} switches at every step from t={t:.9g} s: its "
        f"event function was located more than {MAX_REPEATS} times, then the solver's steps shrank "
        f"below {SLIDE_STEP:g} s on average over {SLIDE_STEPS} steps: the state slides along the switch. "
        + (advice or SLIDING_ADVICE))


#: what a run stuck on a switch can do
SLIDING_ADVICE = ("A variable-step solver cannot cross a sliding mode (Coulomb friction holding a mass still, "
                  "a switch driven by its own output): give the model a mode for it (a stick band, a relay's "
                  "hysteresis), or use a fixed-step solver (rk4, heun), which chatters across it")


def chatter_error(t, names):
    """The error for an event iteration that does not settle (every path raises this one)."""
    return SimulationError(f"event iteration at t={t:.9g} s does not settle after {MAX_ITERATIONS} "
                           f"actions (chattering) in block(s) {', '.join(names)}")


__all__ = ["EventSet", "StopRequest", "located_events", "layout", "zeno_error", "sliding_error", "chatter_error"]
