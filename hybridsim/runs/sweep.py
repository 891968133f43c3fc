"""Parameter sweeps: many runs of one diagram from a sweep file, reduced to a tidy table.

A sweep file::

    diagram: ../diagrams/examples/msd_pid.yaml   # relative to this file
    set: {simulation.t_end: 5}  # fixed for every point
    grid:                      # full factorial over values ...
      rate: [50, 100]
    scale:                     # ... and over multiples of a parameter's value
      pid.Kp: [0.5, 1, 2]
    random:                    # or/and: seeded uniform samples
      n: 20
      seed: 1
      ranges: {pid.Ki: [5.0, 20.0]}
    traces: false              # also keep each run's CSV
    stability: true            # also the linearized closed loop's largest |z|

Every point is run on every variant of the diagram by :func:`~hybridsim.runs.many.run_many`
(on all local cores, or a Dask cluster with ``--dask ADDRESS``) and each run reduced to
one row of metrics (those the registered metric sets compute from the diagram's ``signals``;
``status`` failed with the message for a run that diverged). Points that change
only block numbers run as run-time parameters of one built diagram per worker, logging
only what the metrics read (on the compiled path: one compiled loop for every point).

Resuming: each finished point is one line of ``points.jsonl`` in the output folder
(:class:`~hybridsim.runs.store.Store`), keyed by a hash of its overrides; a second run of the
same sweep runs only the points not there. ``sweep-manifest.json`` holds the identity of
everything else a point's numbers depend on (every file its runs read, ``set``,
``stability``, hybridsim's version and code: :mod:`hybridsim.format.identity`): a different sweep
into the same folder is refused, or with ``restart`` started afresh (the old points kept as
``points.jsonl.old``, its traces as ``traces.old``). Every swept value is checked before any point runs.
"""
import contextlib
import os
from pathlib import Path

import numpy as np

from hybridsim import limits
from hybridsim.errors import HybridsimError, InputError, LoaderError
from hybridsim.files import check_planned, locked_output_dir, unique_names, written_by_hybridsim
from hybridsim.format import parse_file
from hybridsim.format.filekinds import refuse_kind
from hybridsim.format.yamlio import as_path, key_line, not_a_file
from hybridsim.format.identity import check_sweep
from hybridsim.runs.executor import Executor
from hybridsim.runs.experiment import Experiment
from hybridsim.runs.grid import Grid, range_problem
from hybridsim.runs.many import Simulate, run_many
from hybridsim.runs.store import Store, aside
from hybridsim.runs.table import files as table_files, heatmaps, write_table

SWEEP_KEYS = {"diagram", "set", "grid", "scale", "random", "traces", "stability"}


#: where inside a random range a sweep's check tries a value (the golden section: no round number)
INSIDE = 0.3819660112501051


