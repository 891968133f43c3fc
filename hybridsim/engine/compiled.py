"""The compiled path: a whole run as one numba-compiled loop.

``compiled: true`` (YAML ``simulation``, CLI ``--compiled``, or
``Simulator(compiled=True)``) generates, for one system, a Python module with
the fused right-hand side and the solver's stepper of :mod:`hybridsim.engine.fused`
(``advance``, ``observe``; from the method's tableau), and ``run``, the simulator's tick loop written out
for this diagram: every signal element is a local float, every block a call
of its kernel (:mod:`hybridsim.engine.kernels`) - and compiles them with numba in
nopython mode. The blocks' Python kernels are the very code that gets
compiled, and the generic path stays the reference the tests compare with.

Python walks the schedule first (the same walk as the generic loop: hits,
log points, step counts, where each log point lies on the step grid and its
dense-output weights) and hands it over as arrays, so the compiled loop does
no rational arithmetic. Block parameters are arguments, not constants,
so one compiled module serves every parameter value of a diagram's structure;
modules and numba's machine code are cached on disk (``HYBRIDSIM_CACHE``,
default ``~/.cache/hybridsim``), keyed by the generated source and the
kernels' source text.

Needs: a fixed-step Runge-Kutta solver (:class:`~hybridsim.engine.solvers.ExplicitRK`:
RK4, Heun), and kernels in every block that computes something (FMU blocks
have none). Discontinuities are stepped over, as on the other RK paths.
"""
import functools
import hashlib
import math
import importlib.util
import inspect
import logging
import os
import re
import sys
import warnings
from pathlib import Path

import numpy as np

from hybridsim.errors import CompiledPathError, SimulationError
from hybridsim.engine.fused import event_kernels, event_sizes, has_kernels, rk_source
from hybridsim.engine.solvers import ExplicitRK, observations, steps_between
from hybridsim.engine.kernels import marked
from hybridsim.engine.rk_code import tuple_source

log = logging.getLogger(__name__)
_loaded = {}        # source hash -> compiled run function (this process)
_registered = set()  # kernels registered with numba


def problems(system, solver, located=None):
    """Why ``system`` cannot run compiled with ``solver`` (empty list: it can)."""
    located = system.action_events if located is None else located
    out = []
    if not isinstance(solver, ExplicitRK):
        out.append("the compiled path integrates with a fixed-step Runge-Kutta method (rk4, heun); "
                   f"this diagram's solver is {solver!r}")
    missing = [f"{b.name} ({type(b).__name__})" for b in system.blocks
               if (b.outputs or b.n_continuous or b.n_discrete) and not has_kernels(b)]
    if missing:
        out.append("these blocks have no kernels (hybridsim.engine.kernels) to compile: " + ", ".join(missing))
    python = [b.name for b in system.blocks if b.kernels is not None and b.kernels.python_only]
    if python:
        out.append("these blocks' kernels call Pinocchio, which numba cannot compile (they run on the "
                   "fused path): " + ", ".join(python))
    timed = [system.blocks[i].name for i in system.time_events]
    if timed:
        out.append("time events (next_event_time) are not on the compiled path yet: " + ", ".join(timed))
    no_events = [system.blocks[i].name for i in located if not event_kernels(system.blocks[i])]
    if no_events:
        out.append("these blocks give their events as methods, not kernels (zero_crossings, "
                   "event_action): " + ", ".join(no_events))
    return out


def cache_dir():
    """Where generated modules and numba's cache live."""
    root = os.environ.get("HYBRIDSIM_CACHE") or Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "hybridsim"
    return Path(root) / "compiled"


