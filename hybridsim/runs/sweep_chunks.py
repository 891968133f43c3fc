"""Sweep points in chunks on one built diagram per worker process (see :mod:`hybridsim.runs.sweep`).

A sweep whose points change only run-time parameters (block numbers, not a rate,
a width or a setting) is cut into chunks; each worker, a local process or a Dask
worker, builds the diagram once (:func:`_plans`; on the compiled path one compiled
loop) and runs every point of its chunks on it (:func:`run_chunk`), logging only
the signals the metrics read. The rows are those :func:`hybridsim.runs.sweep.run_point`
gives for the same points.
"""
import json
import os
import time
from pathlib import Path

import numpy as np


class RuntimeCheck:
    """Swept values checked as run-time parameters of the base diagram, built once per variant.

    A value that only changes block numbers (not a rate, a width, a setting) passes
    when every block it reaches is rebuilt with it without error and keeps its
    structure: what a full check of the diagram with that value would find. Anything
    else (and any error) is left to the full check, which says what is wrong.
    """

    def __init__(self, base):
        self.base, self.systems, self.seen = base, None, {}

    def accepts(self, key, value):
        """True when ``{key: value}`` is a good run-time change of every variant."""
        tag = json.dumps([key, value], sort_keys=True, default=str)
        if tag not in self.seen:
            self.seen[tag] = self._accepts(key, value)
        return self.seen[tag]

    def _accepts(self, key, value):
        from hybridsim.errors import HybridsimError

        try:
            if self.systems is None:
                self.systems = []
                for _, variant in self.base.variants():
                    diagram, _ = self.base.build(variant)
                    self.systems.append((variant, diagram.build()))
            for variant, system in self.systems:
                system.blocks_with(self.base.runtime_params({key: value}, variant))
            return True
        except (HybridsimError, ValueError, TypeError, KeyError):
            return False



#: most points one worker runs in one call (and then appended to points.jsonl together)
BATCH_CHUNK = 64
#: chunks per worker a sweep is cut into at least (so the workers finish together)
CHUNKS_PER_WORKER = 4
#: built diagrams of this process, per (diagram, fixed overrides, traces): see :func:`_plans`
_PLANS = {}


def _plans(diagram, fixed, traces):
    """One built simulator per variant of ``diagram`` with ``fixed``, kept in this process.

    A list of ``(label, variant, file, simulator, settings)``, built on the first call
    (a compiled loop is generated or read from the cache then) and reused by every
    later chunk of the sweep in this process: a Dask worker or pool process builds once.
    Without ``traces`` only the signals the metrics read are logged.
    """
    from hybridsim.api import build, load

    tag = (diagram, json.dumps(fixed, sort_keys=True, default=str), bool(traces))
    if tag not in _PLANS:
        f = load(diagram, **fixed)
        plans = []
        for label, variant in f.variants():
            _, settings = f.build(variant)
            log = None if traces else list(settings["signals"].values())
            _, sim, settings = build(f, variant, log=log)
            plans.append((label, variant, f, sim, settings))
        _PLANS.clear()  # one sweep at a time per process
        _PLANS[tag] = plans
    return _PLANS[tag]


def run_chunk(diagram, fixed, chunk, traces_dir=None):
    """Run the points of ``chunk`` as run-time parameters of one built diagram; ``{key: rows}``.

    The table rows are those of :func:`hybridsim.runs.sweep.run_point` for the same points (the
    same numbers: a run-time parameter rebuilds only the blocks it names).
    A point that cannot be given at run time runs on its own with :func:`~hybridsim.runs.sweep.run_point`.
    Never raises for a failing run: its row says 'failed' and why.
    """
    from hybridsim.analysis import metrics as _metrics
    from hybridsim.errors import HybridsimError

    try:
        plans = _plans(diagram, fixed, traces_dir)
    except HybridsimError:
        plans = None
    finished, batch = {}, []
    for p in chunk:
        try:
            sets = [f.runtime_params(p["overrides"], variant) for _, variant, f, _, _ in plans]
        except (HybridsimError, ValueError, TypeError, KeyError):
            finished[p["key"]] = _sweep().run_point(diagram, fixed, p, traces_dir)
            continue
        batch.append((p, sets))
    per_variant = []
    for v, (label, _, _, sim, settings) in enumerate(plans or []):
        t0 = time.perf_counter()
        try:
            results = sim.run_batch(settings["simulation"]["t_end"], [sets[v] for _, sets in batch], workers=1)
        except HybridsimError:  # a bad value for one of them: each on its own, to say which
            results = [_run_one(sim, settings, sets[v]) for _, sets in batch]
        per_variant.append((label, settings, results, time.perf_counter() - t0))
    for k, (p, _) in enumerate(batch):
        rows = []
        for label, settings, results, _ in per_variant:
            r = results[k]
            if isinstance(r, Exception):
                rows = [{"key": p["key"], **p["params"], "variant": "", "status": "failed",
                         "message": str(r).splitlines()[0], "wall_time_s": 0.0}]
                break
            m = _metrics.compute(r, settings["signals"], settings["metrics"])
            m["wall_time_s"] = r.meta["wall_time_s"]
            m = {k2: (None if isinstance(v, float) and not np.isfinite(v) else v) for k2, v in m.items()
                 if not isinstance(v, (list, dict))}
            rows.append({"key": p["key"], **p["params"], "variant": label, "status": "ok", "message": "", **m})
            if traces_dir:
                r.to_csv(Path(traces_dir) / f"{p['key']}{('_' + label) if label else ''}.csv")
        finished[p["key"]] = rows
    return finished


def _run_one(sim, settings, params):
    """One run of a batch on its own: its Result, or the error it ends with."""
    from hybridsim.errors import HybridsimError

    try:
        return sim.run(settings["simulation"]["t_end"], params=params)
    except HybridsimError as exc:
        return exc


def _chunks(todo, workers):
    """``todo`` cut into chunks of at most BATCH_CHUNK points, CHUNKS_PER_WORKER per worker at least."""
    size = max(1, min(BATCH_CHUNK, -(-len(todo) // (CHUNKS_PER_WORKER * max(1, workers)))))
    return [todo[c:c + size] for c in range(0, len(todo), size)]


def _execute_chunks(todo, args, traces, jobs, dask):
    """Yield ``{key: rows}`` chunk by chunk as they finish: here, on local processes or on Dask.
    Each worker builds the diagram once (:func:`_plans`) and runs its chunks on it."""
    diagram, fixed, _ = args
    if dask:
        from distributed import as_completed

        workers = max(1, len(dask.scheduler_info().get("workers", {})))
        futs = [dask.submit(run_chunk, diagram, fixed, c, traces, pure=False) for c in _chunks(todo, workers)]
        for fut in as_completed(futs):
            yield fut.result()
        return
    jobs = jobs or os.cpu_count() or 1
    chunks = _chunks(todo, jobs)
    if jobs <= 1 or len(chunks) <= 1:
        for c in chunks:
            yield run_chunk(diagram, fixed, c, traces)
        return
    from concurrent.futures import ProcessPoolExecutor, as_completed as done_first

    with ProcessPoolExecutor(min(jobs, len(chunks))) as pool:
        futs = [pool.submit(run_chunk, diagram, fixed, c, traces) for c in chunks]
        for fut in done_first(futs):
            yield fut.result()


def _sweep():
    """The sweep module (its ``run_point``, looked up at call time)."""
    from hybridsim.runs import sweep

    return sweep
