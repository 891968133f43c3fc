"""Kinds of setting values: each checks a value, says what it is, and gives its JSON Schema.

A kind's :meth:`problem` returns None for a good value, else a short phrase
("must be a positive number, got 'x'"). The tables of :mod:`.tables` are
built from these, so validation, the JSON Schema and the docs page agree (a
section within a section, :class:`~.tables.Record`, is a kind made of a table:
it lives with the tables).
"""
import math
import numbers
import re

import numpy as np

#: a '$name' reference to 'params' (allowed wherever a diagram value goes)
REF_SCHEMA = {"type": "string", "pattern": r"^\$[A-Za-z_][A-Za-z0-9_]*$", "description": "a name in 'params'"}
#: 'block.port' or 'block.port[i]' (block may be 'sub.block')
SIGNAL = re.compile(r"^([^\[\]\s]+)\.([^.\[\]\s]+)(?:\[(\d+)\])?$")
PORT = re.compile(r"^([^\[\]\s]+)\.([^.\[\]\s]+)$")


def _is_number(v):
    """A real number, from YAML or Python (numpy's, a Fraction), not a bool."""
    return isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_))


class Kind:
    """Base: any value."""

    text = "any value"

    def problem(self, v):
        return None

    def schema(self):
        return {}

    def _got(self, v):
        shown = repr(v)
        return f"must be {self.text}, got {shown if len(shown) < 80 else shown[:77] + '...'}"


class Number(Kind):
    """A real number in a range; ``integer`` for whole numbers; ``inf`` allows +infinity."""

    def __init__(self, low=None, high=None, low_open=False, integer=False, inf=False, unit="", text=None):
        self.low, self.high, self.low_open, self.integer, self.inf, self.unit = low, high, low_open, integer, inf, unit
        what = "a whole number" if integer else "a number"
        if low == 0 and high is None and not integer:
            what = "a positive, finite number" if low_open else "a finite number >= 0"
        elif low is not None and high is not None:
            what += f" from {low:g} to {high:g}"
        elif low is not None:
            what += f" {'>' if low_open else '>='} {low:g}"
        self.text = text or (what + (f" ({unit})" if unit else "") + (" or .inf" if inf else ""))

    def problem(self, v):
        if not _is_number(v) or (self.integer and not float(v).is_integer()):
            return self._got(v)
        if math.isnan(v) or (math.isinf(v) and not (self.inf and v > 0)):
            return self._got(v)
        if self.low is not None and (v < self.low or (self.low_open and v == self.low)):
            return self._got(v)
        if self.high is not None and v > self.high:
            return self._got(v)
        return None

    def schema(self):
        s = {"type": "integer" if self.integer else "number"}
        if self.low is not None:
            s["exclusiveMinimum" if self.low_open else "minimum"] = self.low
        if self.high is not None:
            s["maximum"] = self.high
        return s


class Bool(Kind):
    text = "true or false"

    def problem(self, v):
        return None if isinstance(v, bool) else self._got(v)

    def schema(self):
        return {"type": "boolean"}


class Text(Kind):
    """A text; ``nonempty`` refuses ''."""

    def __init__(self, nonempty=False):
        self.nonempty = nonempty
        self.text = "a non-empty text" if nonempty else "a text"

    def problem(self, v):
        return None if isinstance(v, str) and (v or not self.nonempty) else self._got(v)

    def schema(self):
        return {"type": "string", **({"minLength": 1} if self.nonempty else {})}


class Choice(Kind):
    """One of ``options`` (any case); ``hints``: {a name users bring from elsewhere: what to give here}."""

    def __init__(self, options, hints=None):
        self.options = list(options)
        self.hints = dict(hints or {})
        self.text = "one of " + ", ".join(self.options)

    def problem(self, v):
        return None if isinstance(v, str) and v.lower() in self.options else self._got(v)

    def schema(self):
        return {"enum": self.options}


