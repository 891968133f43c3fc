"""The Python API: load a diagram file, override parameters, simulate.

>>> import hybridsim as hs
>>> res = hs.simulate("diagrams/fig9_force_and_position.yaml", rate=120, t_end=1.0)
>>> res.t, res["ctrl.ft.CF[0]"]

:func:`write_outputs` writes CSV, plots and ``metrics.json`` atomically for the runs of
:func:`hybridsim.runs.variants.run_experiment` (every variant of a file, with metrics).
"""
import json
from pathlib import Path

from hybridsim.files import atomic_dir, safe_name, unique_names
from hybridsim.format import tables
from hybridsim.format import DiagramFile
from hybridsim.engine.simulator import Simulator
from hybridsim.engine.solvers import FIXED_STEP, ScipySolver


def make_solver(sim):
    """Solver object from a diagram's ``simulation`` settings."""
    name = str(sim.get("solver", "rk4")).lower()
    if name in FIXED_STEP:
        return FIXED_STEP[name](float(sim.get("step", _SIM["step"])))
    if name == "cvode":
        from hybridsim.engine.cvode import CVode

        return CVode(rtol=float(sim.get("rtol", _SIM["rtol"])), atol=sim.get("atol", _SIM["atol"]),
                     max_step=float(sim.get("max_step", _SIM["max_step"])))
    method = {"radau": "Radau", "bdf": "BDF", "lsoda": "LSODA", "rk45": "RK45",
              "rk23": "RK23", "dop853": "DOP853"}[name]
    atol = sim.get("atol", _SIM["atol"])
    return ScipySolver(method, rtol=float(sim.get("rtol", _SIM["rtol"])),
                       atol=atol if not isinstance(atol, list) else _SIM["atol"], max_step=float(sim.get("max_step", _SIM["max_step"])))


def _atol_vector(system, sim):
    """Per-state absolute tolerances: ``atol`` given one per state, else a block's own where it
    declares them and ``atol`` (a number) elsewhere."""
    import numpy as np

    from hybridsim.errors import InputError

    given = sim.get("atol", _SIM["atol"])
    if isinstance(given, (list, tuple)):
        if len(given) != system.n_x:
            raise InputError(f"simulation setting 'atol' has {len(given)} value(s); one per continuous "
                             f"state needs {system.n_x} (or give one number)")
        return np.asarray(given, float)
    a = system.atol.copy()
    a[np.isnan(a)] = float(given)
    return a


SIMULATION_KEYS = set(tables.keys(tables.SIMULATION))
_SIM = tables.defaults(tables.SIMULATION)  # the defaults of every simulation setting, from its table


def check_plugin_blocks(system):
    """Evaluate each plugin block's outputs once, at t = 0, and check them against its declared ports.

    Raises :class:`~hybridsim.errors.PluginFault` naming the plugin, the block
    and what it did (raised, or returned the wrong number or width of outputs),
    before the run starts.
    """
    import numpy as np

    from hybridsim.errors import PluginFault
    from hybridsim.engine.registry import _is_ours, plugin_fault

    plugin = [i for i, b in enumerate(system.blocks) if not _is_ours(type(b).__module__)]
    if not plugin:
        return
    try:
        ctx = system.create_context()
    except Exception as exc:  # noqa: BLE001 - a plugin's initial state or outputs may raise anything
        raise (plugin_fault(exc) or exc) from None
    for i in plugin:
        b = system.blocks[i]
        who = (f"plugin {type(b).__module__!r}: block {b.name!r} "
               f"({getattr(type(b), 'type_name', type(b).__name__)})")
        try:
            outs = tuple(b.output(0.0, ctx.block_state(i, ctx.xc), ctx.u[i]))
        except Exception as exc:  # noqa: BLE001
            raise PluginFault(f"{who}: output() raised {type(exc).__name__}: {exc}", type(b).__module__,
                              b.name) from None
        if b.outputs and len(outs) != len(b.outputs):
            raise PluginFault(f"{who}: output() returned {len(outs)} value(s); the block declares "
                              f"{len(b.outputs)} output(s) ({', '.join(p.name for p in b.outputs)})",
                              type(b).__module__, b.name)
        for port, v in zip(b.outputs, outs):
            try:
                np.broadcast_to(np.asarray(v, float), (port.width,))
            except (ValueError, TypeError):
                raise PluginFault(f"{who}: output {port.name!r} returned shape {np.shape(v)}; the block "
                                  f"declares width {port.width}", type(b).__module__, b.name) from None


