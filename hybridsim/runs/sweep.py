"""Parameter sweeps: many runs of one diagram, reduced to a tidy table.

A sweep file::

    diagram: ../diagrams/fig7_force_steps.yaml   # relative to this file
    set: {force: 5.0, rate: 60, simulation.t_end: 1.5}   # fixed for every point
    grid:                      # full factorial over values ...
      rate: [60, 120]
    scale:                     # ... and over multiples of a parameter's value
      ctrl.fpi.Kp: [0.5, 1, 2]
    random:                    # or/and: seeded uniform samples
      n: 20
      seed: 1
      ranges: {Kr: [8.0e5, 1.0e6]}
    traces: false              # also keep each run's CSV
    stability: true            # also the linearized closed loop's largest |z|

Every point is one run (per variant of the diagram) reduced to its metrics
(rise time, overshoot, steady-state error, contact lost, max position error,
and the stability verdict: whether the run completed). Points run in
parallel on all local cores, or on a Dask cluster (``--dask ADDRESS``).

Resuming: each finished point is appended as one JSON line to
``points.jsonl`` in the output folder, keyed by a hash of its overrides; a
second run of the same sweep skips the points already there, so an
interrupted sweep loses and duplicates nothing. The folder's
``sweep-manifest.json`` holds a fingerprint of everything else a point's
numbers depend on (every file its runs read, ``set``, ``stability``, the hybridsim version:
:mod:`hybridsim.format.identity`): a different sweep into the same folder is refused, or
with ``force`` starts afresh (the old points kept as ``points.jsonl.old``).
A point whose run diverges is recorded as failed, with the message, and the
sweep carries on. Every point's parameters are checked before any runs.
"""
import hashlib
import itertools
import json
import os
import time
from pathlib import Path

import numpy as np

from hybridsim import limits
from hybridsim.errors import HybridsimError, InputError, LoaderError
from hybridsim.files import atomic_file, locked_output_dir, note_written
from hybridsim.format.identity import check_sweep
from hybridsim.format import parse_file
from hybridsim.runs.sweep_chunks import BATCH_CHUNK, RuntimeCheck, _execute_chunks, run_chunk  # noqa: F401

#: seconds to wait for a Dask scheduler to answer
DASK_TIMEOUT_S = 10
SWEEP_KEYS = {"diagram", "set", "grid", "scale", "random", "traces", "stability"}


