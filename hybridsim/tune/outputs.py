"""What a search writes: the best parameters as a diagram overlay, the table, the plots."""
import csv
import json
import math
import os
from pathlib import Path

import numpy as np
import yaml

from hybridsim.files import atomic_file


def files(spec):
    """The files a search writes at its end: the table, plot and summary, the Pareto front's (two
    objectives) and best.yaml (when a point is feasible)."""
    front = ["pareto.png", "pareto.csv"] if len(spec.objectives) == 2 else []
    return ["evaluations.csv", "convergence.png", "best.json"] + front + ["best.yaml"]


def _whole_values(diagram, ov):
    """``ov`` with each element change (``g.K[1]``) as its parameter's whole value: a file sets whole values."""
    from hybridsim.format.build import load
    from hybridsim.format.paths import ParamPath

    if all(ParamPath.parse(k).index is None for k in ov):
        return ov
    f, out = load(diagram, **ov), {}
    for key, value in ov.items():
        path = ParamPath.parse(key)
        if path.index is None:
            out[key] = value
            continue
        base = path.without_index()
        out[str(base)] = f.params[base.name] if base.kind == "param" else f.param_value(base.key).tolist()
    return out


def overlay(spec, values, outdir):
    """The text of a diagram file that ``extends`` the tuned diagram with ``values`` (and ``set``).

    ``hybridsim run OUTDIR/best.yaml`` then runs the tuned point; the loader's
    ``extends`` merges ``params`` and a block's parameters key by key.
    """
    from hybridsim.tune.space import overrides

    from hybridsim.format.paths import SETTING_SECTIONS

    params, blocks, settings = {}, {}, {s: {} for s in SETTING_SECTIONS}
    ov = {k: v for k, v in spec.fixed.items() if k != "simulation.compiled"}
    ov.update(overrides(spec.parameters, values))
    ov = _whole_values(spec.diagram, ov)
    for key, value in ov.items():
        parts = key.split(".")
        if parts[0] == "params":
            parts = parts[1:]
        elif parts[0] == "blocks":
            parts = parts[1:]
        value = _plain(value)
        if len(parts) == 1:
            params[parts[0]] = value
        elif parts[0] in SETTING_SECTIONS:
            settings[parts[0]][parts[1]] = value
        else:  # block.param, or sub.block.param (the subsystem passes block.param on)
            blocks.setdefault(parts[0], {})[".".join(parts[1:])] = value
    from hybridsim.format.build import load

    f = load(spec.diagram)
    swept = f.data.get("variants") or {}
    fixed = {k: [v] for k, v in params.items() if k in swept}  # a value set for a swept name ends that sweep
    # the tune's own variants (the worst case it scored): those over the diagram's params go with it
    tuned = {k: list(dict.fromkeys(_plain(c[k]) for c in spec.variants)) for k in spec.variants[0]}
    fixed.update({k: v for k, v in tuned.items() if k in f.params})
    left = [k for k in tuned if k not in f.params]
    rel = os.path.relpath(spec.diagram, Path(outdir).resolve())
    doc = {"extends": rel, "name": f"{spec.diagram.stem}_tuned"}
    for key, part in (("params", params), ("variants", fixed), ("blocks", blocks), *settings.items()):
        if part:
            doc[key] = part
    head = f"# the best point of {spec.path.name} (hybridsim tune), over {spec.diagram.name}\n"
    if left:  # block parameters a diagram's variants cannot sweep
        head += f"# scored over the tune's variants of {', '.join(left)} too: run it with --set for each\n"
    return head + yaml.safe_dump(doc, sort_keys=False, default_flow_style=None)


def _plain(v):
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    if isinstance(v, (list, tuple, np.ndarray)):
        return [_plain(x) for x in v]
    return v


