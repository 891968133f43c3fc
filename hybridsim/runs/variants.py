"""Every variant of a diagram file (its ``variants:`` section), with metrics: :func:`run_experiment`."""
from hybridsim.runs.executor import Executor, check_jobs, using
from hybridsim.runs.experiment import Experiment
from hybridsim.runs.grid import point, point_key
from hybridsim.runs.many import Failure, Simulate, run_many


def run_experiment(path_or_file, progress=False, jobs=None, executor=None, **overrides):
    """Run every variant of a file; returns ``(file, runs, settings)``.

    ``runs`` is a list of dicts with keys ``label``, ``overrides`` (the variant), ``result``,
    ``metrics`` and ``settings``, in variant order; ``settings`` are the last variant's.
    Several variants run in parallel on ``jobs`` processes (default: one per core, at most
    one per variant) or on ``executor``; ``jobs=1`` runs them here. A run that fails
    raises its error (the first in variant order). ``progress``: a bar over the variants,
    or over simulated time for a single run, on a terminal.
    """
    exp = Experiment(path_or_file, **overrides)
    variants = exp.variants()
    points = [point(label={"variant": label}, key=point_key([k, label]), experiment=v)
              for k, (label, v) in enumerate(variants)]
    if executor is None:
        executor = Executor(min(len(variants), check_jobs(jobs) or Executor().jobs))
    with using(executor) as ex:
        got = run_many(exp, points, ex, measure=Simulate(progress=progress and len(variants) == 1),
                       progress=progress and len(variants) > 1, desc=exp.file.name)
    runs = []
    for (label, _), (r,) in zip(variants, got):
        if isinstance(r, Failure):
            raise r.error
        runs.append({**r, "label": label})
    return exp.file, runs, runs[-1]["settings"]