class Sweep:
    """A parsed sweep file: the diagram, fixed overrides and the list of points."""

    def __init__(self, path):
        self.path = Path(path)
        data, _ = parse_file(self.path, what="a sweep file is a mapping with at least 'diagram'")
        check_sweep(data, self.path)  # the sweep table; one parameter under two spellings refused
        if "diagram" not in data:
            raise LoaderError("a sweep file is a mapping with at least 'diagram'", self.path, 1)
        lines = data.lines
        for key in data:
            if key not in SWEEP_KEYS:
                raise LoaderError(f"unknown sweep key {key!r}; keys: {', '.join(sorted(SWEEP_KEYS))}",
                                  self.path, lines[key])
        if not isinstance(data["diagram"], str) or not data["diagram"]:
            raise LoaderError(f"'diagram' must be a file name, got {data['diagram']!r}", self.path,
                              lines["diagram"])
        self.diagram = (self.path.parent / data["diagram"]).resolve()
        for key in ("set", "grid", "scale", "random"):
            if data.get(key) is not None and not isinstance(data[key], dict):
                raise LoaderError(f"'{key}' must be a mapping", self.path, lines[key])
        for key in ("traces", "stability"):
            if key in data and not isinstance(data[key], bool):
                raise LoaderError(f"'{key}' must be true or false, got {data[key]!r}", self.path, lines[key])
        self.fixed = {str(k): v for k, v in (data.get("set") or {}).items()}
        self.grid = dict(data.get("grid") or {})
        self.scale = dict(data.get("scale") or {})
        for key, axes in (("grid", self.grid), ("scale", self.scale)):
            for name, values in axes.items():
                if not isinstance(values, list) or not values:
                    raise LoaderError(f"{key} {name!r}: give a non-empty list of values", self.path,
                                      data[key].lines[name])
                if key == "scale" and not all(_number(v) for v in values):
                    raise LoaderError(f"scale {name!r}: factors must be finite numbers, got {values!r}",
                                      self.path, data[key].lines[name])
        self.random = data.get("random")
        if self.random is not None:
            self._check_random(self.random, lines["random"])
        self.traces = bool(data.get("traces", False))
        self.stability = bool(data.get("stability", False))
        self._base = None

    def _check_random(self, spec, line):
        bad = set(spec) - {"n", "seed", "ranges"}
        if bad:
            raise LoaderError(f"random: unknown keys {sorted(bad)}; keys: n, seed, ranges", self.path, line)
        n, seed, ranges = spec.get("n", 10), spec.get("seed", 0), spec.get("ranges")
        if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= limits.MAX_RUNS:
            raise LoaderError(f"random: n must be a whole number from 1 to {limits.MAX_RUNS}, got {n!r}",
                              self.path, line)
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise LoaderError(f"random: seed must be a whole number >= 0, got {seed!r}", self.path, line)
        if not isinstance(ranges, dict) or not ranges:
            raise LoaderError("random: give 'ranges' as {parameter: [low, high]}", self.path, line)
        for k, v in ranges.items():
            if not (isinstance(v, list) and len(v) == 2 and all(_number(x) for x in v) and v[0] <= v[1]):
                raise LoaderError(f"random: range of {k!r} must be [low, high] with finite low <= high, "
                                  f"got {v!r}", self.path, ranges.lines[k])

    def _base_value(self, ref):
        """Value of a parameter or block parameter in the diagram (for scaling)."""
        from hybridsim.analysis.stability import param_value
        from hybridsim.api import load

        if self._base is None:
            self._base = load(self.diagram, **self.fixed)
            self._base_values = {}
        f = self._base
        if ref in self._base_values:  # every point of a scaled axis asks again
            return self._base_values[ref].copy()
        if "." not in ref:
            if ref not in f.params:
                raise InputError(f"{self.path}: sweep: no parameter {ref!r} in {self.diagram.name}")
            value = np.asarray(f.params[ref], float)
        else:
            try:
                value = param_value(f, ref)
            except (KeyError, ValueError, TypeError) as exc:
                raise InputError(f"{self.path}: sweep: cannot scale {ref!r}: {exc}") from None
        self._base_values[ref] = value
        return value.copy()

    def points(self):
        """List of dicts: 'params' (what the table shows) and 'overrides' (what runs)."""
        pts = []
        axes = [(k, v, False) for k, v in self.grid.items()] + [(k, v, True) for k, v in self.scale.items()]
        total = (int(np.prod([len(v) for _, v, _ in axes])) if axes else 0) + \
            (int(self.random.get("n", 10)) if self.random else 0)
        if total > limits.MAX_RUNS:
            raise InputError(f"{self.path}: the sweep has {total} points; at most {limits.MAX_RUNS}")
        if axes:
            for combo in itertools.product(*(v for _, v, _ in axes)):
                params, ov = {}, {}
                for (k, _, scaled), val in zip(axes, combo):
                    if scaled:
                        params[f"{k}*"] = float(val)
                        ov[k] = (self._base_value(k) * float(val)).tolist()
                    else:
                        params[k] = val
                        ov[k] = val
                pts.append({"params": params, "overrides": ov})
        if self.random:
            rng = np.random.default_rng(int(self.random.get("seed", 0)))
            for _ in range(int(self.random.get("n", 10))):
                params = {k: float(rng.uniform(lo, hi)) for k, (lo, hi) in self.random["ranges"].items()}
                pts.append({"params": params, "overrides": dict(params)})
        if not pts:
            raise InputError(f"{self.path}: the sweep has no points (give grid, scale or random)")
        for p in pts:
            p["key"] = point_key(p["overrides"])
        return pts


    def validate(self):
        """Check the diagram, ``set`` and every swept value before any point runs.

        Each grid value, each scale factor and both ends of each random range
        are checked as one run would be (:func:`hybridsim.api.check`), so a
        sweep naming an unknown parameter or a bad value stops here with exit 2.
        """
        from hybridsim.api import check, load

        base = load(self.diagram, **self.fixed)
        check(base)
        quick = self._quick = RuntimeCheck(base)
        seen = set()
        tries = [(k, v) for k, vals in self.grid.items() for v in vals]
        tries += [(k, (self._base_value(k) * float(v)).tolist()) for k, vals in self.scale.items() for v in vals]
        if self.random:
            tries += [(k, float(v)) for k, rng in self.random["ranges"].items() for v in rng]
        for key, value in tries:
            tag = json.dumps([key, value], sort_keys=True, default=str)
            if tag in seen:
                continue
            seen.add(tag)
            if quick.accepts(key, value):
                continue
            try:
                check(load(self.diagram, **{**self.fixed, key: value}))
            except InputError as exc:
                raise InputError(f"{self.path}: swept value {key} = {value!r}: {exc}") from None

    def runtime_points(self, pts):
        """True when every point of ``pts`` changes only run-time parameters of the diagram
        (then the points of a worker share one built diagram: :func:`run_chunk`)."""
        from hybridsim.api import load

        quick = self.__dict__.get("_quick") or RuntimeCheck(load(self.diagram, **self.fixed))
        self._quick = quick
        for p in pts:
            if not all(quick.accepts(k, v) for k, v in p["overrides"].items()):
                return False
        return True

    def fingerprint(self):
        """A hash of everything a point's numbers depend on besides its own overrides: every file
        the runs read (diagram, extends, subsystems, URDFs and meshes, FMUs, plugins, files named
        in the sweep), ``set``, ``stability`` and hybridsim's version (:mod:`hybridsim.format.identity`)."""
        from hybridsim.format.identity import sweep_identity

        return sweep_identity(self)


