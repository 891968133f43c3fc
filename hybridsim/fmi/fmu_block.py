"""The FMU bridge: use any FMU as a block (via fmpy), and compile C sources into an FMU.

* :func:`build_fmu` compiles a C model behind the FMI 2.0 or 3.0 API into a ``.fmu``
  (``hybridsim fmu build`` builds the plant of ``fmus/``; it lives in
  :mod:`hybridsim.fmi.build`).
* :class:`FMUBlock` (``type: fmu`` in YAML) loads an FMI 2.0 or 3.0 FMU.
  Inputs and outputs become ports; variables named ``x[1]``, ``x[2]``, ...
  (or ``x[0]``, ``x[1]``, ...) and FMI 3.0 arrays are grouped into one port ``x``
  of that width (:mod:`hybridsim.fmi.variables`). Co-Simulation FMUs are
  discrete blocks stepped at the block's period (outputs at a hit are the
  FMU's outputs at that time, then the inputs are set and the FMU steps one
  period: zero-order hold on the inputs). Model Exchange FMUs are continuous
  blocks integrated by hybridsim's solver, their event indicators used as
  zero crossings. Direct feedthrough comes from the model structure.

A Co-Simulation FMU keeps its state inside the FMU instance, not in the
hybridsim context: a diagram with one runs one simulation at a time, and
each run re-instantiates it at t = 0.
"""
import contextlib
import ctypes
import functools
import shutil
import tempfile
import zipfile
from pathlib import Path

import numpy as np

from hybridsim.fmi import log as fmi_log
from hybridsim.engine.block import Block
from hybridsim.errors import FMUError, ParameterError, StopRequest
from hybridsim.fmi.model_exchange import ModelExchange, _raise
from hybridsim.fmi.start_values import start_values
from hybridsim.fmi.build import build_fmu, find_compiler, fmi_headers  # noqa: F401 - hybridsim.fmi.fmu_block.build_fmu
from hybridsim.fmi.variables import (PORT_TYPES, _access, _by_type, _check_members, _group,  # noqa: F401
                                     _nominal, _size, _start, to_fmi)
from hybridsim.engine.registry import register

GROUP = "FMU"  # where `hybridsim blocks` lists this module's blocks


@functools.lru_cache(maxsize=32)
def _read(path, resolved, size, mtime_ns):
    """``(model description, platforms with a binary)`` of the FMU at ``path``, read once per
    process for each version of the file (``resolved``, ``size``, ``mtime_ns``): a sweep or a
    search builds the same FMU block again and again. The description is only read, never changed."""
    import fmpy
    from fmpy.model_description import read_model_description

    if not Path(path).is_file() or not zipfile.is_zipfile(path):
        raise FMUError(f"FMU {path!r}: not an FMU (not a zip archive)")
    _check_members(Path(path))
    try:
        md = read_model_description(path)
    except Exception as exc:  # noqa: BLE001 - fmpy raises many kinds
        raise FMUError(f"FMU {path!r}: cannot read modelDescription.xml: {exc}") from None
    return md, frozenset(fmpy.supported_platforms(path))


