"""Advance a system in time: the runs of one built system, on one of three paths.

Every path walks the same stops with the same algorithm, the stepping core
(:mod:`hybridsim.engine.stepping`): at each sample hit the outputs are
computed in dependency order (held, zero-order hold, by the discrete blocks
not due), the log row is recorded, the due blocks update; between hits the
continuous states are integrated with events located and log points read
from the solver's dense output. The paths differ in who computes the
equations:

* generic: the blocks' methods (:mod:`hybridsim.engine.glue`), any solver;
* fused: generated Python from the blocks' kernels (:mod:`hybridsim.engine.fused`),
  fixed-step Runge-Kutta; the same numbers, several times faster;
* compiled: the same glue generated for numba, the core compiled once per
  machine (:mod:`hybridsim.engine.compiled`); the same numbers again.

Ticks run at ``0 <= n * base < t_end``; the run ends with the state at
``t_end``.
"""
import logging
import time as _time
from collections.abc import Mapping
from numbers import Real

import numpy as np

from hybridsim.engine import arguments
from hybridsim.engine import events as _events
from hybridsim.engine import stepping
from hybridsim.engine.context import Context
from hybridsim.engine.glue import GenericGlue, state_derivatives
from hybridsim.engine.result import Result
from hybridsim.engine.solvers import RK4, ExplicitRK, limits, outputs, work
from hybridsim.engine.timeline import rows, schedule, timeline
from hybridsim.errors import InputError, SimulationError, StopRequest

#: events whose times and blocks a run keeps for ``meta["events"]``
MAX_EVENT_LOG = 200_000


_log = logging.getLogger(__name__)