def _number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and bool(np.isfinite(v))


def point_key(overrides):
    """A short stable hash of one point's overrides (its resume key in points.jsonl)."""
    text = json.dumps(overrides, sort_keys=True, default=float)
    return hashlib.sha1(text.encode()).hexdigest()[:16]


def run_point(diagram, fixed, point, traces_dir=None, stability=False):
    """Run one point (all variants); returns a list of result rows. Never raises
    for a failing run: the row says 'failed' and why."""
    from hybridsim.api import run_experiment

    rows = []
    t0 = time.perf_counter()
    extra = {}
    if stability:
        extra["linear_largest_abs_z"] = _linear_growth(diagram, {**fixed, **point["overrides"]})
    try:
        f, runs, _ = run_experiment(diagram, jobs=1, **{**fixed, **point["overrides"]})
    except HybridsimError as exc:
        return [{"key": point["key"], **point["params"], "variant": "", "status": "failed",
                 "message": str(exc).splitlines()[0], "wall_time_s": time.perf_counter() - t0}]
    for r in runs:
        m = {k: (None if isinstance(v, float) and not np.isfinite(v) else v) for k, v in r["metrics"].items()
             if not isinstance(v, (list, dict))}
        rows.append({"key": point["key"], **point["params"], "variant": r["label"], "status": "ok",
                     "message": "", **m, **extra})
        if traces_dir:
            r["result"].to_csv(Path(traces_dir) / f"{point['key']}{('_' + r['label']) if r['label'] else ''}.csv")
    return rows


def _linear_growth(diagram, overrides):
    """Largest |z| of the linearized closed loop on the diagram's analysis branch."""
    from hybridsim.analysis.stability import largest_abs_z, settings_of
    from hybridsim.api import load

    try:
        cfg = settings_of(load(diagram, **overrides))
        return largest_abs_z(diagram, {**cfg["set"], **overrides})
    except HybridsimError:
        return None


def _load_done(jsonl):
    done = {}
    if jsonl.exists():
        for line in jsonl.read_text().splitlines():
            try:
                rec = json.loads(line)
            except json.JSONDecodeError:
                continue  # a line cut by a crash: that point runs again
            done[rec["key"]] = rec["rows"]
    return done


def _append(jsonl, key, rows):
    _append_many(jsonl, {key: rows})


def _append_many(jsonl, finished):
    """Append one JSON line per finished point ``{key: rows}``, in one write."""
    line = "".join(json.dumps({"key": key, "rows": rows}, default=_jsonable) + "\n"
                   for key, rows in finished.items())
    if jsonl.exists() and jsonl.stat().st_size:
        with open(jsonl, "rb") as fh:
            fh.seek(-1, os.SEEK_END)
            if fh.read(1) != b"\n":  # a line cut by a crash: start ours on a fresh line
                line = "\n" + line
    with open(jsonl, "a") as fh:  # one write of whole lines
        fh.write(line)
        fh.flush()
        os.fsync(fh.fileno())
    note_written(jsonl)