class CompiledLoop:
    """The compiled ``run`` of one system with its log layout."""

    def __init__(self, system, solver, log_ports, log_path, located=None, log_period=None):
        self.located = system.action_events if located is None else located
        why = problems(system, solver, self.located)
        if why:
            raise CompiledPathError("cannot use the compiled path: " + "; ".join(why))
        try:
            import numba  # noqa: F401
        except ImportError:  # pragma: no cover - numba is in the test extra
            raise CompiledPathError(
                "the compiled path needs numba: pip install -e \".[fast]\" (or run without --compiled)"
            ) from None
        self.system, self.solver, self.step = system, solver, solver.step
        self.log_ports, self.log_path = log_ports, log_path
        dense_logs = log_period is None or _logs_between_hits(system, log_period)
        self.source, env = _module_source(system, solver, log_ports, log_path, self.located, dense_logs)
        self.run_fn = _load(self.source, env, system.name)

    def run(self, ctx, stops, t_end, final_record, max_state):
        """Run from ``ctx`` over ``stops`` (a :class:`~hybridsim.engine.simulator.Stops`);
        returns (row times, rows, hits per block)."""
        from numba.core.errors import NumbaError, NumbaIRAssumptionWarning

        sysm = self.system
        discrete = sysm.discrete
        T, KIND, DUE, REC, rows_t, NSTEP, HSTEP, OBK, OBW, NEXT = self._arrays(stops, t_end, final_record)
        width = sum(sysm.blocks[i].outputs[o].width for i, o in self.log_ports)
        LOG = np.zeros((len(rows_t), width))
        Y = np.concatenate([np.asarray(v, float) for vals in ctx.y for v in vals] + [np.zeros(0)])
        Z = np.concatenate([np.asarray(z, float) for z in ctx.xd] + [np.zeros(0)])
        status = np.zeros(2, dtype=np.int64)  # stop index + 1 where it diverged, and what
        XO = np.zeros((len(T), sysm.n_x)) if self.located else np.zeros((0, 0))
        room = self.max_log if self.located else 0
        EV = np.zeros(room)  # event times (compiled events)
        EVF = np.zeros(room, dtype=np.int64)  # and which functions fired, as bits
        NEV = np.zeros(1, dtype=np.int64)
        P = ctx.params  # the run's numbers: one compiled module serves every value
        with np.errstate(all="ignore"), warnings.catch_warnings():
            # numba's inliner trips an internal "pedantic" SSA check on some kernels;
            # the results are checked bit for bit against the generic path (tests)
            warnings.simplefilter("ignore", NumbaIRAssumptionWarning)
            try:
                X = self.run_fn(P, tuple(ctx.xc.tolist()), Y, Z, T, KIND, DUE, REC, NSTEP, HSTEP,
                                OBK, OBW, LOG, float(max_state), status, XO, NEXT, float(self.step),
                                EV, EVF, NEV)
            except NumbaError as exc:
                raise CompiledPathError(_compile_failure(exc, sysm)) from None
        ctx.xc = np.array(X, dtype=float)
        k = 0
        for vals in ctx.y:
            for v in vals:
                v[:] = Y[k:k + v.size]
                k += v.size
        k = 0
        for i, z in enumerate(ctx.xd):
            ctx.xd[i] = Z[k:k + z.size].copy()
            k += z.size
        events = self._event_log(EV, EVF, int(NEV[0])) if self.located else []
        if ctx.events is not None:
            ctx.events.log = events
        if status[0]:
            self._diverged(status, T, ctx, max_state, events)
        hits = {sysm.blocks[i].name: int(n) for i, n in zip(discrete, DUE.sum(axis=0))}
        return rows_t, LOG, hits

    def _arrays(self, stops, t_end, final_record):
        """The schedule as the compiled loop reads it (kept for the next run over the same stops)."""
        key = (t_end, final_record)
        cached = getattr(self, "_cache", None)
        if cached is not None and cached[0] is stops and cached[1] == key:
            return cached[2]
        D = len(self.system.discrete)
        T = np.append(stops.times, t_end)
        KIND = np.append(np.where(stops.hit, 0, 1), 3 if final_record else 2).astype(np.int64)
        DUE = np.vstack([stops.due, np.zeros((1, D), dtype=bool)])
        record = np.append(stops.record, final_record)
        REC = np.where(record, np.cumsum(record) - 1, -1).astype(np.int64)
        rows_t = T[record]
        hits = np.flatnonzero(KIND == 0)
        NEXT = np.zeros(len(T), dtype=np.int64)  # at a hit row: the row of the next hit or the end
        NEXT[hits] = np.append(hits[1:], len(T) - 1)
        arrays = (T, KIND, DUE, REC, rows_t) + self._step_plan(T, KIND) + (NEXT,)
        self._cache = (stops, key, arrays)
        return arrays

    def _step_plan(self, T, KIND):
        """Steps of each interval between hits, and where each log point lies in them.

        Returns ``NSTEP``, ``HSTEP`` (at hit rows: step count and size to the
        next hit or the end) and ``OBK``, ``OBW`` (at log rows: the step
        containing the point, ``-1 - k`` for a step point, and its dense-output
        weights) - what :meth:`ExplicitRK.advance` computes for the generic path.
        """
        rows = len(T)
        NSTEP = np.zeros(rows, dtype=np.int64)
        HSTEP = np.zeros(rows)
        OBK = np.zeros(rows, dtype=np.int64)
        OBW = np.zeros((rows, len(self.solver.c)))
        hits = np.flatnonzero(KIND == 0)
        ends = np.append(hits[1:], rows - 1)
        NSTEP[hits] = steps_between(np.stack([T[hits], T[ends]], axis=1).ravel(), self.step)[::2]
        HSTEP[hits] = (T[ends] - T[hits]) / NSTEP[hits]
        logs = np.flatnonzero(KIND == 1)
        if logs.size:
            owner = hits[np.searchsorted(hits, logs, side="right") - 1]
            k, theta = observations(T[owner], HSTEP[owner], NSTEP[owner], T[logs])
            OBK[logs] = np.where(theta == 0.0, -1 - k, k)
            OBW[logs] = self.solver.dense_weights(theta)
        return NSTEP, HSTEP, OBK, OBW

    #: event times kept for the result's meta (and the Zeno check's count)
    max_log = 200_000

    def _event_log(self, EV, EVF, n):
        """[(t, block names)] of the events the compiled loop located."""
        sysm = self.system
        sizes = event_sizes(sysm, self.located)
        cuts = np.cumsum([0] + sizes)
        out = []
        for t, bits in zip(EV[:min(n, self.max_log)].tolist(), EVF[:min(n, self.max_log)].tolist()):
            names = tuple(sorted({sysm.blocks[i].name for k, i in enumerate(self.located)
                                  if any(bits >> j & 1 for j in range(cuts[k], cuts[k + 1]))}))
            out.append((t, names))
        return out

    def _diverged(self, status, T, ctx, max_state, events):
        """The plan's divergence error for what the compiled loop stopped on."""
        from hybridsim.engine.events import chatter_error, zeno_error

        t = T[status[0] - 1]
        plan = self.system.plan
        if status[1] <= -EVENT_CODE:  # events: Zeno or chattering, at the last event's time
            t_ev, names = events[-1] if events else (t, ())
            code = -status[1] // EVENT_CODE
            if code == 3:
                raise chatter_error(t_ev, list(names))
            raise zeno_error(t_ev, list(names), code == 1, -status[1] % EVENT_CODE)
        if status[1] < 0:
            i = -status[1] - 1
            plan.check_discrete(i, ctx.xd[i], t)
        plan.check_continuous(ctx.xc, t, max_state)
        raise SimulationError(f"simulation diverged at t={t:.6g} s")  # pragma: no cover


