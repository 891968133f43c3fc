"""The FMU bridge: use any FMU as a block (via fmpy), and compile C sources into an FMU.

* :func:`build_fmu` compiles a C model behind the FMI 2.0 or 3.0 API into a ``.fmu``
  (``hybridsim fmu build`` builds the plant of ``fmus/``).
* :class:`FMUBlock` (``type: fmu`` in YAML) loads an FMI 2.0 or 3.0 FMU.
  Inputs and outputs become ports; variables named ``x[1]``, ``x[2]``, ...
  are grouped into one port ``x`` of that width. Co-Simulation FMUs are
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
import os
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np

from . import fmi_log
from .block import Block
from .errors import FMUError, ParameterError, StopRequest
from .files import atomic_file
from .registry import closest, register

GROUP = "FMU"  # where `hybridsim blocks` lists this module's blocks

_INDEXED = re.compile(r"^(.*)\[(\d+)\]$")


def _group(variables):
    """[(port name, [variables in element order])] for 'x[1]', 'x[2]', ... and scalars."""
    ports = {}
    for v in variables:
        m = _INDEXED.match(v.name)
        base, idx = (m.group(1), int(m.group(2))) if m else (v.name, 1)
        ports.setdefault(base, []).append((idx, v))
    out = []
    for base, items in ports.items():
        items.sort(key=lambda t: t[0])
        out.append((base.replace(".", "_"), [v for _, v in items]))
    return out


#: FMI types an input or output port may have (values cross the diagram as floats)
PORT_TYPES = {"Real", "Integer", "Enumeration", "Boolean", "Float32", "Float64", "Int8", "UInt8", "Int16",
              "UInt16", "Int32", "UInt32", "Int64", "UInt64"}
_INT_RANGE = {"Int8": 8, "Int16": 16, "Int32": 32, "Int64": 64, "Integer": 32, "Enumeration": 32}
_UINT_RANGE = {"UInt8": 8, "UInt16": 16, "UInt32": 32, "UInt64": 64}


def _by_type(variables):
    """``{type: (positions, value references)}`` of ``variables`` in order."""
    out = {}
    for k, v in enumerate(variables):
        pos, vrs = out.setdefault(v.type, ([], []))
        pos.append(k)
        vrs.append(v.valueReference)
    return out


def _access(typ, fmi3, verb):
    """The fmpy method that gets or sets variables of FMI type ``typ``."""
    if fmi3:
        return verb + ("Int64" if typ == "Enumeration" else typ)
    return verb + {"Real": "Real", "Integer": "Integer", "Enumeration": "Integer", "Boolean": "Boolean"}[typ]


def to_fmi(typ, value, name):
    """A diagram value (float) as the FMI type ``typ``.

    Integers are rounded to the nearest (halves to even, as Python's ``round``)
    and must fit the type's range; a Boolean is true when the value is not 0;
    anything not finite is an error. Raises :class:`FMUError` naming the variable.
    """
    value = float(value)
    if not np.isfinite(value):
        raise FMUError(f"input {name!r} ({typ}) got {value!r}: not a finite number")
    if typ == "Boolean":
        return value != 0.0
    if typ in ("Real", "Float64", "Float32"):
        return value
    n = round(value)
    bits = _INT_RANGE.get(typ)
    lo, hi = (-(2 ** (bits - 1)), 2 ** (bits - 1) - 1) if bits else (0, 2 ** _UINT_RANGE[typ] - 1)
    if not lo <= n <= hi:
        raise FMUError(f"input {name!r} ({typ}) got {value!r}: outside {lo} .. {hi}")
    return n


def _start(variable):
    """A variable's start value as a float, or None."""
    start = variable.start
    if isinstance(start, str) and start.strip().lower() in ("true", "false"):
        return 1.0 if start.strip().lower() == "true" else 0.0
    try:
        return None if start is None else float(start)
    except (TypeError, ValueError):
        return None


def _text_parameter(var, value):
    """A String parameter's text, or a Binary parameter's bytes from hex digits ("0a ff 10").

    Raises :class:`~hybridsim.errors.ParameterError` for anything else.
    """
    if var.type == "String":
        if not isinstance(value, str) or "\0" in value:
            raise ParameterError("parameters", f"{var.name} is a String: give text, got {value!r}")
        return value
    if isinstance(value, (bytes, bytearray)):
        return bytes(value)
    try:
        return bytes.fromhex(value.replace("0x", ""))
    except (AttributeError, ValueError):  # not text, or not hex digits
        raise ParameterError("parameters", f"{var.name} is Binary: give its bytes as hex digits, e.g. "
                                           f"'0a ff 10', got {value!r}") from None


def _raise(exc):
    raise exc


def _nominal(variable):
    """A state variable's nominal value (1 when it gives none or a bad one)."""
    try:
        n = abs(float(getattr(variable, "nominal", None) or 1.0))
    except (TypeError, ValueError):
        return 1.0
    return n if np.isfinite(n) and n > 0 else 1.0


@register("fmu")
class FMUBlock(Block):
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
        from fmpy.model_description import read_model_description

        self.path = Path(path)
        if not self.path.exists():
            raise FMUError(f"FMU {str(self.path)!r}: file not found (the plant FMU is built with "
                           "'hybridsim fmu build -o plant.fmu')")
        if not self.path.is_file() or not zipfile.is_zipfile(self.path):
            raise FMUError(f"FMU {str(self.path)!r}: not an FMU (not a zip archive)")
        _check_members(self.path)
        try:
            md = read_model_description(str(self.path))
        except Exception as exc:  # noqa: BLE001 - fmpy raises many kinds
            raise FMUError(f"FMU {str(self.path)!r}: cannot read modelDescription.xml: {exc}") from None
        if md.fmiVersion not in ("2.0", "3.0"):
            raise FMUError(f"FMU {str(self.path)!r}: FMI version {md.fmiVersion} is not supported "
                           "(FMI 2.0 or 3.0)")
        self.fmi3 = md.fmiVersion == "3.0"
        self.md = md
        self.mode = str(mode).lower()
        kind = {"cs": md.coSimulation, "me": md.modelExchange}.get(self.mode, None)
        if self.mode not in ("cs", "me"):
            raise ValueError(f"mode must be 'cs' or 'me', got {mode!r}")
        self.hidden_state = self.mode == "cs"  # its states live inside the FMU: no linearization reads them
        if kind is None:
            raise FMUError(f"FMU {str(self.path)!r} offers no {'Co-Simulation' if self.mode == 'cs' else 'Model Exchange'}")
        binaries = {p for p in fmpy.supported_platforms(str(self.path))}
        here = fmpy.platform  # fmpy names FMI 3 platform tuples the same way
        if here not in binaries:
            raise FMUError(f"FMU {str(self.path)!r} has no binary for this platform ({here}); "
                           f"it has: {', '.join(sorted(binaries)) or 'none'}")
        self.model_identifier = kind.modelIdentifier
        byname = {v.name: v for v in md.modelVariables}
        self.parameters = {}
        if parameters is not None and not isinstance(parameters, dict):
            raise ParameterError("parameters", f"must map variable names to values, got {parameters!r}")
        for pname, value in (parameters or {}).items():
            var = byname.get(pname)
            if var is not None and var.type in ("String", "Binary"):
                self.parameters[pname] = _text_parameter(var, value)
                continue
            for v in (value if isinstance(value, (list, tuple)) else [value]):
                if not isinstance(v, (bool, int, float)) or not np.isfinite(float(v)):
                    raise ParameterError("parameters", f"{pname}: must be a finite number or a list of "
                                                       f"them, got {value!r}")
            if pname not in byname and f"{pname}[1]" in byname and isinstance(value, (list, tuple)):
                for k, v in enumerate(value, start=1):  # b: [1, 2] sets b[1] and b[2]
                    if f"{pname}[{k}]" not in byname:
                        raise FMUError(f"FMU {str(self.path)!r} has no variable {pname}[{k}]")
                    self.parameters[f"{pname}[{k}]"] = v
                continue
            if pname not in byname:
                raise FMUError(f"FMU {str(self.path)!r} has no variable {pname!r}{closest(pname, byname)}")
            self.parameters[pname] = value
        unsupported = [f"{v.name} ({v.type}, {v.causality})" for v in md.modelVariables
                       if v.causality in ("input", "output") and v.type not in PORT_TYPES]
        if unsupported:
            raise FMUError(f"FMU {str(self.path)!r}: these inputs/outputs cannot be ports (numbers and "
                           f"Booleans can: {', '.join(sorted(PORT_TYPES))}): {', '.join(unsupported)}")
        self.in_ports = _group([v for v in md.modelVariables if v.causality == "input"])
        self.out_ports = _group([v for v in md.modelVariables if v.causality == "output"])
        for pname, vs in self.in_ports:  # an input whose variables all have start values may stay unwired
            starts = [_start(v) for v in vs]
            self.declare_input(pname, len(vs), default=None if None in starts else starts)
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
            self.declare_output(pname, len(vs), depends_on=None if dep is None else sorted(dep))
        self.in_vrs = [[v.valueReference for v in vs] for _, vs in self.in_ports]
        self.out_vrs = [[v.valueReference for v in vs] for _, vs in self.out_ports]
        self.out_flat = [vr for vrs in self.out_vrs for vr in vrs]
        self.cuts = np.cumsum([0] + [len(v) for v in self.out_vrs])
        self.in_flat = [vr for vrs in self.in_vrs for vr in vrs]
        # values cross the diagram as floats; each type is read and written with its own call
        self.out_types = _by_type([v for _, vs in self.out_ports for v in vs])
        self.in_vars = [v for _, vs in self.in_ports for v in vs]
        self.in_types = _by_type(self.in_vars)
        # Model Exchange: discrete-time inputs may be set in event mode only (FMI 2.0 and 3.0)
        discrete = [k for k, v in enumerate(self.in_vars) if v.variability == "discrete"]
        self.in_discrete = discrete if self.mode == "me" else []
        self._last_discrete = None
        if self.mode == "cs":
            if (rate is None) == (period is None):
                raise ValueError("a Co-Simulation FMU needs exactly one of rate (Hz) or period (s)")
            self.declare_rate(period=period, rate=rate)
            self.T = float(self.period)
        else:
            self.nx = md.numberOfContinuousStates
            self.nz = md.numberOfEventIndicators
            # absolute tolerances from the states' nominal values (1e-12 of each; nominal 1 when none)
            nominals = [_nominal(d.variable.derivative) for d in md.derivatives][:self.nx]
            nominals += [1.0] * (self.nx - len(nominals))
            self.declare_continuous_state(self.nx, atol=[1e-12 * n for n in nominals] or None)
        self._fmu = None
        self._unzipdir = None
        self._messages = []

    # -- the FMU instance ------------------------------------------------------
    def _call(self, what, fn, *args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except Exception as exc:  # noqa: BLE001
            log = "; ".join(self._messages[-3:])
            raise FMUError(f"FMU block {self.name!r}: {what} failed: {exc}"
                           + (f" - the FMU says: {log}" if log else "")) from None

    def _instantiate(self):
        import fmpy

        self.close()
        self._last_discrete = None
        self._unzipdir = tempfile.mkdtemp(prefix="hybridsim-fmu-")
        try:
            fmpy.extract(str(self.path), unzipdir=self._unzipdir)
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
                if var.type in ("String", "Binary"):
                    self._call(f"setting {pname}", getattr(fmu, "set" + var.type), [var.valueReference], [value])
                    continue
                setter = getattr(fmu, _access(var.type, self.fmi3, "set"), None)
                if var.type not in PORT_TYPES or setter is None:
                    raise FMUError(f"FMU block {self.name!r}: parameter {pname!r} is a {var.type}; "
                                   "numeric, Boolean, String and Binary parameters can be set")
                self._call(f"setting {pname}", setter, [var.valueReference], [to_fmi(var.type, value, pname)])
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
        self._call("fmi2Instantiate", fmu.instantiate, False, cbs)
        self._call("setupExperiment", fmu.setupExperiment, None, 0.0)
        self._call("enterInitializationMode", fmu.enterInitializationMode)
        self._get_der = getattr(fmu, "getDerivatives", None)  # ME only
        return fmu

    def _instantiate3(self, kw):
        from fmpy.fmi3 import FMU3Model, FMU3Slave

        fmu = self._call("loading the binary", FMU3Slave if self.mode == "cs" else FMU3Model, **kw)

        def logger(env, status, category, message):
            self._messages.append(message.decode(errors="replace") if message else "")

        self._call("fmi3Instantiate", fmu.instantiate, logMessage=logger)
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
        state.update(_fmu=None, _unzipdir=None, _log_key=None, _callbacks=None, _get_der=None)
        return state

    def _outputs(self):
        vals = np.zeros(len(self.out_flat))
        for typ, (positions, vrs) in self.out_types.items():
            got = self._call(f"get {typ} outputs", getattr(self._fmu, _access(typ, self.fmi3, "get")), vrs)
            vals[positions] = np.asarray(got, float)
        return tuple(vals[a:b] for a, b in zip(self.cuts[:-1], self.cuts[1:]))

    def _set_inputs(self, u, only=None):
        """Set the inputs (``only``: those positions; default all but ME discrete-time ones)."""
        if not self.in_flat:
            return
        values = np.concatenate(u)
        skip = set() if only is not None else set(self.in_discrete)
        for typ, (positions, vrs) in self.in_types.items():
            pick = [(k, vr) for k, vr in zip(positions, vrs) if k not in skip and (only is None or k in only)]
            if not pick:
                continue
            conv = [to_fmi(typ, values[k], self.in_vars[k].name) for k, _ in pick]
            self._call(f"set {typ} inputs", getattr(self._fmu, _access(typ, self.fmi3, "set")),
                       [vr for _, vr in pick], conv)

    def _discrete_inputs(self, t, x, u):
        """Model Exchange: discrete-time inputs that changed enter the FMU through event mode."""
        values = np.concatenate(u)[self.in_discrete]
        if self._last_discrete is not None and np.array_equal(values, self._last_discrete):
            return
        self._last_discrete = values.copy()
        fmu = self._fmu
        self._call(f"enterEventMode at t={t:.9g}", fmu.enterEventMode)
        self._set_inputs(u, only=set(self.in_discrete))
        if self._event_update(t):
            raise FMUError(f"FMU block {self.name!r} changed its continuous states at t={t:.9g} s when a "
                           "discrete input changed; hybridsim cannot take that from an input yet")
        self._call("enterContinuousTimeMode", fmu.enterContinuousTimeMode)

    # -- block API ----------------------------------------------------------------
    def initial_state(self, u=None):
        fmu = self._instantiate()
        if self.mode == "me":
            x = np.zeros(self.nx)
            self._call("getContinuousStates", fmu.getContinuousStates, x.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), self.nx)
            return x
        return np.zeros(0)

    def output(self, t, x, u):
        if self.mode == "me":
            self._me_set(t, x, u)
            if self.in_discrete:
                self._discrete_inputs(t, x, u)
        else:
            self._set_inputs(u)
        return self._outputs()

    def update(self, t, x, u):
        """One Co-Simulation step from ``t``. A step the FMU discards (FMI 2.0) or ends with
        terminateSimulation / earlyReturn (FMI 3.0) ends the run cleanly at ``t``: a
        :class:`~hybridsim.errors.StopRequest` (hybridsim has no step-size control to retry,
        nor Co-Simulation event mode)."""
        self._set_inputs(u)
        try:
            res = self._fmu.doStep(t, self.T)
        except Exception as exc:  # noqa: BLE001 - fmpy raises its own exception per status
            if getattr(exc, "status", None) == 2:  # fmi2Discard
                raise StopRequest(t, self.name, "doStep discarded the step (fmi2Discard)") from None
            self._call(f"doStep at t={t:.6g}", _raise, exc)
        if self.fmi3 and res:
            _event, terminate, early, _last = res
            if terminate or early:
                raise StopRequest(t, self.name, "terminateSimulation" if terminate else
                                  "earlyReturn (Co-Simulation event mode is not supported)")
        return x

    def _me_set(self, t, x, u):
        fmu = self._fmu
        self._call(f"setTime({t:.9g})", fmu.setTime, t)
        self._call(f"setContinuousStates at t={t:.9g}", fmu.setContinuousStates,
                   np.ascontiguousarray(x, dtype=float).ctypes.data_as(ctypes.POINTER(ctypes.c_double)), self.nx)
        self._set_inputs(u)

    def derivatives(self, t, x, u):
        self._me_set(t, x, u)
        dx = np.zeros(self.nx)
        self._call("get derivatives", self._get_der, dx.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), self.nx)
        return dx

    # -- Model Exchange events (FMI 2.0 and 3.0) -----------------------------------
    @property
    def has_event_action(self):
        """A Model Exchange FMU with event indicators: its events go through event mode."""
        return self.mode == "me" and self.nz > 0

    @property
    def has_time_events(self):
        return self.mode == "me"

    def _event_update(self, t):
        """The newDiscreteStates / updateDiscreteStates loop of event mode; returns whether the
        continuous states changed. Remembers the next time event."""
        update = self._fmu.updateDiscreteStates if self.fmi3 else self._fmu.newDiscreteStates
        changed = False
        for _ in range(100):
            need, terminate, _nominals, values, time_defined, t_next = self._call(
                f"{'updateDiscreteStates' if self.fmi3 else 'newDiscreteStates'} at t={t:.9g}", update)
            changed |= bool(values)
            self._next_event = float(t_next) if time_defined else np.inf
            if terminate:
                raise StopRequest(t, self.name, "terminateSimulation")
            if not need:
                return changed
        raise FMUError(f"FMU block {self.name!r}: the event iteration at t={t:.9g} s does not settle "
                       "(newDiscreteStatesNeeded after 100 updates)")

    def next_event_time(self, t, x):
        """The FMU's next time event (nextEventTime), or inf."""
        return getattr(self, "_next_event", np.inf)

    def event_action(self, t, x, u, fired):
        """Event mode at a state or time event: update the discrete states, read back the
        continuous ones if the FMU changed them, back to continuous-time mode."""
        self._me_set(t, x, u)
        fmu = self._fmu
        self._call(f"enterEventMode at t={t:.9g}", fmu.enterEventMode)
        changed = self._event_update(t)
        self._call("enterContinuousTimeMode", fmu.enterContinuousTimeMode)
        if not changed:
            return None
        x_new = np.zeros(self.nx)
        self._call("getContinuousStates", fmu.getContinuousStates,
                   x_new.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), self.nx)
        return x_new

    def zero_crossings(self, t, x, u):
        if self.mode != "me" or not self.nz:
            return np.zeros(0)
        self._me_set(t, x, u)
        z = np.zeros(self.nz)
        self._call("getEventIndicators", self._fmu.getEventIndicators, z.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), self.nz)
        return z