def _jsonable(v):
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    if isinstance(v, np.bool_):
        return bool(v)
    return str(v)


def run_sweep(path, outdir, jobs=None, dask=None, progress=True, compiled=False, force=False, batch=True):
    """Run (or resume) a sweep; returns the table as a list of row dicts.

    ``compiled``: run every point on the compiled path (as ``simulation.compiled:
    true`` in ``set``); the same numbers, so finished points are reused either way.
    ``force``: start afresh when ``outdir`` holds points of a different sweep
    (otherwise that is an :class:`~hybridsim.errors.InputError`).
    Points that differ only in run-time parameters (block numbers, not a
    rate, a width or a setting) run in chunks on one built diagram per worker
    process (:func:`run_chunk`: on the compiled path one compiled loop for
    every point), logging only what the metrics read, each chunk appended to
    ``points.jsonl`` as it finishes; ``batch=False`` runs each point on its
    own instead (the same table).
    Raises InputError before anything runs for a bad sweep file, diagram,
    parameter or value, or a Dask address that does not answer.
    """
    sw = Sweep(path)
    if jobs is not None and (isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1):
        raise InputError(f"jobs must be a whole number >= 1, got {jobs!r}")
    pts = sw.points()
    sw.validate()
    if compiled:
        sw.fixed["simulation.compiled"] = True
    fixed_run = dict(sw.fixed)
    sw.fixed.pop("simulation.compiled", None)  # the same numbers either way: not in the fingerprint
    fp = sw.fingerprint()
    sw.fixed = fixed_run
    client = _dask_client(dask) if isinstance(dask, str) else dask
    try:
        with locked_output_dir(outdir) as outdir:  # one sweep per folder at a time
            jsonl = outdir / "points.jsonl"
            _claim(outdir, jsonl, fp, sw, force)
            return _run(sw, pts, outdir, jsonl, jobs, client, progress, batch)
    finally:
        if client is not None and isinstance(dask, str):
            client.close()


def _dask_client(address):
    """A Dask client for ``address``, or InputError when nothing answers within DASK_TIMEOUT_S."""
    from distributed import Client

    try:
        return Client(address, timeout=f"{DASK_TIMEOUT_S}s")
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        raise InputError(f"cannot reach a Dask scheduler at {address!r} within {DASK_TIMEOUT_S} s "
                         f"({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else 'no answer'}); "
                         "is the scheduler running and the address right (tcp://HOST:8786)?") from None


def _claim(outdir, jsonl, fp, sw, force):
    """Make ``outdir`` this sweep's: refuse points of another sweep unless ``force``."""
    manifest = outdir / "sweep-manifest.json"
    old = None
    if manifest.exists():
        try:
            old = json.loads(manifest.read_text()).get("fingerprint")
        except (OSError, ValueError, AttributeError):
            old = "unreadable"
    has_points = jsonl.exists() and jsonl.stat().st_size > 0
    if has_points and old != fp:
        why = ("no sweep-manifest.json says which sweep they belong to" if old is None else
               "a file its runs read (the diagram, a file it extends, a subsystem, URDF, FMU, plugin or a "
               "file the sweep names), 'set', 'stability' or the hybridsim version changed")
        if not force:
            raise InputError(f"{outdir} holds points of a different sweep ({why}); they would "
                             "not match this one. Use another -o, or --force to start afresh "
                             "(the old points are kept as points.jsonl.old)")
        os.replace(jsonl, jsonl.with_name("points.jsonl.old"))
    if old != fp or not manifest.exists():
        with atomic_file(manifest) as fh:
            json.dump({"fingerprint": fp, "sweep": str(sw.path), "diagram": str(sw.diagram)}, fh, indent=1)