class Simulator:
    """Runs a :class:`~hybridsim.engine.system.System`.

    Parameters
    ----------
    system : System
    solver : RK4, Heun, ScipySolver or CVode, optional
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
        With a fixed-step Runge-Kutta method and kernels in every block on the
        right-hand side, integrate with generated Python (:mod:`hybridsim.engine.fused`):
        same numbers, several times faster. ``False`` forces the generic path.
    compiled : bool
        Run compiled with numba (:mod:`hybridsim.engine.compiled`): a fixed-step
        Runge-Kutta method, every block with kernels; raises
        :class:`~hybridsim.errors.CompiledPathError` otherwise. A new diagram
        structure compiles its glue once (cached on disk).
    locate_switches : bool
        With a fixed-step method, also locate every zero crossing without a
        reset (stick/slip, contact make/break) and restart the step grid
        there, as events with resets always are (default False: stepped over;
        the variable-step solvers always locate them).
    aliases : dict, optional
        Other names of logged outputs, ``{"ctrl.tau": "ctrl.sum.y"}``: a result answers to
        both (:class:`~hybridsim.engine.result.Result`).
    """

    def __init__(self, system, solver=None, log=(), log_period=0.0005,
                 max_state=1e6, progress=False, fused=True, compiled=False, locate_switches=False, aliases=None):
        from hybridsim.engine.block import to_period

        log = arguments.checked(system, solver, log)
        self._made = dict(log=log, log_period=log_period, max_state=max_state, locate_switches=locate_switches,
                          aliases=aliases)
        self.aliases = arguments.aliases(aliases)
        progress, fused, compiled, locate_switches = (
            arguments.flag(k, v) for k, v in (("progress", progress), ("fused", fused), ("compiled", compiled),
                                              ("locate_switches", locate_switches)))
        self.system = system
        self.solver = solver or RK4()
        self.log_period = to_period(log_period, "log period")
        schedule(system, self.log_period)  # rates the log cannot share are refused here (a check sees it)
        self.max_state = arguments.max_state(max_state)
        self.progress = progress
        refs = arguments.log_refs(system, log)
        self.log_refs = refs
        self._log_ports = [system.port_ref(r) for r in refs]
        ys, blocks = system.yslices, system.blocks
        #: the elements of the wire vector that the log's columns copy
        self._log_columns = np.array([j for i, o in self._log_ports for j in range(ys[i][o].start, ys[i][o].stop)],
                                     np.int64)
        #: which discrete states ``max_state`` bounds (over ``z``)
        self._bounded = np.repeat([b.discrete_bounded for b in blocks], [b.n_discrete for b in blocks]).astype(bool)
        self.log_path = system.evaluation_path({i for i, _ in self._log_ports})
        self.located = _events.located_events(system, self.solver, locate_switches)
        self._timelines = {}
        self._step_checked = False
        self._compiled = self._twin = self._fused_code = None
        self._fusable = False
        if compiled:
            from hybridsim.engine.compiled import CompiledGlue

            self._compiled = CompiledGlue(system, self.solver, self.log_path, self.located)
        elif fused:
            from hybridsim.engine import fused as _fused

            self._fusable = _fused.eligible(system, self.solver)

    @property
    def _fused(self):
        """The fused path's code (None: not fused), written on first use: a check, or an analysis of
        its branches, builds simulators it never runs."""
        if self._fusable and self._fused_code is None:
            from hybridsim.engine import fused as _fused

            self._fused_code = _fused.build(self.system, self.solver, self.located)
        return self._fused_code

    @property
    def path(self):
        """Which path runs: ``"compiled"``, ``"fused"`` or ``"generic"``."""
        return "compiled" if self._compiled is not None else "fused" if self._fusable else "generic"

    # -- the right-hand side, for analysis ------------------------------------------------
    def rhs(self, ctx):
        """``f(t, x)``: the derivatives of the continuous states over ``ctx`` (its held outputs as
        they are), evaluating the blocks the right-hand side needs (the generic path's)."""
        return state_derivatives(self.system, ctx)

    # -- runs ------------------------------------------------------------------------------
    def run(self, t_end, context=None, params=None, logged=True):
        """Simulate from t = 0 to ``t_end`` s; return a :class:`Result`.

        ``params``: ``{"block.param": value}`` for this run only, without
        rebuilding the system (or the compiled glue): the blocks named are
        rebuilt with :meth:`~hybridsim.engine.block.Block.with_params`, which refuses
        a change of structure (a width, a rate). The result's context holds the
        state at ``t_end``, the held outputs of discrete blocks and every other
        output evaluated at ``t_end``. ``logged=False``: no log rows, only that
        state (an operating point), without evaluating the log points (the same
        state bit for bit, but on CVODE, which returns at each log time: within
        its tolerance).
        """
        t_end = self._check_t_end(t_end)
        if context is not None and params:
            raise InputError("give run-time params or a context, not both (the context holds its blocks)")
        ctx, numbers = (context, None) if context is not None else self._context(params)
        return self._run(ctx, self._timeline(t_end, logged), t_end, numbers=numbers)

    def run_batch(self, t_end, param_sets, workers=None):
        """Run once per entry of ``param_sets`` (each ``{"block.param": value}``); a list of Results.

        One built system for every run: on the compiled path the runs share
        the compiled glue and run on ``workers`` threads (default: one per
        core; the compiled core releases the GIL). Elsewhere they run one after
        the other. A run that diverges gives its
        :class:`~hybridsim.errors.SimulationError` in place of a Result.
        """
        import os
        from concurrent.futures import ThreadPoolExecutor

        t_end = self._check_t_end(t_end)
        if isinstance(param_sets, (Mapping, str)) or not hasattr(param_sets, "__iter__"):
            raise InputError(f"param_sets is a list of {{'block.param': value}} mappings, got {param_sets!r}")
        tl = self._timeline(t_end)
        contexts = [self._context(p) for p in param_sets]  # bad params: raise here

        def one(made):
            try:
                return self._run(made[0], tl, t_end, progress=False, numbers=made[1])
            except SimulationError as exc:
                return exc

        workers = workers or os.cpu_count() or 1
        if self._compiled is None or workers == 1 or len(contexts) < 2:
            return [one(c) for c in contexts]
        with ThreadPoolExecutor(workers) as pool:
            return list(pool.map(one, contexts))

    def _context(self, params):
        """``(ctx, numbers)``: a fresh context; on the compiled path its flattened params
        (:meth:`~hybridsim.engine.compiled.CompiledGlue.numbers`) and outputs computed by the glue."""
        if params is not None and not isinstance(params, Mapping):
            raise InputError(f"run-time params are a mapping {{'block.param': value}}, got {params!r}")
        if self._compiled is not None:
            return self._compiled.context(params)
        return self.system.create_context(params), None

    def _check_t_end(self, t_end):
        if not isinstance(t_end, Real) or isinstance(t_end, bool):
            raise InputError(f"end time must be a number of seconds, got {t_end!r}")
        t_end = float(t_end)
        if not (t_end > 0 and np.isfinite(t_end)):
            raise InputError(f"end time must be positive and finite, got {t_end!r}")
        return t_end

    def _timeline(self, t_end, logged=True):
        tl = self._timelines.get((t_end, logged))
        if tl is None:
            arguments.check_size(self, t_end)
            tl = self._timelines[(t_end, logged)] = timeline(self.system, self.log_period, t_end, logged)
        return tl

    # -- one run ------------------------------------------------------------------------
    def session(self, ctx, rows=0, numbers=None):
        """A :class:`Session`: the stepping core set up to advance ``ctx`` (``rows``: log rows it
        may write; ``numbers``: its params as the compiled path flattened them, if it has)."""
        if not self._fits(ctx):
            return Session(self._generic(), ctx, rows)
        return Session(self, ctx, rows, numbers)

    def _fits(self, ctx):
        """True when this simulator's path can run ``ctx``: the generic path runs any context, the
        fused and compiled paths those whose blocks have the kernels the code was written from (an
        exported FMU's input blocks, or a parameter that changes a block's kernels, do not)."""
        if self._compiled is None and self._fused is None:
            return True
        return all(a is b or a.kernels == b.kernels for a, b in zip(ctx.blocks, self.system.blocks))

    def _generic(self):
        """This simulator on the generic path (made once)."""
        if self._twin is None:
            self._twin = Simulator(self.system, self.solver, fused=False, **self._made)
        return self._twin

    def _run(self, ctx, tl, t_end, progress=None, numbers=None):
        if not self._fits(ctx):
            return self._generic()._run(ctx, tl, t_end, progress)
        if self._compiled is None and self._fused is None:
            return self._walk(ctx, tl, t_end, progress)
        if self._compiled is None:
            start = ctx.xc.copy(), ctx.z.copy(), ctx.ywire.copy()
            try:
                return self._walk(ctx, tl, t_end, progress)
            except (ArithmeticError, ValueError) as exc:
                from hybridsim.engine.fused import raised_in_generated_code

                if not raised_in_generated_code(exc):
                    raise
                # Python floats raised where the generic path's float64 arrays give inf or nan
                # (1 / 0.0, an overflow): the same run on the generic path gives the answer, or its error
                _log.debug("the fused path raised %s: %s; the run is repeated on the generic path",
                          type(exc).__name__, exc)
                ctx.xc[:], ctx.z[:], ctx.ywire[:] = start
                ctx.t, ctx.events, ctx.stopped = 0.0, None, None
                return self._generic()._walk(ctx, tl, t_end, progress)
        # a kernel that raises inside compiled code: numba prints it as "ignored" and the run goes on
        blocks, raised = list(ctx.blocks), []
        from hybridsim.engine.compiled import caught_unraisable

        with caught_unraisable(raised):
            try:
                res = self._walk(ctx, tl, t_end, progress, numbers)
            except SimulationError:
                if not raised:
                    raise
        if not raised:
            return res
        # the same run on the Python path says which block raised what (or names its non-finite output)
        self._generic()._walk(Context(self.system, blocks), tl, t_end, False)
        exc = raised[0].exc_value
        raise SimulationError(f"a block's compiled kernel raised {type(exc).__name__}: {exc} (on the Python "
                              "path the same run went through)")

    def _walk(self, ctx, tl, t_end, progress=None, numbers=None):
        sysm = self.system
        if not self._step_checked and isinstance(self.solver, ExplicitRK):
            self._step_checked = True  # once per simulator: a sweep's points share its structure
            from hybridsim.engine.stiffness import check_step

            def owner(k):
                name, j = sysm.state_owner(k)
                return f"state {j} of block {name!r}"

            check_step(self.solver, state_derivatives(sysm, ctx), 0.0, ctx.xc, owner)
        progress = self.progress if progress is None else progress
        run = self.session(ctx, rows(tl), numbers)
        wall0 = _time.perf_counter()
        bar = _progress(t_end) if progress else None
        try:
            code = stepping.OK
            for k0, k1 in _chunks(tl, 100 if bar is not None else 1):
                code = run.walk(tl, k0, k1)
                if code != stepping.OK:
                    break
                if bar is not None:
                    bar.update(tl.t[k1 - 1] - bar.n)
            if code not in (stepping.OK, stepping.STOPPED):
                run.fail(code)
            if code == stepping.STOPPED and run.stop is not None:
                ctx.stopped = run.stop
                t_end = run.stop.t
            elif not (self._compiled is not None
                      and self._compiled.evaluate((run.glue, run.pf, run.pi), t_end, ctx)):
                # the context ends consistent: every output not held, evaluated at t_end
                ctx.evaluate([i for i in range(len(sysm.blocks)) if sysm.kind[i] != "discrete"], t_end, ctx.xc)
        finally:
            if bar is not None:
                bar.close()
            for b in ctx.blocks:
                b.release()
        ctx.t = t_end
        ctx.events = run.event_log()
        last = int(run.out.status[2]) if code != stepping.OK else len(tl.t) - 1
        return self._result(tl, run.out, ctx, t_end, _time.perf_counter() - wall0, last)

    def _machinery(self, ctx, out, numbers=None):
        """``(glue, ops, state, pf, pi, keeper)`` of this simulator's path for ``ctx`` (``keeper``
        keeps the names of blocks acting at time and step events, and a stop request)."""
        if self._compiled is not None:
            glue, ops, s, pf, pi = self._compiled.machinery(ctx, numbers)
            return glue, ops, s, pf, pi, None
        keeper = GenericGlue(self.system, ctx, self.located, self.log_path, out.nev)
        glue = keeper.glue()
        if self._fused is not None:
            glue, ops, s = self._fused.machinery(ctx, glue)
        else:
            ops, s = self.solver.stepper()
        return glue, ops, s, np.zeros(0), np.zeros(0, np.int64), keeper

    def _result(self, tl, out, ctx, t_end, wall, last):
        blocks = self.system.blocks
        n = int(out.nrow[0])
        data = out.log[:n]
        signals, col = {}, 0
        for ref, (i, o) in zip(self.log_refs, self._log_ports):
            w = blocks[i].outputs[o].width
            signals[ref] = data[:, col:col + w]
            col += w
        times = tl.t[tl.rec >= 0][:n]
        upto = last if last < len(tl.t) - 1 else len(tl.t) - 1
        hits = dict(zip((blocks[i].name for i in self.system.discrete), (int(v) for v in tl.due[:upto].sum(axis=0))))
        stopped = ctx.stopped
        meta = {"diagram": self.system.name, "solver": repr(self.solver), "t_end": t_end,
                "stopped": None if stopped is None else
                {"t": stopped.t, "block": stopped.block, "reason": stopped.reason},
                "wall_time_s": wall, "hits": hits, "events": list(ctx.events),
                "sampled": [ref for ref, (i, _) in zip(self.log_refs, self._log_ports)  # held between hits
                            if self.system.kind[i] == "discrete"]}
        return Result(np.array(times), signals, meta, context=ctx, aliases=self.aliases)


