"""From a diagram file to a runnable simulator: load, build, check, simulate.

:func:`load` parses a file with overrides (:class:`~hybridsim.format.DiagramFile`),
:func:`build` turns one of its variants into ``(system, simulator, settings)`` (the
solver from the ``simulation`` settings, per-state tolerances, the compiled path
when asked), :func:`check` builds every variant as a run would, without running,
and :func:`simulate` runs one. The public API (:mod:`hybridsim.api`) re-exports them.
"""
import logging
import os
import re
from hybridsim.engine.simulator import Simulator
from hybridsim.errors import RateError
from hybridsim.engine.solvers import FIXED_STEP, ScipySolver
from hybridsim.format import tables
from hybridsim.format.diagram_file import DiagramFile


def make_solver(sim):
    """Solver object from a diagram's ``simulation`` settings."""
    name = str(sim.get("solver", "rk4")).lower()
    scan = float(sim.get("scan", _SIM["scan"]))
    if name in FIXED_STEP:
        return FIXED_STEP[name](float(sim.get("step", _SIM["step"])), scan=scan)
    if name == "cvode":
        from hybridsim.engine.cvode import CVode

        return CVode(rtol=float(sim.get("rtol", _SIM["rtol"])), atol=sim.get("atol", _SIM["atol"]),
                     max_step=float(sim.get("max_step", _SIM["max_step"])), scan=scan)
    method = {"radau": "Radau", "bdf": "BDF", "lsoda": "LSODA", "rk45": "RK45",
              "rk23": "RK23", "dop853": "DOP853"}[name]
    atol = sim.get("atol", _SIM["atol"])
    return ScipySolver(method, rtol=float(sim.get("rtol", _SIM["rtol"])),
                       atol=atol if not isinstance(atol, list) else _SIM["atol"],
                       max_step=float(sim.get("max_step", _SIM["max_step"])), scan=scan)


def _atol_vector(system, sim, where=None):
    """Per-state absolute tolerances: ``atol`` given one per state, else ``atol`` (a number) where a
    block declares none, and a block's own where it does, at most ``atol`` when the diagram gives it
    (a user's tighter tolerance tightens every state). ``where``: 'file:line' (or the override) of it."""
    import numpy as np

    from hybridsim.errors import InputError

    given = sim.get("atol", _SIM["atol"])
    if isinstance(given, (list, tuple)):
        if len(given) != system.n_x:
            raise InputError(f"{where + ': ' if where else ''}simulation setting 'atol' has {len(given)} "
                             f"value(s); one per continuous state needs {system.n_x} (or give one number)")
        return np.asarray(given, float)
    a = system.atol.copy()
    a[np.isnan(a)] = float(given)
    return np.minimum(a, float(given)) if "atol" in sim else a


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
        for port, v in zip(b.outputs, outs):  # its width exactly: the compiled glue reads every element
            try:
                size = np.asarray(v, float).size
            except (ValueError, TypeError):
                size = None
            if size != port.width:
                raise PluginFault(f"{who}: output {port.name!r} returned shape {np.shape(v)}; the block "
                                  f"declares width {port.width}", type(b).__module__, b.name) from None


def load(path, **overrides):
    """Parse a diagram file (or take a parsed :class:`DiagramFile`), applying ``overrides``.

    Keys: a name in ``params`` (``rate=80``), a block parameter
    (``**{"arm.damping": [5, 50]}``), or a simulation setting (``t_end=1``).
    A name that is both a parameter and a setting is the parameter, as with
    ``--set``; the setting is then ``**{"simulation.step": 1e-3}``.
    """
    if isinstance(path, DiagramFile):  # a parsed file: ``overrides`` over its own
        return again(path, overrides) if overrides else path
    if isinstance(path, (str, os.PathLike)) and str(path) and not os.path.lexists(path):
        from hybridsim.shipped import find_diagram

        path, note = find_diagram(path)  # 'diagrams/NAME.yaml' from any folder, as the CLI
        if note:
            logging.getLogger("hybridsim").info("%s", note.removeprefix("note: "))
    return DiagramFile(path, overrides)


def again(f, overrides=None):
    """DiagramFile ``f`` parsed afresh with its overrides, each mapping as it was applied, then ``overrides``."""
    layers = list(f.layers) + ([overrides] if overrides else [])
    g = DiagramFile(f.path, layers[0] if layers else None)
    for layer in layers[1:]:
        g.apply(layer)
    return g