class Signal(Kind):
    """'block.port' or 'block.port[i]' (the block and port are checked against the built diagram)."""

    text = "a signal 'block.port' or 'block.port[i]'"
    pattern = SIGNAL

    def problem(self, v):
        return None if isinstance(v, str) and self.pattern.match(v) else self._got(v)

    def schema(self):
        return {"type": "string", "pattern": self.pattern.pattern}


class Port(Signal):
    """'block.port', a whole port (what a wire joins: a subsystem's declared inputs and outputs)."""

    text = "a whole port 'block.port'"
    pattern = PORT


class PathText(Kind):
    """A parameter path: 'name', 'block.param', 'sub.block.param', 'simulation.key'."""

    text = "a parameter path ('name', 'block.param' or 'sub.block.param')"

    def __init__(self, blocks_only=False):
        self.blocks_only = blocks_only  # a block's parameter only ('block.param', 'sub.block.param')
        if blocks_only:
            self.text = "a block parameter path ('block.param' or 'sub.block.param')"

    def problem(self, v):
        from hybridsim.format.paths import ParamPath

        if not isinstance(v, str):
            return self._got(v)
        try:
            ParamPath.parse(v)
        except ValueError as exc:
            return f"{v!r}: {exc}"
        if self.blocks_only and "." not in v:
            return f"{v!r} is not a block's parameter ('block.param')"
        return None

    def schema(self):
        return {"type": "string"}


class ListOf(Kind):
    """A list of ``item`` values; ``exact`` or ``min_len`` items."""

    def __init__(self, item, min_len=1, exact=None, increasing=False):
        self.item, self.min_len, self.exact, self.increasing = item, min_len, exact, increasing
        n = f"{exact}" if exact else (f"at least {min_len}" if min_len else "any number of")
        self.text = f"a list of {n} item(s), each {item.text}" + (", increasing" if increasing else "")

    def problem(self, v):
        if not isinstance(v, list) or len(v) < self.min_len or (self.exact and len(v) != self.exact):
            return self._got(v)
        for k, x in enumerate(v):
            why = self.item.problem(x)
            if why:
                return f"item {k}: {why}"
        if self.increasing and any(a >= b for a, b in zip(v, v[1:])):
            return self._got(v)
        return None

    def schema(self):
        item = self.item.schema()
        s = {"type": "array", "items": {"anyOf": [item, REF_SCHEMA]} if item else {}}  # '$name' items too
        if self.exact:
            s["minItems"] = s["maxItems"] = self.exact
        elif self.min_len:
            s["minItems"] = self.min_len
        return s


class Either(Kind):
    def __init__(self, *kinds):
        self.kinds = kinds
        self.text = " or ".join(k.text for k in kinds)

    def problem(self, v):
        return None if any(k.problem(v) is None for k in self.kinds) else self._got(v)

    def schema(self):
        return {"anyOf": [k.schema() for k in self.kinds]}


class MapOf(Kind):
    """A mapping from names (or parameter paths, ``keys``) to ``value`` values."""

    def __init__(self, value=None, keys=None, what="name", nonempty=False):
        self.value, self.keys, self.nonempty = value or Kind(), keys, nonempty
        self.text = f"a{' non-empty' if nonempty else ''} mapping {{{what}: {self.value.text}}}"

    def problem(self, v):
        if not isinstance(v, dict):
            return self._got(v)
        if self.nonempty and not v:
            return f"must be {self.text}, got an empty one"
        for k, x in v.items():
            if self.keys is not None:
                why = self.keys.problem(k)
                if why:
                    return f"key {k!r}: {why}"
            elif not isinstance(k, str):
                return f"key {k!r} must be a text"
            why = self.value.problem(x)
            if why:
                return f"{k!r}: {why}"
        return None

    def schema(self):
        value = self.value.schema()
        return {"type": "object", "additionalProperties": {"anyOf": [value, REF_SCHEMA]} if value else {},
                **({"minProperties": 1} if self.nonempty else {})}