class Sweep:
    """A parsed sweep file: the diagram, fixed overrides (``fixed``) and the axes of its points."""

    def __init__(self, path):
        self.path = as_path(path, "a sweep file")
        data, _ = parse_file(self.path, what="a sweep file is a mapping with at least 'diagram'")
        refuse_kind(data, "sweep", self.path)
        check_sweep(data, self.path)  # the sweep table; one parameter under two spellings refused
        if "diagram" not in data:
            raise LoaderError("a sweep file is a mapping with at least 'diagram'", self.path, 1)
        lines = data.lines
        for key in data:
            if key not in SWEEP_KEYS:
                raise LoaderError(f"unknown sweep key {key!r}; keys: {', '.join(sorted(SWEEP_KEYS))}",
                                  self.path, key_line(data, key))
        if not isinstance(data["diagram"], str) or not data["diagram"]:
            raise LoaderError(f"'diagram' must be a file name, got {data['diagram']!r}", self.path,
                              lines["diagram"])
        self.diagram = (self.path.parent / data["diagram"]).resolve()
        why = not_a_file(self.diagram)
        if why:
            raise LoaderError(f"'diagram' {data['diagram']!r}: {why}", self.path, lines["diagram"])
        for key in ("set", "grid", "scale", "random"):
            if data.get(key) is not None and not isinstance(data[key], dict):
                raise LoaderError(f"'{key}' must be a mapping", self.path, lines[key])
        for key in ("traces", "stability"):
            if key in data and not isinstance(data[key], bool):
                raise LoaderError(f"'{key}' must be true or false, got {data[key]!r}", self.path, lines[key])
        self.fixed = {str(k): v for k, v in (data.get("set") or {}).items()}
        self._set_lines = dict(getattr(data.get("set"), "lines", None) or {})
        self._sections = {k: data.lines[k] for k in ("grid", "scale", "random") if k in data}
        self._diagram_line = lines["diagram"]
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
        #: the line of each swept name (what an error about its values points at)
        self._lines = {name: sec.lines[name] for sec in (data.get("grid"), data.get("scale"),
                                                          (self.random or {}).get("ranges")) if sec for name in sec}
        self.traces = bool(data.get("traces", False))
        self.stability = bool(data.get("stability", False))
        self.compiled = False  # every run compiled (``simulation.compiled: true``; not in the identity)
        self._experiment = None
        self._base = {}  # parameter -> its value in the diagram with set (what a scale multiplies)

    def _check_random(self, spec, line):
        """What the table (check_sweep) does not say of ``random``: a range's low above its high, no range."""
        ranges = spec.get("ranges")
        if not isinstance(ranges, dict) or not ranges:
            raise LoaderError("random: give 'ranges' as {parameter: [low, high]}", self.path, line)
        for k, v in ranges.items():
            why = range_problem(k, v)
            if why:
                raise LoaderError(f"random: {why}", self.path, ranges.lines[k])

    @property
    def experiment(self):
        """The diagram with ``set`` (and the compiled path when asked): what every point changes."""
        if self._experiment is None:
            from hybridsim.format.overrides import overrides_from

            fixed = {**self.fixed, **({"simulation.compiled": True} if self.compiled else {})}
            with self._blaming_set():
                with overrides_from("set"):
                    self._experiment = Experiment(self.diagram, **fixed)
        return self._experiment

    @contextlib.contextmanager
    def _blaming_set(self):
        """Within: an input error is this file's, at the line of the 'set' value it names (the
        diagram's words after it), else at 'diagram'."""
        try:
            yield
        except InputError as exc:
            key = next((k for k in self.fixed if f"set {k}:" in str(exc)), None)
            if key is None:
                raise LoaderError(f"'diagram': {exc}", self.path, self._diagram_line) from None
            raise LoaderError(f"in 'set': {exc}", self.path, self._set_lines.get(key)) from None

    def _base_value(self, ref):
        """Value of a parameter or block parameter in the diagram with ``set`` (for scaling)."""
        if ref not in self._base:
            f = self.experiment.file
            if "." not in ref:
                if ref not in f.params:
                    raise LoaderError(f"cannot scale {ref!r}: no parameter {ref!r} in {self.diagram.name}",
                                      self.path, self._lines.get(ref))
                self._base[ref] = np.asarray(f.params[ref], float)
            else:
                try:
                    self._base[ref] = f.param_value(ref)  # a subsystem's parameter reads its file
                except (HybridsimError, KeyError, ValueError, TypeError) as exc:
                    from hybridsim.format.build import check

                    with self._blaming_set():  # a diagram that does not build says what is wrong itself
                        check(f)
                    raise LoaderError(f"cannot scale {ref!r}: {exc}", self.path, self._lines.get(ref)) from None
            if not np.all(np.isfinite(self._base[ref])):  # inf times any factor: one point under many names
                raise LoaderError(f"cannot scale {ref!r}: its value is {self._base[ref].tolist()!r}, not "
                                  "finite; sweep it with 'grid' instead", self.path, self._lines.get(ref))
        return self._base[ref]

    def axes(self):
        """The table columns of the swept axes, in order (a scaled one as ``name*``)."""
        return list(self.grid) + [f"{k}*" for k in self.scale]

    def points(self):
        """The sweep's :class:`~hybridsim.runs.grid.Grid`: grid x scale (full factorial), then the random draws."""
        total = (int(np.prod([len(v) for v in [*self.grid.values(), *self.scale.values()]]))
                 if self.grid or self.scale else 0) + (int(self.random.get("n", 10)) if self.random else 0)
        if total > limits.MAX_RUNS:  # at the line of the section that makes the most
            counts = {"grid": int(np.prod([len(v) for v in self.grid.values()])),
                      "scale": int(np.prod([len(v) for v in self.scale.values()])),
                      "random": int(self.random.get("n", 10)) if self.random else 0}
            most = max(self._sections, key=counts.get, default=None)
            raise LoaderError(f"the sweep has {total} points; at most {limits.MAX_RUNS}", self.path,
                              self._sections.get(most))
        pts = Grid()
        if self.grid or self.scale:
            pts = Grid.values(self.grid) * Grid.scaled(self.scale, {k: self._base_value(k) for k in self.scale})
        if self.random:
            pts = pts + Grid.random(self.random["ranges"], self.random.get("n", 10), self.random.get("seed", 0))
        if not len(pts):
            self.validate()  # a mistake in 'set' or the diagram first: it is not hidden behind this
            raise InputError(f"{self.path}: the sweep has no points (give grid, scale or random)")
        seen = {}
        for i, p in enumerate(pts, 1):  # one point twice: two rows under one key, a resume that mixes them
            if p.key in seen:
                line = next((self._lines[k] for k in pts[seen[p.key] - 1].changes
                             if k in self._lines and pts[seen[p.key] - 1].changes[k] == p.changes.get(k)), None)
                raise LoaderError(f"points {seen[p.key]} and {i} are the same run "
                                  f"({', '.join(f'{k} = {v!r}' for k, v in p.changes.items())}): a value listed "
                                  "twice in 'grid', a 'random' range of zero width, or factors of a parameter "
                                  "that is 0", self.path, line)
            seen[p.key] = i
        return pts

    def validate(self):
        """Check the diagram, ``set`` and every swept value before any point runs.

        Each grid value, each scale factor, both ends of each random range and a value inside it
        (draws are anywhere in it: a sample rate there is rarely commensurate) are checked as one
        run would be: a run-time change by the blocks it reaches, anything else by
        :func:`hybridsim.format.build.check` of the diagram with it. A sweep naming an unknown
        parameter or a bad value stops here with exit 2.
        """
        from hybridsim.format.build import check, load, warn_unused
        from hybridsim.format.overrides import overrides_from

        exp = self.experiment
        with self._blaming_set():
            check(exp.file)
        warn_unused(exp.file, set(self.grid) | set(self.scale) | set((self.random or {}).get("ranges") or {}))
        tries = [(k, v) for k, vals in self.grid.items() for v in vals]
        tries += [(k, (self._base_value(k) * float(v)).tolist()) for k, vals in self.scale.items() for v in vals]
        if self.random:
            tries += [(k, float(v)) for k, rng in self.random["ranges"].items()
                      for v in (*rng, rng[0] + INSIDE * (rng[1] - rng[0]))]
        for key, value in tries:
            if all(v._unchanged(key, value) or v.runtime(key, value, names=True) for _, v in exp.variants()):
                continue
            try:
                with overrides_from("the sweep's"):
                    check(load(self.diagram, **{**self.fixed, key: value}))
            except InputError as exc:
                raise LoaderError(f"swept value {key} = {value!r}: {exc}", self.path, self._lines.get(key)) from None
        together = {}  # one value of every swept name at once: names that cancel each other (a parameter
        for key, value in tries:  # and every block value that uses it) are refused by the diagram file
            together.setdefault(key, value)
        try:
            with overrides_from("the sweep's"):
                load(self.diagram, **{**self.fixed, **together})
        except InputError as exc:
            key = next((k for k in together if f"the sweep's {k}:" in str(exc)), None)
            raise LoaderError(str(exc), self.path, self._lines.get(key)) from None

    def fingerprint(self):
        """The identity of everything a point's numbers depend on besides its own overrides: every file
        the runs read (diagram, extends, subsystems, URDFs and meshes, FMUs, plugins, files named
        in the sweep), ``set``, ``stability``, ``traces`` and hybridsim's version (:mod:`hybridsim.format.identity`)."""
        from hybridsim.format.identity import sweep_identity

        return sweep_identity(self)