@register("fmu")
class FMUBlock(ModelExchange, Block):
    """Any FMI 2.0 or 3.0 FMU as a block (numeric and Boolean inputs and outputs).

    Parameters
    ----------
    path : str       the .fmu file (relative paths: to the working folder)
    mode : 'cs' or 'me'   Co-Simulation (needs ``rate`` or ``period``) or Model Exchange
    parameters : dict     start values to set, by variable name
    rate, period          sample rate (Hz) or period (s) of a Co-Simulation FMU
    """

    def __init__(self, name="fmu", path=None, mode="cs", parameters=None, rate=None, period=None):
        super().__init__(name)
        if not path:
            raise ValueError("an fmu block needs 'path'")
        import fmpy

        self.path = Path(path)
        if not self.path.is_file():  # the user's path, not the FMU: bad input
            why = "is a folder, not an .fmu file" if self.path.is_dir() else "names no file"
            hint = (" (the shipped plant FMU is built with 'hybridsim fmu build -o plant.fmu')"
                    if self.path.name.startswith("plant") else "")
            if (self.path / "modelDescription.xml").is_file():  # an extracted FMU: its zip is what is read
                hint = (" (an extracted FMU: zip its contents back into one, e.g. "
                        f"'cd {self.path} && zip -r ../model.fmu .')")
            raise ParameterError("path", f"{why}: {str(self.path)!r}{hint}")
        stat = self.path.stat()
        md, binaries = _read(str(self.path), str(self.path.resolve()), stat.st_size, stat.st_mtime_ns)
        if md.fmiVersion not in ("2.0", "3.0"):
            raise FMUError(f"FMU {str(self.path)!r}: FMI version {md.fmiVersion} is not supported "
                           "(FMI 2.0 or 3.0)")
        self.fmi3 = md.fmiVersion == "3.0"
        self.md = md
        self.mode = str(mode).lower()
        kind = {"cs": md.coSimulation, "me": md.modelExchange}.get(self.mode, None)
        if self.mode not in ("cs", "me"):
            raise ValueError(f"mode must be 'cs' or 'me', got {mode!r}")
        if kind is None and getattr(md, "scheduledExecution", None) is not None and not (
                md.coSimulation or md.modelExchange):
            raise FMUError(f"FMU {str(self.path)!r} is a Scheduled Execution FMU (FMI 3.0): hybridsim runs "
                           "Co-Simulation and Model Exchange FMUs, not Scheduled Execution")
        self.hidden_state = self.mode == "cs"  # its states live inside the FMU: no linearization reads them
        if kind is None:
            raise FMUError(f"FMU {str(self.path)!r} offers no {'Co-Simulation' if self.mode == 'cs' else 'Model Exchange'}")
        here = fmpy.platform  # fmpy names FMI 3 platform tuples the same way
        if here not in binaries:
            raise FMUError(f"FMU {str(self.path)!r} has no binary for this platform ({here}); "
                           f"it has: {', '.join(sorted(binaries)) or 'none'}")
        self.model_identifier = kind.modelIdentifier
        byname = {v.name: v for v in md.modelVariables}
        self.parameters = start_values(self.path, byname, parameters)
        # text and bytes cannot cross the diagram: such inputs keep their start values, such
        # outputs are not ports (both listed in text_variables)
        self.text_variables = [f"{v.name} ({v.type} {v.causality})" for v in md.modelVariables
                               if v.causality in ("input", "output") and v.type in ("String", "Binary")]
        unsupported = [f"{v.name} ({v.type}, {v.causality})" for v in md.modelVariables
                       if v.causality in ("input", "output") and v.type not in PORT_TYPES | {"String", "Binary"}]
        if unsupported:  # clocks: hybridsim has no clocked partitions
            raise FMUError(f"FMU {str(self.path)!r}: these inputs/outputs cannot be ports (numbers and "
                           f"Booleans can; String and Binary ones stay out of the diagram): {', '.join(unsupported)}")
        ported = lambda c: [v for v in md.modelVariables if v.causality == c and v.type in PORT_TYPES]  # noqa: E731
        self.in_ports = _group(ported("input"))
        self.out_ports = _group(ported("output"))
        for pname, vs in self.in_ports:  # an input whose variables all have start values may stay unwired
            starts = [_start(v) for v in vs]
            self.declare_input(pname, sum(map(_size, vs)),
                               default=None if None in starts else [x for st in starts for x in st])
        in_index = {v.valueReference: pname for pname, vs in self.in_ports for v in vs}
        deps = {}
        for u in md.outputs:
            if u.dependencies is None:
                deps[u.variable.name] = None
            else:
                deps[u.variable.name] = {in_index[d.valueReference] for d in u.dependencies
                                         if d.valueReference in in_index}
        for pname, vs in self.out_ports:
            dep = set()
            for v in vs:
                d = deps.get(v.name)
                if d is None:
                    dep = None
                    break
                dep |= d
            self.declare_output(pname, sum(map(_size, vs)), depends_on=None if dep is None else sorted(dep))
        widths = [sum(map(_size, vs)) for _, vs in self.out_ports]
        self.n_out = sum(widths)
        self.cuts = np.cumsum([0] + widths)
        # values cross the diagram as floats; each type is read and written with its own call
        self.out_types = _by_type([v for _, vs in self.out_ports for v in vs])
        self.in_vars = [v for _, vs in self.in_ports for v in vs]
        # element k of the flat input vector belongs to variable in_elem[k], element in_part[k] of it
        self.in_elem = [j for j, v in enumerate(self.in_vars) for _ in range(_size(v))]
        self.in_part = [e for v in self.in_vars for e in range(_size(v))]
        self.in_first = np.cumsum([0] + [_size(v) for v in self.in_vars])
        self._in_members = {}  # {type: [(value reference, index in in_vars)]}
        for j, v in enumerate(self.in_vars):
            self._in_members.setdefault(v.type, []).append((v.valueReference, j))
        # Model Exchange: discrete-time inputs may be set in event mode only (FMI 2.0 and 3.0)
        discrete = [k for k, j in enumerate(self.in_elem) if self.in_vars[j].variability == "discrete"]
        self.in_discrete = discrete if self.mode == "me" else []
        self._last_discrete = None
        if self.mode == "cs":
            if (rate is None) == (period is None):
                raise ValueError("a Co-Simulation FMU needs exactly one of rate (Hz) or period (s)")
            self.declare_rate(period=period, rate=rate)
            self.T = float(self.period)
        else:
            for key, given in (("rate", rate), ("period", period)):
                if given is not None:  # it was dropped, silently
                    raise ParameterError(key, "is a Co-Simulation FMU's (mode: cs): a Model Exchange FMU is "
                                              "integrated by the diagram's solver, remove it")
            self.nx = md.numberOfContinuousStates
            # fmpy reads FMI 2.0's completedIntegratorStepNotNeeded into this flag too
            self.needs_completed_step = bool(md.modelExchange.needsCompletedIntegratorStep)
            self.nz = md.numberOfEventIndicators
            # absolute tolerances from the states' nominal values (1e-12 of each; nominal 1 when none)
            nominals = [_nominal(d.variable.derivative) for d in md.derivatives][:self.nx]
            nominals += [1.0] * (self.nx - len(nominals))
            # an FMU without continuous states gets one of zero derivative (as OpenModelica's dummy
            # state): the event loop then serves its time and state events like any other block's
            self.declare_continuous_state(self.nx or 1, atol=[1e-12 * n for n in nominals] or None)
        self._starts = np.array([x for v in self.in_vars for x in (_start(v) or [np.nan] * _size(v))])
        self._held = None  # the input values the FMU holds (its start values after instantiation)
        self._inputs_set = None
        self._pending_stop = None  # a stop the FMU asked for at the end of a completed step
        self._fmu = None
        self._unzipdir = None
        self._messages = []

    # -- the FMU instance ------------------------------------------------------
    def _call(self, what, fn, *args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except Exception as exc:  # noqa: BLE001
            log = "; ".join(self._messages[-3:])
            said = str(exc).replace(str(self._unzipdir), f"{self.path}:") if self._unzipdir else str(exc)
            raise FMUError(f"FMU block {self.name!r} ({self.path}): {what} failed: {said}"
                           + (f" - the FMU says: {log}" if log else "")) from None

    def _instantiate(self):
        import fmpy

        self.close()
        self._last_discrete = None
        self._held = self._starts.copy()
        self._inputs_set = None  # the input values last set in full (bytes): unchanged ones are skipped
        self._sent_state = self._calls = None  # what the new instance was last given; its bound calls
        self._pending_stop = None
        self._unzipdir = tempfile.mkdtemp(prefix="hybridsim-fmu-")
        try:
            # what an instance needs, as fmpy.simulate_fmu extracts: not sources/ nor documentation/
            fmpy.extract(str(self.path), unzipdir=self._unzipdir,
                         include=lambda n: n.startswith(("binaries/", "resources/")))
        except Exception as exc:  # noqa: BLE001 - zipfile and fmpy raise many kinds
            self.close()
            raise FMUError(f"FMU {str(self.path)!r}: cannot extract: {exc}") from None
        self._messages = []
        kw = dict(guid=self.md.guid, unzipDirectory=self._unzipdir,
                  modelIdentifier=self.model_identifier, instanceName=self.name)
        try:
            fmu = self._fmu = (self._instantiate3 if self.fmi3 else self._instantiate2)(kw)
            byname = {v.name: v for v in self.md.modelVariables}
            for pname, value in self.parameters.items():
                var = byname[pname]
                if var in self.in_vars:  # an input given a value here: the FMU no longer holds its start
                    j = self.in_vars.index(var)
                    self._held[self.in_first[j]:self.in_first[j + 1]] = np.nan
                if var.type in ("String", "Binary"):
                    self._call(f"setting {pname}", getattr(fmu, "set" + var.type), [var.valueReference], [value])
                    continue
                setter = getattr(fmu, _access(var.type, self.fmi3, "set"), None)
                if var.type not in PORT_TYPES or setter is None:
                    raise FMUError(f"FMU block {self.name!r}: parameter {pname!r} has type {var.type}; "
                                   "numeric, Boolean, String and Binary parameters can be set")
                values = value if isinstance(value, (list, tuple)) else [value]
                self._call(f"setting {pname}", setter, [var.valueReference],
                           [to_fmi(var.type, v, pname) for v in values])
            self._call("exitInitializationMode", fmu.exitInitializationMode)
            if self.mode == "me":
                try:
                    self._event_update(0.0)  # the event iteration after initialization
                except StopRequest:
                    raise FMUError(f"FMU block {self.name!r} asks to terminate the simulation during "
                                   "its initialization (terminateSimulation at t = 0)") from None
                self._call("enterContinuousTimeMode", fmu.enterContinuousTimeMode)
        except BaseException:
            self.close()  # terminate and free the instance, remove the extracted files
            raise
        return fmu

    def _instantiate2(self, kw):
        from fmpy.fmi2 import FMU2Model, FMU2Slave, fmi2CallbackFunctions
        from fmpy.fmi2 import defaultCallbacks as cb2

        fmu = self._call("loading the binary", FMU2Slave if self.mode == "cs" else FMU2Model, **kw)
        cbs = fmi2CallbackFunctions()
        cbs.logger = fmi_log.logger()  # one process-wide logger: see fmi_log
        cbs.componentEnvironment = self._log_key = fmi_log.open_sink(self._messages)
        cbs.allocateMemory, cbs.freeMemory = cb2.allocateMemory, cb2.freeMemory
        self._callbacks = cbs
        self._call("fmi2Instantiate", fmu.instantiate, False, cbs, True)  # logging on: the FMU says why
        self._call("setupExperiment", fmu.setupExperiment, None, 0.0)
        self._call("enterInitializationMode", fmu.enterInitializationMode)
        self._get_der = getattr(fmu, "getDerivatives", None)  # ME only
        return fmu

    def _instantiate3(self, kw):
        from fmpy.fmi3 import FMU3Model, FMU3Slave

        fmu = self._call("loading the binary", FMU3Slave if self.mode == "cs" else FMU3Model, **kw)

        def logger(env, status, category, message):
            self._messages.append(message.decode(errors="replace") if message else "")

        self._call("fmi3Instantiate", fmu.instantiate, loggingOn=True, logMessage=logger)
        self._call("enterInitializationMode", fmu.enterInitializationMode, startTime=0.0)
        self._get_der = getattr(fmu, "getContinuousStateDerivatives", None)  # ME only
        return fmu

    def close(self):
        """Free the FMU instance and delete its extracted files."""
        if self._fmu is not None:
            with contextlib.suppress(Exception):
                self._fmu.terminate()
            with contextlib.suppress(Exception):
                self._fmu.freeInstance()
            self._fmu = None
        fmi_log.close_sink(getattr(self, "_log_key", None))
        self._log_key = None
        if self._unzipdir:
            shutil.rmtree(self._unzipdir, ignore_errors=True)
            self._unzipdir = None

    def release(self):
        self.close()

    def __del__(self):  # pragma: no cover - interpreter shutdown order varies
        with contextlib.suppress(Exception):
            self.close()

    def __getstate__(self):
        state = dict(self.__dict__)
        state.update(_fmu=None, _unzipdir=None, _log_key=None, _callbacks=None, _get_der=None,
                     _sent_state=None, _calls=None, _inputs_set=None)
        return state

    def _outputs(self):
        vals = np.zeros(self.n_out)
        for typ, (positions, vrs, n) in self.out_types.items():
            get = getattr(self._fmu, _access(typ, self.fmi3, "get"))
            got = self._call(f"get {typ} outputs", get, vrs, n) if self.fmi3 else self._call(
                f"get {typ} outputs", get, vrs)
            vals[positions] = np.asarray(got, float)
        return tuple(vals[a:b] for a, b in zip(self.cuts[:-1], self.cuts[1:]))

    def _set_inputs(self, u, only=None):
        """Set the inputs (``only``: those positions; default all but ME discrete-time ones)."""
        if not self.in_vars:
            return
        key = None
        if only is None:  # the inputs as bytes: as last set in full, there is nothing to write
            try:
                key = b"".join([a.tobytes() for a in u])
            except AttributeError:  # not arrays
                key = np.concatenate(u).tobytes()
            if key == self._inputs_set:
                return
        values = np.concatenate(u)
        skip = set() if only is not None else set(self.in_discrete)
        held, first = self._held, self.in_first
        changed = ~(values == held)
        for typ, members in self._in_members.items():
            # only what changed: an input left at its start value (unwired) is never written;
            # an array is written whole
            pick = []
            for vr, j in members:
                ks = range(first[j], first[j + 1])
                if changed[ks].any() and first[j] not in skip and (only is None or first[j] in only):
                    pick.append((vr, ks))
            if not pick:
                continue
            conv = [to_fmi(typ, values[k], self._port_name(k)) for _, ks in pick for k in ks]
            self._call(f"set {typ} inputs", getattr(self._fmu, _access(typ, self.fmi3, "set")),
                       [vr for vr, _ in pick], conv)
            for _, ks in pick:
                held[ks] = values[ks]
        if key is not None:
            self._inputs_set = key

    def _port_name(self, k):
        """'block.port[j] (FMU variable name)' of flat input position ``k``, for messages."""
        var = self.in_vars[self.in_elem[k]]
        element = f"{var.name}[{self.in_part[k]}]" if _size(var) > 1 else var.name
        for pname, vs in self.in_ports:
            width = sum(map(_size, vs))
            if k < width:
                return f"{self.name}.{pname}[{k}] ({element})" if width > 1 else f"{self.name}.{pname} ({element})"
            k -= width
        return element  # pragma: no cover

    # -- block API ----------------------------------------------------------------
    def initial_state(self, u=None):
        fmu = self._instantiate()
        if self.mode == "me":
            x = np.zeros(self.nx)
            if not self.nx:
                return np.zeros(1)
            self._call("getContinuousStates", fmu.getContinuousStates, x.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), self.nx)
            return x
        return np.zeros(0)

    def output(self, t, x, u):
        if self.mode == "me":
            self._me_set(t, x, u)
            if self.in_discrete:
                self._discrete_inputs(t, x, u)
            return self._me_outputs()
        self._set_inputs(u)
        return self._outputs()

    def update(self, t, x, u):
        """One Co-Simulation step from ``t``. A step the FMU discards (FMI 2.0) or ends with
        terminateSimulation / earlyReturn (FMI 3.0) ends the run cleanly at ``t``: a
        :class:`~hybridsim.errors.StopRequest` (hybridsim has no step-size control to retry,
        nor Co-Simulation event mode)."""
        if self._pending_stop is not None:  # the row of the completed step is recorded: stop now
            raise self._pending_stop
        self._set_inputs(u)
        try:
            res = self._fmu.doStep(t, self.T)
        except Exception as exc:  # noqa: BLE001 - fmpy raises its own exception per status
            if getattr(exc, "status", None) == 2:  # fmi2Discard
                self._stop_after(t, self._last_time2(t), "doStep discarded the step (fmi2Discard)")
                return x
            self._call(f"doStep at t={t:.6g}", _raise, exc)
        if self.fmi3 and res:
            _event, terminate, early, last = res
            if terminate or early:
                self._stop_after(t, float(last), "terminateSimulation" if terminate else
                                 "earlyReturn (Co-Simulation event mode is not supported)")
        return x

    def _last_time2(self, t):
        """FMI 2.0 after a discard: fmi2LastSuccessfulTime when the FMU tells it, else ``t``."""
        from fmpy.fmi2 import fmi2LastSuccessfulTime, fmi2Terminated

        try:
            if self._fmu.getBooleanStatus(fmi2Terminated):
                return float(self._fmu.getRealStatus(fmi2LastSuccessfulTime))
        except Exception:  # noqa: BLE001 - the status functions are optional
            pass
        return t

    def _stop_after(self, t, last, reason):
        """End the run: at ``t`` when the step did nothing, else after the completed step is recorded."""
        if last >= t + self.T * (1 - 1e-9):  # the step completed: its row is recorded first
            self._pending_stop = StopRequest(t + self.T, self.name, reason)
            return
        raise StopRequest(t, self.name, reason)
