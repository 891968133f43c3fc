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


def _size(variable):
    """Number of elements of a variable (an FMI 3.0 array has its dimensions' product)."""
    shape = getattr(variable, "shape", None)
    return int(np.prod(shape)) if shape else 1


def _by_type(variables):
    """``{type: (element positions, value references, number of values)}`` of ``variables`` in order."""
    out, k = {}, 0
    for v in variables:
        n = _size(v)
        pos, vrs, count = out.setdefault(v.type, ([], [], [0]))
        pos.extend(range(k, k + n))
        vrs.append(v.valueReference)
        count[0] += n
        k += n
    return {t: (pos, vrs, count[0]) for t, (pos, vrs, count) in out.items()}


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
    if typ == "Float32" and abs(value) > 3.4028234663852886e38:
        raise FMUError(f"input {name!r} (Float32) got {value!r}: overflows Float32 (largest 3.4028235e+38)")
    if typ in ("Real", "Float64", "Float32"):
        return value
    n = round(value)
    bits = _INT_RANGE.get(typ)
    lo, hi = (-(2 ** (bits - 1)), 2 ** (bits - 1) - 1) if bits else (0, 2 ** _UINT_RANGE[typ] - 1)
    if not lo <= n <= hi:
        raise FMUError(f"input {name!r} ({typ}) got {value!r}: outside {lo} .. {hi}")
    return n


def _start(variable):
    """A variable's start values as a list of floats (one per element), or None."""
    start = variable.start
    if start is None:
        return None
    words = start.split() if isinstance(start, str) else [start]
    out = []
    for w in words:
        if isinstance(w, str) and w.lower() in ("true", "false"):
            out.append(1.0 if w.lower() == "true" else 0.0)
            continue
        try:
            out.append(float(w))
        except (TypeError, ValueError):
            return None
    n = _size(variable)
    return out * n if len(out) == 1 and n > 1 else (out if len(out) == n else None)


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


