"""Small helpers on diagram values: '$name' references, numbers, subsystem specs."""
import logging
import math
import os
from pathlib import Path

from hybridsim.format.paths import OverrideLoc
from hybridsim.format.yamlio import plain

_noted = set()  # the notes given in this process: a file is read more than once per command


def note(message, *args):
    """A warning about a file (``message % args``) on the "hybridsim" logger, once per process."""
    text = message % args
    if text not in _noted:
        _noted.add(text)
        logging.getLogger("hybridsim").warning(text)

def subsystem_path(spec, fallback):
    """The file a subsystem spec names, relative to the file that wrote its ``file:`` line.

    A diagram that ``extends`` a base from another folder keeps the base's
    subsystem paths working; a ``file`` given by ``--set`` is relative to
    ``fallback`` (the working folder).
    """
    loc = (getattr(spec, "locs", None) or {}).get("file", "")
    base = Path(loc.rsplit(":", 1)[0]).parent if loc and not isinstance(loc, OverrideLoc) else Path(fallback)
    return Path(os.path.normpath(base / spec["file"]))


def _is_subsystem(spec):
    """Whether a block spec is ``type: subsystem`` (a diagram file used as a block)."""
    return isinstance(spec, dict) and spec.get("type") == "subsystem"


def _references(value):
    """The '$name' references anywhere in ``value``."""
    if isinstance(value, str):
        return {value[1:]} if value.startswith("$") else set()
    if isinstance(value, dict):
        return set().union(*(_references(v) for v in value.values())) if value else set()
    if isinstance(value, list):
        return set().union(*(_references(v) for v in value)) if value else set()
    return set()


def _number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _positive_number(v):
    return _number(v) and v > 0


def _has_nan(v):
    if isinstance(v, float):
        return math.isnan(v)
    if isinstance(v, (list, tuple)):
        return any(_has_nan(x) for x in v)
    if isinstance(v, dict):
        return any(_has_nan(x) for x in v.values())
    return False


_plain = plain
