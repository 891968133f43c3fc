"""An experiment: a diagram file parsed once, built once per variant, and the changes made to it.

``Experiment(path, **overrides)`` holds the parsed file; its system, simulator and
settings are built when first asked for. A change of a block parameter
(``ctrl.fpi.Kp``) is made at run time - a fresh context with the block rebuilt
(:meth:`~hybridsim.engine.system.System.create_context`), no re-parse and no rebuild -
and for runs so is a ``params`` name that only block numbers use (``Kr``); a change of
structure or rate, or of a name the file resolves while loading (a setting, a variant,
a subsystem's parameter), builds a new experiment (:meth:`Experiment.split`). The
analysis, the report and :func:`~hybridsim.runs.many.run_many` take one.

An experiment pickles as what it was made from (file, variant, overrides): a worker
process builds it once and keeps it for every later call of the same experiment.
"""
import copy
import json
from collections import OrderedDict

import numpy as np

from hybridsim.format.build import build, load
from hybridsim.errors import HybridsimError, InputError, ParameterError, SimulationError
from hybridsim.format.settings import horizon_problems
from hybridsim.analysis.linearize import Linearization, LinearizationError, start_outputs

#: experiments a worker process keeps built (each with its simulator, maybe a compiled loop)
KEPT = 8
_KEPT = OrderedDict()


