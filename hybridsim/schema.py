"""A JSON Schema of the diagram format, generated from the block registry (``hybridsim schema``).

An editor with a YAML language server (VS Code's YAML extension, for one)
completes block types and parameters from it and flags mistakes as you type.
Attach it with the first line of a diagram::

    # yaml-language-server: $schema=hybridsim-diagram.schema.json

The schema knows what a schema can: sections, block types and their parameter
names and kinds (number, list, true/false, text), simulation keys, signal roles.
Widths, wiring, units and ranges are checked by ``hybridsim check``.
"""
import inspect

from . import analysis, loader
from .registry import lookup, parameters, types

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
    cls = lookup(type_name)
    required, optional = parameters(cls)
    sig = inspect.signature(cls.__init__).parameters
    props = {"type": {"const": type_name}}
    for name in required + optional:
        default = sig[name].default
        entry = _kind(None if default is inspect.Parameter.empty else default)
        if default is not inspect.Parameter.empty:
            try:
                entry = {**entry, "default": loader._plain(default) if not isinstance(default, tuple)
                         else list(default)}
            except Exception:  # noqa: BLE001 - a default JSON cannot hold is simply not shown
                pass
        props[name] = entry
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
    sim = {k: {} for k in loader.SIM_KEYS}
    for k in ("t_end", "step", "rtol", "max_step", "log_period", "max_state"):
        sim[k] = {"anyOf": [_NUMBER, _REF]}
    sim["atol"] = {"anyOf": [_NUMBER, _NUMBERS, _REF]}
    sim["solver"] = {"enum": loader.SOLVERS}
    for k in ("fused", "compiled", "locate_switches"):
        sim[k] = {"type": "boolean"}
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
            "simulation": {"type": "object", "properties": sim, "additionalProperties": False},
            "log": {"type": "array", "items": ref},
            "signals": {"type": "object", "propertyNames": {"enum": loader.SIGNAL_ROLES},
                        "additionalProperties": ref},
            "metrics": {"type": "object", "propertyNames": {"enum": loader.METRIC_KEYS}},
            "variants": {"type": "object", "additionalProperties": {"type": "array", "minItems": 1}},
            "plot": {"type": "object", "propertyNames": {"enum": loader.PLOT_KEYS},
                     "additionalProperties": {"type": "string"}},
            "analysis": {"type": "object", "propertyNames": {"enum": analysis.KEYS}},
            "inputs": {"type": "object", "additionalProperties": {"anyOf": [ref, {"type": "array", "items": ref}]}},
            "outputs": {"type": "object", "additionalProperties": ref},
        },
        "required": ["blocks"],
        "additionalProperties": False,
    }
