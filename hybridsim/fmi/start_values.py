"""The start values an fmu block sets (its ``parameters``), checked against the FMU's variables."""
import numpy as np

from hybridsim.engine.registry import closest
from hybridsim.errors import ParameterError
from hybridsim.fmi.variables import _INDEXED, _settable, _size, _text_parameter, cannot_set


def start_values(path, byname, parameters):
    """``{variable name: value to set}`` from a block's ``parameters``.

    Parameters
    ----------
    path : Path
        The FMU (for messages).
    byname : dict
        The FMU's model variables by name.
    parameters : dict or None
        ``{name: value}``: a number (or Boolean), a list for an array or for indexed variables
        (``b: [1, 2]`` sets ``b[1]``, ``b[2]``, or ``b[0]``, ``b[1]``), a text for a String or Binary.

    Raises
    ------
    ParameterError
        A name the FMU does not have, a value that is not a finite number, or the wrong number
        of them (exit 2: the diagram's values, checked against the FMU).
    """
    try:
        return _start_values(path, byname, parameters)
    except ParameterError as exc:  # the FMU named: its variables are what the values are checked against
        raise ParameterError("parameters", str(exc).split(" ", 2)[2] + f" (FMU {path})") from None


def _start_values(path, byname, parameters):
    out = {}
    if parameters is not None and not isinstance(parameters, dict):
        raise ParameterError("parameters", f"must map variable names to values, got {parameters!r}")
    for pname, value in (parameters or {}).items():
        var = byname.get(pname)
        if var is not None and var.type in ("String", "Binary"):
            out[pname] = _text_parameter(var, value)
            continue
        for v in (value if isinstance(value, (list, tuple)) else [value]):
            if not isinstance(v, (bool, int, float)) or not np.isfinite(float(v)):
                if var is not None and var.type == "Boolean":
                    raise ParameterError("parameters", f"{pname} is a Boolean variable of the FMU: give true "
                                                       f"or false (or 1, 0), got {value!r}")
                raise ParameterError("parameters", f"{pname}: must be a finite number or a list of "
                                                   f"them, got {value!r}")
        first = 0 if f"{pname}[0]" in byname else 1  # the element names the FMU declares
        if pname not in byname and f"{pname}[{first}]" in byname:
            why = cannot_set(byname[f"{pname}[{first}]"])  # an output array: said first, not its length
            if why:
                raise ParameterError("parameters", why.replace(f"{pname}[{first}] is", f"{pname} is", 1))
            last = max(int(m.group(2)) for m in map(_INDEXED.match, byname) if m and m.group(1) == pname)
            if not isinstance(value, (list, tuple)) or len(value) != last - first + 1:
                raise ParameterError("parameters", f"{pname}: the FMU has {last - first + 1} elements "
                                     f"{pname}[{first}] .. {pname}[{last}]: give {last - first + 1} values "
                                     f"(or set one as {pname}[{first}]), got {value!r}")
            for k, v in enumerate(value, start=first):  # b: [1, 2] sets b[1], b[2] (or b[0], b[1])
                if f"{pname}[{k}]" not in byname:
                    raise ParameterError("parameters", f"names {pname}[{k}], a variable the FMU does not have")
                out[f"{pname}[{k}]"] = _settable(byname[f"{pname}[{k}]"], v)
            continue
        if pname not in byname:
            m = _INDEXED.match(pname)
            if m and m.group(1) in byname:  # Kw[1] of a scalar Kw
                raise ParameterError("parameters", f"{pname}: {m.group(1)} is one value of the FMU, not an "
                                                   f"array: set it as {m.group(1)}")
            settable = [n for n, v in byname.items() if not cannot_set(v)]  # no output suggested
            raise ParameterError("parameters", f"names a variable the FMU does not have: {pname!r}"
                             f"{closest(pname, settable)}")
        var = byname[pname]
        if _size(var) == 1 and isinstance(value, (list, tuple)):
            raise ParameterError("parameters", f"{pname} is one value: give a number, got {value!r}")
        if _size(var) > 1 and (not isinstance(value, (list, tuple)) or len(value) != _size(var)):
            raise ParameterError("parameters", f"{pname} is an array of {_size(var)} elements "
                                               f"{list(var.shape)}: give {_size(var)} values, got {value!r}")
        out[pname] = _settable(var, value)
    return out
