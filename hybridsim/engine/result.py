"""Simulation results: time vector, logged signals, run metadata."""
import csv

import numpy as np

from hybridsim.engine.registry import closest
from hybridsim.files import atomic_file


def parse_signal(ref):
    """'block.port' or 'block.port[i]' -> ('block.port', i or None)."""
    if ref.endswith("]") and "[" in ref:
        base, idx = ref[:-1].split("[", 1)
        return base, int(idx)
    return ref, None


class Result:
    """Logged signals of one run.

    ``result.t`` is the time vector (s); ``result["block.port"]`` an array of
    shape (len(t), width); ``result["block.port[i]"]`` one element as a 1-D
    array. ``meta`` holds the diagram name, solver, wall time and the number
    of sample hits of each discrete block; ``context`` the final state;
    ``aliases`` other names of logged signals (a subsystem's output
    ``ctrl.tau`` for the inner block's ``ctrl.sum.y``).
    """

    def __init__(self, t, signals, meta=None, context=None, aliases=None):
        self.t = np.asarray(t, float)
        self.signals = dict(signals)
        self.meta = dict(meta or {})
        self.context = context
        self.aliases = {a: r for a, r in (aliases or {}).items() if r in self.signals}

    def __getitem__(self, ref):
        if not isinstance(ref, str):
            raise TypeError(f"a logged signal is named 'block.port' or 'block.port[i]', got {ref!r}")
        try:
            base, idx = parse_signal(ref)
        except ValueError:
            raise KeyError(f"{ref!r} is not 'block.port' or 'block.port[i]'") from None
        base = self.aliases.get(base, base)
        if base not in self.signals:
            raise KeyError(f"{base!r} was not logged{closest(base, list(self.signals) + list(self.aliases))}; "
                           f"logged: {', '.join(self.signals) or 'nothing'}")
        a = self.signals[base]
        if idx is None:
            return a
        if not -a.shape[1] <= idx < a.shape[1]:
            raise IndexError(f"{base} has {a.shape[1]} element(s): [{idx}] is not one of them")
        return a[:, idx]

    def __contains__(self, ref):
        if not isinstance(ref, str):
            return False
        base = parse_signal(ref)[0]
        return self.aliases.get(base, base) in self.signals

    def columns(self):
        """Column names: 'time' then 'block.port[i]' for every element."""
        cols = ["time"]
        for ref, arr in self.signals.items():
            cols += [f"{ref}[{k}]" for k in range(arr.shape[1])]
        return cols

    def table(self):
        """All logged data as one 2-D array, columns as in :meth:`columns`."""
        parts = [self.t[:, None]] + [a for a in self.signals.values()]
        return np.hstack(parts) if len(self.t) else np.zeros((0, len(self.columns())))

    def to_csv(self, path):
        """Write every logged signal to ``path`` atomically."""
        with atomic_file(path, "w") as fh:
            w = csv.writer(fh)
            w.writerow(self.columns())
            table = self.table()
            with np.errstate(invalid="ignore"):
                near_max = bool(np.any(np.isfinite(table) & (np.abs(table) >= 1.7976931e308)))
            for row in table:  # (near the largest float, all digits: see _text)
                w.writerow([_text(v) for v in row] if near_max else [f"{v:.10g}" for v in row])

    def to_dataframe(self):
        """All logged data as a pandas DataFrame indexed by time (s), columns as in :meth:`columns`.

        Returns
        -------
        pandas.DataFrame
        """
        import pandas as pd

        cols = self.columns()
        return pd.DataFrame(self.table()[:, 1:], index=pd.Index(self.t, name="time"), columns=cols[1:])

    def plot(self, signals=None, ax=None):
        """Plot logged signals against time, one panel per signal (all by default).

        Parameters
        ----------
        signals : list of str, optional
            ``"block.port"`` or ``"block.port[i]"`` references (default: every logged signal).
        ax : matplotlib Axes or list of them, optional
            Where to draw (default: a new figure with one panel per signal).

        Returns
        -------
        matplotlib.figure.Figure
        """
        import matplotlib.pyplot as plt

        refs = list(signals or self.signals)
        if ax is None:
            fig, axes = plt.subplots(len(refs), 1, sharex=True, squeeze=False,
                                     figsize=(7, 1.8 + 1.6 * len(refs)))
            axes = list(axes[:, 0])
        else:
            axes = list(ax) if isinstance(ax, (list, tuple, np.ndarray)) else [ax] * len(refs)
            fig = axes[0].figure
        for a, ref in zip(axes, refs):
            v = np.atleast_2d(self[ref].T).T
            for j in range(v.shape[1]):
                a.plot(self.t, v[:, j], lw=1.2, label=f"[{j}]" if v.shape[1] > 1 else None)
            a.set_ylabel(ref, fontsize=8)
            a.grid(True, alpha=0.3)
            if v.shape[1] > 1:
                a.legend(fontsize=7, loc="best")
        axes[-1].set_xlabel("time (s)")
        fig.tight_layout()
        return fig


def _text(v):
    """A CSV number: 10 significant digits, all 17 where 10 would read back as another kind of number
    (1.7976931348e308 rounds up past the largest float, to inf)."""
    short = f"{v:.10g}"
    return short if abs(v) < 1.7976931e308 or not np.isfinite(v) else repr(float(v))