def _check_members(path):
    """FMUError unless every member of the zip stays inside the folder it is extracted to."""
    try:
        with zipfile.ZipFile(path) as z:
            names = z.namelist()
    except (zipfile.BadZipFile, OSError) as exc:
        raise FMUError(f"FMU {str(path)!r}: cannot read the archive: {exc}") from None
    for n in names:
        parts = n.replace("\\", "/").split("/")
        if n.startswith(("/", "\\")) or ":" in n or "\\" in n or ".." in parts:
            raise FMUError(f"FMU {str(path)!r}: unsafe member {n!r} in the archive (an absolute path, "
                           "'..' or a drive letter); not extracted")


# -- building -------------------------------------------------------------------------

def find_compiler():
    """Path of the system C compiler (cc or gcc), or raise FMUError."""
    for name in (os.environ.get("CC"), "cc", "gcc"):
        if name and shutil.which(name):
            return shutil.which(name)
    raise FMUError("no C compiler found (looked for $CC, cc, gcc): install gcc "
                   "(Debian/Ubuntu: sudo apt-get install gcc)")


def fmi_headers():
    """The folder of the FMI 2.0 and 3.0 C headers that fmpy ships (``fmpy/c-code``).

    Returns
    -------
    pathlib.Path
        The folder with ``fmi2Functions.h``, ``fmi3Functions.h`` and their includes.
    """
    import fmpy

    return Path(fmpy.__file__).parent / "c-code"


