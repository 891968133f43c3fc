"""Advance a system in time: sample hits, zero-order hold, integration, logging.

At each sample hit (tick ``n``, time ``n * base``):

1. outputs are computed in dependency order for every block that is not
   discrete and for the discrete blocks due at this tick (the others hold
   their last outputs: zero-order hold);
2. logged signals due at this tick are recorded;
3. due discrete blocks update their states (``update``), in order;
4. the continuous states are integrated to the next hit, with the held
   discrete outputs constant over the interval (the right-hand side evaluates
   only ``system.rhs_path``).

Ticks run at ``0 <= n * base < t_end``; the run ends with the state at
``t_end``.
"""
import time as _time
from typing import NamedTuple

import numpy as np

from hybridsim.engine import events as _events
from hybridsim.errors import DiagramError, InputError, SimulationError, StopRequest
from hybridsim.engine.result import Result, parse_signal
from hybridsim.engine.schedule import Schedule
from hybridsim.engine.solvers import RK4


class Simulator:
    """Runs a :class:`~hybridsim.engine.system.System`.

    Parameters
    ----------
    system : System
    solver : RK4 or ScipySolver, optional
        Integrator for the continuous states (default ``RK4(1e-4)``).
    log : list of str
        Output references ``block.port`` to record. The inputs of blocks
        with ``log_inputs`` (recorders) are added automatically.
    log_period : float or Fraction, optional
        Recording interval in s (default 0.5 ms). Sample hits do not add
        extra rows; every row is on this grid.
    max_state : float
        A continuous state larger than this in magnitude (or not finite) after
        any accepted step stops the run with :class:`SimulationError`; so does
        a non-finite block output (unless the block sets ``may_be_nonfinite``).
    progress : bool
        Show a progress bar (tqdm) on runs that last more than a second.
    fused : bool
        With RK4 and kernels in every block on the right-hand side, integrate with
        one generated function (:mod:`hybridsim.engine.fused`): same numbers, several
        times faster. ``False`` forces the generic path.
    locate_switches : bool
        With a fixed-step method, also locate every zero crossing without a
        reset (stick/slip, contact make/break) and restart the step grid
        there, as events with resets always are (default False: stepped over;
        the scipy solvers always locate them).
    compiled : bool
        Run the whole loop compiled with numba (:mod:`hybridsim.engine.compiled`):
        RK4 only, every block with kernels; raises
        :class:`~hybridsim.errors.CompiledPathError` otherwise. The first run of
        a diagram structure compiles (seconds; cached on disk after that).
    """

    def __init__(self, system, solver=None, log=(), log_period=0.0005,
                 max_state=1e6, progress=False, fused=True, compiled=False, locate_switches=False):
        from hybridsim.engine.block import to_period

        self.system = system
        self.solver = solver or RK4()
        self.log_period = to_period(log_period, "log period")
        self.max_state = float(max_state)
        self.progress = progress
        refs = []
        for ref in log:
            base, _ = parse_signal(ref)
            if base not in refs:
                refs.append(base)
        for i, b in enumerate(system.blocks):
            if b.log_inputs:
                for k, (a, o) in enumerate(system.sources[i]):
                    r = f"{system.blocks[a].name}.{system.blocks[a].outputs[o].name}"
                    if r not in refs:
                        refs.append(r)
        for r in refs:
            try:
                system.port_ref(r)
            except (KeyError, AttributeError, ValueError):
                raise DiagramError([f"cannot log {r!r}: no such output"], system.source) from None
        self.log_refs = refs
        self._log_ports = [system.port_ref(r) for r in refs]
        self.log_path = system.evaluation_path({i for i, _ in self._log_ports})
        from hybridsim.engine import fused as _fused

        self.located = located_events(system, self.solver, locate_switches)

        self._fused = (_fused.build(system, self.solver, self.located)
                       if fused and not system.after_step and _fused.eligible(system, self.solver) else None)
        self._compiled = None
        if compiled:
            from hybridsim.engine.compiled import CompiledLoop

            self._compiled = CompiledLoop(system, self.solver, self._log_ports, self.log_path, self.located,
                                          self.log_period)

    # -- the right-hand side ----------------------------------------------------
    def _bind(self, ctx):
        """Build rhs(t, x) and events(t, x) closures over one context (and its blocks).

        ``events`` holds the zero crossings that only restart a solver (blocks
        without actions); ``ctx.events`` (an :class:`~hybridsim.engine.events.EventSet`,
        or None) the events with resets and the time events.
        """
        sysm, blocks = self.system, ctx.blocks
        y, u, xd, n_x = ctx.y, ctx.u, ctx.xd, sysm.n_x
        steps = [(blocks[i].output, sysm.xslices[i], u[i], y[i], xd[i]) for i in sysm.rhs_path]
        ders = [(blocks[i].derivatives, sysm.xslices[i], u[i]) for i in sysm.stateful]

        def outputs(t, x):
            for out, s, ui, yi, xdi in steps:
                vals = out(t, x[s] if s is not None else xdi, ui)
                for buf, v in zip(yi, vals):
                    buf[:] = v

        def rhs(t, x):
            outputs(t, x)
            dx = np.empty(n_x)
            for der, s, ui in ders:
                dx[s] = der(t, x[s], ui)
            return dx

        evs = [(blocks[i].zero_crossings, sysm.xslices[i], u[i], xd[i]) for i in sysm.events
               if i not in self.located]
        ctx.events = None
        if self.located or sysm.time_events or sysm.after_step:
            from hybridsim.engine.events import EventSet

            ctx.events = EventSet(sysm, ctx, outputs, self.located)

        def events(t, x):
            rhs(t, x)
            return np.concatenate([
                np.atleast_1d(zc(t, x[s] if s is not None else xdi, ui)) for zc, s, ui, xdi in evs
            ])

        return rhs, (events if evs else None)

    # -- the run ------------------------------------------------------------------
    def run(self, t_end, context=None, params=None):
        """Simulate from t = 0 to ``t_end`` s; return a :class:`Result`.

        ``params``: ``{"block.param": value}`` for this run only, without
        rebuilding the system (or the compiled module): the blocks named are
        rebuilt with :meth:`~hybridsim.engine.block.Block.with_params`, which refuses
        a change of structure (a width, a rate). The result's context holds the
        state at ``t_end``, the held outputs of discrete blocks and every other
        output evaluated at ``t_end``.
        """
        t_end = self._check_t_end(t_end)
        if context is not None and params:
            raise InputError("give run-time params or a context, not both (the context holds its blocks)")
        ctx = context or self.system.create_context(params)
        return self._run(ctx, self._stops(t_end), t_end)

    def run_batch(self, t_end, param_sets, workers=None):
        """Run once per entry of ``param_sets`` (each ``{"block.param": value}``); a list of Results.

        One built system for every run: on the compiled path the runs share
        one compiled module and run on ``workers`` threads (default: one per
        core; the compiled loop releases the GIL), with no process started per
        run. Elsewhere they run one after the other. A run that diverges gives
        its :class:`~hybridsim.errors.SimulationError` in place of a Result.
        """
        import os
        from concurrent.futures import ThreadPoolExecutor

        t_end = self._check_t_end(t_end)
        stops = self._stops(t_end)
        contexts = [self.system.create_context(p) for p in param_sets]  # bad params: raise here

        def one(ctx):
            try:
                return self._run(ctx, stops, t_end, progress=False)
            except SimulationError as exc:
                return exc

        workers = workers or os.cpu_count() or 1
        if self._compiled is None or workers == 1 or len(contexts) < 2:
            return [one(c) for c in contexts]
        with ThreadPoolExecutor(workers) as pool:
            return list(pool.map(one, contexts))

    def _check_t_end(self, t_end):
        t_end = float(t_end)
        if not (t_end > 0 and np.isfinite(t_end)):
            raise InputError(f"end time must be positive and finite, got {t_end!r}")
        return t_end

    def _stops(self, t_end):
        sysm = self.system
        blocks, discrete = sysm.blocks, sysm.discrete
        sched = Schedule(
            [(blocks[i].period, blocks[i].time_offset) for i in discrete] + [(self.log_period, 0)],
            [blocks[i].name for i in discrete] + ["log"],
        )
        return _stops(sched, t_end, len(discrete))

    def _run(self, ctx, stops, t_end, progress=None):
        """One run from ``ctx`` over ``stops`` (see :meth:`run`)."""
        sysm, blocks = self.system, ctx.blocks
        rhs, events = self._bind(ctx)
        progress = self.progress if progress is None else progress
        bar = _progress(t_end) if progress else None
        wall0 = _time.perf_counter()
        try:
            if self._compiled is not None:
                saved = _snapshot(ctx)
                try:
                    rows_t, rows, hits = self._compiled.run(ctx, stops, t_end, self._final_record(t_end),
                                                            self.max_state)
                    failed = not np.isfinite(rows).all()
                except SimulationError:
                    failed = True
                if failed:  # the Python loop (the same numbers) says where and why, at its step
                    _restore(ctx, saved)
                    rows_t, rows, hits = self._loop(ctx, self._walk(stops, t_end), rhs, events, bar, t_end)
                hits = dict(hits)
            else:
                rows_t, rows, hits = self._loop(ctx, self._walk(stops, t_end), rhs, events, bar, t_end)
            if ctx.stopped is not None:  # a block ended the run: the results so far
                t_end = ctx.stopped.t
            else:  # the context ends consistent: every output not held, evaluated at t_end
                ctx.evaluate([i for i in range(len(blocks)) if sysm.kind[i] != "discrete"], t_end, ctx.xc)
        finally:
            if bar is not None:
                bar.close()
            for b in blocks:
                b.release()
        ctx.t = t_end
        wall = _time.perf_counter() - wall0
        return self._result(rows_t, rows, ctx, t_end, wall, hits)

    def _walk(self, stops, t_end):
        """The hits of a run in order, as ``(t, due, record, t_out, t_next)``.

        ``due``: the discrete blocks due at ``t``; ``record``: a log row at
        ``t``; ``t_out``: the log times between ``t`` and the next hit
        ``t_next`` (``t_end`` after the last hit).
        """
        discrete = self.system.discrete
        starts = np.flatnonzero(stops.hit).tolist() + [len(stops.times)]
        times = stops.times.tolist()
        for a, b in zip(starts[:-1], starts[1:]):
            due_now = frozenset(discrete[j] for j in np.flatnonzero(stops.due[a]))
            yield times[a], due_now, bool(stops.record[a]), times[a + 1:b], (times[b] if b < len(times) else t_end)

    def divergence_check(self, ctx):
        """``check(t, x)``, called with the state after every accepted step: raises
        :class:`~hybridsim.errors.SimulationError` naming the state and block when a state is not
        finite or exceeds ``max_state``. ``check.ok(x)`` tests without raising; ``check.blame(t, x)``
        names the block whose output was not finite."""
        plan, max_state = self.system.plan, self.max_state

        def check(tb, xb):
            if not np.max(np.abs(xb)) <= max_state:
                plan.check_continuous(xb, tb, max_state, ctx)

        check.blame = lambda tb, xb: plan.blame(ctx, tb, xb)
        check.ok = lambda xb: np.max(np.abs(xb)) <= max_state  # False for NaN
        return check

    def _loop(self, ctx, walk, rhs, events, bar, t_end):
        """The tick loop of :meth:`run`; returns (times, rows, hits per block)."""
        sysm, plan = self.system, self.system.plan
        blocks, discrete = ctx.blocks, sysm.discrete
        rows_t, rows = [], []
        hits = {blocks[i].name: 0 for i in discrete}

        def record(t):
            rows_t.append(t)
            row = np.concatenate([ctx.y[i][o] for i, o in self._log_ports]) if self._log_ports else np.zeros(0)
            rows.append(row)
            return row

        try:
            self._hits(ctx, walk, rhs, events, bar, t_end, plan, blocks, hits, record)
        except StopRequest as stop:
            ctx.stopped = stop
            if stop.x is not None:
                ctx.xc = np.asarray(stop.x, float)
        return rows_t, rows, hits

    def _hits(self, ctx, walk, rhs, events, bar, t_end, plan, blocks, hits, record):
        """The hits of :meth:`_loop` in order (a :class:`StopRequest` ends them)."""
        sysm = self.system
        xc = ctx.xc
        check = self.divergence_check(ctx)

        log_checked = plan.checked_outputs(self.log_path)

        def observe(tb, xb):  # with events: recorded in order, before the next event's actions
            ctx.evaluate(self.log_path, tb, xb)
            if not np.isfinite(record(tb)).all():  # a logged value: name the block it came from
                plan.check_outputs(ctx, log_checked, tb)

        with np.errstate(over="ignore", invalid="ignore"):
            for t, due, log_here, t_out, t_next in walk:
                plan.outputs(ctx, t, xc, due)
                plan.check_outputs(ctx, plan.hit_checked(due), t)
                if log_here:
                    record(t)
                for i, x in plan.updates(ctx, t, due):
                    ctx.xd[i] = x  # a copy: never a wire's buffer
                    hits[blocks[i].name] += 1
                    plan.check_discrete(i, x, t)
                if sysm.n_x:
                    if ctx.events is not None:
                        xc, _ = _events.integrate(self._stepper(ctx), rhs, ctx.events, t, t_next, xc, t_out,
                                                  observe, check, mute=not hasattr(self.solver, "dense"))
                        xs, t_out = [], ()
                    elif self._fused is not None:
                        xc, xs = self._advance_fused(ctx, t, t_next, xc, t_out, check)
                    else:
                        xc, xs = self.solver.advance(rhs, t, t_next, xc, t_out, events, check=check)
                    plan.check_continuous(xc, t_next, self.max_state, ctx)
                else:
                    xs = [xc] * len(t_out)
                for tb, xb in zip(t_out, xs):
                    observe(tb, xb)
                ctx.xc = xc
                if bar is not None:
                    bar.update(t_next - bar.n)
            if self._final_record(t_end):
                observe(t_end, xc)

    def _final_record(self, t_end):
        """A row at t_end when it lies on the log grid (the hits stop before it)."""
        return _on_grid(t_end, float(self.log_period))

    def _result(self, rows_t, rows, ctx, t_end, wall, hits):
        blocks = self.system.blocks
        data = np.asarray(rows, float) if len(rows) else np.zeros((0, 0))  # the compiled log: no copy
        signals, col = {}, 0
        for ref, (i, o) in zip(self.log_refs, self._log_ports):
            w = blocks[i].outputs[o].width
            signals[ref] = data[:, col:col + w] if data.size else np.zeros((0, w))
            col += w
        stopped = ctx.stopped
        meta = {"diagram": self.system.name, "solver": repr(self.solver), "t_end": t_end,
                "stopped": None if stopped is None else
                {"t": stopped.t, "block": stopped.block, "reason": stopped.reason},
                "wall_time_s": wall, "hits": hits,
                "events": list(ctx.events.log) if ctx.events is not None else []}
        return Result(np.array(rows_t), signals, meta, context=ctx)

    def _stepper(self, ctx):
        """What the event loop steps with: the solver, or the fused path's generated steps."""
        if self._fused is None:
            return self.solver
        from hybridsim.engine.fused import FusedStepper

        advance, held = self._fused
        return FusedStepper(self.solver, advance, tuple(tuple(ctx.y[a][o].tolist()) for a, o in held), ctx.params)

    def _advance_fused(self, ctx, t0, t1, x, t_out, check=None):
        """The solver's steps over [t0, t1] with the generated fused stepper; states at t_out
        from its dense output (the same step grid whatever is logged). ``check``: the
        divergence check, on the final state; when it fails the interval is stepped again
        one step at a time (the same numbers) so that it fails at the first bad step."""
        from hybridsim.engine.solvers import observation, steps

        (advance, advance_obs), held = self._fused
        H = tuple(tuple(ctx.y[a][o].tolist()) for a, o in held)
        P = ctx.params
        X = tuple(x.tolist())
        n = steps(t0, t1, self.solver.step)
        h = (t1 - t0) / n
        outs, k, after = [], 0, None  # X: the state at the start of step k; after: at its end
        with np.errstate(over="ignore", invalid="ignore"):
            for tb in t_out:
                kb, theta = observation(t0, h, n, tb)
                if after is not None and kb != k:
                    X, k, after = after, k + 1, None
                if theta == 0.0:
                    X = advance(t0, h, k, kb, X, H, P)
                    k = kb
                    outs.append(np.array(X))
                    continue
                after, X, Xo = advance_obs(t0, h, k, kb + 1, X, H, kb, self.solver.dense_weights(theta), P)
                k = kb
                outs.append(np.array(Xo))
            if after is not None:
                X, k = after, k + 1
            X = advance(t0, h, k, n, X, H, P)
            if check is not None and not check.ok(np.array(X)):
                X = tuple(x.tolist())
                for k in range(n):
                    X = advance(t0, h, k, k + 1, X, H, P)
                    check(t0 + (k + 1) * h, np.array(X))
        return np.array(X), outs