def build(path_or_file, variant=None, check_only=False, log=None, **overrides):
    """(system, simulator, settings) for one variant of a diagram file.

    ``check_only``: do not generate the compiled module (only check that the
    compiled path can take the diagram), as ``hybridsim check`` does.
    ``log``: the signals to record, instead of the file's ``log`` and
    ``signals`` (e.g. only the signals metrics need).
    """
    f = load(path_or_file, **overrides)
    diagram, settings = f.build(variant)
    try:
        system = diagram.build()
    except RateError as exc:  # rates with no small common tick: the file, and the line of each block named
        locs = f._locs("blocks")
        listing = re.search(r"\(([^)]*)\)", str(exc))  # "(z2 8.1 Hz, z 10 Hz)"
        listed = {item.rsplit(" ", 2)[0].split(".")[0] for item in listing.group(1).split(", ")} if listing else set()
        named = [f"{n} at {loc}" for n, loc in locs.items() if n in listed]
        raise RateError(f"{f.path}: {exc}" + (f" (blocks: {', '.join(named)})" if named else "")) from None
    check_plugin_blocks(system)
    sim = settings["simulation"]
    solver = make_solver(sim)
    if not isinstance(solver, tuple(FIXED_STEP.values())):  # scipy and CVODE: per-state tolerances
        locs = getattr(f.data.get("simulation"), "locs", None) or {}
        solver.atol = _atol_vector(system, sim, str(locs.get("atol", f.path)))
    if log is None:
        log = list(settings["log"]) + list(settings["signals"].values())
    elif isinstance(log, str) or not all(isinstance(r, str) for r in _items(log)):
        raise TypeError(f"log is a list of signals 'block.port' or 'block.port[i]', got {log!r}")
    else:  # a subsystem's output named as 'sub.port', as in the file's log
        log = [f._alias(r) for r in log]
    compiled = bool(sim.get("compiled", False))
    if compiled and check_only:
        from hybridsim.engine.compiled import problems
        from hybridsim.errors import CompiledPathError

        from hybridsim.engine.simulator import located_events

        why = problems(system, solver, located_events(system, solver, bool(sim.get("locate_switches", False))))
        if why:
            raise CompiledPathError("cannot use the compiled path: " + "; ".join(why))
    try:
        simulator = Simulator(system, solver, log=log,
                              log_period=sim.get("log_period", _SIM["log_period"]),
                              max_state=sim.get("max_state", _SIM["max_state"]),
                              fused=bool(sim.get("fused", _SIM["fused"])), compiled=compiled and not check_only,
                              locate_switches=bool(sim.get("locate_switches", _SIM["locate_switches"])),
                              aliases=f.aliases)
    except RateError as exc:  # the log period's: its file and line (or its override)
        locs = getattr(f.data.get("simulation"), "locs", None) or {}
        raise RateError(f"{locs.get('log_period', f.path)}: simulation setting 'log_period': {exc}") from None
    _warn_many_events(f, system, float(sim.get("t_end", _SIM["t_end"])))
    return system, simulator, settings


#: regular events of one block over a run above which the run is warned it will be long
MANY_EVENTS = 20_000


def _warn_many_events(f, system, t_end):
    """Warn of a block whose regular events (``event_spacing``) number more than MANY_EVENTS to t_end:
    each one ends a solver step and is located, so such a run is long."""
    from hybridsim.engine.registry import type_name

    for b in system.blocks:
        if b.event_spacing and t_end / b.event_spacing > MANY_EVENTS:
            logging.getLogger("hybridsim").warning(
                "%s: block %r makes an event every %.3g s, %.3g of them to t_end %g s, each ending a solver "
                "step: a long run (its parameters set the spacing: hybridsim blocks -v %s)",
                f._locs("blocks").get(b.name.split(".")[0], f.path), b.name, b.event_spacing,
                t_end / b.event_spacing, t_end, type_name(b) or type(b).__name__)


def _items(value):
    try:
        return list(value)
    except TypeError:
        return [value]


_SAID = set()  # the warnings check_analysis_branches gave