#: status codes of the compiled event loop: -code * EVENT_CODE - detail
EVENT_CODE = 10**9


def _logs_between_hits(system, log_period):
    """True when some log point of ``log_period`` falls between sample hits (then the
    module needs the dense-output step, which adds to the compile time)."""
    from hybridsim.engine.block import to_period
    from hybridsim.engine.schedule import Schedule

    blocks = system.blocks
    timings = [(blocks[i].period, blocks[i].time_offset) for i in system.discrete]
    sched = Schedule(timings + [(to_period(log_period, "log period"), 0)])
    horizon = 1
    for p, o in sched.ticks:
        horizon = horizon * p // math.gcd(horizon, p)
        if horizon > 10**6:
            return True
    horizon += max((o for _, o in sched.ticks), default=0)
    _, due = sched.hits(horizon)
    hit = due[:, :-1].any(axis=1)
    hit[0] = True
    return bool((due[:, -1] & ~hit).any())


def _module_source(system, solver, log_ports, log_path, located, dense_logs=True):
    """Source of the generated module and the names it needs: (source, env)."""
    sysm = system
    rk, env, held = rk_source(sysm, solver, params_arg=True, located=located)
    blocks = sysm.blocks
    y = lambda i, o: [f"y{i}_{o}_{j}" for j in range(blocks[i].outputs[o].width)]  # noqa: E731
    z = lambda i: [f"z{i}_{j}" for j in range(blocks[i].n_discrete)]  # noqa: E731
    tup = tuple_source
    due_col = {i: c for c, i in enumerate(sysm.discrete)}

    def state(i, xname="X"):
        s = sysm.xslices[i]
        if s is not None:
            return f"{xname}[{s.start}:{s.stop}]"
        return tup(z(i))

    def inputs(i):
        return tup(tup(y(a, o)) for a, o in sysm.sources[i])

    def evaluate(i, indent, xname="X"):
        b = blocks[i]
        if not b.outputs:
            return []
        env[f"out{i}"] = b.kernels.output
        pad = " " * indent
        lines = [f"{pad}r{i} = out{i}(P[{i}], t, {state(i, xname)}, {inputs(i)})"]  # one name per block: one type
        for o in range(len(b.outputs)):
            lines += [f"{pad}{name} = r{i}[{o}][{j}]" for j, name in enumerate(y(i, o))]
        return lines

    wires = [name for i, b in enumerate(blocks) for o in range(len(b.outputs)) for name in y(i, o)]
    states = [name for i in range(len(blocks)) for name in z(i)]
    held_in = tup(tup(y(a, o)) for a, o in held)
    weights = tup(f"OBW[k, {j}]" for j in range(len(solver.c)))
    events = bool(located) and sysm.n_x > 0
    L = ["def run(P, X, Y, Z, T, KIND, DUE, REC, NSTEP, HSTEP, OBK, OBW, LOG, max_state, STATUS, XO, NEXT, "
         "step, EV, EVF, NEV):"]
    L += [f"    {name} = Y[{k}]" for k, name in enumerate(wires)]  # every signal element a local float
    L += [f"    {name} = Z[{k}]" for k, name in enumerate(states)]
    # the interval being integrated: from t0, steps of h, ks taken of n; Xa the state after step ks
    L += ["    t0 = 0.0", "    h = 0.0", "    n = 0", "    ks = 0", "    Xa = X", "    after = False",
          "    Xo = X", "    Xs = X"]
    L += ["    for k in range(T.shape[0]):", "        t = T[k]"]
    if sysm.n_x and not events:
        L += ["        if k > 0 and KIND[k] != 1:  # the interval ends: its remaining steps",
              "            if after:",
              "                X = Xa",
              "                ks += 1",
              "                after = False",
              f"            X = advance(t0, h, ks, n, X, {held_in}, P)",
              f"            for j in range({sysm.n_x}):",
              "                if not abs(X[j]) <= max_state:",
              "                    STATUS[0] = k + 1",
              "                    STATUS[1] = j",
              "                    break",
              "            if STATUS[0]:",
              "                break"]
    L += ["        if KIND[k] == 0:  # a sample hit: outputs (plan.hit_sequence)"]
    for i, disc in sysm.plan.hit_sequence():
        if disc:
            L.append(f"            if DUE[k, {due_col[i]}]:")
            L += evaluate(i, 16) or ["                pass"]
        else:
            L += evaluate(i, 12)
    L.append("        elif KIND[k] == 1:  # a log point between hits: the state from the dense output")
    if events:
        L.append("            Xo = " + tup(f"XO[k, {j}]" for j in range(sysm.n_x)))
    elif sysm.n_x and dense_logs:
        L += ["            kb = OBK[k] if OBK[k] >= 0 else -1 - OBK[k]",
              "            if after and kb != ks:",
              "                X = Xa",
              "                ks += 1",
              "                after = False",
              "            if OBK[k] < 0:",
              f"                X = advance(t0, h, ks, kb, X, {held_in}, P)",
              "                Xo = X",
              "            else:",
              f"                Xa, X, Xo = advance_obs(t0, h, ks, kb + 1, X, {held_in}, kb, {weights}, P)",
              "                after = True",
              "            ks = kb"]
    L += [line for i in log_path for line in evaluate(i, 12, "Xo")] or ["            pass"]
    L.append("        elif KIND[k] == 3:  # the end, on the log grid")
    L += [line for i in log_path for line in evaluate(i, 12)] or ["            pass"]
    logged = [name for i, o in log_ports for name in y(i, o)]
    L.append("        if REC[k] >= 0:")
    L += [f"            LOG[REC[k], {c}] = {name}" for c, name in enumerate(logged)] or ["            pass"]
    for i in sysm.plan.update_order(sysm.discrete):  # updates, after every output of the hit
        if blocks[i].n_discrete:
            env[f"upd{i}"] = blocks[i].kernels.update
            ok = " and ".join(f"math.isfinite({name})" for name in z(i))
            L += [f"        if KIND[k] == 0 and DUE[k, {due_col[i]}]:",
                  f"            s{i} = upd{i}(P[{i}], t, {state(i)}, {inputs(i)})"]
            L += [f"            {name} = s{i}[{j}]" for j, name in enumerate(z(i))]
            L += [f"            if not ({ok}):", "                STATUS[0] = k + 1",
                  f"                STATUS[1] = {-i - 1}", "                break"]
    if events:  # the whole interval at once, events located and acted on (interval())
        L += ["        if KIND[k] == 0:",
              f"            X, code = interval(t, T[NEXT[k]], X, {held_in}, P, step, T, XO, k + 1, NEXT[k], "
              "EV, EVF, NEV)",
              "            if code != 0:",
              "                STATUS[0] = NEXT[k] + 1",
              "                STATUS[1] = code",
              "                break",
              f"            for j in range({sysm.n_x}):",
              "                if not abs(X[j]) <= max_state:",
              "                    STATUS[0] = NEXT[k] + 1",
              "                    STATUS[1] = j",
              "                    break",
              "            if STATUS[0]:",
              "                break"]
    else:
        L += ["        if KIND[k] == 0:  # the next interval starts here",
              "            t0 = t", "            n = NSTEP[k]", "            h = HSTEP[k]", "            ks = 0",
              "            after = False"]
    L += [f"    Y[{k}] = {name}" for k, name in enumerate(wires)]
    L += [f"    Z[{k}] = {name}" for k, name in enumerate(states)]
    L.append("    return X")
    body = "\n".join(L)
    stamp = _stamp(reachable(env.values()))
    # which kernel each name is: part of the source, so of the cache key
    names = "".join(f"#   {name} = {f.__module__}.{f.__qualname__}\n" for name, f in sorted(env.items()))
    head = (f"# generated by hybridsim.engine.compiled for diagram {sysm.name!r}; kernels {stamp}\n{names}"
            "import math\n\nimport numpy as np\nfrom numba import njit\n\n\n")
    extra = _njit(_interval_source(sysm, solver, located)) + "\n\n\n" if events else ""
    source = head + (_njit(rk) + "\n\n\n" if sysm.n_x else "") + extra + _njit(body) + "\n"
    return source, env


