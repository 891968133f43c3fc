"""The Python API: load a diagram file, override parameters, simulate.

>>> import hybridsim as hs
>>> res = hs.simulate("diagrams/fig9_force_and_position.yaml", rate=120, t_end=1.0)
>>> res.t, res["ctrl.ft.CF[0]"]

:func:`run_experiment` runs every variant of a file and adds metrics;
:func:`write_outputs` writes CSV, plots and ``metrics.json`` atomically.
"""
import json
import os
from pathlib import Path

from . import metrics as _metrics
from .files import atomic_dir, safe_name
from .loader import DiagramFile
from .simulator import Simulator, on_terminal
from .solvers import FIXED_STEP, ScipySolver


def make_solver(sim):
    """Solver object from a diagram's ``simulation`` settings."""
    name = str(sim.get("solver", "rk4")).lower()
    if name in FIXED_STEP:
        return FIXED_STEP[name](float(sim.get("step", 1e-4)))
    if name == "cvode":
        from .cvode import CVode

        return CVode(rtol=float(sim.get("rtol", 1e-8)), atol=sim.get("atol", 1e-10),
                     max_step=float(sim.get("max_step", float("inf"))))
    method = {"radau": "Radau", "bdf": "BDF", "lsoda": "LSODA", "rk45": "RK45",
              "rk23": "RK23", "dop853": "DOP853"}[name]
    return ScipySolver(method, rtol=float(sim.get("rtol", 1e-8)),
                       atol=sim.get("atol", 1e-10), max_step=float(sim.get("max_step", float("inf"))))


def _atol_vector(system, sim):
    """Per-state absolute tolerances: a block's own where it declares them."""
    import numpy as np

    default = float(sim.get("atol", 1e-10))
    a = system.atol.copy()
    a[np.isnan(a)] = default
    return a


SIMULATION_KEYS = {"t_end", "solver", "step", "rtol", "atol", "max_step", "log_period", "max_state", "fused", "compiled",
                   "locate_switches"}


def load(path, **overrides):
    """Parse a diagram file, applying ``overrides``.

    Keys: a name in ``params`` (``rate=80``), a block parameter
    (``**{"arm.damping": [5, 50]}``), or a simulation setting (``t_end=1``).
    """
    ov = {(f"simulation.{k}" if k in SIMULATION_KEYS else k): v for k, v in overrides.items()}
    return DiagramFile(path, ov)


def build(path_or_file, variant=None, check_only=False, log=None, **overrides):
    """(system, simulator, settings) for one variant of a diagram file.

    ``check_only``: do not generate the compiled module (only check that the
    compiled path can take the diagram), as ``hybridsim check`` does.
    ``log``: the signals to record, instead of the file's ``log`` and
    ``signals`` (e.g. only the signals metrics need).
    """
    f = path_or_file if isinstance(path_or_file, DiagramFile) else load(path_or_file, **overrides)
    diagram, settings = f.build(variant)
    system = diagram.build()
    sim = settings["simulation"]
    solver = make_solver(sim)
    if not isinstance(solver, tuple(FIXED_STEP.values())):  # scipy and CVODE: per-state tolerances
        solver.atol = _atol_vector(system, sim)
    if log is None:
        log = list(settings["log"]) + list(settings["signals"].values())
    compiled = bool(sim.get("compiled", False))
    if compiled and check_only:
        from .compiled import problems
        from .errors import CompiledPathError

        why = problems(system, solver)
        if why:
            raise CompiledPathError("cannot use the compiled path: " + "; ".join(why))
    simulator = Simulator(system, solver, log=log,
                          log_period=sim.get("log_period", 0.0005),
                          max_state=sim.get("max_state", 1e6), fused=bool(sim.get("fused", True)),
                          compiled=compiled and not check_only,
                          locate_switches=bool(sim.get("locate_switches", False)))
    return system, simulator, settings