def load(path, **overrides):
    """Parse a diagram file, applying ``overrides``.

    Keys: a name in ``params`` (``rate=80``), a block parameter
    (``**{"arm.damping": [5, 50]}``), or a simulation setting (``t_end=1``).
    """
    return DiagramFile(path, load_keys(overrides))


def load_keys(overrides):
    """``overrides`` with a bare simulation setting (``t_end``) named as a path (``simulation.t_end``)."""
    return {(f"simulation.{k}" if k in SIMULATION_KEYS else k): v for k, v in overrides.items()}


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
    check_plugin_blocks(system)
    sim = settings["simulation"]
    solver = make_solver(sim)
    if not isinstance(solver, tuple(FIXED_STEP.values())):  # scipy and CVODE: per-state tolerances
        solver.atol = _atol_vector(system, sim)
    if log is None:
        log = list(settings["log"]) + list(settings["signals"].values())
    compiled = bool(sim.get("compiled", False))
    if compiled and check_only:
        from hybridsim.engine.compiled import problems
        from hybridsim.errors import CompiledPathError

        from hybridsim.engine.simulator import located_events

        why = problems(system, solver, located_events(system, solver, bool(sim.get("locate_switches", False))))
        if why:
            raise CompiledPathError("cannot use the compiled path: " + "; ".join(why))
    simulator = Simulator(system, solver, log=log,
                          log_period=sim.get("log_period", _SIM["log_period"]),
                          max_state=sim.get("max_state", _SIM["max_state"]), fused=bool(sim.get("fused", _SIM["fused"])),
                          compiled=compiled and not check_only,
                          locate_switches=bool(sim.get("locate_switches", _SIM["locate_switches"])))
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
    """Run one variant of a diagram file; returns a :class:`~hybridsim.engine.result.Result`."""
    system, simulator, settings = build(path_or_file, variant, **overrides)
    simulator.progress = progress
    return simulator.run(settings["simulation"]["t_end"])


def write_outputs(f, runs, settings, outdir, only_ours=False):
    """Write CSV per variant, the figure (PNG, SVG) and metrics.json, atomically.

    CSV names cannot collide (a short hash where two labels slug alike);
    ``only_ours`` (a default folder): replace no file hybridsim did not write.
    """
    from hybridsim.report.figures import experiment_figure

    outdir = Path(outdir)
    name = safe_name(f.name)
    with atomic_dir(outdir, only_ours=only_ours) as tmp:
        for r, stem in zip(runs, unique_names([r["label"] for r in runs], name)):
            r["csv"] = f"{stem}.csv"
            r["result"].to_csv(tmp / f"{stem}.csv")
        fig = experiment_figure(f, runs, settings)
        fig.savefig(tmp / f"{name}.png", dpi=130)
        fig.savefig(tmp / f"{name}.svg")
        import matplotlib.pyplot as plt

        plt.close(fig)
        doc = {"diagram": f.name, "file": str(f.path), "description": f.description,
               "runs": [{"label": r["label"], "csv": r["csv"], "overrides": r["overrides"],
                         "solver": r["result"].meta["solver"], "metrics": r["metrics"]}
                        for r in runs]}
        (tmp / "metrics.json").write_text(json.dumps(doc, indent=2, default=float) + "\n")
    return outdir



def _file(source, overrides):
    """The DiagramFile of ``source`` (a path, or a DiagramFile whose overrides ``overrides`` extend)."""
    if isinstance(source, DiagramFile):
        return DiagramFile(source.path, {**source.overrides, **load_keys(overrides)}) if overrides else source
    return load(source, **overrides)


def run(source, outdir=None, progress=False, jobs=None, **overrides):
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
    **overrides
        As :func:`load` takes them.

    Returns
    -------
    dict
        ``file`` (the DiagramFile), ``runs`` (as :func:`run_experiment`), ``settings`` and ``outdir``.
    """
    from hybridsim.files import output_dir

    f = _file(source, overrides)
    outdir, only_ours = output_dir(outdir, Path("out") / safe_name(f.name), whole=False)
    check(f)
    from hybridsim.runs.variants import run_experiment

    f, runs, settings = run_experiment(f, progress=progress, jobs=jobs)
    write_outputs(f, runs, settings, outdir, only_ours=only_ours)
    return {"file": f, "runs": runs, "settings": settings, "outdir": outdir}