class Session:
    """The stepping core set up for one context of a simulator: glue, stepper, buffers.

    :meth:`walk` advances the context over stops of a timeline (a whole run, or an
    exported FMU's communication step at a time); the context's continuous state is
    ``ctx.xc`` before and after. ``out`` holds the log rows and events written.
    """

    def __init__(self, sim, ctx, rows=0, numbers=None):
        self.sim, self.ctx = sim, ctx
        sysm = sim.system
        self.y, self.z = ctx.flat()
        columns = sim._log_columns if rows else []
        timed, stepped = bool(sysm.time_events), bool(sysm.after_step)
        located = sim.located
        sizes, dirs, switch = _events.layout(sysm, ctx, located) if located else ([], None, None)
        owner = np.repeat(np.arange(len(sizes)), sizes) if located else None
        cap = MAX_EVENT_LOG if (located or timed or stepped) else 0
        self.out = outputs(rows, len(columns), cap, len(located), columns)
        self.glue, self.ops, self.s, self.pf, self.pi, self.keeper = sim._machinery(ctx, self.out, numbers)
        self.w = work(sysm.n_x, getattr(self.s, "c", np.zeros(1)).size, int(sum(sizes)), dirs, switch, owner,
                      sim._bounded, sysm.x_bounded)
        variable = not isinstance(sim.solver, ExplicitRK)
        # steps in batches: a fixed-step method between checks; a solver that returns its own points
        batch = (not variable and not located and not timed) or getattr(sim.solver, "returns_points", False)
        self.lim = limits(sim.max_state, scan=getattr(sim.solver, "scan", 1e-3), stepped=stepped, timed=timed,
                          batch=batch and not stepped, max_repeats=_events.MAX_REPEATS if variable or located else 0,
                          crawl=variable and not getattr(sim.solver, "returns_points", False))
        self._run = sim._compiled.run if sim._compiled is not None else stepping.run

    @property
    def stop(self):
        """A block's request that ended the walk (a :class:`~hybridsim.errors.StopRequest`), or None."""
        return self.keeper.stop if self.keeper is not None else None

    def walk(self, tl, k0=0, k1=None):
        """Advance over stops ``k0 .. k1 - 1`` of ``tl``; returns the status code (0: done). The
        context's state is updated (on a stop request: the state where it stopped)."""
        k1 = len(tl.t) if k1 is None else k1
        self.w.x[:] = self.ctx.xc
        try:
            with np.errstate(all="ignore"):
                code = self._run(tl, k0, k1, self.glue, self.ops, self.s, self.lim, self.w, self.out,
                                 self.y, self.z, self.pf, self.pi)
        except StopRequest as stop:  # a block ended the run from its outputs or updates (a CS FMU)
            self.keeper.stop = stop
            code = stepping.STOPPED
        self.ctx.xc = self.w.x.copy()
        if code == stepping.STOPPED and self.stop is not None and self.stop.x is not None:
            self.ctx.xc = np.asarray(self.stop.x, float)
        return code

    def event_log(self):
        """``[(t, block names)]`` of the events so far, in order: one entry per instant (events
        within ``10 time_tol`` of each other, the core's measure of one instant, are one entry
        naming every block that acted)."""
        names = [self.sim.system.blocks[i].name for i in self.sim.located]
        out, log = self.out, []
        same = 10.0 * self.lim.time_tol
        for k in range(min(int(out.nev[0]), out.evt.size)):
            acting = {names[b] for b in np.flatnonzero(out.evb[k])} if names else set()
            if self.keeper is not None:
                acting |= self.keeper.names.get(k, set())
            t = float(out.evt[k])
            if log and t - log[-1][0] <= same:
                log[-1] = (log[-1][0], tuple(sorted(acting | set(log[-1][1]))))
            else:
                log.append((t, tuple(sorted(acting))))
        return log

    def fail(self, code):
        """Raise the :class:`SimulationError` of a failed walk (:func:`~.failures.explain`)."""
        from hybridsim.engine.failures import explain

        explain(self, code)


def _chunks(tl, pieces):
    """``(k0, k1)`` ranges of the timeline's rows, cut at hits into about ``pieces`` parts."""
    m = len(tl.t)
    if pieces <= 1:
        return [(0, m)]
    from hybridsim.engine.stepping import HIT

    hits = np.flatnonzero(tl.kind == HIT)
    cuts = sorted({int(hits[int(q)]) for q in np.linspace(0, len(hits) - 1, pieces + 1)[1:-1]} - {0})
    bounds = [0] + cuts + [m]
    return list(zip(bounds[:-1], bounds[1:]))


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


located_events = _events.located_events  # where api.check finds it