def write_table(path, spec, history):
    """evaluations.csv: one row per evaluated point (parameters, quantities, status, score)."""
    names = [q.name for q in spec.objectives + spec.constraints]
    with atomic_file(path, "w") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(["n", "key", *(p.path for p in spec.parameters), *names, "feasible", "status", "message",
                    "score"])
        for rec in history:
            vals = rec.get("values") or {}
            w.writerow([rec["n"], rec["key"], *(vals.get(p.path, "") for p in spec.parameters),
                        *(rec["quantities"].get(n, "") for n in names), rec["feasible"], rec["status"],
                        rec["message"], rec["score"]])


def write_json(path, doc):
    """``doc`` as JSON (infinities as strings), atomically."""
    def fix(v):
        if isinstance(v, float) and not math.isfinite(v):
            return None if math.isnan(v) else str(v)
        if isinstance(v, dict):
            return {k: fix(x) for k, x in v.items()}
        if isinstance(v, list):
            return [fix(x) for x in v]
        return _plain(v)

    with atomic_file(path, "w") as fh:
        json.dump(fix(doc), fh, indent=2, default=str)
        fh.write("\n")


def pareto(points):
    """Indices of the non-dominated rows of ``points`` (every column minimised)."""
    P = np.asarray(points, float)
    keep = []
    for i, p in enumerate(P):
        dominated = np.any(np.all(P <= p, axis=1) & np.any(P < p, axis=1))
        if not dominated:
            keep.append(i)
    return keep


def convergence_plot(path, spec, history):
    """The best feasible objective so far against the evaluation number (one panel per objective)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axs = plt.subplots(1, len(spec.objectives), figsize=(5.2 * len(spec.objectives), 3.6), squeeze=False)
    n = [r["n"] for r in history]
    for ax, q in zip(axs[0], spec.objectives):
        best, cur = [], math.nan
        sign = 1.0 if q.goal == "min" else -1.0
        for r in history:
            v = r["quantities"].get(q.name, math.nan)
            if r["feasible"] and np.isfinite(v) and (not np.isfinite(cur) or sign * v < sign * cur):
                cur = v
            best.append(cur)
        feas = [(r["n"], r["quantities"].get(q.name)) for r in history if r["feasible"]]
        infeas = [(r["n"], r["quantities"].get(q.name)) for r in history if not r["feasible"] and r["quantities"]]
        if infeas:
            ax.plot(*zip(*infeas), "x", color="0.6", ms=4, label="breaks a constraint")
        if feas:
            ax.plot(*zip(*feas), ".", color="C0", ms=5, label="feasible")
        ax.step(n, best, where="post", color="C3", label="best feasible so far")
        ax.set_xlabel("evaluation")
        ax.set_ylabel(f"{q.describe()} ({'min' if q.goal == 'min' else 'max'})")
        ax.legend(fontsize=7)
    fig.suptitle(f"{spec.path.name}: {spec.method}", fontsize=10)
    fig.tight_layout()
    with atomic_file(path, "wb") as fh:
        fig.savefig(fh, format="png", dpi=110)
    plt.close(fig)


def pareto_plot(path, spec, history, front):
    """The two objectives of every feasible point, the Pareto front joined."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    a, b = spec.objectives
    fig, ax = plt.subplots(figsize=(5.4, 4.2))
    feas = [r for r in history if r["feasible"]]
    infeas = [r for r in history if not r["feasible"] and r["quantities"]]
    if infeas:
        ax.plot([r["quantities"][a.name] for r in infeas], [r["quantities"][b.name] for r in infeas], "x",
                color="0.6", ms=4, label="breaks a constraint")
    ax.plot([r["quantities"][a.name] for r in feas], [r["quantities"][b.name] for r in feas], ".", color="C0",
            label="feasible")
    fr = sorted(front, key=lambda r: r["quantities"][a.name])
    ax.plot([r["quantities"][a.name] for r in fr], [r["quantities"][b.name] for r in fr], "o-", color="C3",
            label="Pareto front")
    ax.set_xlabel(f"{a.describe()} ({a.goal})")
    ax.set_ylabel(f"{b.describe()} ({b.goal})")
    ax.legend(fontsize=7)
    fig.tight_layout()
    with atomic_file(path, "wb") as fh:
        fig.savefig(fh, format="png", dpi=110)
    plt.close(fig)
