"""Points to run an experiment at: a full factorial grid, scaled values, seeded random draws, lists.

A :class:`Point` is one set of changes to an experiment (``{"ctrl.fpi.Kp": [0.8, 0.6],
"rate": 60}``), the columns a table shows for it (``{"ctrl.fpi.Kp*": 2.0, "rate": 60}``)
and its resume key, a hash of the changes. A :class:`Grid` is an ordered list of points;
grids combine with ``*`` (every point of one with every point of the other) and ``+``
(one after the other)::

    Grid.values({"rate": [60, 120]}) * Grid.scaled({"ctrl.fpi.Kp": [0.5, 1, 2]}, base)
    + Grid.random({"Kr": (8e5, 1e6)}, n=20, seed=1)
"""
import hashlib
import itertools
import json
from typing import NamedTuple

import numpy as np

from hybridsim.errors import InputError
from hybridsim.format import tables


def point_key(changes):
    """A short stable hash of ``changes`` (a point's key in a resume store); a whole number the same
    written 20 or 20.0 (one run)."""
    text = json.dumps(_plain(changes), sort_keys=True, default=float)
    return hashlib.sha1(text.encode()).hexdigest()[:16]


def _plain(v):
    """``v`` with whole floats as ints, in lists and mappings too."""
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, float) and v.is_integer() and abs(v) < 2.0 ** 53:
        return int(v)
    return v


def range_problem(name, lo_hi):
    """What is wrong with ``lo_hi`` as the ``[low, high]`` range of ``name`` (a sweep's ``random``,
    :meth:`Grid.random`), or None."""
    v = list(lo_hi) if isinstance(lo_hi, (list, tuple)) else lo_hi
    ok = isinstance(v, list) and len(v) == 2 and all(
        isinstance(x, (int, float)) and not isinstance(x, bool) and np.isfinite(x) for x in v) and v[0] <= v[1]
    return None if ok else f"range of {name!r} must be [low, high] with finite low <= high, got {lo_hi!r}"


def _checked(name, table, values):
    """InputError for the first value of ``values`` (``{key: value}``) that its row of the sweep file's
    ``table`` refuses, the file's check; ``name`` the function called."""
    for row in table:
        if row.key in values:
            why = row.kind.problem(values[row.key])
            if why:
                raise InputError(f"{name}: {'axes' if row.key in ('grid', 'scale') else row.key} "
                                 f"{why if why.startswith('must') else '- ' + why}")


class Point(NamedTuple):
    """One point: the changes made to the experiment, what a table shows, the resume key.

    ``experiment``: an :class:`~hybridsim.runs.experiment.Experiment` of its own, run
    instead of the one :func:`~hybridsim.runs.many.run_many` is given (the reproduction's
    searches mix diagrams); None for that one.
    """

    changes: dict
    label: dict
    key: str
    experiment: object = None


def point(changes=None, label=None, key=None, experiment=None):
    """A :class:`Point` of ``changes`` (default: none), shown as ``label`` (default: the changes),
    keyed by ``key`` (default: :func:`point_key` of the changes)."""
    changes = dict(changes or {})
    return Point(changes, dict(changes if label is None else label), key or point_key(changes), experiment)


def _lists(axes):
    """``axes`` with each sequence (a tuple, range, numpy array) as a list of plain numbers, what the
    tables' kinds take; as given when not a mapping."""
    def plain(v):
        if isinstance(v, np.ndarray):
            return v.tolist()
        return list(v) if isinstance(v, (tuple, range)) else v

    return {k: plain(v) for k, v in axes.items()} if isinstance(axes, dict) else axes


class Grid:
    """An ordered list of :class:`Point`.

    Parameters
    ----------
    points : iterable of Point or dict
        A dict is a point's changes (:func:`point`).
    """

    def __init__(self, points=()):
        self.points = [p if isinstance(p, Point) else point(p) for p in points]

    @classmethod
    def values(cls, axes):
        """The full factorial of ``axes`` (``{name: [value, ...]}``), the first axis slowest."""
        _checked("Grid.values", tables.SWEEP, {"grid": _lists(axes)})
        names = list(axes)
        return cls(point(dict(zip(names, combo))) for combo in itertools.product(*(axes[n] for n in names)))

    @classmethod
    def scaled(cls, axes, base):
        """The full factorial of scale factors ``axes`` (``{name: [factor, ...]}``) of each
        parameter's own value ``base[name]`` (a number or a list); the table shows the factor
        (column ``name*``), the run gets ``factor x base``."""
        _checked("Grid.scaled", tables.SWEEP, {"scale": _lists(axes)})
        names = list(axes)
        for n in names:
            try:
                value = np.asarray(base[n], float)
            except (KeyError, IndexError, TypeError, ValueError):
                raise InputError(f"Grid.scaled: base gives {n!r} no value to scale (a number or a list of "
                                 f"numbers), got {base!r}") from None
            if not value.size or not np.all(np.isfinite(value)):
                raise InputError(f"Grid.scaled: base[{n!r}] is not a finite number or list of them, got {base[n]!r}")
        pts = []
        for combo in itertools.product(*(axes[n] for n in names)):
            changes = {n: (np.asarray(base[n], float) * float(s)).tolist() for n, s in zip(names, combo)}
            pts.append(point(changes, {f"{n}*": float(s) for n, s in zip(names, combo)}))
        return cls(pts)

    @classmethod
    def random(cls, ranges, n, seed=0):
        """``n`` points drawn uniformly from ``ranges`` (``{name: (low, high)}``) with numpy's
        generator seeded by ``seed``: the same points every time."""
        ranges = _lists(ranges)
        _checked("Grid.random", tables.SWEEP_RANDOM, {"n": n, "seed": seed, "ranges": ranges})
        why = next(filter(None, (range_problem(k, v) for k, v in ranges.items())), None)
        if why:
            raise InputError(f"Grid.random: {why}")
        rng = np.random.default_rng(int(seed))
        return cls(point({k: float(rng.uniform(lo, hi)) for k, (lo, hi) in ranges.items()}) for _ in range(int(n)))

    def __mul__(self, other):
        if not self.points:
            return Grid(other)
        if not other.points:
            return Grid(self)
        return Grid(point({**a.changes, **b.changes}, {**a.label, **b.label}) for a in self for b in other)

    def __add__(self, other):
        return Grid(list(self) + list(other))

    def __len__(self):
        return len(self.points)

    def __iter__(self):
        return iter(self.points)

    def __getitem__(self, k):
        return self.points[k]

    def __repr__(self):
        return f"Grid({len(self)} points)"