def _interval_source(sysm, solver, located):
    """Source of ``interval``: one interval between hits with located events, as
    :func:`hybridsim.engine.events.integrate` and :meth:`ExplicitRK.advance_to_event` do it
    (the same arithmetic, so the same numbers), and its helpers."""
    from hybridsim.engine.events import MAX_EVENTS, MAX_ITERATIONS, MAX_STALLS, TIME_TOL

    n = sysm.n_x
    dirs = []
    for i, m in zip(located, event_sizes(sysm, located)):
        d = sysm.blocks[i].event_directions
        dirs += list(d) if d is not None else [0] * m
    tup = tuple_source

    def cross(j, d):
        rising, falling = f"(a[{j}] <= 0.0 and b[{j}] > 0.0)", f"(a[{j}] >= 0.0 and b[{j}] < 0.0)"
        return rising if d > 0 else falling if d < 0 else f"({rising} or {falling})"

    L = ["def crossed(a, b):", f"    return {tup(cross(j, d) for j, d in enumerate(dirs))}", "",
         "def anyc(f):", "    return " + " or ".join(f"f[{j}]" for j in range(len(dirs))), "",
         "def bits(f):", "    return " + " + ".join(f"(1 << {j} if f[{j}] else 0)" for j in range(len(dirs))), "",
         "def dense_w(theta):"]
    for j, poly in enumerate(solver.dense):  # as ExplicitRK.dense_weights
        L += ["    q = theta", f"    w{j} = {poly[0]!r} * theta"]
        for p in poly[1:]:
            L += ["    q = q * theta", f"    w{j} = w{j} + {p!r} * q"]
    L += [f"    return {tup(f'w{j}' for j in range(len(solver.dense)))}", "",
          "def obs_point(t0, h, n, tb):  # as solvers.observations",
          "    r = (tb - t0) / h",
          "    near = np.rint(r)",
          "    if abs(r - near) <= 1e-9 and near < n:",
          "        return int(near), 0.0",
          "    k = int(min(math.floor(r), n - 1))",
          "    return k, (tb - (t0 + k * h)) / h", ""]
    store = lambda x: [f"            XO[j, {c}] = {x}[{c}]" for c in range(n)]  # noqa: E731
    L += ["def interval(t0, t1, X, H, P, step, LT, XO, j, j1, EV, EVF, NEV):",
          "    stalls = 0",
          "    count = 0",
          "    while True:",
          "        n = max(1, math.ceil((t1 - t0) / step - 1e-9))",
          "        h = (t1 - t0) / n",
          "        g_k = zc(t0, X, H, P)",
          "        ev = False",
          "        hi = 1.0",
          "        k = 0",
          "        x_hi = X",
          "        g_lo = g_k",
          "        g_hi = g_k",
          "        for k in range(n):",
          "            while j < j1:",
          "                kb, th = obs_point(t0, h, n, LT[j])",
          "                if kb != k or th != 0.0:",
          "                    break"] + ["    " + line for line in store("X")] + [
          "                j += 1",
          "            Xn = advance(t0, h, k, k + 1, X, H, P)",
          "            g_n = zc(t0 + (k + 1) * h, Xn, H, P)",
          "            if anyc(crossed(g_k, g_n)):",
          "                lo = 0.0",
          "                hi = 1.0",
          "                g_lo = g_k",
          "                g_hi = g_n",
          "                x_hi = Xn",
          "                t = t0 + k * h",
          f"                while (hi - lo) * h > {TIME_TOL!r}:",
          "                    mid = 0.5 * (lo + hi)",
          "                    xm = advance_obs(t0, h, k, k + 1, X, H, k, dense_w(mid), P)[2]",
          "                    gm = zc(t + mid * h, xm, H, P)",
          "                    if anyc(crossed(g_lo, gm)):",
          "                        hi = mid",
          "                        x_hi = xm",
          "                        g_hi = gm",
          "                    else:",
          "                        lo = mid",
          "                        g_lo = gm",
          "                if hi < 1.0:  # re-stepped if past the surface too, as ExplicitRK._locate does",
          "                    x_re = advance(t, hi * h, 0, 1, X, H, P)",
          "                    if anyc(crossed(g_lo, zc(t + hi * h, x_re, H, P))):",
          "                        x_hi = x_re",
          "                ev = True",
          "            g_k = g_n",
          "            th_stop = hi if ev else 1.0",
          "            while j < j1:",
          "                kb, th = obs_point(t0, h, n, LT[j])",
          "                if kb != k or not th < th_stop:",
          "                    break",
          "                xo = advance_obs(t0, h, k, k + 1, X, H, k, dense_w(th), P)[2]"] + [
          "    " + line for line in store("xo")] + [
          "                j += 1",
          "            if ev:",
          "                break",
          "            X = Xn",
          "        if not ev:",
          "            return X, 0",
          "        t_stop = t0 + k * h + hi * h if hi < 1.0 else t0 + (k + 1) * h",
          "        fired = crossed(g_lo, g_hi)",
          "        count += 1",
          f"        stalls = stalls + 1 if t_stop - t0 <= {10 * TIME_TOL!r} else 0",
          "        if NEV[0] < EV.shape[0]:",
          "            EV[NEV[0]] = t_stop",
          "            EVF[NEV[0]] = bits(fired)",
          "        NEV[0] += 1",
          f"        if count > {MAX_EVENTS}:",
          f"            return X, -{EVENT_CODE}",
          f"        if stalls > {MAX_STALLS}:",
          f"            return X, -2 * {EVENT_CODE} - stalls",
          "        g_m = zc(t_stop, x_hi, H, P)",
          "        x = x_hi",
          "        settled = False",
          f"        for it in range({MAX_ITERATIONS}):",
          "            x = act(t_stop, x, H, fired, P)",
          "            g_p = zc(t_stop, x, H, P)",
          "            fired = crossed(g_m, g_p)",
          "            if not anyc(fired):",
          "                settled = True",
          "                break",
          "            g_m = g_p",
          "        if not settled:",
          f"            return x, -3 * {EVENT_CODE}",
          "        X = x",
          "        t0 = t_stop",
          f"        if t1 - t0 <= {TIME_TOL!r}:",
          "            while j < j1:"] + ["    " + line for line in store("X")] + [
          "                j += 1",
          "            return X, 0"]
    return "\n".join(L)


