"""Results a wing adds to the stability analysis, computed from the linearized plant.

:func:`hybridsim.analysis.stability.analyze` gives poles, margins and sweeps of any
diagram. A wing that knows more about a kind of plant registers a result here
(:func:`register`): it reads the diagram's ``analysis`` settings (the keys the
wing added to that table) and the plant's continuous matrix ``A``, and returns a
number or None; the analysis stores it under its key, ``hybridsim analyze``
prints its line and the report shows its column. The generic layers register
none.
"""
from dataclasses import dataclass


@dataclass(frozen=True)
class Extra:
    """One added result: ``compute(settings, A) -> value or None``, ``line(value) -> str``."""

    key: str
    compute: object
    line: object


EXTRAS = []


def register(key, compute, line):
    """Add a result to every analysis.

    Parameters
    ----------
    key : str
        Its key in the analysis results (a second registration of the key replaces the first).
    compute : callable
        ``compute(settings, A)``: the diagram's ``analysis`` settings (a dict) and the
        linearized plant's ``A`` (xc' = A xc + B h, an n x n array); returns the value, or None
        when the settings do not ask for it.
    line : callable
        ``line(value) -> str``: its line in ``hybridsim analyze``'s summary.
    """
    EXTRAS[:] = [x for x in EXTRAS if x.key != key] + [Extra(key, compute, line)]


def compute_all(settings, A):
    """``{key: value}`` of every registered result the settings ask for."""
    out = {}
    for x in EXTRAS:
        v = x.compute(settings, A)
        if v is not None:
            out[x.key] = v
    return out


def lines(res):
    """The summary lines of the registered results present in analysis results ``res``."""
    return [x.line(res[x.key]) for x in EXTRAS if x.key in res]


def keys():
    """The keys of the registered results."""
    return [x.key for x in EXTRAS]
