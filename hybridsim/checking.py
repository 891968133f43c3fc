"""``check`` of any file a command reads: a diagram, a sweep file or a tune file.

Not in :mod:`hybridsim.api` (which ``import hybridsim`` loads): the sweep and tune layers sit
above the format layer that the API is made of.
"""
from hybridsim.format.build import check, check_analysis_branches, load, warn_unused


def check_file(path, **overrides):
    """Validate a diagram, sweep or tune file without running it; ``hybridsim check``.

    A file with a ``diagram`` key and no ``blocks`` or ``extends`` is a sweep file (its
    points as :meth:`hybridsim.runs.sweep.Sweep.validate` checks them), or a tune file when it
    has ``parameters`` or ``objectives`` (:func:`hybridsim.tune.spec.load_tune`).

    Returns
    -------
    dict
        ``kind`` ("diagram", "subsystem", "sweep" or "tune"); for a diagram what :func:`check` gives
        (``blocks``, ``states``, ``rates``, ``runs``); for a subsystem file (one with ``inputs:``) the
        same, checked as a diagram that holds its inputs at 0 would run it (its ``simulation:``
        section as an exported FMU's), with ``inputs`` and ``outputs`` [(name, width)]; for a sweep
        ``diagram`` and ``points``; for a tune file ``diagram``, ``parameters`` and ``method``.
    """
    from hybridsim.errors import InputError
    from hybridsim.format import parse_file
    from hybridsim.format.filekinds import file_kind

    data, _ = parse_file(path)
    kind = file_kind(data) or "diagram"  # (one showing no kind is read as a diagram, which says what is missing)
    if kind == "diagram" and isinstance(data, dict) and (data.get("inputs") or data.get("extends")):
        from hybridsim.format.diagram_file import DiagramFile

        if DiagramFile(path).data.get("inputs"):  # its own or from a file it extends
            return _check_subsystem(path, overrides)
    if kind == "diagram":
        f = load(path, **overrides)
        summary = check(f)
        check_analysis_branches(f)
        return {"kind": "diagram", **summary, "unused_params": warn_unused(f)}
    if overrides:
        raise InputError(f"{path}: --set applies to a diagram; a {kind} file gives its diagram's values "
                         "in its own 'set' section")
    if kind == "tune":
        from hybridsim.tune.spec import load_tune

        spec = load_tune(path)
        return {"kind": kind, "diagram": str(spec.diagram), "parameters": len(spec.parameters),
                "method": spec.method}
    from hybridsim.runs.sweep import Sweep

    sw = Sweep(path)
    points = len(sw.points())
    sw.validate()
    return {"kind": kind, "diagram": str(sw.diagram), "points": points}


def _check_subsystem(path, overrides):
    """check_file of a subsystem file: staged as the closed diagram an FMU export builds. ``overrides``
    name its parameters, its simulation settings or its blocks' parameters."""
    import re
    import tempfile
    from pathlib import Path

    from hybridsim.errors import InputError

    from hybridsim.format import standalone
    from hybridsim.format.overrides import ORIGIN

    with tempfile.TemporaryDirectory(prefix="hybridsim-check-") as tmp:
        staged = standalone.Staged(path, Path(tmp) / "diagram")
        params = dict(staged.params)
        sets = {k if k in params or str(k).startswith("simulation.") else f"sub.{k}": v
                for k, v in overrides.items()}
        try:
            system, _, _ = staged.build(**sets)
        except InputError as exc:  # an override given to the wrapper's 'sub' named as the user gave it
            said = ORIGIN.get()
            text = re.sub(r"subsystem 'sub' \(([^)]*)\) has", r"\1 has", str(exc).replace(f"{said} sub.", f"{said} "))
            raise InputError(text) from None
    rates = sorted({float(1 / b.period) for b in system.blocks if b.period})
    from hybridsim.engine.diagram import DefaultValue
    from hybridsim.format.diagram_file import DiagramFile

    unused = warn_unused(DiagramFile(path))  # as a parent's block sets them: one no value uses changes nothing

    shown = [b for b in system.blocks if not isinstance(b, DefaultValue)]  # not an input's default
    return {"kind": "subsystem", "blocks": len(shown) - len(staged.inputs), "states": system.n_x,
            "held_states": int(system.x_held.sum()),
            "rates": rates, "runs": 1, "inputs": [(n, w) for n, w, _ in staged.inputs],
            "outputs": [(n, w) for n, _, w in staged.outputs], "unused_params": unused}
