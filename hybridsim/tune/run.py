"""``hybridsim tune``: a search over a diagram's run parameters, from a tune file.

:func:`run_tune` does everything the command does: checks the tune file and
the diagram, measures the diagram as it is ("before"), runs the optimiser on
the executor with the store (resumable), and writes into the output folder
``best.yaml`` (an overlay that ``extends`` the diagram), ``best.json``,
``evaluations.csv``, ``evaluations.jsonl``, ``convergence.png`` and, for two
objectives, ``pareto.png`` and ``pareto.csv``.
"""
import math
import time
from pathlib import Path

import numpy as np

from hybridsim.files import check_planned, make_output_dir
from hybridsim.runs.grid import point
from hybridsim.runs.many import run_many
from hybridsim.tune import drivers
from hybridsim.tune import outputs
from hybridsim.tune.quantities import measure
from hybridsim.tune.spec import load_tune


def evaluate_point(spec, values=None):
    """Measure one point of ``spec`` (see :func:`hybridsim.tune.quantities.measure`)."""
    return measure(spec, values)


def violations(spec, rec):
    """Each constraint's relative violation in record ``rec`` (0 inside its bounds)."""
    return [q.violation(rec["quantities"].get(q.name)) for q in spec.constraints]


def objectives(spec, rec):
    """The objective values of record ``rec`` (NaN where none)."""
    return [rec["quantities"].get(q.name, math.nan) for q in spec.objectives]


def score(spec, rec):
    """The penalised scalar a minimiser sees (:mod:`.drivers`)."""
    if rec["status"] != "ok":
        return drivers.FAILED
    objs = objectives(spec, rec)
    if any(not np.isfinite(v) for v in objs):
        return drivers.FAILED
    viol = sum(violations(spec, rec))
    if viol > 0:
        return drivers.INFEASIBLE + 1e6 * min(viol, 1e3)
    q = spec.objectives[0]
    return objs[0] if q.goal == "min" else -objs[0]


def judged(spec, rec):
    """``rec`` with ``feasible`` and ``score`` (from its status and quantities)."""
    feasible = rec["status"] == "ok" and not any(v > 0 for v in violations(spec, rec)) and \
        all(np.isfinite(v) for v in objectives(spec, rec))
    return {**rec, "feasible": feasible, "score": score(spec, rec)}


class PointMeasure:
    """The tuner's measure for :func:`~hybridsim.runs.many.run_many`: a point's record (``key``,
    ``values``, ``status``, ``message``, ``quantities``, ``wall_s``, ``feasible``, ``score``)."""

    def __init__(self, spec):
        self.spec = spec

    def __call__(self, experiment, pt):
        """Measure point ``pt`` (its changes are the parameter values) and judge it."""
        got = measure(self.spec, pt.changes or None)
        rec = {"key": pt.key, "values": pt.changes, "status": got["status"], "message": got["message"],
               "quantities": got["quantities"], "wall_s": got.get("wall_s", 0.0)}
        return judged(self.spec, rec)


class Evaluator:
    """Points to records through :func:`~hybridsim.runs.many.run_many` (a point in the store is not
    run again) on one executor.

    A record: ``n`` (evaluation number), ``key``, ``values``, ``status``, ``message``,
    ``quantities``, ``feasible``, ``score`` (the penalised scalar, :mod:`.drivers`).
    """

    def __init__(self, spec, store, executor, experiment, bar=None):
        self.spec, self.store, self.ex, self.experiment, self.bar = spec, store, executor, experiment, bar
        self.objectives_q = spec.objectives
        self.history = []
        self.ran = 0

    @property
    def width(self):
        """How many points run at once."""
        return self.ex.width

    def violations(self, rec):
        """Each constraint's relative violation (0 inside its bounds)."""
        return violations(self.spec, rec)

    def objectives(self, rec):
        """The objective values of ``rec`` (NaN where none)."""
        return objectives(self.spec, rec)

    def score(self, rec):
        """The penalised scalar a minimiser sees (:mod:`.drivers`)."""
        return score(self.spec, rec)

    def batch(self, points):
        """Records for ``points`` (``{path: value}`` each), in order; new ones run in parallel."""
        pts = [point(p) for p in points]
        self.ran += len({p.key for p in pts if p.key not in self.store})
        recs = run_many(self.experiment, pts, self.ex, measure=PointMeasure(self.spec), store=self.store)
        out = []
        for p, rec in zip(pts, recs):
            rec = {**judged(self.spec, {**rec, "values": p.changes}), "n": len(self.history) + 1}
            self.history.append(rec)
            out.append(rec)
            if self.bar is not None:
                self.bar.update(1)
        if self.bar is not None:
            best = self.best()
            if best is not None:
                self.bar.set_postfix_str(", ".join(f"{q.name}={best['quantities'][q.name]:.4g}"
                                                   for q in self.spec.objectives))
        return out

    def best(self):
        """The best record so far: the feasible one with the best first objective (lowest score)."""
        ok = [r for r in self.history if r["status"] == "ok"]
        return min(ok, key=lambda r: (r["score"], r["n"])) if ok else None


