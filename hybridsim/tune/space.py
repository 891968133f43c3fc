"""The searched parameters: bounds, linear or log scale, integer or a choice of values.

Every parameter maps a unit coordinate ``u`` in [0, 1] to a value, so the
optimisers that need a box (differential evolution, Nelder-Mead) search the
unit cube; Optuna is given each parameter natively.
"""
import math

import numpy as np

SCALES = ("linear", "log")


class Parameter:
    """One searched parameter.

    Parameters
    ----------
    path : str
        A run parameter as ``--set`` takes it: a name in ``params``, ``block.param``
        or ``sub.block.param``.
    low, high : float, optional
        Bounds (in the parameter's unit), for a numeric parameter.
    scale : {"linear", "log"}
        How ``u`` maps onto [low, high]; "log" needs low > 0.
    integer : bool
        Round to whole numbers.
    values : list, optional
        A choice among these values instead of bounds.
    repeat : int, optional
        Give the value as a list of this many equal elements (a vector parameter
        such as the Fig 6 controller's ``fpi.Kp: [Kp, Kp]``).
    """

    def __init__(self, path, low=None, high=None, scale="linear", integer=False, values=None, repeat=None):
        self.path, self.low, self.high = path, low, high
        self.scale, self.integer, self.values, self.repeat = scale, bool(integer), values, repeat

    @property
    def kind(self):
        """'choice', 'int' or 'float'."""
        return "choice" if self.values is not None else ("int" if self.integer else "float")

    def from_unit(self, u):
        """The value at unit coordinate ``u`` (clipped to [0, 1])."""
        u = min(1.0, max(0.0, float(u)))
        if self.values is not None:
            return self.values[min(int(u * len(self.values)), len(self.values) - 1)]
        if self.scale == "log":
            v = math.exp(math.log(self.low) + u * (math.log(self.high) - math.log(self.low)))
        else:
            v = self.low + u * (self.high - self.low)
        return int(round(v)) if self.integer else float(v)

    def to_unit(self, value):
        """The unit coordinate of ``value`` (the middle of its cell for a choice), or None outside."""
        if self.values is not None:
            if value not in self.values:
                return None
            return (self.values.index(value) + 0.5) / len(self.values)
        v = float(value)
        if not self.low <= v <= self.high:
            return None
        if self.high == self.low:
            return 0.5
        if self.scale == "log":
            return (math.log(v) - math.log(self.low)) / (math.log(self.high) - math.log(self.low))
        return (v - self.low) / (self.high - self.low)

    def as_override(self, value):
        """The value as the loader takes it (a list when ``repeat`` is given)."""
        return [value] * self.repeat if self.repeat else value

    def suggest(self, trial):
        """The value an Optuna trial suggests for this parameter."""
        if self.values is not None:
            return trial.suggest_categorical(self.path, self.values)
        if self.integer:
            return trial.suggest_int(self.path, int(self.low), int(self.high), log=self.scale == "log")
        return trial.suggest_float(self.path, self.low, self.high, log=self.scale == "log")

    def ends(self):
        """The values a spec check tries: both bounds, or every choice."""
        return list(self.values) if self.values is not None else [self.from_unit(0.0), self.from_unit(1.0)]


def decode(params, u):
    """``{path: value}`` for the unit vector ``u`` (one coordinate per parameter)."""
    return {p.path: p.from_unit(x) for p, x in zip(params, np.asarray(u, float).ravel())}


def overrides(params, values):
    """``{path: value as the loader takes it}`` for ``values`` = ``{path: value}``."""
    return {p.path: p.as_override(values[p.path]) for p in params}
