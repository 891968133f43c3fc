"""The Python API: load a diagram file, override parameters, simulate.

>>> import hybridsim as hs
>>> res = hs.simulate("diagrams/fig9_force_and_position.yaml", rate=120, t_end=1.0)
>>> res.t, res["ctrl.ft.CF[0]"]

:func:`write_outputs` writes CSV, plots and ``metrics.json`` atomically for the runs of
:func:`hybridsim.runs.variants.run_experiment` (every variant of a file, with metrics).
"""
import json
import logging
from pathlib import Path

from hybridsim.files import atomic_dir, check_planned, safe_name, unique_names
from hybridsim.format import DiagramFile
from hybridsim.format.build import (SIMULATION_KEYS, build, check, check_plugin_blocks, load,  # noqa: F401
                                     make_solver, simulate, warn_unused)


def write_outputs(f, runs, settings, outdir):
    """Write CSV per variant, the figure (PNG, SVG) and metrics.json, atomically.

    CSV names cannot collide (a short hash where two labels slug alike); a file of the same name
    that hybridsim did not write is not replaced (the write is refused).
    """
    from hybridsim.report.figures import experiment_figure

    outdir = Path(outdir)
    name = safe_name(f.name)
    with atomic_dir(outdir) as tmp:
        for r, csv in zip(runs, output_names(f, [r["label"] for r in runs])):
            r["csv"] = csv
            r["result"].to_csv(tmp / csv)
        import matplotlib.pyplot as plt

        fig = None
        try:
            fig = experiment_figure(f, runs, settings)
            fig.savefig(tmp / f"{name}.png", dpi=130)
            fig.savefig(tmp / f"{name}.svg")
        except (ValueError, OverflowError) as exc:  # values matplotlib cannot scale (near 1e308): the
            logging.getLogger("hybridsim").warning(  # tables are written all the same
                "%s: no figure drawn: matplotlib cannot draw these values (%s); the CSV has them", f.path, exc)
            for ext in ("png", "svg"):
                (tmp / f"{name}.{ext}").unlink(missing_ok=True)
        finally:
            plt.close(fig or "all")
        doc = {"diagram": f.name, "file": str(f.path), "description": f.description,
               "set": dict(getattr(f, "overrides", None) or {}),  # the changes given (--set), over every run
               "runs": [{"label": r["label"], "csv": r["csv"], "overrides": r["overrides"],
                         "solver": r["result"].meta["solver"], "metrics": r["metrics"],
                         "notes": r["result"].meta.get("metric_notes", [])}
                        for r in runs]}
        (tmp / "metrics.json").write_text(json.dumps(doc, indent=2, default=float) + "\n")
    return outdir


def output_names(f, labels=None):
    """The files :func:`write_outputs` writes for diagram file ``f``: a CSV per variant (``labels``,
    default the file's), the figure (PNG, SVG) and metrics.json."""
    name = safe_name(f.name)
    labels = [label for label, _ in f.variants()] if labels is None else labels
    return [f"{stem}.csv" for stem in unique_names(labels, name)] + [f"{name}.png", f"{name}.svg", "metrics.json"]


def _file(source, overrides):
    """The DiagramFile of ``source`` (a path, or a DiagramFile whose overrides ``overrides`` extend)."""
    return load(source, **overrides)


def run(source, outdir=None, progress=False, jobs=None, announce=None, **overrides):
    """Run every variant of a diagram and write its CSV, figure and metrics; ``hybridsim run``.

    Parameters
    ----------
    source : str, Path or DiagramFile
        The diagram.
    outdir : path-like, optional
        The output folder (default ``out/<name>``, where no file hybridsim did not write is replaced).
    progress : bool
        A progress bar on a terminal.
    jobs : int, optional
        Processes for several variants (default one per core).
    announce : callable, optional
        Called with the DiagramFile once it has passed the checks, before the first run.
    **overrides
        As :func:`load` takes them.

    Returns
    -------
    dict
        ``file`` (the DiagramFile), ``runs`` (as :func:`run_experiment`), ``settings`` and ``outdir``.
    """
    from hybridsim.engine.arguments import flag
    from hybridsim.files import output_dir
    from hybridsim.runs.executor import check_jobs

    progress, jobs = flag("progress", progress), check_jobs(jobs)
    f = _file(source, overrides)
    outdir, _ = output_dir(outdir, Path("out") / safe_name(f.name), whole=False)
    check(f)
    warn_unused(f)
    check_planned(outdir, output_names(f))  # refused now, not after the runs
    if announce is not None:
        announce(f)
    from hybridsim.runs.variants import run_experiment

    f, runs, settings = run_experiment(f, progress=progress, jobs=jobs)
    write_outputs(f, runs, settings, outdir)
    return {"file": f, "runs": runs, "settings": settings, "outdir": outdir}


def analyze(source, at=None, sweeps=True, **overrides):
    """Linearize a diagram and judge its stability; what ``hybridsim analyze`` prints (without files).

    Parameters
    ----------
    source : str, Path or Experiment
        The diagram (``overrides`` as ``--set`` gives them).
    at : float, optional
        Linearize about the state reached at ``at`` s of simulation (default: the start, or the
        file's ``analysis: at``).
    sweeps : bool
        Also the rate and gain sweeps of the ``analysis`` section (the slow part).

    Returns
    -------
    dict
        Poles, largest ``|z|`` (or Re s), loop margins with ``closed_loop_stable`` and
        ``open_loop_unstable_poles``, cases and sweeps: see
        :func:`hybridsim.analysis.stability.analyze`.
    """
    from hybridsim.analysis.stability import analyze as _analyze

    return _analyze(source, at=at, sweeps=sweeps, **overrides)