def _start(spec):
    """The diagram's own values of the parameters as a unit vector, or None when one is outside its bounds."""
    from hybridsim.analysis.stability import param_value
    from hybridsim.format.build import load

    f = load(spec.diagram, **spec.fixed)
    u = []
    for p in spec.parameters:
        try:
            v = f.params[p.path] if "." not in p.path else param_value(f, p.path)
        except Exception:  # noqa: BLE001 - a parameter the file does not give: no start there
            return None
        v = np.ravel(np.asarray(v, float if p.values is None else object))
        if v.size == 0 or any(x != v[0] for x in v):
            return None
        x = p.to_unit(v[0].item() if hasattr(v[0], "item") else v[0])
        if x is None:
            return None
        u.append(x)
    return np.array(u)


def run_tune(path, outdir, jobs=None, dask=None, progress=True, restart=False, compiled=False):
    """Run (or resume) the search of tune file ``path``; returns a summary dict.

    Parameters
    ----------
    path : str or Path
        The tune file (:mod:`hybridsim.tune.spec`).
    outdir : str or Path
        Output folder (made if missing); holds the store of evaluated points.
    jobs : int, optional
        Local processes (default one per core).
    dask : str or distributed.Client, optional
        A Dask scheduler address (or client) to run the points on instead.
    progress : bool
        A progress bar on the terminal.
    restart : bool
        Start afresh when ``outdir`` holds another search's points.
    compiled : bool
        Every run on the compiled path (``simulation.compiled: true``).

    Returns
    -------
    dict
        ``before`` and ``best`` (records: values, quantities, feasible), ``front`` (two objectives),
        ``evaluations`` (points the optimiser asked for), ``ran`` (run now, not from the store),
        ``wall_time_s``, ``files``.
    """
    from hybridsim.format.identity import identity, run_files
    from hybridsim.runs.executor import Executor
    from hybridsim.runs.experiment import Experiment
    from hybridsim.runs.progress import bar as progress_bar
    from hybridsim.runs.store import Store

    t0 = time.perf_counter()
    spec = load_tune(path)
    ex = Executor(jobs, dask)
    if compiled:
        spec.fixed["simulation.compiled"] = True
    exp = Experiment(spec.diagram, **spec.fixed)
    fp = identity(run_files(exp.file), {"tune": spec.text,
                                        "set": {k: v for k, v in spec.fixed.items() if k != "simulation.compiled"}})
    outdir = make_output_dir(Path(outdir))
    check_planned(outdir, outputs.files(spec))  # refused now, not after the search
    store = Store(outdir, fp, "evaluations.jsonl", "tune-manifest.json", "search",
                  "another diagram or tune file, a file its runs read, or hybridsim's version or code", restart,
                  {"tune_file": str(spec.path), "diagram": str(spec.diagram)})
    shown = progress_bar(drivers.budget(spec.method, spec.options, len(spec.parameters)), desc="tune",
                         unit="point", show=progress)
    try:
        with ex:
            ev = Evaluator(spec, store, ex, exp)
            before = ev.batch([{}])[0]  # the diagram as it is (and a check of every quantity)
            before["values"] = None
            ev.history.clear()
            ev.bar = shown
            drivers.run(spec.method, spec.options, spec.parameters, ev, _start(spec))
    finally:
        shown.close()
    return _write(spec, outdir, ev, before, time.perf_counter() - t0)


def _write(spec, outdir, ev, before, wall):
    hist = ev.history
    best = ev.best()
    files = ["evaluations.jsonl"] + outputs.files(spec)[:3]
    outputs.write_table(outdir / "evaluations.csv", spec, hist)
    outputs.convergence_plot(outdir / "convergence.png", spec, hist)
    front = []
    if len(spec.objectives) == 2:
        feas = [r for r in hist if r["feasible"]]
        uniq = list({r["key"]: r for r in feas}.values())
        pts = [[(1 if q.goal == "min" else -1) * r["quantities"][q.name] for q in spec.objectives] for r in uniq]
        front = [uniq[i] for i in outputs.pareto(pts)] if pts else []
        outputs.pareto_plot(outdir / "pareto.png", spec, hist, front)
        outputs.write_table(outdir / "pareto.csv", spec, front)
        files += ["pareto.png", "pareto.csv"]
    if best is not None and best["values"]:
        from hybridsim.files import atomic_file

        with atomic_file(outdir / "best.yaml", "w") as fh:
            fh.write(outputs.overlay(spec, best["values"], outdir))
        files.append("best.yaml")
    doc = {"tune_file": str(spec.path), "diagram": str(spec.diagram), "method": spec.method,
           "options": {**drivers.DEFAULTS[spec.method], **spec.options},
           "objectives": [q.describe() + f" ({q.goal})" for q in spec.objectives],
           "constraints": [q.describe() + "".join(f" {s} {b:g}" for s, b in (("<=", q.upper), (">=", q.lower))
                                                  if b is not None) for q in spec.constraints],
           "before": _brief(before), "best": _brief(best), "front": [_brief(r) for r in front],
           "evaluations": len(hist), "ran": ev.ran, "wall_time_s": wall}
    outputs.write_json(outdir / "best.json", doc)
    from hybridsim.files import written_by_hybridsim

    for name in ("pareto.png", "pareto.csv", "best.yaml"):  # an earlier search's, which this one has none of
        stale = outdir / name
        if name not in files and stale.is_file() and written_by_hybridsim(stale):
            stale.unlink()
    return {**doc, "before": before, "best": best, "front": front, "files": files, "outdir": str(outdir)}


def _brief(rec):
    if rec is None:
        return None
    return {k: rec.get(k) for k in ("values", "quantities", "feasible", "status", "message", "n")}
