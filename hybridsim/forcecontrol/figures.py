"""The figure of a force-controlled run, laid out like the paper's: position above force.

Force is drawn after the display filter (solid, ``metrics: filter_cutoff``, 12 Hz
by default), with the raw signal faint behind it and the desired force dashed;
every variant of a diagram gets its own colour, a two-parameter grid of variants
(Fig 7: force x rate) one small panel per case. Then the surface and the hand,
the ringing force of eq 18 (in ms) and contact. Registered with
:func:`hybridsim.report.figures.register_layout` for diagrams that name one of
these roles.
"""
from hybridsim import limits
from hybridsim.forcecontrol.metrics import display_filter
from hybridsim.forcecontrol.settings import DISPLAY_CUTOFF_HZ
from hybridsim.report.figures import column, finite_span, literal, pyplot, register_layout, title

#: the roles that make a panel of this layout
PANEL_ROLES = {"position", "force", "surface", "hand", "oscillation", "contact"}


def _labels(settings):
    """The panels' axis names: the diagram's ``plot: {position_label, force_label, surface_label}``."""
    plot = settings.get("plot") or {}
    return {k: str(plot.get(f"{k}_label", k)) for k in ("position", "force", "surface")}


def applies(settings):
    """Whether a diagram names a role this layout draws."""
    return bool(set(settings["signals"]) & PANEL_ROLES)


def draw(f, runs, settings):
    """Position above force (then the surface, the ringing force, contact) for all runs of a diagram."""
    plt = pyplot()
    sig = settings["signals"]
    name = _labels(settings)
    cutoff = float((settings.get("metrics") or {}).get("filter_cutoff", DISPLAY_CUTOFF_HZ))
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
    grid = _grid_axes(runs)
    if grid and "force" in sig:  # a grid of variants (Fig 7: force x rate): one small panel per case
        return _grid_figure(f, runs, sig, *grid, force_label=name["force"], title=title(f, settings),
                            cutoff=cutoff)
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
                ax.plot(r.t, column(r, sig["position"]) * 100, color=c, lw=1.2, label=label)
                if "position_desired" in sig and k == 0:
                    ax.plot(r.t, column(r, sig["position_desired"]) * 100, "k--", lw=1, label="desired")
                ax.set_ylabel(f"{name['position']} (cm)")
            elif p == "force":
                raw = column(r, sig["force"])
                filt = display_filter(r.t, raw, cutoff)
                ax.plot(r.t, raw, color=c, lw=0.4, alpha=0.25)
                ax.plot(r.t, filt, color=c, lw=1.4, label=label)
                force_range.extend(finite_span(filt) or [])
                if "force_desired" in sig:
                    ax.plot(r.t, column(r, sig["force_desired"]), "--", color="k" if len(runs) == 1 else c, lw=1)
                ax.set_ylabel(f"{name['force']} (N)\n{cutoff:g} Hz filtered")
            elif p == "surface":
                if "surface" in sig:
                    ax.plot(r.t, column(r, sig["surface"]) * 100, "k--", lw=1, label="surface" if k == 0 else None)
                if "hand" in sig:
                    ax.plot(r.t, column(r, sig["hand"]) * 100, color=c, lw=1.2, label="hand")
                ax.set_ylabel(f"{name['surface']} (cm)")
            elif p == "oscillation":
                ax.plot(r.t * 1000, column(r, sig["oscillation"]), color=c, lw=1, label=label)
                ax.set_ylabel("force (N)")
            elif p == "contact":
                ax.step(r.t, column(r, sig["contact"]) + 0.05 * k, where="post", color=c, lw=1)
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
    fig.suptitle(title(f, settings), fontsize=10)
    literal(fig)
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


def _grid_figure(f, runs, sig, rkey, rvals, ckey, cvals, force_label="force", title=None, cutoff=DISPLAY_CUTOFF_HZ):
    """Force against time, one small panel per case of a two-parameter grid, shared axes (the paper
    draws each case of Fig 7 on its own)."""
    plt = pyplot()
    fig, axes = plt.subplots(len(rvals), len(cvals), sharex=True, sharey="row", squeeze=False,
                             figsize=(2.6 * len(cvals) + 1.2, 1.9 * len(rvals) + 1.0))
    ranges = {}  # per row: the filtered force's range (the raw ringing may be cut)
    for run in runs:
        i = rvals.index(repr(run["overrides"][rkey]))
        j = cvals.index(repr(run["overrides"][ckey]))
        ax, r = axes[i, j], run["result"]
        raw = column(r, sig["force"])
        filt = display_filter(r.t, raw, cutoff)
        ax.plot(r.t, raw, color="C0", lw=0.4, alpha=0.25)
        ax.plot(r.t, filt, color="C0", lw=1.2)
        lo, hi = ranges.get(i, (0.0, 0.0))
        span = finite_span(filt) or (lo, hi)
        ranges[i] = (min(lo, span[0]), max(hi, span[1]))
        if "force_desired" in sig:
            ax.plot(r.t, column(r, sig["force_desired"]), "k--", lw=0.9)
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
    fig.suptitle((title or f.description or f.name) + f" ({cutoff:g} Hz filtered, raw faint, desired dashed)", fontsize=9)
    literal(fig)
    fig.tight_layout()
    return fig


register_layout("forcecontrol", applies, draw)
