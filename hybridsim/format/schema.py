"""A JSON Schema of the diagram format, generated from the block registry (``hybridsim schema``).

An editor with a YAML language server (VS Code's YAML extension, for one)
completes block types and parameters from it and flags mistakes as you type.
Attach it with the first line of a diagram::

    # yaml-language-server: $schema=hybridsim-diagram.schema.json

The schema knows what a schema can: sections, block types and their parameter
names and kinds (number, list, true/false, text), and every settings section
from its table in :mod:`hybridsim.format.tables` (keys, kinds, ranges, docs).
Widths and wiring are checked by ``hybridsim check``.
"""
import inspect

from hybridsim.engine.registry import types
from hybridsim.format import tables
from hybridsim.format.catalog import block_info

SCHEMA_ID = "https://hybridsim.invalid/diagram.schema.json"
_REF = {"type": "string", "pattern": r"^\$[A-Za-z_][A-Za-z0-9_]*$", "description": "a name in 'params'"}
_NUMBER = {"type": "number"}
_NUMBERS = {"type": "array", "items": {"anyOf": [_NUMBER, _REF, {"type": "array", "items": _NUMBER}]}}


def _kind(default):
    """The JSON Schema of a parameter from its default value (a $reference is always allowed)."""
    if isinstance(default, bool):
        kinds = [{"type": "boolean"}]
    elif isinstance(default, (int, float)):
        kinds = [_NUMBER, _NUMBERS]  # a number, or one per element (width)
    elif isinstance(default, (list, tuple)):
        kinds = [_NUMBER, _NUMBERS]
    elif isinstance(default, str):
        kinds = [{"type": "string"}]
    else:  # None or an object: anything the block accepts
        return {}
    return {"anyOf": kinds + [_REF]}


_NO_JSON = object()


def _json_default(value):
    """``value`` as JSON data (tuples as lists), or _NO_JSON when JSON cannot hold it (an object,
    NaN): such a default is not shown, and the schema stays valid JSON."""
    import json

    def plain(v):
        if isinstance(v, (list, tuple)):
            return [plain(x) for x in v]
        if isinstance(v, dict):
            return {str(k): plain(x) for k, x in v.items()}
        if hasattr(v, "tolist"):  # numpy arrays and scalars
            return plain(v.tolist())
        return v

    try:
        out = plain(value)
        json.dumps(out, allow_nan=False)
        return out
    except (TypeError, ValueError):
        return _NO_JSON


def block_schema(type_name):
    """The schema of one block type's mapping (``{type: ..., parameter: value, ...}``).

    Parameters
    ----------
    type_name : str
        A registered block type.

    Returns
    -------
    dict
    """
    info = block_info(type_name, ports=False)
    cls, required = info.cls, info.required
    props = {"type": {"const": type_name}, **{name: _kind(None) for name in required}}
    for name, default in info.defaults.items():
        shown = _json_default(default)
        props[name] = {**_kind(default), **({"default": shown} if shown is not _NO_JSON else {})}
    if cls.__module__.startswith("hybridsim."):
        for s in tables.BLOCK_SETTINGS.get(type_name, ()):  # a table says more than a default does
            if s.key in props:
                props[s.key] = {"anyOf": [s.kind.schema(), _REF], "description": s.doc}
    doc = (inspect.getdoc(cls) or "").splitlines()
    return {"type": "object", "title": type_name, "description": doc[0] if doc else type_name,
            "properties": props, "required": ["type"] + required, "additionalProperties": False}


def diagram_schema():
    """The JSON Schema (draft 2020-12) of a diagram file, with every registered block type.

    Returns
    -------
    dict
    """
    blocks = [block_schema(t) for t in types()]
    subsystem = {"type": "object", "title": "subsystem",
                 "description": "a diagram file used as one block; other keys set its params or 'block.param'",
                 "properties": {"type": {"const": "subsystem"}, "file": {"type": "string"}},
                 "required": ["type", "file"], "additionalProperties": True}
    partial = {"type": "object", "not": {"required": ["type"]},
               "description": "without 'type': changes parameters of the block of the file this one extends"}
    sim = tables.section_schema(tables.SIMULATION)
    ref = {"type": "string", "pattern": r"^[^\s\[\]]+\.[^.\s\[\]]+(\[\d+\])?$"}
    wire = {"anyOf": [{"type": "string", "pattern": r"^\s*\S+\.\S+\s*->\s*\S+\.\S+\s*$"},
                      {"type": "array", "items": ref, "minItems": 2, "maxItems": 2}]}
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": SCHEMA_ID,
        "title": "hybridsim diagram",
        "type": "object",
        "properties": {
            "extends": {"type": "string", "description": "a diagram file this one starts from"},
            "name": {"type": "string"},
            "description": {"type": "string"},
            "params": {"type": "object"},
            "blocks": {"type": "object", "propertyNames": {"pattern": r"^[^.\[\]\s:=]+$"},
                       "additionalProperties": {"anyOf": blocks + [subsystem, partial, {"type": "null"}]}},
            "wires": {"type": "array", "items": wire},
            "simulation": sim,
            "log": {"type": "array", "items": ref},
            "signals": tables.section_schema(tables.SIGNALS),
            "metrics": tables.section_schema(tables.METRICS),
            "variants": {"type": "object", "additionalProperties": {"type": "array", "minItems": 1}},
            "plot": tables.section_schema(tables.PLOT),
            "analysis": tables.section_schema(tables.ANALYSIS),
            "inputs": {"type": "object", "additionalProperties": {"anyOf": [ref, {"type": "array", "items": ref}]}},
            "outputs": {"type": "object", "additionalProperties": ref},
        },
        "required": ["blocks"],
        "additionalProperties": False,
    }


def sweep_schema():
    """The JSON Schema of a sweep file, from its table."""
    out = tables.section_schema(tables.SWEEP)
    out.update({"$schema": "https://json-schema.org/draft/2020-12/schema", "title": "hybridsim sweep"})
    return out


def write_schema(path):
    """Write the diagram format's JSON Schema (:func:`diagram_schema`) to ``path`` (a ``.json`` file),
    atomically; ``hybridsim schema -o FILE``. Returns the path.

    Attach it to a diagram with its first line ``# yaml-language-server: $schema=PATH``.
    """
    import json

    from hybridsim.files import atomic_file, check_output_file

    out = check_output_file(path, ["json"])
    with atomic_file(out, "w") as fh:
        fh.write(json.dumps(diagram_schema(), indent=1) + "\n")
    return out
