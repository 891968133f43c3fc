"""Lines for the terminal: a search's objectives and constraints before and after."""
import math


def _fmt(v):
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "n/a"
    return f"{v:.4g}"


def summary_lines(res):
    """Human-readable lines from :func:`hybridsim.tune.run_tune`'s summary."""
    best, before = res["best"], res["before"]
    stored = max(0, res["evaluations"] + 1 - res["ran"])  # + 1: the diagram as it is, evaluated first
    lines = [f"{res['evaluations']} evaluations and the diagram as it is: {res['ran']} simulated now"
             + (f", {stored} points already in the store (evaluated earlier in this search or a previous one)"
                if stored else "") + f"; {res['method']}, {res['wall_time_s']:.1f} s"]
    names = list((before or best or {}).get("quantities", {}))
    lines.append(f"  {'quantity':<28}{'before':>12}{'best':>12}")
    for n in names:
        b = before["quantities"].get(n) if before else None
        a = best["quantities"].get(n) if best else None
        lines.append(f"  {n:<28}{_fmt(b):>12}{_fmt(a):>12}")
    if best is None or not best["feasible"]:
        lines.append("  no evaluated point meets every constraint")
    if best is not None and best.get("values"):
        lines.append("  best: " + ", ".join(f"{k} = {v:.4g}" if isinstance(v, float) else f"{k} = {v}"
                                            for k, v in best["values"].items()))
    if res.get("front"):
        lines.append(f"  Pareto front: {len(res['front'])} points (pareto.csv, pareto.png)")
    lines.append(f"wrote {res['outdir']}/ ({', '.join(res['files'])})")
    return lines