def _compile_failure(exc, system):
    """What to tell a user whose kernels numba cannot compile."""
    text = re.sub(r"\x1b\[[0-9;]*m", "", str(exc))  # numba colours its messages
    culprits = sorted({f"{b.name} ({type(b).__name__})" for b in system.blocks if b.kernels is not None
                       for f in b.kernels if callable(f) and f.__name__ in text})
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    why = ("Untyped global", "Unknown attribute", "Cannot", "not supported", "unsupported", "Invalid use")
    first = next((line for line in lines if any(w in line for w in why)), lines[0] if lines else "")
    return ("numba cannot compile the kernels of this diagram"
            + (f"; the message names block(s) {', '.join(culprits)}" if culprits else "")
            + f": {first} (kernels must keep to numba's nopython subset, see hybridsim.engine.kernels; "
              "or run without compiled)")


def reachable(functions):
    """``functions`` and every :func:`~hybridsim.engine.kernels.kernel` they call, directly or not.

    What a generated module's machine code depends on: its cache key, so
    defining or editing an unrelated kernel recompiles nothing.
    """
    kernels = {id(f): f for f in marked()}
    seen, todo = {}, list(functions)
    while todo:
        f = todo.pop()
        if id(f) in seen:
            continue
        seen[id(f)] = f
        code = getattr(f, "__code__", None)
        if code is None:
            continue
        names = set(code.co_names)
        for const in code.co_consts:  # nested functions' names too
            if hasattr(const, "co_names"):
                names |= set(const.co_names)
        glb = getattr(f, "__globals__", {})
        todo += [glb[n] for n in names if n in glb and id(glb[n]) in kernels]
    return frozenset(seen.values())


