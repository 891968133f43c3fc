"""The figure of a run: a registered layout where one applies, else a scope of the logged signals.

``hybridsim run`` draws every run of a diagram in one figure (:func:`experiment_figure`).
A wing registers a layout for diagrams whose ``signals`` section names its roles
(:func:`register_layout`; :mod:`hybridsim.forcecontrol` registers one); without
one that applies, every logged signal gets a panel of its own (:func:`scope_figure`).

The helpers below are for layouts: a signal's first column, the finite range of
values, the title a diagram asks for, and text shown as written (no mathtext).
matplotlib is imported only when a figure is drawn.
"""
from dataclasses import dataclass

import numpy as np

from hybridsim import limits


@dataclass(frozen=True)
class Layout:
    """A way to draw a diagram's runs: ``applies(settings)`` says whether it can, ``draw(f, runs,
    settings)`` returns the matplotlib Figure."""

    name: str
    applies: object
    draw: object


LAYOUTS = []


def register_layout(name, applies, draw):
    """Add a figure layout (the first registered that applies to a diagram draws it).

    Parameters
    ----------
    name : str
        A short name (a second registration under the same name replaces the first).
    applies : callable
        ``applies(settings) -> bool`` from the diagram's built settings (``signals``, ``plot``, ...).
    draw : callable
        ``draw(f, runs, settings) -> matplotlib.figure.Figure``: ``f`` the
        :class:`~hybridsim.format.DiagramFile`, ``runs`` as :func:`hybridsim.runs.variants.run_experiment` gives them.
    """
    LAYOUTS[:] = [lay for lay in LAYOUTS if lay.name != name] + [Layout(name, applies, draw)]


def experiment_figure(f, runs, settings):
    """One figure for all runs of a diagram file, in the first layout that applies; returns the Figure."""
    for layout in LAYOUTS:
        if layout.applies(settings):
            return layout.draw(f, runs, settings)
    return scope_figure(f, runs, title(f, settings))


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend: figures for files, no window."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def literal(fig):
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


def thin(t, y):
    """(t, y) with at most ``MAX_PLOT_POINTS`` rows (every k-th): a figure of a very long log stays small."""
    k = -(-len(t) // limits.get("MAX_PLOT_POINTS"))
    return (t[::k], y[::k]) if k > 1 else (t, y)


def finite_span(values):
    """(lo, hi) of the finite values, or None (all NaN or infinite: the axis keeps its own limits)."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    return (float(v.min()), float(v.max())) if v.size else None


def column(result, ref):
    """Signal ``ref`` of a result as one column (its first element when it is wider)."""
    v = result[ref]
    return v[:, 0] if v.ndim == 2 else v


def title(f, settings):
    """The figure's title: the diagram's ``plot: {title}``, else its description, else its name."""
    return str((settings.get("plot") or {}).get("title") or f.description or f.name)


def scope_figure(f, runs, title=None, most=8):
    """Every logged signal (up to ``most``) in its own panel, each run in its own colour."""
    plt = pyplot()

    refs = list(runs[0]["result"].signals)[:most] if runs else []
    fig, axes = plt.subplots(max(1, len(refs)), 1, sharex=True, figsize=(8, 1.5 + 1.6 * max(1, len(refs))),
                             squeeze=False)
    axes = axes[:, 0]
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, run in enumerate(runs):
        r, c = run["result"], colors[k % len(colors)]
        for ax, ref in zip(axes, refs):
            t, v = thin(r.t, r.signals[ref])
            shown = min(v.shape[1], limits.get("MAX_PLOT_LINES"))
            many = shown > 8  # no legend entry per element then
            stairs = "steps-post" if ref in r.meta.get("sampled", ()) else "default"  # a sampled signal is held
            for j in range(shown):
                ax.plot(t, v[:, j], color=c, lw=1.2 if not many else 0.5, ls=("-", "--", ":", "-.")[j % 4],
                        drawstyle=stairs,
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
    literal(fig)
    fig.tight_layout()
    return fig


__all__ = ["Layout", "LAYOUTS", "register_layout", "experiment_figure", "scope_figure", "pyplot", "literal", "thin",
           "finite_span", "column", "title"]
