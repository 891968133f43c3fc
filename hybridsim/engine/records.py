"""The records the stepping core works on: the stops, the policies, the buffers, what a run
writes, and the two sets of functions it calls (a diagram's glue, a solver's steps).

Each is a NamedTuple of numbers and arrays (or of functions), so numba passes it as one typed
argument (:mod:`hybridsim.engine.native`) and plain Python reads the same fields.
"""
from typing import Callable, NamedTuple

import numpy as np

# -- stop kinds (Timeline.kind) ------------------------------------------------
HIT, LOG, END, END_LOG = 0, 1, 2, 3

# -- status codes (Out.status[0]); status[1] says which state, block or count --
OK = 0
DIVERGED = 1    # a continuous state not finite or beyond max_state: status[1] = state index
BAD_OUTPUT = 2  # a block output not finite: status[1] = block index
BAD_UPDATE = 3  # a discrete state not finite: status[1] = block index
ZENO = 4        # more than max_events events, on average under 1000 time_tol apart
STALLED = 5     # max_stalls events in a row within 10 time_tol of each other
CHATTER = 6     # an event iteration that does not settle
STOPPED = 7     # a block asked to end the run (its request is kept by the glue)
FAILED = 8      # the solver failed (its message is kept by the stepper)
MISSED = 9      # a stepper that locates crossings itself stepped over one: status[1] = function index
BIG_UPDATE = 10  # a bounded discrete state beyond max_state: status[1] = its index in z
SLIDING = 11    # stuck sliding along a muted switch (tiny steps): status[1] = its function index
CRAWLING = 12   # a variable-step solver's steps shrank to nothing (crawl_steps of them below slide_step)

# -- what glue.stepped / glue.timed / glue.act answer --------------------------
GO, STEP_EVENT, STOP = 0, 1, 2

#: where a stepper that locates crossings itself says what it found (``s.num[ROOT]``): +1 the step
#: ends at a crossing (``w.fired`` set), -1 none in the step (the core checks that none changed sign
#: from ``w.g``, which such a stepper may set to the side a function leaves its surface to), -2 none,
#: and its own search covered the step from its last point (the core does not look again), 0 it
#: does not look (then the core bisects)
ROOT = 6


class Timeline(NamedTuple):
    """The stops of a run, in order, as arrays (:func:`hybridsim.engine.timeline.timeline`)."""

    t: np.ndarray     # float64[m]: stop times, s; the last row is the end of the run
    kind: np.ndarray  # int64[m]: HIT, LOG (a log point between hits), END, END_LOG (the end, logged)
    due: np.ndarray   # bool[m, d]: discrete block j (in system.discrete order) due at stop k
    rec: np.ndarray   # int64[m]: log row written at stop k, or -1
    next: np.ndarray  # int64[m]: at a hit, the row of the next hit or of the end


class Limits(NamedTuple):
    """The policies of a run (numbers the core compares with)."""

    max_state: float      # a larger |state| is divergence
    time_tol: float       # events are located to this many seconds
    scan: float           # longest stretch, s, between two checks of the event functions in a step
    max_events: int       # events between two hits before the run counts as Zeno
    max_stalls: int       # events in a row, each within 10 time_tol of the one before
    max_iterations: int   # actions at one instant before the iteration counts as chattering
    max_repeats: int      # a switch without an action located more often is stepped over (0: never)
    slide_steps: int      # steps after such a switch is muted before their length is judged
    slide_step: float     # the mean step, s, below which a run sliding along a switch is stuck there
    crawl_steps: int      # steps over which a mean step below slide_step stops any run (0: never)
    timed: bool           # the glue has time events (next_time / timed)
    stepped: bool         # the glue wants to hear of every accepted step
    batch: bool           # steps may be taken several at a time (no located events, no step hooks)


class Work(NamedTuple):
    """Buffers of one run: states (n), stages (s x n), event functions (e)."""

    x: np.ndarray       # float64[n]: the state
    xn: np.ndarray      # float64[n]: the state at the end of the step being taken
    xo: np.ndarray      # float64[n]: a state observed inside a step
    xe: np.ndarray      # float64[n]: the state at an event
    xm: np.ndarray      # float64[n]: a trial state of the bisection
    xs: np.ndarray      # float64[n]: a stage's state (Runge-Kutta)
    k: np.ndarray       # float64[s * n]: the stages of the step just taken, one after the other
    kr: np.ndarray      # float64[s * n]: the stages of a fresh step to an event
    xr: np.ndarray      # float64[n]: a stage's state in that step
    wts: np.ndarray     # float64[s]: dense-output weights
    g: np.ndarray       # float64[e]: event functions at the step's start
    gn: np.ndarray      # float64[e]: at its end
    glo: np.ndarray     # float64[e]: the bisection's bracket, low side
    ghi: np.ndarray     # float64[e]: high side
    gm: np.ndarray      # float64[e]: at a trial point
    gp: np.ndarray      # float64[e]: at the last stop, before its hit changed the held outputs (NaN: none yet)
    fired: np.ndarray   # bool[e]: the functions that crossed
    dirs: np.ndarray    # int64[e]: +1 fires rising, -1 falling, 0 both
    switch: np.ndarray  # bool[e]: a function of a block without an action (only restarts)
    muted: np.ndarray   # bool[e]: a switch stepped over for the rest of the interval
    repeats: np.ndarray  # int64[e]: how often each switch was located in this interval
    owner: np.ndarray   # int64[e]: the located block (column of Out.evb) of each function
    zb: np.ndarray      # bool[d]: the discrete states max_state bounds
    xb: np.ndarray      # bool[n]: the continuous states max_state bounds (all are checked finite)


