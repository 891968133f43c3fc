"""Parameter checks shared by the block library.

Each helper validates one parameter where the block declares it and raises
:class:`~hybridsim.errors.ParameterError` naming it, so the loader can point
at the parameter's file and line. Numbers must be finite unless ``inf_ok``.
"""
import numpy as np

from hybridsim.errors import ParameterError

#: from here on every float is a whole number (kernels return it as it is: numba's floor, ceil and
#: round pass an int64, which overflows at 2^63)
WHOLE = 2.0 ** 52


def _not_a(what, value, name, word=None):
    """The error for ``value`` where ``what`` was needed; a string (``word``, in a list) that spells
    infinity gets YAML's spelling (``inf`` is a string to YAML, ``.inf`` a number)."""
    word = value if word is None else word
    bare = word.strip().lstrip("+-").lower() if isinstance(word, str) else ""
    hint = ""
    if bare in ("inf", "infinity"):
        hint = f" (YAML writes infinity as {'-' if word.strip().startswith('-') else ''}.inf)"
    elif bare == "nan":
        hint = " (YAML writes not-a-number as .nan)"
    return ParameterError(name, f"must be {what}, got {value!r}{hint}")


def _a_string(value):
    """The first string inside a (nested) list, or None: numpy would read '1e3' or 'inf' as numbers."""
    if isinstance(value, str):
        return value
    if isinstance(value, (list, tuple)):
        for v in value:
            found = _a_string(v)
            if found is not None:
                return found
    return None


def _has_none(value):
    return value is None or isinstance(value, (list, tuple)) and any(_has_none(v) for v in value)


def as_floats(value, name, what):
    """``value`` as a float array, or the error saying it must be ``what``: a bool, a string, or a
    list holding one (numpy would read '1e3' or 'inf' as numbers), or anything not numeric."""
    word = _a_string(value)
    if isinstance(value, bool) or word is not None:
        raise _not_a(what, value, name, word)
    if _has_none(value):  # numpy reads None as nan
        raise ParameterError(name, f"must be {what}, got {value!r} (null: a value left empty in YAML)")
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise _not_a(what, value, name) from None


def _check_values(arr, name, inf_ok, sign, given=None):
    """ParameterError for a NaN, an infinity (unless ``inf_ok``) or a value of the wrong ``sign`` in
    ``arr``; the message shows the value as ``given`` (a number where one was given, not broadcast)."""
    shown = arr.tolist() if given is None else given
    if np.isnan(arr).any() or (not inf_ok and np.isinf(arr).any()):
        raise ParameterError(name, f"must be finite, got {shown!r}")
    if sign == "positive" and not (arr > 0).all():
        raise ParameterError(name, f"must be positive (it divides), got {shown!r}")
    if sign == "nonnegative" and not (arr >= 0).all():
        raise ParameterError(name, f"must not be negative, got {shown!r}")


def scalar(value, name, sign=None, inf_ok=False):
    """A parameter as one finite float; ``sign``: None, 'positive' or 'nonnegative'."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise _not_a("a number", value, name)
    v = float(value)
    _check_values(np.array([v]), name, inf_ok, sign, v)
    return v


def choice(value, name, options):
    """A parameter that names one of ``options`` (strings); returns it."""
    if isinstance(value, str) and value in options:
        return value
    listed = ", ".join(options[:-1]) + " or " + options[-1] if len(options) > 1 else options[0]
    raise ParameterError(name, f"must be {listed}, got {value!r}")


def flag(value, name):
    """A parameter that is true or false (YAML ``true``/``false``, not a string)."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise ParameterError(name, f"must be true or false, got {value!r}")


