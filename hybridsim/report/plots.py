"""Figures laid out like the paper's: position above force, desired dashed.

Force is drawn after the paper's 12 Hz display filter (solid), with the raw
signal faint behind it; every variant of a diagram gets its own colour.
"""
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


from hybridsim import limits  # noqa: E402
from hybridsim.analysis.metrics import display_filter  # noqa: E402


def _literal(fig):
    """Show every title, label, legend entry and note of ``fig`` as written: a '$' in a diagram's
    name, description or label is a character, not the start of mathtext (which may not parse)."""
    texts = list(fig.texts) + ([fig._suptitle] if fig._suptitle is not None else [])
    for ax in fig.axes:
        texts += [ax.title, ax._left_title, ax._right_title, ax.xaxis.label, ax.yaxis.label, *ax.texts]
        leg = ax.get_legend()
        if leg is not None:
            texts += leg.get_texts() + [leg.get_title()]
    for t in texts:
        t.set_parse_math(False)
    return fig


def _thin(t, y):
    """(t, y) with at most ``MAX_PLOT_POINTS`` rows (every k-th): a figure of a very long log stays small."""
    k = -(-len(t) // limits.get("MAX_PLOT_POINTS"))
    return (t[::k], y[::k]) if k > 1 else (t, y)


def _span(values):
    """(lo, hi) of the finite values, or None (all NaN or infinite: the axis keeps its own limits)."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    return (float(v.min()), float(v.max())) if v.size else None


def _col(result, ref):
    v = result[ref]
    return v[:, 0] if v.ndim == 2 else v


def _labels(settings):
    """The panels' axis names: the diagram's ``plot: {position_label, force_label, surface_label}``."""
    plot = settings.get("plot") or {}
    return {k: str(plot.get(f"{k}_label", k)) for k in ("position", "force", "surface")}


def _title(f, settings):
    """The figure's title: the diagram's ``plot: {title}``, else its description, else its name."""
    return str((settings.get("plot") or {}).get("title") or f.description or f.name)


def experiment_figure(f, runs, settings):
    """One figure for all runs of a diagram file; returns the Figure."""
    sig = settings["signals"]
    name = _labels(settings)
    panels = []
    if "position" in sig:
        panels.append("position")
    if "force" in sig:
        panels.append("force")
    if "surface" in sig or "hand" in sig:
        panels.append("surface")
    if "oscillation" in sig:
        panels.append("oscillation")
    if "contact" in sig and "oscillation" not in sig:
        panels.append("contact")
    if not panels:  # no roles given: a scope, one panel per logged signal
        return _scope_figure(f, runs, _title(f, settings))
    grid = _grid_axes(runs)
    if grid and "force" in sig:  # a grid of variants (Fig 7: force x rate): one small panel per case
        return _grid_figure(f, runs, sig, *grid, force_label=name["force"], title=_title(f, settings))
    heights = [3 if p in ("position", "force", "surface", "oscillation") else 1 for p in panels]
    fig, axes = plt.subplots(len(panels), 1, sharex=True, figsize=(8, 1.2 + 1.3 * sum(heights) / 1.5),
                             gridspec_kw={"height_ratios": heights}, squeeze=False)
    axes = axes[:, 0]
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    force_range = []
    for k, run in enumerate(runs):
        r, c = run["result"], colors[k % len(colors)]
        label = run["label"] or f.name
        for ax, p in zip(axes, panels):
            if p == "position":
                ax.plot(r.t, _col(r, sig["position"]) * 100, color=c, lw=1.2, label=label)
                if "position_desired" in sig and k == 0:
                    ax.plot(r.t, _col(r, sig["position_desired"]) * 100, "k--", lw=1, label="desired")
                ax.set_ylabel(f"{name['position']} (cm)")
            elif p == "force":
                raw = _col(r, sig["force"])
                filt = display_filter(r.t, raw)
                ax.plot(r.t, raw, color=c, lw=0.4, alpha=0.25)
                ax.plot(r.t, filt, color=c, lw=1.4, label=label)
                force_range.extend(_span(filt) or [])
                if "force_desired" in sig:
                    ax.plot(r.t, _col(r, sig["force_desired"]), "--", color="k" if len(runs) == 1 else c, lw=1)
                ax.set_ylabel(f"{name['force']} (N)\n12 Hz filtered")
            elif p == "surface":
                if "surface" in sig:
                    ax.plot(r.t, _col(r, sig["surface"]) * 100, "k--", lw=1, label="surface" if k == 0 else None)
                if "hand" in sig:
                    ax.plot(r.t, _col(r, sig["hand"]) * 100, color=c, lw=1.2, label="hand")
                ax.set_ylabel(f"{name['surface']} (cm)")
            elif p == "oscillation":
                ax.plot(r.t * 1000, _col(r, sig["oscillation"]), color=c, lw=1, label=label)
                ax.set_ylabel("force (N)")
            elif p == "contact":
                ax.step(r.t, _col(r, sig["contact"]) + 0.05 * k, where="post", color=c, lw=1)
                ax.set_ylim(-0.2, 1.3)
                ax.set_yticks([0, 1], ["off", "on"])
                ax.set_ylabel("contact")
    for ax, p in zip(axes, panels):
        if p == "force" and force_range:
            # scale to the filtered force; the raw ~272 Hz ringing is drawn faint and may be cut
            lo, hi = min(force_range + [0.0]), max(force_range)
            pad = 0.1 * (hi - lo or 1.0)
            ax.set_ylim(lo - pad, hi + pad)
        ax.grid(True, alpha=0.3)
        if p in ("position", "force", "surface", "oscillation") and (len(runs) > 1 or p == "surface") \
                and len(runs) <= limits.get("MAX_PLOT_LINES"):
            ax.legend(fontsize=7, loc="best", ncol=2 if len(runs) > 4 else 1)
    axes[-1].set_xlabel("time (ms)" if panels[-1] == "oscillation" else "time (s)")
    fig.suptitle(_title(f, settings), fontsize=10)
    _literal(fig)
    fig.tight_layout()
    return fig


def _grid_axes(runs):
    """(row parameter, its values, column parameter, its values) when the runs are a 2-D grid, else None."""
    if len(runs) < 4:
        return None
    keys = [k for k in runs[0].get("overrides", {})
            if len({repr(r["overrides"].get(k)) for r in runs}) > 1]
    if len(keys) != 2:
        return None
    values = [list(dict.fromkeys(repr(r["overrides"][k]) for r in runs)) for k in keys]
    if len(values[0]) * len(values[1]) != len(runs) or len(runs) > limits.get("MAX_PLOT_LINES"):
        return None  # not a full grid, or too many panels for one figure
    return keys[0], values[0], keys[1], values[1]


def _grid_figure(f, runs, sig, rkey, rvals, ckey, cvals, force_label="force", title=None):
    """Force against time, one small panel per case of a two-parameter grid, shared axes (the paper
    draws each case of Fig 7 on its own)."""
    fig, axes = plt.subplots(len(rvals), len(cvals), sharex=True, sharey="row", squeeze=False,
                             figsize=(2.6 * len(cvals) + 1.2, 1.9 * len(rvals) + 1.0))
    ranges = {}  # per row: the filtered force's range (the raw ringing may be cut)
    for run in runs:
        i = rvals.index(repr(run["overrides"][rkey]))
        j = cvals.index(repr(run["overrides"][ckey]))
        ax, r = axes[i, j], run["result"]
        raw = _col(r, sig["force"])
        filt = display_filter(r.t, raw)
        ax.plot(r.t, raw, color="C0", lw=0.4, alpha=0.25)
        ax.plot(r.t, filt, color="C0", lw=1.2)
        lo, hi = ranges.get(i, (0.0, 0.0))
        span = _span(filt) or (lo, hi)
        ranges[i] = (min(lo, span[0]), max(hi, span[1]))
        if "force_desired" in sig:
            ax.plot(r.t, _col(r, sig["force_desired"]), "k--", lw=0.9)
        ax.grid(True, alpha=0.3)
        if i == 0:
            ax.set_title(f"{ckey} = {run['overrides'][ckey]}", fontsize=8)
        if j == 0:
            ax.set_ylabel(f"{rkey} = {run['overrides'][rkey]}\n{force_label} (N)", fontsize=8)
        if i == len(rvals) - 1:
            ax.set_xlabel("time (s)", fontsize=8)
        ax.tick_params(labelsize=7)
    for i, (lo, hi) in ranges.items():
        pad = 0.1 * (hi - lo or 1.0)
        axes[i, 0].set_ylim(lo - pad, hi + pad)
    fig.suptitle((title or f.description or f.name) + " (12 Hz filtered, raw faint, desired dashed)", fontsize=9)
    _literal(fig)
    fig.tight_layout()
    return fig


def _scope_figure(f, runs, title=None, most=8):
    """Every logged signal (up to ``most``) in its own panel, each run in its own colour."""
    refs = list(runs[0]["result"].signals)[:most] if runs else []
    fig, axes = plt.subplots(max(1, len(refs)), 1, sharex=True, figsize=(8, 1.5 + 1.6 * max(1, len(refs))),
                             squeeze=False)
    axes = axes[:, 0]
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, run in enumerate(runs):
        r, c = run["result"], colors[k % len(colors)]
        for ax, ref in zip(axes, refs):
            t, v = _thin(r.t, r.signals[ref])
            shown = min(v.shape[1], limits.get("MAX_PLOT_LINES"))
            many = shown > 8  # no legend entry per element then
            for j in range(shown):
                ax.plot(t, v[:, j], color=c, lw=1.2 if not many else 0.5, ls=("-", "--", ":", "-.")[j % 4],
                        label=None if many else (f"{run['label'] or f.name} [{j}]"
                                                 if v.shape[1] > 1 or len(runs) > 1 else None))
            if k == 0 and (shown < v.shape[1] or len(t) < len(r.t)):
                ax.text(0.01, 0.97, f"elements 0..{shown - 1} of {v.shape[1]} drawn"
                        + (f", every {-(-len(r.t) // len(t))}th row" if len(t) < len(r.t) else "")
                        + " (the CSV has all)", transform=ax.transAxes, fontsize=6, va="top")
            ax.set_ylabel(ref, fontsize=8)
    for ax in axes:
        ax.grid(True, alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7, loc="best")
    axes[-1].set_xlabel("time (s)")
    fig.suptitle(title or f.description or f.name, fontsize=10)
    _literal(fig)
    fig.tight_layout()
    return fig


BOX_W, BOX_H = 2.0, 0.9  # a block's box in the picture's units (inches for Graphviz)


def _dot_layout(nodes, edges, back):
    """Positions and edge paths from Graphviz's ``dot``, or None where it is not installed.

    ``edges`` are (a, b) node indices; the ``back`` ones (feedback: against the
    evaluation order) are given to dot reversed with ``dir=back``, so that the
    forward path is ranked left to right and feedback is routed around it.
    Returns ``(pos, paths)``: node -> (x, y) and edge -> [(x, y), ...] cubic
    Bezier control points from the source block to the destination block.
    """
    import shutil
    import subprocess

    dot = shutil.which("dot")
    if dot is None:
        return None
    lines = ["digraph G {", "rankdir=LR; nodesep=0.35; ranksep=0.7; splines=spline;",
             f'node [shape=box, fixedsize=true, width={BOX_W}, height={BOX_H}];']
    lines += [f'n{v};' for v in range(len(nodes))]
    for (a, b) in edges:
        lines.append(f"n{b} -> n{a} [dir=back];" if (a, b) in back else f"n{a} -> n{b};")
    lines.append("}")
    try:
        out = subprocess.run([dot, "-Tplain"], input="\n".join(lines), capture_output=True, text=True,
                             timeout=30, check=True).stdout
    except (OSError, subprocess.SubprocessError):
        return None  # a broken Graphviz falls back to the layered layout
    pos, paths = {}, {}
    for line in out.splitlines():
        f = line.split()
        if f and f[0] == "node":
            pos[int(f[1][1:])] = (float(f[2]), float(f[3]))
        elif f and f[0] == "edge":
            t, h, n = int(f[1][1:]), int(f[2][1:]), int(f[3])
            pts = [(float(f[4 + 2 * k]), float(f[5 + 2 * k])) for k in range(n)]
            paths[(h, t) if (h, t) in back else (t, h)] = pts[::-1] if (h, t) in back else pts
    if len(pos) != len(nodes):
        return None
    return pos, paths


def _layered_layout(n, first, edges, back):
    """Positions by dependency layer (the fallback without Graphviz) and feedback wires in lanes under the boxes.

    Returns ``(pos, paths, cols)``: node -> (x, y), feedback edge -> polyline, layer -> its nodes.
    """
    order = sorted(range(n), key=first.__getitem__)
    layer = [0] * n  # longest forward path from a source (edges against the order are feedback)
    for v in order:
        for (a, b) in edges:
            if b == v and first[a] < first[v]:
                layer[v] = max(layer[v], layer[a] + 1)
    cols = {}
    for v in order:
        cols.setdefault(layer[v], []).append(v)
    pos = {v: (lx * 3.0, -j * 1.4) for lx, vs in cols.items() for j, v in enumerate(vs)}
    bottom = min((y for _, y in pos.values()), default=0.0) - BOX_H
    paths = {}
    for k, (a, b) in enumerate(sorted(back)):  # feedback: down to a lane of its own, under every box
        (x0, y0), (x1, y1) = pos[a], pos[b]
        lane, out, into = bottom - 0.25 * k, x0 + BOX_W / 2 + 0.15 + 0.05 * k, x1 - BOX_W / 2 - 0.15 - 0.05 * k
        paths[(a, b)] = [(x0 + BOX_W / 2, y0), (out, y0), (out, lane), (into, lane), (into, y1),
                         (x1 - BOX_W / 2, y1)]
    return pos, paths, cols


def draw_diagram(system, title=None, expand=False):
    """Picture of a built system: the forward path left to right, feedback routed around it.

    Laid out by Graphviz's ``dot`` where it is installed (as Drake's diagrams
    are), else in dependency layers; one colour per rate.

    Parameters
    ----------
    system : hybridsim.engine.system.System
        A built system.
    title : str, optional
        The figure's title (default the system's name).
    expand : bool
        Draw every block of a subsystem (``ctrl.pid``, ...); by default a
        subsystem is one box named after it.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.patches import FancyBboxPatch

    from hybridsim.engine.diagram import DefaultValue

    keep = [i for i, b in enumerate(system.blocks) if not isinstance(b, DefaultValue)]
    key = (lambda name: name) if expand else (lambda name: name.split(".")[0])
    nodes, members = [], {}
    for i in keep:
        k = key(system.blocks[i].name)
        if k not in members:
            nodes.append(k)
            members[k] = []
        members[k].append(i)
    node_of = {i: nodes.index(key(system.blocks[i].name)) for i in keep}
    first = [min(members[k]) for k in nodes]  # evaluation order of a node: its first block's
    edges = sorted({(node_of[a], node_of[i]) for i in keep for (a, _) in system.sources[i]
                    if a in node_of and node_of[a] != node_of[i]})
    back = {(a, b) for (a, b) in edges if first[b] <= first[a]}
    laid = _dot_layout(nodes, edges, back)
    if laid is not None:
        pos, paths = laid
    else:
        pos, paths, cols = _layered_layout(len(nodes), first, edges, back)
    blocks = system.blocks
    rates = sorted({b.period for b in blocks if b.period is not None})
    palette = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    kind_color = {"continuous": "#cfe8cf", "direct": "#eeeeee", "constant": "#f5f5dc", "subsystem": "#dde6f5"}
    xs = [p[0] for p in pos.values()] or [0.0]
    ys = [p[1] for p in pos.values()] or [0.0]
    for pts in paths.values():
        xs += [p[0] for p in pts]
        ys += [p[1] for p in pts]
    if laid is not None:  # dot's units are inches: draw at that scale, whole
        width, height = max(6.0, max(xs) - min(xs) + 2.6), max(3.0, max(ys) - min(ys) + 2.0)
    else:
        width = max(8, 2.2 * len(cols))
        height = max(4, 1.0 * max((len(m) for m in cols.values()), default=1))
    fig, ax = plt.subplots(figsize=(width, height))
    for v, name in enumerate(nodes):
        x, y = pos[v]
        inside = members[name]
        b = blocks[inside[0]]
        if len(inside) > 1 or "." in b.name and not expand:
            fc, label = kind_color["subsystem"], f"subsystem ({len(inside)} blocks)"
        elif b.period is not None:
            fc, label = palette[rates.index(b.period) % len(palette)], getattr(type(b), "type_name", type(b).__name__)
        else:
            fc, label = kind_color[system.kind[inside[0]]], getattr(type(b), "type_name", type(b).__name__)
        ax.add_patch(FancyBboxPatch((x - BOX_W / 2 + 0.05, y - BOX_H / 2 + 0.05), BOX_W - 0.1, BOX_H - 0.1,
                                    boxstyle="round,pad=0.05",
                                    fc=fc, ec="k", lw=0.8, alpha=0.85))
        ax.text(x, y + 0.12, name, ha="center", va="center", fontsize=8, weight="bold")
        ax.text(x, y - 0.2, label, ha="center", va="center", fontsize=6.5)
    for (a, b) in edges:
        color = "tab:red" if (a, b) in back else "0.3"
        pts = paths.get((a, b))
        if pts:  # dot's cubic Bezier spline, or a feedback lane of the layered layout
            from matplotlib.patches import FancyArrowPatch
            from matplotlib.path import Path

            codes = [Path.MOVETO] + [Path.CURVE4 if laid is not None else Path.LINETO] * (len(pts) - 1)
            ax.add_patch(FancyArrowPatch(path=Path(pts, codes), arrowstyle="-|>", mutation_scale=8,
                                         lw=0.7, color=color))
            continue
        (x0, y0), (x1, y1) = pos[a], pos[b]
        ax.annotate("", xy=(x1 - 1.0, y1), xytext=(x0 + 1.0, y0),
                    arrowprops=dict(arrowstyle="->", lw=0.6, color=color,
                                    connectionstyle="arc3,rad=0.25" if x1 <= x0 else "arc3,rad=0.0"))
    handles = [plt.Rectangle((0, 0), 1, 1, fc=palette[k % len(palette)]) for k in range(len(rates))]
    labels = [f"{float(1 / r):g} Hz" for r in rates]
    for kind, c in kind_color.items():
        handles.append(plt.Rectangle((0, 0), 1, 1, fc=c, ec="k"))
        labels.append({"continuous": "continuous state", "direct": "direct (no rate)",
                       "constant": "piecewise constant", "subsystem": "subsystem"}[kind])
    ax.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, 0.0), ncol=len(labels), fontsize=7)
    ax.set_xlim(min(xs) - 1.3, max(xs) + 1.3)
    ax.set_ylim(min(ys) - 0.8, max(ys) + 0.8)
    ax.set_axis_off()
    ax.set_title(title or system.name)
    _literal(fig)
    fig.tight_layout()
    return fig


__all__ = ["experiment_figure", "draw_diagram"]