def located_events(system, solver, locate_switches=False):
    """The blocks whose events ``solver`` locates: those with resets, and on the scipy solvers
    (or with ``locate_switches``) every block with zero crossings."""
    from hybridsim.engine.solvers import ExplicitRK

    located = list(system.action_events)
    if locate_switches or not isinstance(solver, ExplicitRK):
        located += [i for i in system.events if i not in located]
    return located


def _snapshot(ctx):
    """Copies of a context's numbers (states, wires, event log)."""
    return (ctx.xc.copy(), [x.copy() for x in ctx.xd], [[v.copy() for v in vals] for vals in ctx.y])


def _restore(ctx, saved):
    """Put back what :func:`_snapshot` took (the wire buffers in place: inputs alias them)."""
    xc, xd, y = saved
    ctx.xc, ctx.xd = xc.copy(), [x.copy() for x in xd]
    for vals, old in zip(ctx.y, y):
        for v, o in zip(vals, old):
            v[:] = o
    if ctx.events is not None:
        ctx.events.log = []


class Stops(NamedTuple):
    """Where a run stops before ``t_end``: sample hits and log points, in order."""

    times: np.ndarray   # s
    due: np.ndarray     # due[k, j]: discrete block j (in system.discrete order) due at stop k
    hit: np.ndarray     # a sample hit (a full pass); else a log point between hits
    record: np.ndarray  # a log row at this stop


def _stops(sched, t_end, n_discrete):
    """The :class:`Stops` of ``sched`` (discrete blocks' timings, then the log's) before ``t_end``."""
    ticks, due = sched.hits(sched.last_tick_before(t_end))
    hit = due[:, :n_discrete].any(axis=1)
    hit[0] = True  # the first pass of a run, due or not
    return Stops(sched.time(ticks), due[:, :n_discrete], hit, due[:, n_discrete])


def _on_grid(t, period):
    """True when ``t`` is a whole number of ``period`` (to 1e-9 of a period)."""
    k = round(t / period)
    return abs(k * period - t) <= 1e-9 * period


def _progress(total):
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover
        return None
    return tqdm(total=total, unit="s sim", delay=1.0, leave=False, disable=not on_terminal(),
                bar_format="{l_bar}{bar}| {n:.2f}/{total:.2f} s [{elapsed}<{remaining}]")


def on_terminal():
    """True when stderr is a terminal: progress bars only there (a log file gets no
    carriage-return frames)."""
    import sys

    return bool(getattr(sys.stderr, "isatty", lambda: False)())