class Experiment:
    """A diagram file, parsed once, with its overrides; built (one variant) when first run.

    Parameters
    ----------
    path : str, Path or DiagramFile
        The diagram file, or one parsed already (:func:`hybridsim.format.build.load`).
    variant : dict, optional
        The variant to build (``{"rate": 60}``, as :meth:`variants` gives them; default:
        the file's ``params`` as they are).
    **overrides
        As ``hybridsim --set``: ``params`` names, ``block.param``, simulation keys.
    """

    def __init__(self, path, variant=None, **overrides):
        from hybridsim.format import DiagramFile

        self.variant, self.overrides = variant, dict(overrides)
        if isinstance(path, DiagramFile):  # parsed already (its own overrides applied): kept as it is
            self.path, self.file, self._given = path.path, path, True
            if overrides:
                self.file = copy.deepcopy(path)
                self.file.apply(overrides)
        else:
            self.path, self.file, self._given = path, load(path, **overrides), False
        self._start()

    def _start(self, records=None):
        self.records = records  # what the simulator logs: None (the file's log), "metrics" or a list
        self._system = self._settings = self._simulator = None
        self._at = {}  # at -> (Linearization, closed loop) of this experiment unchanged
        self._checked = {}  # (key, value) -> whether it is a run-time change
        self._variants = None

    def _like(self, variant, records):
        """This experiment (the same parsed file) for ``variant``, recording ``records``."""
        exp = Experiment.__new__(Experiment)
        exp.path, exp.variant, exp.overrides, exp.file, exp._given = (self.path, variant, self.overrides, self.file,
                                                                       self._given)
        exp._start(records)
        return exp

    def __reduce__(self):  # what it was made from: a worker builds it once (see _kept)
        from hybridsim.format.identity import file_identity

        if self._given:  # a parsed file given, not a path: it travels itself
            return _of_file, (self.file, self.variant, self.records)
        # with the contents of the files it reads: a worker that outlives a sweep (Dask) must not
        # answer an edited diagram or subsystem with what it built from the old one
        return _kept, (str(self.path), self.variant, self.file.layers, self.records, file_identity(self.file))

    # -- what it is built into ----------------------------------------------------------------
    @property
    def system(self):
        """The built :class:`~hybridsim.engine.system.System` (the simulator's, once that is built)."""
        if self._system is None:
            diagram, self._settings = self.file.build(self.variant)
            self._system = diagram.build()
        return self._system

    @property
    def settings(self):
        """The variant's settings (simulation, log, signals, metrics, ...)."""
        if self._settings is None:
            self._settings = self.file.build(self.variant)[1]
        return self._settings

    @property
    def simulator(self):
        """The :class:`~hybridsim.engine.simulator.Simulator` (built on first use; on the compiled
        path that generates or loads the compiled loop)."""
        if self._simulator is None:
            log = self.records
            if log == "metrics":
                log = list(self.settings["signals"].values())
            self._system, self._simulator, self._settings = build(self.file, self.variant, log=log)
        return self._simulator

    @property
    def t_end(self):
        """The run length, s."""
        return float(self.settings["simulation"]["t_end"])

    def variants(self):
        """``[(label, experiment)]``: one experiment per variant of the file (this one when it has
        none, or when it is one variant already); they share the parsed file."""
        if self._variants is None:
            self._variants = [("", self)] if self.variant is not None else \
                [(label, self if not v else self._like(v, self.records)) for label, v in self.file.variants()]
        return self._variants

    def recording(self, signals):
        """This experiment recording only ``signals`` (a list of ``block.port``, or "metrics": what its
        metrics read; None: the file's ``log`` and ``signals``)."""
        return self if signals == self.records else self._like(self.variant, signals)

    # -- changes -------------------------------------------------------------------------------
    def _unchanged(self, key, value):
        """Whether ``key = value`` is what this experiment (its variant) already has (a ``params`` name)."""
        params = {**self.file.params, **(self.variant or {})}
        if key not in params:
            return False
        try:
            return np.array_equal(np.asarray(value, float), np.asarray(params[key], float))
        except (TypeError, ValueError):
            return value == params[key]

    def runtime(self, key, value, names=False):
        """Whether ``key = value`` can be given at run time: a parameter of a block of the built system
        that the block takes without a change of structure; with ``names``, also a ``params`` name
        whose every use is such a parameter (runs take it; :meth:`closed_loop` rebuilds for a name:
        a block's structure check misses some switches a linearization sees, such as friction on/off)."""
        if not names and str(key).rpartition(".")[0] not in self.system.index:
            return False
        tag = json.dumps([key, value], sort_keys=True, default=str)
        if tag not in self._checked:
            try:
                self.system.blocks_with(self.params_of({key: value}))
                self._checked[tag] = True
            except (HybridsimError, ValueError, TypeError, KeyError):
                self._checked[tag] = False
        return self._checked[tag]

    def params_of(self, changes):
        """``changes`` as run-time block parameters ``{"block.param": value}`` (a ``params`` name becomes
        every block parameter that refers to it); not checked (:meth:`runtime` checks)."""
        index = self.system.index
        if all(str(k).rpartition(".")[0] in index for k in changes):
            return dict(changes)
        return self.file.runtime_params(changes, self.variant)

    def _sort(self, changes, names=False):
        """(run-time changes, structural changes) of ``changes``, as given (see :meth:`split`)."""
        named, structural = {}, {}
        for key, value in (changes or {}).items():
            if self._unchanged(key, value):
                continue
            if self.runtime(key, value, names):
                named[key] = value
            else:
                structural[key] = value
        return named, structural

    def split(self, changes, names=False):
        """(run-time ``{"block.param": value}``, structural overrides) of ``changes``: what
        :meth:`runtime` accepts (with ``names``: ``params`` names too) is made at run time; anything
        else needs a rebuild."""
        named, structural = self._sort(changes, names)
        return (self.params_of(named) if named else {}), structural

    @classmethod
    def layered(cls, path, layers, variant=None):
        """The experiment of diagram ``path`` with each mapping of ``layers`` applied in turn, each
        checked as given (a later one may set what an earlier one replaced); empty ones skipped."""
        layers = [layer for layer in layers if layer]
        exp = cls(path, variant, **(layers[0] if layers else {}))
        for layer in layers[1:]:
            exp = exp.rebuilt(layer)
        return exp

    def rebuilt(self, structural):
        """A new experiment with ``structural`` overrides added (parsed and built anew)."""
        # a layer over the file's own overrides (an analysis set over a sweep's: each checked as given)
        exp = Experiment(self.file, self.variant, **structural)
        exp.overrides, exp._given = {**self.overrides, **structural}, self._given
        return exp.recording(self.records)

    def changed(self, changes):
        """(experiment, run-time params) for ``changes``: this experiment when every change can be made at
        run time, else a new one built with the structural changes (and the rest at run time)."""
        named, structural = self._sort(changes)
        exp = self.rebuilt(structural) if structural else self
        return exp, (exp.params_of(named) if named else {})

    # -- runs and linear models ----------------------------------------------------------------
    def run(self, params=None):
        """One run with run-time ``params`` (``{"block.param": value}``): a
        :class:`~hybridsim.engine.result.Result`."""
        return self.simulator.run(self.t_end, params=params or None)

    def operating_point(self, params=None, at=None):
        """(context, t): the initial state with ``params`` (None: the system's own, started by the
        linearization), or the state after ``at`` s of simulation."""
        at = self._checked_at(at)
        if at:
            why = horizon_problems(self.system.blocks, self.settings["simulation"], at, 0, "linearize at")
            if why:
                raise InputError(f"{self.path}: " + "; ".join(why))
            return self.simulator.run(float(at), params=params or None, logged=False).context, float(at)
        if not params:
            return None, 0.0  # Linearization starts a fresh context itself
        ctx = self.system.create_context(params)
        start_outputs(self.system, ctx)
        return ctx, 0.0

    def _checked_at(self, at):
        """``at`` as a float (None stays None), checked as a file's analysis ``at`` is."""
        if at is None:
            return None
        from hybridsim.format.tables import ANALYSIS, check_values

        bad = check_values(ANALYSIS, {"at": at}, "analysis")
        if bad:
            raise InputError(f"{self.path}: {bad[0][0]}")
        return float(at)

    def linearization(self, changes=None, at=None):
        """A :class:`~hybridsim.analysis.linearize.Linearization` with ``changes`` (run time where they can be)
        about the initial state, or about the state reached at ``at`` s of simulation."""
        at = self._checked_at(at)
        exp, params = self.changed(changes)
        if exp is self and not params and at in self._at:
            return self._at[at][0]
        try:
            ctx, t = exp.operating_point(params, at)
        except ParameterError:  # a run-time change of structure (a width): build it instead
            exp, params = self.rebuilt(changes), {}
            ctx, t = exp.operating_point(None, at)
        try:
            lin = Linearization(exp.system, ctx, t)
        except LinearizationError as exc:  # a block it cannot see: at the block's line
            named = [n for n in exp.file._locs("blocks") if f"'{n}'" in str(exc) or f"'{n}." in str(exc)]
            where = exp.file._locs("blocks")[named[0]] if named else str(self.path)
            raise LinearizationError(f"{where}: {exc}") from None
        if exp is self and not params:
            self._at[at] = (lin, None)
        return lin

    def closed_loop(self, changes=None, at=None):
        """The closed loop with ``changes`` (see :meth:`linearization`), or None where it cannot be
        linearized."""
        at = self._checked_at(at)
        exp, params = self.changed(changes)
        if exp is self and not params and self._at.get(at, (None, None))[1] is not None:
            return self._at[at][1]  # this experiment unchanged: computed once per operating point
        try:
            lin = self.linearization(changes, at)
            cl = lin.closed_loop()
        except (LinearizationError, np.linalg.LinAlgError):  # no finite model there (e.g. expm overflowed): no verdict
            return None
        except SimulationError:  # a change (a scaled gain) whose run to ``at`` failed: no operating point
            if changes and at:  # there, no verdict (the analysis's own point still fails loudly)
                return None
            raise
        if exp is self and not params:
            self._at[at] = (lin, cl)
        return cl


def _kept(path, variant, layers, records, files):
    """The experiment of (path, variant, the overrides ``layers`` in turn, records) this process built
    before from the same file contents (``files``: :func:`~hybridsim.format.identity.file_identity`),
    or a new one (kept: the last :data:`KEPT`)."""
    tag = json.dumps([path, variant, layers, records, files], sort_keys=True, default=str)
    exp = _KEPT.pop(tag, None)
    if exp is None:
        exp = Experiment.layered(path, layers, variant).recording(records)
    _KEPT[tag] = exp
    while len(_KEPT) > KEPT:
        _KEPT.popitem(last=False)
    return exp


def _of_file(file, variant, records):
    """The experiment of a parsed ``file`` (sent whole to a worker)."""
    return Experiment(file, variant).recording(records)