def count(value, name, minimum=1):
    """A parameter that is a whole number >= ``minimum`` (widths, sizes)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) and not (
            isinstance(value, float) and value.is_integer()):
        raise ParameterError(name, f"must be a whole number, got {value!r}")
    if int(value) < minimum:
        raise ParameterError(name, f"must be at least {minimum}, got {value!r}")
    if int(value) > 10_000:
        raise ParameterError(name, f"must be at most 10000, got {value!r}")
    return int(value)


def vector(value, name, width=None, sign=None, inf_ok=False):
    """A parameter as a 1-D float array.

    A single number broadcasts to ``width``; a list must have exactly
    ``width`` elements (``[0.5]`` where two are needed is an error, not a
    broadcast).
    """
    arr = as_floats(value, name, "a number or a list of numbers")
    if arr.ndim > 1:
        raise ParameterError(name, f"must be a flat list, got shape {arr.shape}")
    given = float(arr) if arr.ndim == 0 else None
    if arr.ndim == 0:
        arr = np.full(width if width is not None else 1, float(arr))
    elif width is not None and arr.size != width:
        raise ParameterError(name, f"must have {width} element{'' if width == 1 else 's'}, got {arr.size}")
    if arr.size == 0:
        raise ParameterError(name, "must not be empty")
    _check_values(arr, name, inf_ok, sign, given)
    return arr


def zero_one(value, name, width=None, meaning="0 or 1"):
    """A selection parameter (a diagonal of 0s and 1s) as a float array (see :func:`vector`);
    ``meaning`` says what 0 and 1 stand for in the error."""
    arr = vector(value, name, width)
    if not set(np.unique(arr)) <= {0.0, 1.0}:
        raise ParameterError(name, f"entries must be {meaning}, got {arr.tolist()}")
    return arr


def floats(value, name, width=None, sign=None, inf_ok=False):
    """A parameter as a tuple of floats (what kernels read; see :func:`vector`)."""
    return tuple(float(v) for v in vector(value, name, width, sign, inf_ok))


def matrix(value, name, n):
    """A gain as an n x n matrix: a scalar, a diagonal list, or a full matrix (finite)."""
    arr = as_floats(value, name, "a number, a list or a matrix")
    if arr.ndim == 0:
        _check_values(arr.reshape(1), name, False, None)
        return np.eye(n) * float(arr)
    if arr.ndim == 1:
        return np.diag(vector(arr, name, n))
    if arr.shape != (n, n):
        raise ParameterError(name, f"must be {n}x{n}, got shape {arr.shape}")
    _check_values(arr.ravel(), name, False, None)
    return arr


def finite_matrix(value, name):
    """A 2-D float array of finite numbers (state-space matrices)."""
    arr = np.atleast_2d(as_floats(value, name, "a matrix of numbers"))
    if arr.ndim != 2:
        raise ParameterError(name, f"must be a matrix, got shape {arr.shape}")
    _check_values(arr.ravel(), name, False, None)
    return arr



def pid_gains(Kp, Ki, Kd, lower, upper, Kb, n):
    """``(Kp, Ki, Kd, lower, upper, Kb)`` of a PID with ``n`` channels, checked; the back-calculation
    gain ``Kb`` defaults to Ki / Kp (1 where Kp is 0)."""
    Kp_, Ki_, Kd_ = vector(Kp, "Kp", n), vector(Ki, "Ki", n), vector(Kd, "Kd", n)
    lo, hi = vector(lower, "lower", n, inf_ok=True), vector(upper, "upper", n, inf_ok=True)
    if np.any(lo > hi):
        raise ParameterError("lower", f"must not exceed upper ({lower!r} > {upper!r})")
    if Kb is None:
        Kb_ = np.where(Kp_ != 0.0, Ki_ / np.where(Kp_ != 0.0, Kp_, 1.0), 1.0)
    else:
        Kb_ = vector(Kb, "Kb", n, "nonnegative")
    return Kp_, Ki_, Kd_, lo, hi, Kb_


def one_rate(rate, period):
    """ParameterError unless exactly one of ``rate`` (Hz) and ``period`` (s) is given."""
    if rate is None and period is None:
        raise ParameterError("rate", "or period: give one of rate (Hz) or period (s); neither has a value "
                                     "(null, a value left empty, is none)")
    if rate is not None and period is not None:
        raise ParameterError("rate", "or period: give exactly one of rate (Hz) or period (s), not both")