def _settable(var, value):
    """``value`` for variable ``var``, or ParameterError when it cannot be set or is out of its range."""
    if var.causality == "independent" or var.variability == "constant":
        raise ParameterError("parameters", f"{var.name} is {'the independent variable' if var.causality == 'independent' else 'a constant'}"
                                           " of the FMU: it cannot be set")
    if var.causality not in ("parameter", "input") and var.initial not in ("exact", "approx") and var.start is None:
        raise ParameterError("parameters", f"{var.name} is a {var.causality} variable of the FMU "
                                           f"(initial={var.initial}): it cannot be set")
    for bound, bad in (("min", lambda v, b: v < b), ("max", lambda v, b: v > b)):
        b = getattr(var, bound, None)
        if b is not None and not isinstance(value, (list, tuple)):
            try:
                b = float(b)
            except (TypeError, ValueError):
                continue
            if bad(float(value), b):
                raise ParameterError("parameters", f"{var.name} = {value!r} is outside its range: "
                                                   f"{bound} = {b:g} in the FMU's model description")
    return value


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
        if kind is None and getattr(md, "scheduledExecution", None) is not None and not (
                md.coSimulation or md.modelExchange):
            raise FMUError(f"FMU {str(self.path)!r} is a Scheduled Execution FMU (FMI 3.0): hybridsim runs "
                           "Co-Simulation and Model Exchange FMUs, not Scheduled Execution")
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
            first = 0 if f"{pname}[0]" in byname else 1  # the element names the FMU declares
            if pname not in byname and f"{pname}[{first}]" in byname and isinstance(value, (list, tuple)):
                last = max(int(m.group(2)) for m in map(_INDEXED.match, byname) if m and m.group(1) == pname)
                if len(value) != last - first + 1:
                    raise ParameterError("parameters", f"{pname}: the FMU has {last - first + 1} elements "
                                         f"{pname}[{first}] .. {pname}[{last}], got {len(value)} values")
                for k, v in enumerate(value, start=first):  # b: [1, 2] sets b[1], b[2] (or b[0], b[1])
                    if f"{pname}[{k}]" not in byname:
                        raise FMUError(f"FMU {str(self.path)!r} has no variable {pname}[{k}]")
                    self.parameters[f"{pname}[{k}]"] = _settable(byname[f"{pname}[{k}]"], v)
                continue
            if pname not in byname:
                raise FMUError(f"FMU {str(self.path)!r} has no variable {pname!r}{closest(pname, byname)}")
            var = byname[pname]
            if _size(var) > 1 and (not isinstance(value, (list, tuple)) or len(value) != _size(var)):
                raise ParameterError("parameters", f"{pname} is an array of {_size(var)} elements "
                                                   f"{list(var.shape)}: give {_size(var)} values, got {value!r}")
            self.parameters[pname] = _settable(var, value)
        # text and bytes cannot cross the diagram: such inputs keep their start values, such
        # outputs are not ports (both listed in text_variables)
        self.text_variables = [f"{v.name} ({v.type} {v.causality})" for v in md.modelVariables
                               if v.causality in ("input", "output") and v.type not in PORT_TYPES]
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
        self.in_types = _by_type(self.in_vars)
        # element k of the flat input vector belongs to variable in_elem[k], element in_part[k] of it
        self.in_elem = [j for j, v in enumerate(self.in_vars) for _ in range(_size(v))]
        self.in_part = [e for v in self.in_vars for e in range(_size(v))]
        self.in_first = np.cumsum([0] + [_size(v) for v in self.in_vars])
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
            self.nx = md.numberOfContinuousStates
            self.nz = md.numberOfEventIndicators
            # absolute tolerances from the states' nominal values (1e-12 of each; nominal 1 when none)
            nominals = [_nominal(d.variable.derivative) for d in md.derivatives][:self.nx]
            nominals += [1.0] * (self.nx - len(nominals))
            # an FMU without continuous states gets one of zero derivative (as OpenModelica's dummy
            # state): the event loop then serves its time and state events like any other block's
            self.declare_continuous_state(self.nx or 1, atol=[1e-12 * n for n in nominals] or None)
        self._starts = np.array([x for v in self.in_vars for x in (_start(v) or [np.nan] * _size(v))])
        self._held = None  # the input values the FMU holds (its start values after instantiation)
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
            raise FMUError(f"FMU block {self.name!r}: {what} failed: {exc}"
                           + (f" - the FMU says: {log}" if log else "")) from None

    def _instantiate(self):
        import fmpy

        self.close()
        self._last_discrete = None
        self._held = self._starts.copy()
        self._pending_stop = None
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
        state.update(_fmu=None, _unzipdir=None, _log_key=None, _callbacks=None, _get_der=None)
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
        values = np.concatenate(u)
        skip = set() if only is not None else set(self.in_discrete)
        held, first = self._held, self.in_first
        changed = ~(values == held)
        for typ, (positions, vrs, _n) in self.in_types.items():
            # only what changed: an input left at its start value (unwired) is never written;
            # an array is written whole
            pick = []
            for vr in vrs:
                j = next(i for i, v in enumerate(self.in_vars) if v.valueReference == vr and v.type == typ)
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
        else:
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

    def _me_set(self, t, x, u):
        fmu = self._fmu
        self._call(f"setTime({t:.9g})", fmu.setTime, t)
        if self.nx:
            self._call(f"setContinuousStates at t={t:.9g}", fmu.setContinuousStates,
                       np.ascontiguousarray(x, dtype=float).ctypes.data_as(ctypes.POINTER(ctypes.c_double)), self.nx)
        self._set_inputs(u)

    def derivatives(self, t, x, u):
        self._me_set(t, x, u)
        dx = np.zeros(self.nx)
        if not self.nx:
            return np.zeros(1)  # the dummy state
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
        if not changed or not self.nx:
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