@functools.lru_cache(maxsize=None)
def _stamp(functions):
    """A hash of the kernels' source text (a kernel edited means a new module)."""
    def text(f):
        try:
            return inspect.getsource(f)
        except (OSError, TypeError):  # defined at a prompt: its byte code then
            return f.__code__.co_code.hex() + repr(f.__code__.co_consts)

    key = lambda f: (f.__module__, f.__qualname__)  # noqa: E731
    return hashlib.sha256("".join(text(f) for f in sorted(functions, key=key)).encode()).hexdigest()[:16]


def _njit(source):
    """Put ``@njit(cache=True, nogil=True)`` over every top-level def of ``source`` (threads
    of a batch run side by side)."""
    return "\n".join("@njit(cache=True, nogil=True)\n" + line if line.startswith("def ") else line
                     for line in source.split("\n"))


def _inline(f):
    """How numba takes kernel ``f``: inlined when it works on floats and tuples (the plant's
    kernels, called on every stage: inlined they run several times faster), called when it works on numpy
    arrays (controllers, gains: their inlining dominated the compile time, and they run once a hit)."""
    try:
        text = inspect.getsource(f)
    except (OSError, TypeError):
        return "always"
    return "never" if re.search(r"\bnp\.", text) else "always"


def _load(source, env, name):
    """Import the generated module (written once to the cache) and return ``run``."""
    key = hashlib.sha256(source.encode()).hexdigest()[:24]
    if key in _loaded:
        return _loaded[key]
    from numba.extending import register_jitable

    for f in set(marked()) | set(env.values()):
        if f not in _registered:
            register_jitable(inline=_inline(f))(f)
            _registered.add(f)
    folder = cache_dir()
    path = folder / f"loop_{key}.py"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        if not path.exists():
            log.info("compiling %r with numba (once: later runs load it from %s)", name, folder)
            tmp = path.with_suffix(f".{os.getpid()}.tmp")
            tmp.write_text(source)
            os.replace(tmp, path)
    except OSError as exc:
        raise CompiledPathError(f"cannot write the compiled module to {folder}: {exc} "
                                "(set HYBRIDSIM_CACHE to a writable folder)") from None
    spec = importlib.util.spec_from_file_location(f"hybridsim_loop_{key}", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # numba's cache finds the module by name
    spec.loader.exec_module(module)
    vars(module).update(env)  # the kernels, by the names the source uses
    _loaded[key] = module.run
    return module.run