def _run(sw, pts, outdir, jsonl, jobs, dask, progress, use_batch=True):
    """Run the points of ``pts`` not yet in ``jsonl``; write the table and heat map."""
    done = _load_done(jsonl)
    todo = [p for p in pts if p["key"] not in done]
    traces = None
    if sw.traces:
        traces = outdir / "traces"
        traces.mkdir(exist_ok=True)
    bar = None
    if progress:
        from tqdm import tqdm

        from hybridsim.engine.simulator import on_terminal

        bar = tqdm(total=len(pts), initial=len(pts) - len(todo), unit="run", smoothing=0.1, disable=not on_terminal(),
                   desc=sw.path.stem)
    args = (str(sw.diagram), sw.fixed, sw.stability)
    batched = use_batch and not sw.stability and bool(todo) and sw.runtime_points(todo)
    try:
        if batched:
            for finished in _execute_chunks(todo, args, traces, jobs, dask):
                _append_many(jsonl, finished)  # one write and one fsync per chunk
                done.update(finished)
                if bar is not None:
                    bar.update(len(finished))
        else:
            for key, rows in _execute(todo, args, traces, jobs, dask):
                _append(jsonl, key, rows)
                done[key] = rows
                if bar is not None:
                    bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    table = [row for p in pts if p["key"] in done for row in done[p["key"]]]
    write_table(table, outdir)
    heatmaps(table, sw, outdir)
    return table


def _execute(todo, args, traces, jobs, dask):
    """Yield (key, rows) as points finish: serially, on local processes, or on Dask."""
    diagram, fixed, stability = args
    if dask:
        from distributed import as_completed

        futs = {dask.submit(run_point, diagram, fixed, p, traces, stability, pure=False): p["key"] for p in todo}
        for fut in as_completed(futs):
            yield futs[fut], fut.result()
        return
    jobs = jobs or os.cpu_count() or 1
    if jobs <= 1 or len(todo) <= 1:
        for p in todo:
            yield p["key"], run_point(diagram, fixed, p, traces, stability)
        return
    from concurrent.futures import ProcessPoolExecutor, as_completed as done_first

    with ProcessPoolExecutor(jobs) as pool:
        futs = {pool.submit(run_point, diagram, fixed, p, traces, stability): p["key"] for p in todo}
        for fut in done_first(futs):
            yield futs[fut], fut.result()


def write_table(rows, outdir):
    """sweep.csv and sweep.parquet (tidy: one row per point and variant), atomically."""
    import pandas as pd

    df = pd.DataFrame(rows)
    with atomic_file(Path(outdir) / "sweep.csv") as fh:
        df.to_csv(fh, index=False)
    with atomic_file(Path(outdir) / "sweep.parquet", "wb") as fh:
        df.to_parquet(fh, index=False)
    return df


def heatmaps(rows, sw, outdir):
    """A heat map of the main metrics over the first two swept parameters."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import pandas as pd

    axes = list(sw.grid) + [f"{k}*" for k in sw.scale]
    if len(axes) < 2 or not rows:
        return
    df = pd.DataFrame(rows)
    xa, ya = axes[0], axes[1]
    metrics = [m for m in ("ss_force_error_filtered_N", "overshoot_pct", "contact_lost") if m in df]
    if not metrics:
        return
    fig, axs = plt.subplots(1, len(metrics), figsize=(4.6 * len(metrics), 3.8), squeeze=False)
    for ax, m in zip(axs[0], metrics):
        piv = df[df["status"] == "ok"].groupby([ya, xa])[m].mean().unstack(xa).astype(float)
        im = ax.imshow(piv.values, origin="lower", aspect="auto", cmap="viridis")
        ax.set_xticks(range(len(piv.columns)), [f"{v:g}" for v in piv.columns])
        ax.set_yticks(range(len(piv.index)), [f"{v:g}" for v in piv.index])
        ax.set_xlabel(xa)
        ax.set_ylabel(ya)
        ax.set_title(m, fontsize=9)
        fig.colorbar(im, ax=ax, shrink=0.8)
        # the paper's operating point: scale 1 of a scaled axis, or the base value
        px = _index_of_one(piv.columns, xa)
        py = _index_of_one(piv.index, ya)
        if px is not None and py is not None:
            ax.plot(px, py, "r*", ms=14, label="paper (Appendix A)")
            ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    with atomic_file(Path(outdir) / "heatmap.png", "wb") as fh:
        fig.savefig(fh, format="png", dpi=110)
    plt.close(fig)


def _index_of_one(values, axis):
    if not axis.endswith("*"):
        return None
    for k, v in enumerate(values):
        if abs(float(v) - 1.0) < 1e-12:
            return k
    return None