def build_fmu(out, model_identifier, sources, model_description, headers, include_dirs=None,
              extra_files=None):
    """Compile ``sources`` into a shared library and pack an FMU at ``out``.

    The binary goes where the model description's FMI version expects it
    (``binaries/linux64`` for 2.0, ``binaries/x86_64-linux`` for 3.0, and the
    matching folder and library suffix on macOS and Windows).

    Parameters
    ----------
    out : path-like
        The ``.fmu`` file to write (atomically).
    model_identifier : str
        The library's name, as in the model description.
    sources : list of path-like
        C files, compiled and packed into ``sources/``.
    model_description : str
        The text of ``modelDescription.xml``.
    headers : dict
        {file name: text} of generated headers, packed into ``sources/``.
    include_dirs : list of path-like, optional
        Folders whose ``*.h`` are packed and compiled against; default: the
        FMI headers of :func:`fmi_headers`.
    extra_files : dict, optional
        {path in the archive: text}, e.g. ``sources/buildDescription.xml``.

    Returns
    -------
    pathlib.Path
        ``out``.
    """
    import fmpy

    cc = find_compiler()
    out = Path(out)
    include_dirs = [fmi_headers()] if include_dirs is None else include_dirs
    with tempfile.TemporaryDirectory(prefix="hybridsim-fmu-") as tmp:
        tmp = Path(tmp)
        src = tmp / "sources"
        fmi3 = 'fmiVersion="3.0"' in model_description
        binary = tmp / "binaries" / (fmpy.platform_tuple if fmi3 else fmpy.platform)
        src.mkdir(parents=True)
        binary.mkdir(parents=True)
        for d in include_dirs:
            for h in Path(d).glob("*.h"):
                shutil.copy(h, src / h.name)
        for name, text in headers.items():
            (src / name).write_text(text)
        for f in sources:
            shutil.copy(f, src / Path(f).name)
        for name, text in (extra_files or {}).items():
            (tmp / name).parent.mkdir(parents=True, exist_ok=True)
            (tmp / name).write_text(text)
        (tmp / "modelDescription.xml").write_text(model_description)
        lib = binary / (model_identifier + {"darwin": ".dylib", "win32": ".dll"}.get(sys.platform, ".so"))
        cmd = [cc, "-std=c99", "-O2", "-fPIC", "-shared", "-Wall", "-I", str(src), "-o", str(lib)]
        cmd += [str(src / Path(f).name) for f in sources] + ["-lm"]
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            raise FMUError(f"compiling {model_identifier} failed:\n{proc.stderr.strip()}")
        with atomic_file(out, "wb") as fh, zipfile.ZipFile(fh, "w", zipfile.ZIP_DEFLATED) as z:
            for f in sorted(tmp.rglob("*")):
                if f.is_file():
                    z.write(f, f.relative_to(tmp).as_posix())
    return out
