"""Many runs of one experiment: :func:`run_many` (experiment, points, executor).

Every "many runs" of hybridsim goes through here: a diagram's ``variants:``, sweep
files, the analysis section's rate, gain and case sweeps, the reproduction's searches and
``hybridsim tune``. What a point gives is its *measure*:

* :class:`Simulate` (the default) runs the point on every variant of the experiment and
  reduces each run (its :class:`Run`) to a value: a table row, metrics, the whole result;
* :class:`Linearize` gives the point's closed loop;
* any picklable ``fn(experiment, point)`` gives whatever it returns.

How :class:`Simulate` runs the points: the changes each point makes are sorted into
run-time changes (block numbers: :meth:`Experiment.split
<hybridsim.runs.experiment.Experiment.split>`) and structural ones (a rate, a width, a
setting); points with the same structural changes share one built experiment. Their
runs go to the executor in chunks, one variant of one built experiment per chunk: a
worker builds it once (and keeps it for later chunks), then runs the whole chunk as one
:meth:`~hybridsim.engine.simulator.Simulator.run_batch` (one compiled loop, the
contexts made with the chunk's parameters) and sends back only the reduced values.
The values stream back chunk by chunk, into the resume store when there is one.
"""
import json
import logging
from typing import NamedTuple

from hybridsim.errors import HybridsimError, InputError
from hybridsim.runs.executor import using
from hybridsim.runs.grid import Grid
from hybridsim.runs.progress import bar

#: most runs of one chunk (one call of a worker)
CHUNK = 64
#: chunks per worker a job is cut into at least (so that the workers finish together)
CHUNKS_PER_WORKER = 4


class Failure:
    """A run that ended with a :class:`~hybridsim.errors.HybridsimError`: ``error`` (in another
    process rebuilt from its class and message)."""

    def __init__(self, error):
        self.error = error

    def __reduce__(self):
        return _failure, (type(self.error), str(self.error))

    def __repr__(self):
        return f"Failure({type(self.error).__name__}: {self.error})"


def _failure(kind, message):
    error = kind.__new__(kind)
    Exception.__init__(error, message)
    return Failure(error)


class Run(NamedTuple):
    """One run of a point on one variant, as a :class:`Simulate` measure reduces it.

    ``result``: the :class:`~hybridsim.engine.result.Result`, or None when the run failed
    with ``error``; ``experiment``: the built experiment it ran (its ``settings``, ``file``);
    ``index``: the variant's number.
    """

    point: object
    label: str
    variant: dict
    result: object
    error: object
    experiment: object
    index: int


def outcome(run):
    """A run as :func:`~hybridsim.runs.variants.run_experiment` gives it: ``label``, ``overrides``
    (the variant), ``result``, ``metrics`` and ``settings``; a :class:`Failure` when it failed."""
    from hybridsim.analysis import metrics

    if run.error is not None:
        return Failure(run.error)
    settings = run.experiment.settings
    m = metrics.compute(run.result, settings["signals"], settings["metrics"])
    m["wall_time_s"] = run.result.meta["wall_time_s"]
    run.result.context = None  # the final state stays in the worker
    return {"label": run.label, "overrides": run.variant, "result": run.result, "metrics": m, "settings": settings}


