"""An experiment: a diagram file parsed and built once, and the changes made to it.

``Experiment(path, **overrides)`` holds the parsed file, the built system, its
simulator and settings. A change of a block parameter (``ctrl.fpi.Kp``) is made
at run time - a fresh context with the block rebuilt
(:meth:`~hybridsim.system.System.create_context`), no re-parse and no rebuild;
only a change of structure or rate, or of a ``params`` name the file resolves
while loading, builds a new experiment. The analysis and the report take one.
"""
from .api import build, load
from .errors import ParameterError
from .linearize import Linearization, LinearizationError


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

    def split(self, changes):
        """(run-time ``{"block.param": value}``, structural overrides) of ``changes``: a key naming a
        parameter of a block of the built system is a run-time change; any other needs a rebuild."""
        params, structural = {}, {}
        for key, value in (changes or {}).items():
            block = str(key).rpartition(".")[0]
            (params if block in self.system.index else structural)[key] = value
        return params, structural

    def changed(self, changes):
        """(experiment, run-time params) for ``changes``: this experiment when every change can be made at
        run time, else a new one built with the structural changes (and the rest at run time)."""
        params, structural = self.split(changes)
        if not structural:
            return self, params
        return Experiment(self.path, self.variant, **{**self.overrides, **structural}), params

    def operating_point(self, params=None, at=None):
        """(context, t): the initial state with ``params``, or the state after ``at`` s of simulation."""
        if at:
            return self.simulator.run(float(at), params=params or None).context, float(at)
        return self.system.create_context(params or None), 0.0

    def linearization(self, changes=None, at=None):
        """A :class:`~hybridsim.linearize.Linearization` with ``changes`` (run time where they can be)
        about the initial state, or about the state reached at ``at`` s of simulation."""
        exp, params = self.changed(changes)
        try:
            ctx, t = exp.operating_point(params, at)
        except ParameterError:  # a run-time change of structure (a width): build it instead
            exp, params = Experiment(self.path, self.variant, **{**self.overrides, **changes}), {}
            ctx, t = exp.operating_point(None, at)
        return Linearization(exp.system, ctx, t)

    def closed_loop(self, changes=None, at=None):
        """The closed loop with ``changes`` (see :meth:`linearization`), or None where it cannot be
        linearized."""
        try:
            return self.linearization(changes, at).closed_loop()
        except LinearizationError:
            return None