def check_analysis_branches(f):
    """Build the ``analysis`` section's ``set`` and each of its ``cases`` of the parsed file ``f`` as
    ``analyze`` builds them (``hybridsim check``; not part of :func:`check`, which sweeps and tune
    searches call once per value)."""
    from hybridsim.errors import InputError, LoaderError
    from hybridsim.format.overrides import overrides_from
    from hybridsim.format.values import _references as references

    if not f.data.get("analysis") or f.path is None:
        return
    build(f, check_only=True)  # the section's own problems first, not as a branch's
    cfg = f.analysis_settings()
    branches = [("set", "", cfg.get("set") or {})]
    branches += [("cases", name, {**(cfg.get("set") or {}), **ov}) for name, ov in (cfg.get("cases") or {}).items()]
    branches += [("compare", name, {**(cfg.get("set") or {}), **ov})
                 for name, ov in (cfg.get("compare") or {}).items() if isinstance(ov, dict)]
    step = cfg.get("step") if isinstance(cfg.get("step"), dict) else {}
    if step.get("set"):
        branches.append(("step", "", {**(cfg.get("set") or {}), **step["set"]}))
    # the sweeps' extremes: the lowest and highest servo rate, each gain at the smallest and largest scale
    rates, scales, base = cfg.get("rates") or [], cfg.get("scales") or [], cfg.get("set") or {}
    if rates and cfg.get("rate_param", "rate") in f.params:
        branches += [("rates", "", {**base, cfg.get("rate_param", "rate"): r}) for r in sorted({min(rates), max(rates)})]
    for gname, ref in (cfg.get("gains") or {}).items():
        value = None
        try:
            value = f.param_value(ref)
        except (InputError, KeyError, TypeError, ValueError):
            continue  # the gain's own check names it
        branches += [("scales", gname, {**base, ref: (value * k).tolist()}) for k in sorted({min(scales), max(scales)})]
    for key, name, ov in branches:
        if not ov:
            continue
        try:
            with overrides_from("the analysis section's"):
                g = again(f)  # the user's overrides, then the branch's over them
                left = references({k: v for k, v in g.data.items() if k != "params"})
                for k in ov:
                    said = (f"{f.path}: analysis {key} {name}".rstrip() + f": {k!r} changes nothing here: the "
                            f"overrides given set every value that uses ${k}")
                    if k in g.replaced_uses and k not in left and said not in _SAID:
                        _SAID.add(said)  # once: analyze and report check the branches for each case they run
                        logging.getLogger("hybridsim").warning("%s", said)
                g.apply(ov)
                build(g, check_only=True)
        except InputError as exc:
            where = cfg.get("_locs", {}).get(key, f.path)
            if key in ("cases", "compare"):
                where = f._locs("analysis", key).get(name, where)
            elif key == "step":
                where = f._locs("analysis", "step").get("set", where)
            raise LoaderError(f"analysis {key} {name}".rstrip() + f" ({ov}): {exc}", where) from None


def check(path_or_file, **overrides):
    """Validate every variant of a diagram file as a run would, without running it.

    Builds each variant's system and simulator (what ``run`` does before its
    first step), so a file that passes cannot fail later for a reason this
    could have seen. Returns a summary dict: ``blocks``, ``states``,
    ``rates`` (Hz, over all variants) and ``runs``. Raises the
    :class:`~hybridsim.errors.InputError` of the first bad variant.
    """
    f = load(path_or_file, **overrides)
    rates, system = set(), None
    variants = f.variants()
    for label, variant in variants:
        system, simulator, settings = build(f, variant, check_only=True)
        rates |= {float(1 / b.period) for b in system.blocks if b.period}
    from hybridsim.engine.diagram import DefaultValue

    return {"blocks": sum(not isinstance(b, DefaultValue) for b in system.blocks),  # not an input's default
            "states": system.n_x, "held_states": int(system.x_held.sum()), "rates": sorted(rates),
            "runs": len(variants)}


def warn_unused(f, names=None):
    """Log a warning for each name in ``params`` of DiagramFile ``f`` (of ``names`` only, when given)
    that no value uses: setting it (``--set``, a sweep, tune) changes nothing. Returns the names warned of."""
    from hybridsim.engine.registry import closest

    warned = []
    for name, where in f.unused_params():
        if names is None or name in names:
            logging.getLogger("hybridsim").warning("%s: parameter %r is used by no value of the file (no $%s): "
                                                   "setting it changes nothing%s", where, name, name,
                                                   closest(name, [k for k in f.params if k != name]))
            warned.append(name)
    return warned


def simulate(path_or_file, variant=None, progress=False, **overrides):
    """Run one variant of a diagram file (writes nothing; :func:`hybridsim.api.run` writes files).

    Parameters
    ----------
    path_or_file : str, Path or DiagramFile
        The diagram.
    variant : dict, optional
        One point of the file's ``variants`` (default: the parameters as they are).
    progress : bool
        A progress bar on a terminal.
    **overrides
        Parameters and settings, as :func:`load` takes them (``rate=120``, ``t_end=1.0`` in s,
        ``**{"ctrl.fpi.Ki": [100, 100]}``).

    Returns
    -------
    hybridsim.engine.result.Result
        ``res.t`` (s) and ``res["block.port"]`` / ``res["block.port[i]"]`` (the port's units).

    Raises
    ------
    hybridsim.errors.InputError
        A bad file, parameter or setting (file, line and what is wrong); exit status 2 in the CLI.
    hybridsim.errors.SimulationError
        The model diverged or its solver failed (the time and the block); exit status 3.
    """
    from hybridsim.engine.arguments import flag

    progress = flag("progress", progress)
    system, simulator, settings = build(path_or_file, variant, **overrides)
    simulator.progress = progress
    return simulator.run(settings["simulation"]["t_end"])
