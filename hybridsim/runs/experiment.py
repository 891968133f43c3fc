"""An experiment: a diagram file parsed and built once, and the changes made to it.

``Experiment(path, **overrides)`` holds the parsed file, the built system, its
simulator and settings. A change of a block parameter (``ctrl.fpi.Kp``) is made
at run time - a fresh context with the block rebuilt
(:meth:`~hybridsim.engine.system.System.create_context`), no re-parse and no rebuild;
only a change of structure or rate, or of a ``params`` name the file resolves
while loading, builds a new experiment. The analysis and the report take one.
"""
import numpy as np

from hybridsim.api import build, load
from hybridsim.errors import InputError, ParameterError
from hybridsim.format.settings import horizon_problems
from hybridsim.analysis.linearize import Linearization, LinearizationError, start_outputs


class Experiment:
    """A diagram file, built once (one variant), with its overrides.

    Parameters
    ----------
    path : str or Path
        The diagram file.
    variant : str, optional
        The variant to build (default: the first).
    **overrides
        As ``hybridsim --set``: ``params`` names, ``block.param``, simulation keys.
    """

    def __init__(self, path, variant=None, **overrides):
        self.path, self.variant, self.overrides = path, variant, dict(overrides)
        self.file = load(path, **overrides)
        self.system, self.simulator, self.settings = build(self.file, variant)
        self._at = {}  # at -> (Linearization, closed loop) of this experiment unchanged

    def _unchanged(self, key, value):
        """Whether ``key = value`` is what this experiment already has (a ``params`` name)."""
        if key not in self.file.params:
            return False
        try:
            return np.array_equal(np.asarray(value, float), np.asarray(self.file.params[key], float))
        except (TypeError, ValueError):
            return value == self.file.params[key]

    def split(self, changes):
        """(run-time ``{"block.param": value}``, structural overrides) of ``changes``: a key naming a
        parameter of a block of the built system is a run-time change; any other needs a rebuild."""
        params, structural = {}, {}
        for key, value in (changes or {}).items():
            block = str(key).rpartition(".")[0]
            if block in self.system.index:
                params[key] = value
            elif not self._unchanged(key, value):
                structural[key] = value
        return params, structural

    def changed(self, changes):
        """(experiment, run-time params) for ``changes``: this experiment when every change can be made at
        run time, else a new one built with the structural changes (and the rest at run time)."""
        params, structural = self.split(changes)
        if not structural:
            return self, params
        return Experiment(self.path, self.variant, **{**self.overrides, **structural}), params

    def operating_point(self, params=None, at=None):
        """(context, t): the initial state with ``params`` (None: the system's own, started by the
        linearization), or the state after ``at`` s of simulation."""
        if at:
            why = horizon_problems(self.system.blocks, self.settings["simulation"], at, 0, "linearize at")
            if why:
                raise InputError(f"{self.path}: " + "; ".join(why))
            return self.simulator.run(float(at), params=params or None).context, float(at)
        if not params:
            return None, 0.0  # Linearization starts a fresh context itself
        ctx = self.system.create_context(params)
        start_outputs(self.system, ctx)
        return ctx, 0.0

    def linearization(self, changes=None, at=None):
        """A :class:`~hybridsim.analysis.linearize.Linearization` with ``changes`` (run time where they can be)
        about the initial state, or about the state reached at ``at`` s of simulation."""
        exp, params = self.changed(changes)
        if exp is self and not params and at in self._at:
            return self._at[at][0]
        try:
            ctx, t = exp.operating_point(params, at)
        except ParameterError:  # a run-time change of structure (a width): build it instead
            exp, params = Experiment(self.path, self.variant, **{**self.overrides, **changes}), {}
            ctx, t = exp.operating_point(None, at)
        lin = Linearization(exp.system, ctx, t)
        if exp is self and not params:
            self._at[at] = (lin, None)
        return lin

    def closed_loop(self, changes=None, at=None):
        """The closed loop with ``changes`` (see :meth:`linearization`), or None where it cannot be
        linearized."""
        exp, params = self.changed(changes)
        if exp is self and not params and self._at.get(at, (None, None))[1] is not None:
            return self._at[at][1]  # this experiment unchanged: computed once per operating point
        try:
            lin = self.linearization(changes, at)
            cl = lin.closed_loop()
        except (LinearizationError, np.linalg.LinAlgError):  # no finite model there (e.g. expm overflowed): no verdict
            return None
        if exp is self and not params:
            self._at[at] = (lin, cl)
        return cl
