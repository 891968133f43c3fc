"""A sweep's table and heat map: ``sweep.csv``, ``sweep.parquet`` and ``heatmap.png``, written atomically."""
from pathlib import Path

from hybridsim.files import atomic_file



def files(axes):
    """The files a sweep over ``axes`` writes at its end (a heat map from two axes on)."""
    return ("sweep.csv", "sweep.parquet") + (("heatmap.png",) if len(axes) >= 2 else ())


def write_table(rows, outdir):
    """sweep.csv and sweep.parquet (tidy: one row per point and variant), atomically."""
    import pandas as pd

    df = pd.DataFrame(rows)
    with atomic_file(Path(outdir) / "sweep.csv") as fh:
        df.to_csv(fh, index=False)
    with atomic_file(Path(outdir) / "sweep.parquet", "wb") as fh:
        _parquet_ready(df).to_parquet(fh, index=False)
    return df


def _parquet_ready(df):
    """``df`` with each column Parquet cannot type (a swept value that is a number in one row and a
    list in another) as its JSON text, as the CSV writes it too."""
    import json

    out = df.copy()
    for col in out.columns:
        if out[col].dtype == object and any(isinstance(v, (list, tuple, dict)) for v in out[col]):
            out[col] = [v if v is None else json.dumps(v) for v in out[col]]
    return out


def heatmaps(rows, axes, outdir):
    """A heat map of the main metrics over the first two swept parameters ``axes`` (table columns);
    True when one was written (two axes or more, and metrics to show)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import pandas as pd

    if len(axes) < 2 or not rows:
        return False
    df = pd.DataFrame(rows)
    xa, ya = axes[0], axes[1]
    for a in (xa, ya):  # an axis of lists (or lists and numbers): its values as labels, in their order
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in df[a]):
            labels = list(dict.fromkeys(_label(v) for v in df[a]))
            df[a] = pd.Categorical([_label(v) for v in df[a]], categories=labels, ordered=True)
    from hybridsim.analysis.metrics import headline

    metrics = [m for m in headline() if m in df][:3]
    if not metrics:
        return False
    fig, axs = plt.subplots(1, len(metrics), figsize=(4.6 * len(metrics), 3.8), squeeze=False)
    for ax, m in zip(axs[0], metrics):
        piv = df[df["status"] == "ok"].groupby([ya, xa], observed=True)[m].mean().unstack(xa).astype(float)
        im = ax.imshow(piv.values, origin="lower", aspect="auto", cmap="viridis")
        ax.set_xticks(range(len(piv.columns)), [_tick(v) for v in piv.columns])
        ax.set_yticks(range(len(piv.index)), [_tick(v) for v in piv.index])
        ax.set_xlabel(xa)
        ax.set_ylabel(ya)
        ax.set_title(m, fontsize=9)
        fig.colorbar(im, ax=ax, shrink=0.8)
        # the diagram as it is: scale 1 of a scaled axis
        px = _index_of_one(piv.columns, xa)
        py = _index_of_one(piv.index, ya)
        if px is not None and py is not None:
            ax.plot(px, py, "r*", ms=14, label="the diagram's own values")
            ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    with atomic_file(Path(outdir) / "heatmap.png", "wb") as fh:
        fig.savefig(fh, format="png", dpi=110)
    plt.close(fig)
    return True


def _label(v):
    return str(list(v)) if isinstance(v, (list, tuple)) else str(v)


def _tick(v):
    return f"{v:g}" if isinstance(v, (int, float)) and not isinstance(v, bool) else str(v)


def _index_of_one(values, axis):
    if not axis.endswith("*"):
        return None
    for k, v in enumerate(values):
        if isinstance(v, (int, float)) and abs(float(v) - 1.0) < 1e-12:
            return k
    return None