def _number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and bool(np.isfinite(v))


class Row:
    """A sweep's reduce: a run to its row of the table (and its CSV under ``traces``); the first
    variant's row of each point also gets the linearized loop's growth of ``analysis``."""

    def __init__(self, traces=None, analysis=None):
        self.traces, self.analysis = traces, analysis

    def __call__(self, run):
        """The table row of :class:`~hybridsim.runs.many.Run` ``run``."""
        from hybridsim.analysis import metrics

        p = run.point
        head = {"key": p.key, **p.label, "variant": run.label}
        if run.error is not None:
            row = {**head, "status": "failed", "message": str(run.error).splitlines()[0], "wall_time_s": 0.0}
        else:
            settings = run.experiment.settings
            m = metrics.compute(run.result, settings["signals"], settings["metrics"])
            m["wall_time_s"] = run.result.meta["wall_time_s"]
            row = {**head, "status": "ok", "message": "",
                   **{k: (None if isinstance(v, float) and not np.isfinite(v) else v) for k, v in m.items()
                      if not isinstance(v, (list, dict))}}
            if self.traces:
                labels = [label for label, _ in run.experiment.file.variants()]
                run.result.to_csv(Path(self.traces) / trace_name(p.key, run.label, labels))
        if self.analysis is not None:  # this variant's loop (a variant may set the rate)
            row["linear_largest_abs_z"], row["linear_stable"] = self._growth({**(run.variant or {}), **p.changes})
        return row

    def _growth(self, changes):
        """(growth, stable) of the linearized closed loop: the largest |z| of a sampled loop, the
        largest real part of s of a continuous one; (None, None) where it cannot be linearized."""
        try:
            cl = self.analysis.closed_loop(changes)
        except HybridsimError:
            return None, None
        return (None, None) if cl is None else (cl.growth, bool(cl.stable))


