"""FMU variables as hybridsim sees them: ports, element names, types, start values, checks.

Used by :class:`hybridsim.fmi.fmu_block.FMUBlock`; plain functions of fmpy's model
description objects.
"""
import re
import zipfile

import numpy as np

from hybridsim.errors import FMUError, ParameterError

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


def cannot_set(var):
    """Why variable ``var`` of an FMU cannot be given a start value, or None."""
    if var.causality == "independent" or var.variability == "constant":
        what = "the independent variable" if var.causality == "independent" else "a constant"
        return f"{var.name} is {what} of the FMU: it cannot be set"
    if var.causality not in ("parameter", "input") and var.initial not in ("exact", "approx") and var.start is None:
        article = "an" if var.causality[:1] in "aeiou" else "a"
        return f"{var.name} is {article} {var.causality} variable of the FMU (initial={var.initial}): it cannot be set"
    return None


def _settable(var, value):
    """``value`` for variable ``var``, or ParameterError when it cannot be set or is out of its range."""
    why = cannot_set(var)
    if why:
        raise ParameterError("parameters", why)
    whole = var.type in _INT_RANGE or var.type in _UINT_RANGE
    for v in (value if isinstance(value, (list, tuple)) else [value]):
        if var.type != "Boolean" and isinstance(v, bool):  # 'yes' reads as true in YAML: set as 1.0, silently
            raise ParameterError("parameters", f"{var.name} is a {var.type} variable of the FMU: give a number, "
                                               f"got {v!r} (YAML reads yes/no/on/off/true/false as true or false)")
        if var.type == "Boolean" and v not in (0, 1):  # 2 was set as true, silently
            raise ParameterError("parameters", f"{var.name} is a Boolean variable of the FMU: give true or false "
                                               f"(or 1, 0), got {v!r}")
        if whole and not isinstance(v, bool) and not float(v).is_integer():  # rounded, it was silently another
            raise ParameterError("parameters", f"{var.name} is an {var.type} variable of the FMU: give a whole "
                                               f"number, got {v!r}")
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


def _nominal(variable):
    """A state variable's nominal value (1 when it gives none or a bad one)."""
    try:
        n = abs(float(getattr(variable, "nominal", None) or 1.0))
    except (TypeError, ValueError):
        return 1.0
    return n if np.isfinite(n) and n > 0 else 1.0


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