class Out(NamedTuple):
    """What a run writes: log rows, events, status."""

    log: np.ndarray     # float64[rows, cols]: the log
    cols: np.ndarray    # int64[cols]: the elements of y each log column copies
    nrow: np.ndarray    # int64[1]: rows written so far
    evt: np.ndarray     # float64[cap]: event times, s
    evb: np.ndarray     # bool[cap, b]: which located blocks fired at each event
    nev: np.ndarray     # int64[1]: events so far (may exceed cap: only the first cap are kept)
    status: np.ndarray  # int64[3]: code, which state / block / count, stop row
    tfail: np.ndarray   # float64[1]: when it failed, s


class Glue(NamedTuple):
    """A diagram's equations as the core calls them (generated per diagram, or closures).

    Every function takes ``(t, x, ...)`` then the run's arrays ``y`` (every output
    element), ``z`` (every discrete state), ``pf`` / ``pi`` (the blocks' numbers,
    floats and integers) and writes in place. ``due[k]`` is the row of the stop: the
    discrete blocks due. (Whole arrays and offsets are passed, never views. The compiled
    core passes each array as its data pointer, which the generated glue views again with
    the sizes it knows: :data:`hybridsim.engine.native.CORE_TAIL`'s ``glue_*`` adapters.)
    """

    outputs: Callable   # (t, x, y, z, pf, pi, due, k) -> block with a non-finite output, or -1
    update: Callable    # (t, x, y, z, pf, pi, due, k) -> block with a non-finite new state, or -1
    rhs: Callable       # (t, x, dx, at, y, z, pf, pi): derivatives into dx[at:at + n]
    zc: Callable        # (t, x, g, y, z, pf, pi): located event functions
    act: Callable       # (t, x, xn, fired, y, z, pf, pi) -> GO or STOP: the state after the actions
    observe: Callable   # (t, x, y, z, pf, pi) -> block with a non-finite logged output, or -1
    next_time: Callable  # (t, x, y, z, pf, pi) -> the next time event after t (inf: none)
    timed: Callable     # (t, x, xn, y, z, pf, pi) -> GO or STOP: the state after the time events at t
    stepped: Callable   # (t, x, y, z, pf, pi) -> GO, STEP_EVENT or STOP, after every accepted step
    # a compiled glue's own Runge-Kutta steps, its right-hand side inlined (rk_code.glue_steps_lines);
    # the compiled core takes every step and restep through it and never calls that glue's rhs
    steps: Callable = None  # (num, t_lim, x, xn, kk, xs, xm, y, z, pf, pi) -> t_end


class Ops(NamedTuple):
    """A stepper: how the core takes steps (Runge-Kutta here; scipy's solvers in Python).

    ``s`` is the stepper's own record (``s.num`` a float64 array of its numbers);
    ``begin`` starts an integration at (t0, x) that must stop at t1 (``times[j:j1]``:
    the log times ahead, for a stepper that serves them itself); ``step`` takes one
    accepted step from ``x`` into ``xn`` and returns its end time (NaN: the solver
    failed); ``steps`` takes as many steps as end at or before ``t_lim`` (at least
    one) and returns the end time; ``dense`` the state at ``t`` inside the last step;
    ``restep`` one fresh step of ``hh`` s from the last step's start, False where the
    stepper cannot; ``rewind`` puts the stepper back to the start of the last
    ``steps`` (False: it cannot). The steppers call ``gl.rhs`` for the derivatives (the
    compiled core's Runge-Kutta steps call ``gl.steps``, the glue's own).
    """

    begin: Callable    # (s, t0, t1, x, times, j, j1)
    step: Callable     # (s, x, xn, w, gl, y, z, pf, pi) -> t_end of the step
    steps: Callable    # (s, t_lim, x, xn, w, gl, y, z, pf, pi) -> t_end
    dense: Callable    # (s, t, x, w, xo)
    restep: Callable   # (s, hh, x, w, gl, y, z, pf, pi, xr) -> bool
    rewind: Callable   # (s) -> bool