class Simulate:
    """Measure: run each point on every variant of the experiment; a point gives the list of its runs'
    reduced values, in variant order.

    Parameters
    ----------
    reduce : callable, optional
        ``reduce(run)`` -> value, in the worker (default :func:`outcome`). A value that is
        stored must be JSON-able.
    records : None, "metrics" or list of str
        What each run logs: the file's ``log`` and ``signals`` (None), only the signals the
        metrics read, or these signals.
    chunk : int
        Most runs a worker gets in one call.
    rebuild : bool
        Build every point anew from the file, making no change at run time (the reference
        the batched runs must equal).
    progress : bool
        The engine's bar of simulated time for a chunk of one run (a single run on a terminal).
    """

    per_variant = True

    def __init__(self, reduce=None, records=None, chunk=CHUNK, rebuild=False, progress=False):
        self.reduce, self.records, self.chunk, self.rebuild = reduce or outcome, records, chunk, rebuild
        self.progress = progress

    def __call__(self, experiment, label, index, items):
        """Run ``items`` (``[(point, run-time changes)]``) on ``experiment`` (one variant, built here once):
        ``[(key, index, value)]``."""
        try:
            sim = experiment.simulator
        except HybridsimError as exc:  # a structure that does not build: every run of it fails so
            return [(p.key, index, self.reduce(Run(p, label, experiment.variant, None, exc, experiment, index)))
                    for p, _ in items]
        batch, alone = [], []
        for p, changes in items:
            try:
                batch.append((p, changes, experiment.params_of(
                    {k: v for k, v in changes.items() if not experiment._unchanged(k, v)})))
            except (HybridsimError, ValueError, TypeError, KeyError):
                alone.append((p, changes))
        results = []
        if self.progress and len(batch) == 1:
            sim.progress = True
            try:
                results = [_one(experiment, batch[0][1], batch[0][2])]
            finally:
                sim.progress = False
        elif batch:
            try:
                results = sim.run_batch(experiment.t_end, [params for _, _, params in batch], workers=1)
            except HybridsimError:  # a value one of them cannot take at run time: each on its own, to say which
                results = [_one(experiment, changes, params) for _, changes, params in batch]
        got = [(p, r) for (p, _, _), r in zip(batch, results)]
        got += [(p, _one(experiment, changes, None)) for p, changes in alone]
        out = []
        for p, r in got:
            failed = isinstance(r, HybridsimError)
            run = Run(p, label, experiment.variant or {}, None if failed else r, r if failed else None, experiment,
                      index)
            out.append((p.key, index, self.reduce(run)))
        return out


def _one(experiment, changes, params):
    """One run on its own: its Result, or the error it ends with. ``params`` None, or refused at run
    time: ``changes`` built into a new experiment."""
    try:
        if params is not None:
            try:
                return experiment.run(params)
            except InputError:  # refused at run time (a change of structure): built anew below
                pass
        return experiment.rebuilt(changes).run()
    except HybridsimError as exc:
        return exc


class Linearize:
    """Measure: each point's closed loop about the initial state, or about the state reached at ``at`` s
    (:meth:`Experiment.closed_loop <hybridsim.runs.experiment.Experiment.closed_loop>`; None where it
    cannot be linearized), reduced by ``reduce(closed_loop, point)`` when given."""

    per_variant = False

    def __init__(self, at=None, reduce=None):
        self.at, self.reduce = at, reduce

    def __call__(self, experiment, label, index, items):
        """``[(key, 0, closed loop)]`` of ``items`` on ``experiment``."""
        out = []
        for p, _ in items:
            cl = experiment.closed_loop(p.changes, self.at)
            out.append((p.key, 0, cl if self.reduce is None else self.reduce(cl, p)))
        return out


class _PerPoint:
    """Measure: ``fn(experiment, point)`` for each point."""

    per_variant = False

    def __init__(self, fn):
        self.fn = fn

    def __call__(self, experiment, label, index, items):
        return [(p.key, 0, self.fn(experiment, p)) for p, _ in items]