def check(path_or_file, **overrides):
    """Validate every variant of a diagram file as a run would, without running it.

    Builds each variant's system and simulator (what ``run`` does before its
    first step), so a file that passes cannot fail later for a reason this
    could have seen. Returns a summary dict: ``blocks``, ``states``,
    ``rates`` (Hz, over all variants) and ``runs``. Raises the
    :class:`~hybridsim.errors.InputError` of the first bad variant.
    """
    f = path_or_file if isinstance(path_or_file, DiagramFile) else load(path_or_file, **overrides)
    rates, system = set(), None
    variants = f.variants()
    for label, variant in variants:
        system, simulator, settings = build(f, variant, check_only=True)
        rates |= {float(1 / b.period) for b in system.blocks if b.period}
    return {"blocks": len(system.blocks), "states": system.n_x, "rates": sorted(rates),
            "runs": len(variants)}


def simulate(path_or_file, variant=None, progress=False, **overrides):
    """Run one variant of a diagram file; returns a :class:`~hybridsim.result.Result`."""
    system, simulator, settings = build(path_or_file, variant, **overrides)
    simulator.progress = progress
    return simulator.run(settings["simulation"]["t_end"])


def _run_variant(f, label, variant, progress=False):
    system, simulator, settings = build(f, variant)
    simulator.progress = progress
    result = simulator.run(settings["simulation"]["t_end"])
    m = _metrics.compute(result, settings["signals"], settings["metrics"])
    m["wall_time_s"] = result.meta["wall_time_s"]
    result.context = None  # the final state stays in the worker
    return {"label": label, "overrides": variant, "result": result, "metrics": m}, settings


def run_experiment(path_or_file, progress=False, jobs=None, **overrides):
    """Run every variant of a file; returns ``(file, runs, settings)``.

    ``runs`` is a list of dicts with keys ``label``, ``overrides``, ``result``
    and ``metrics``, in variant order. Several variants run in parallel on
    ``jobs`` processes (default: one per core); ``jobs=1`` runs them here.
    """
    f = path_or_file if isinstance(path_or_file, DiagramFile) else load(path_or_file, **overrides)
    variants = f.variants()
    jobs = min(len(variants), jobs or os.cpu_count() or 1)
    if jobs <= 1:
        out = [_run_variant(f, label, v, progress) for label, v in variants]
    else:
        from concurrent.futures import ProcessPoolExecutor

        bar = None
        if progress:
            from tqdm import tqdm

            bar = tqdm(total=len(variants), unit="run", delay=1.0, leave=False, disable=not on_terminal())
        with ProcessPoolExecutor(jobs) as pool:
            futures = [pool.submit(_run_variant, f, label, v) for label, v in variants]
            out = []
            for fut in futures:
                out.append(fut.result())
                if bar is not None:
                    bar.update(1)
        if bar is not None:
            bar.close()
    return f, [r for r, _ in out], out[-1][1]


def write_outputs(f, runs, settings, outdir):
    """Write CSV per variant, the figure (PNG, SVG) and metrics.json, atomically."""
    from .plots import experiment_figure

    outdir = Path(outdir)
    name = safe_name(f.name)
    with atomic_dir(outdir) as tmp:
        for r in runs:
            stem = name + (("_" + _slug(r["label"])) if r["label"] else "")
            r["result"].to_csv(tmp / f"{stem}.csv")
        fig = experiment_figure(f, runs, settings)
        fig.savefig(tmp / f"{name}.png", dpi=130)
        fig.savefig(tmp / f"{name}.svg")
        import matplotlib.pyplot as plt

        plt.close(fig)
        doc = {"diagram": f.name, "file": str(f.path), "description": f.description,
               "runs": [{"label": r["label"], "overrides": r["overrides"],
                         "solver": r["result"].meta["solver"], "metrics": r["metrics"]}
                        for r in runs]}
        (tmp / "metrics.json").write_text(json.dumps(doc, indent=2, default=float) + "\n")
    return outdir


def _slug(label):
    return safe_name("".join(c if c.isalnum() or c in "-." else "-" for c in label.replace("=", "")), "run")