def trace_name(key, label, labels):
    """The file of one run's trace under ``traces/``: the point's key, then its variant's label as a
    file name (``labels``: every variant's, so that two never share one)."""
    return dict(zip(labels, unique_names(labels, key)))[label] + ".csv"


def run_sweep(path, outdir, jobs=None, dask=None, progress=True, compiled=False, restart=False, batch=True):
    """Run (or resume) a sweep; returns the table as a list of row dicts (one per point and variant).

    Raises InputError before anything runs for a bad sweep file, diagram, parameter or value,
    or a Dask address that does not answer.

    Parameters
    ----------
    path : str or Path
        The sweep file.
    outdir : str or Path
        Output folder: ``points.jsonl``, ``sweep-manifest.json``, ``sweep.csv``,
        ``sweep.parquet``, ``heatmap.png`` (and ``traces/``). One sweep at a time writes it.
    jobs : int, optional
        Local processes (default: one per core).
    dask : str or distributed.Client, optional
        A Dask scheduler address (or client) to run the points on instead.
    progress : bool
        A progress bar on a terminal.
    compiled : bool
        Every point on the compiled path (as ``simulation.compiled: true`` in ``set``); the same
        numbers, so finished points are reused either way.
    restart : bool
        Start afresh when ``outdir`` holds the points of a different sweep (otherwise that is an
        :class:`~hybridsim.errors.InputError`).
    batch : bool
        Points that change only block numbers run as run-time parameters of one built diagram
        per worker, in chunks; False builds every point anew from the file (the same table).
    """
    sw = Sweep(path)
    outdir = as_path(outdir, "an output folder")
    for name, flag in (("progress", progress), ("compiled", compiled), ("restart", restart), ("batch", batch)):
        if not isinstance(flag, (bool, np.bool_)):
            raise InputError(f"{name} is True or False, got {flag!r}")
    ex = Executor(jobs, dask)
    pts = sw.points()
    sw.compiled = bool(compiled)
    sw.validate()
    fp = sw.fingerprint()
    analysis = None
    if sw.stability:
        from hybridsim.analysis.stability import settings_of

        branch = settings_of(sw.experiment.file)["set"]  # the analysis section's, then the sweep's set over it
        analysis = Experiment.layered(sw.diagram, [branch, sw.fixed])
    with ex, locked_output_dir(outdir) as outdir:  # one sweep per folder at a time
        labels = [label for label, _ in sw.experiment.variants()]
        traced = [f"traces/{trace_name(p.key, label, labels)}" for p in pts for label in labels]
        check_planned(outdir, table_files(sw.axes()) + (("traces/", *traced) if sw.traces else ()))
        store = Store(outdir, fp, "points.jsonl", "sweep-manifest.json", "sweep",
                      "a file its runs read (the diagram, a file it extends, a subsystem, URDF, FMU, plugin or "
                      "a file the sweep names), 'set', 'stability', 'traces' or hybridsim's version or code changed",
                      restart, {"sweep": str(sw.path), "diagram": str(sw.diagram)})
        traces = None
        old = outdir / "traces"
        if store.set_aside is not None and old.is_dir() and not old.is_symlink() and \
                all(written_by_hybridsim(f) for f in old.iterdir()):  # the other job's traces, beside its points
            os.replace(old, aside(old))
        if sw.traces:
            traces = outdir / "traces"
            traces.mkdir(exist_ok=True)
        measure = Simulate(Row(traces, analysis), records=None if traces else "metrics", rebuild=not batch)
        done = run_many(sw.experiment, pts, ex, measure=measure, store=store, progress=progress,
                        desc=sw.path.stem)
        table = [r for rows in done for r in rows]
        write_table(table, outdir)
        stale = outdir / "heatmap.png"  # an earlier sweep's, in a folder this one (with none to draw) reuses
        if not heatmaps(table, sw.axes(), outdir) and stale.is_file() and written_by_hybridsim(stale):
            stale.unlink()
    return table
