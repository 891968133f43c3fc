"""The stops of a run as the stepping core walks them (:class:`~.stepping.Timeline`).

Sample hits of the discrete blocks and the log grid are merged on one
integer tick grid (:class:`~hybridsim.engine.schedule.Schedule`: exact
times, coincident hits coincide), then written as arrays: the stop times,
their kind (a hit, a log point between hits, the end), which discrete blocks
are due, which log row each writes and where each interval ends.
"""
import numpy as np

from hybridsim.engine.schedule import Schedule
from hybridsim.engine.stepping import END, END_LOG, HIT, LOG, Timeline


def schedule(system, log_period):
    """The :class:`Schedule` of the discrete blocks' sample times and the log grid (its columns in
    that order); raises :class:`~hybridsim.errors.RateError` where they share no small base tick."""
    blocks = [system.blocks[i] for i in system.discrete]
    return Schedule([(b.period, b.time_offset) for b in blocks] + [(log_period, 0)],
                    [b.name for b in blocks] + ["log"])


def timeline(system, log_period, t_end, logged=True):
    """The :class:`Timeline` of a run of ``system`` to ``t_end`` s, logged every ``log_period`` s.

    Ticks run at ``0 <= t < t_end``; the run ends with a row at ``t_end``, logged
    whether or not ``t_end`` lies on the log grid. The first row is always a hit (the
    first pass of a run evaluates every block, due or not). ``logged=False``: the
    hits and the end only, no row logged (a run for its final state).
    """
    sched = schedule(system, log_period)
    ticks, due = sched.hits(sched.last_tick_before(t_end))
    d = len(system.discrete)
    hit = due[:, :d].any(axis=1)
    hit[0] = True
    if not logged:
        return build(sched.time(ticks)[hit], hit[hit], due[hit, :d], np.zeros(int(hit.sum()), bool), t_end)
    log_end = True  # the last row is at t_end, on the log grid or not (as Simulink logs its stop time)
    return build(sched.time(ticks), hit, due[:, :d], due[:, d], t_end, log_end)


def build(times, hit, due, record, t_end, log_end=False):
    """A :class:`Timeline` from stops before ``t_end`` (``times``, whether each is a ``hit``, the
    blocks ``due`` and whether it is ``record``-ed) and the end row."""
    m = len(times)
    t = np.append(np.asarray(times, float), float(t_end))
    kind = np.append(np.where(hit, HIT, LOG), END_LOG if log_end else END).astype(np.int64)
    due = np.ascontiguousarray(np.vstack([np.asarray(due, bool).reshape(m, -1),
                                          np.zeros((1, np.shape(due)[1] if m else 0), bool)]))
    rec_mask = np.append(np.asarray(record, bool), bool(log_end))
    rec = np.where(rec_mask, np.cumsum(rec_mask) - 1, -1).astype(np.int64)
    hits = np.flatnonzero(kind == HIT)
    nxt = np.zeros(m + 1, dtype=np.int64)
    nxt[hits] = np.append(hits[1:], m)
    return Timeline(t, kind, due, rec, nxt)


def rows(tl):
    """The number of log rows a run over ``tl`` writes."""
    return int((tl.rec >= 0).sum())


def window(system, t0, t1, due_at):
    """The stops of one stretch from ``t0`` to ``t1`` (an exported FMU's communication step): a hit
    at ``t0`` and at every sample hit inside, none logged. ``due_at(t)``: the discrete blocks (as
    positions in ``system.discrete``) due at a hit time ``t``; returns ``(timeline, hit times)``."""
    times = [t0]
    while True:
        nxt = due_at.next_after(times[-1])
        if not nxt < t1 - 1e-9 * (t1 - t0):
            break
        times.append(nxt)
    d = len(system.discrete)
    due = np.zeros((len(times), d), bool)
    for r, tt in enumerate(times):
        for j in due_at(tt):
            due[r, j] = True
    return build(times, np.ones(len(times), bool), due, np.zeros(len(times), bool), t1)