def run_many(experiment, points, executor=None, *, measure=None, store=None, progress=False, desc=None):
    """Run ``experiment`` at every point of ``points``; the points' values, in the order of ``points``.

    Parameters
    ----------
    experiment : Experiment
        What runs (a point may carry an experiment of its own: :class:`~hybridsim.runs.grid.Point`).
    points : Grid or iterable of Point or dict
        The points (a dict is a point's changes). Points with the same key run once.
    executor : Executor or int, optional
        Where: an :class:`~hybridsim.runs.executor.Executor` (left open), or a number of local
        processes; default here, one after the other.
    measure : Simulate, Linearize or callable, optional
        What a point gives (see the module doc; default ``Simulate()``: per variant, the run
        with its metrics).
    store : Store, optional
        Finished points are read back from it instead of run, and each new one is appended
        as its chunk finishes (:class:`~hybridsim.runs.store.Store`; the values must be JSON-able).
    progress : bool
        A progress bar of the points on a terminal (:func:`~hybridsim.runs.progress.bar`).
    desc : str, optional
        The bar's label.

    Returns
    -------
    list
        Per point: with :class:`Simulate`, the list of its runs' values in variant order (a
        failed run's value is what ``reduce`` made of it; the default gives a :class:`Failure`);
        else the measure's value.
    """
    measure = measure or Simulate()
    if not hasattr(measure, "per_variant"):
        measure = _PerPoint(measure)
    pts = list(points if isinstance(points, Grid) else Grid(points))
    unique = {}
    for p in pts:
        unique.setdefault(p.key, p)
    values = {k: store.get(k) for k in unique if store is not None and k in store}
    todo = [p for k, p in unique.items() if k not in values]
    if values and progress:
        logging.getLogger("hybridsim").info("%d of %d points found in %s from an earlier run; %d to run",
                                            len(values), len(unique), store.path.name, len(todo))
    shown = bar(len(unique), len(values), desc, show=progress)
    try:
        with using(executor, jobs=1) as ex:
            for finished in _stream(experiment, todo, ex, measure):
                if store is not None:
                    store.add(finished)  # one write per finished chunk
                values.update(finished)
                shown.update(len(finished))
    finally:
        shown.close()
    return [values[p.key] for p in pts]


def _stream(experiment, todo, ex, measure):
    """Yield ``{key: value}`` of the points of ``todo`` as their last run finishes."""
    if not todo:
        return
    tasks, runs = _tasks(experiment, todo, ex.width, measure)
    got = {k: [None] * n for k, n in runs.items()}
    left = dict(runs)
    for _, outputs in ex.as_completed(_work, tasks):
        finished = {}
        for key, index, value in outputs:
            got[key][index] = value
            left[key] -= 1
            if not left[key]:
                finished[key] = got[key] if measure.per_variant else got[key][0]
        if finished:
            yield finished


def _work(task):
    """A worker's call: the measure over one chunk of one (variant of an) experiment."""
    measure, experiment, label, index, items = task
    return measure(experiment, label, index, items)


def _tasks(experiment, todo, width, measure):
    """The chunks of ``todo`` (``[(measure, experiment, label, variant index, [(point, changes)])]``) and
    how many runs each point's value waits for."""
    groups = {}  # (experiment, structural changes) -> (experiment to build, [(point, run-time changes)])
    for p in todo:
        exp = p.experiment or experiment
        shipped = p._replace(experiment=None)
        if not measure.per_variant:
            groups.setdefault((id(exp), ""), (exp, []))[1].append((shipped, p.changes))
            continue
        runtime, structural = ({}, p.changes) if measure.rebuild else _sort(exp, p.changes)
        tag = (id(exp), json.dumps(structural, sort_keys=True, default=str))
        if tag not in groups:
            groups[tag] = ((exp.rebuilt(structural) if structural else exp).recording(measure.records), [])
        groups[tag][1].append((shipped, runtime))
    tasks, runs = [], {}
    for exp, items in groups.values():
        variants = exp.variants() if measure.per_variant else [("", exp)]
        size = 1 if not measure.per_variant else \
            max(1, min(measure.chunk, -(-len(items) // (CHUNKS_PER_WORKER * max(1, width)))))
        for index, (label, exp_v) in enumerate(variants):
            tasks += [(measure, exp_v, label, index, items[c:c + size]) for c in range(0, len(items), size)]
        for p, _ in items:
            runs[p.key] = len(variants)
    return tasks, runs


def _sort(experiment, changes):
    """(run-time changes, structural changes) of ``changes``: run-time when every variant of
    ``experiment`` takes the change at run time."""
    variants = experiment.variants()
    runtime, structural = {}, {}
    for key, value in changes.items():
        if all(v._unchanged(key, value) or v.runtime(key, value, names=True) for _, v in variants):
            runtime[key] = value
        else:
            structural[key] = value
    return runtime, structural
