"""A parsed diagram file: its sections checked, overrides applied, built into a Diagram."""
import copy
import logging
import os
import re
from collections.abc import Mapping
from pathlib import Path

from hybridsim import limits
from hybridsim.engine.diagram import Diagram
from hybridsim.errors import DiagramError, InputError, LoaderError
from hybridsim.engine.registry import closest
from hybridsim.format import tables
from hybridsim.format.expand import ExpandMixin, count_blocks
from hybridsim.format.extends import read_merged
from hybridsim.format.kinds import ListOf, MapOf, Text
from hybridsim.format.tables import Record
from hybridsim.format.overrides import ORIGIN, OverridesMixin
from hybridsim.format.settings import SettingsMixin
from hybridsim.format.values import _plain, _references
from hybridsim.format.filekinds import refuse_kind
from hybridsim.format.yamlio import _Dict, key_file, key_line

TOP_KEYS = tables.keys(tables.DIAGRAM)
_log = logging.getLogger("hybridsim")
_SAID = set()  # notes already given in this process

_BAD_PARAM = re.compile(r"[.\[\]\s:=$]")  # a parameter name as --set and $name spell it


def _shape(kind):
    """The Python type a top-level section must have (its contents are checked by their own tables)."""
    if isinstance(kind, (MapOf, Record)):
        return dict, "a mapping"
    if isinstance(kind, ListOf):
        return list, "a list"
    if isinstance(kind, Text):
        return (str, int, float), "a text"
    return object, "a value"


class DiagramFile(OverridesMixin, ExpandMixin, SettingsMixin):
    """A parsed diagram file. ``build(overrides)`` makes Diagram + settings.

    Parameters
    ----------
    path : str or Path
    overrides : dict, optional
        ``{"rate": 80, "arm.damping": [10, 100], "simulation.t_end": 1}``:
        a bare name sets ``params``; ``block.param`` a block parameter;
        ``simulation.key`` a setting (see :class:`~.paths.ParamPath`).
        Kept, with those :meth:`apply` adds, as ``overrides``.
    """

    def __init__(self, path, overrides=None):
        if not isinstance(path, (str, os.PathLike)):
            raise TypeError(f"a diagram file is a path (str or pathlib.Path), got {path!r}")
        self.path = Path(path)
        self.files = []  # this file and every file it extends, resolved
        data = read_merged(self.path, files=self.files)
        self.data = data
        refuse_kind(data, "diagram", self.path)  # a sweep or tune file given where a diagram goes
        for key in data:
            if key not in TOP_KEYS:
                raise LoaderError(f"unknown section {key!r}{closest(key, TOP_KEYS)}; sections: "
                                  f"{', '.join(TOP_KEYS)}", key_file(data, key, self.path), key_line(data, key))
        if "blocks" not in data:
            self._fail("missing required section 'blocks'", 1)
        for s in tables.DIAGRAM:
            kind, what = _shape(s.kind)
            if s.key in data and data[s.key] is not None and not isinstance(data[s.key], kind):
                raise LoaderError(f"section {s.key!r} must be {what}", key_file(data, s.key, self.path),
                                  data.lines[s.key])
            if s.key in data and data[s.key] is None and s.key == "blocks":
                raise LoaderError("section 'blocks' must be a mapping", key_file(data, s.key, self.path),
                                  data.lines[s.key])
            if getattr(s.kind, "nonempty", False) and s.key in data and not data[s.key]:  # blocks: {}
                raise LoaderError(f"section {s.key!r} is empty; it holds {s.doc}, at least one", key_file(data, s.key, self.path),
                                  data.lines[s.key])
        self.name = str(data.get("name", self.path.stem))
        self.description = str(data.get("description", ""))
        self.params = _Dict(data.get("params") or {})
        self.params.lines = getattr(data.get("params"), "lines", {}) or {}
        for k in self.params:  # '$name' and --set name reach it: a plain word
            at = key_file(data.get("params"), k, self.path)
            if not isinstance(k, str) or not k or _BAD_PARAM.search(k):
                raise LoaderError(f"parameter name {k!r} may not be empty or contain '.', '[', ']', ':', '=', '$' "
                                  "or spaces ($name and --set name must reach it)", at, self.params.lines.get(k))
            refs = sorted(_references(self.params[k]))
            if refs:
                raise LoaderError(f"parameter {k!r} refers to ${refs[0]}: a parameter's value is a number, list "
                                  "or word, not another parameter (give its value)", at, self.params.lines.get(k))
        self.overrides = {}  # every override applied, as given (a copy of the file is parsed with them)
        self.layers = []  # the same, one mapping per apply: replayed in turn (a later one may set what
        # an earlier one replaced, as an analysis case over the user's --set)
        self.replaced_uses = set()  # parameters whose uses an override replaced (the file as written uses them)
        self.origin = ORIGIN.get()  # what messages call their source ("--set", a sweep's)
        self.apply(overrides or {})

    def _fail(self, message, line=None):
        raise LoaderError(message, self.path, line)

    def _fail_at(self, mapping, key, message):
        """LoaderError at ``key`` of a parsed ``mapping``: its line, in the file that gave it."""
        raise LoaderError(message, key_file(mapping, key, self.path), (getattr(mapping, "lines", None) or {}).get(key))

    def _resolve(self, value, loc, params):
        """Substitute '$name' references; ``loc`` is 'file:line' for errors."""
        if isinstance(value, str) and value.startswith("$"):
            name = value[1:]
            if name not in params:
                raise LoaderError(f"undefined parameter reference {value!r}{closest(name, params)}", loc)
            return copy.deepcopy(_plain(params[name]))
        if isinstance(value, dict):
            locs = getattr(value, "locs", None) or {}
            return {k: self._resolve(v, locs.get(k, loc), params) for k, v in value.items()}
        if isinstance(value, list):
            locs = getattr(value, "locs", None) or [loc] * len(value)
            return [self._resolve(v, ln, params) for v, ln in zip(value, locs)]
        return value

    def unused_params(self):
        """``[(name, "file:line")]``: the names in ``params`` that no value of the file uses (no
        ``$name``, not the analysis's ``rate_param``; a use an override replaced counts): setting one
        (``--set``, a sweep) changes nothing."""
        used = _references({k: v for k, v in self.data.items() if k != "params"}) | self.replaced_uses
        analysis = self.data.get("analysis")
        if isinstance(analysis, dict) and isinstance(analysis.get("rate_param"), str):
            used.add(analysis["rate_param"])
        locs = getattr(self.data.get("params"), "locs", None) or {}
        return [(k, str(locs.get(k, self.path))) for k in self.params if k not in used]

    def subsystem_files(self):
        """Every subsystem file this diagram reads (with the files they extend), resolved."""
        return sorted(count_blocks(self)[1])

    def check_block_budget(self):
        """Refuse a hierarchy of more than ``MAX_BLOCKS`` blocks, counted before expanding anything."""
        n, _ = count_blocks(self)
        if n > limits.get("MAX_BLOCKS"):
            self._fail(f"the diagram expands to more than {limits.get('MAX_BLOCKS')} blocks (its subsystems "
                       "use subsystems in turn); nothing was expanded" + limits.raise_hint("MAX_BLOCKS"),
                       self.data.lines.get("blocks"))
        return n

    def build(self, overrides=None):
        """Return ``(diagram, settings)`` for this file with ``overrides`` applied.

        ``settings`` is a dict with keys simulation, log, signals, metrics, plot,
        params and analysis. Every section is checked first, then the block
        budget, then the blocks are built. Raises :class:`DiagramError`
        listing every problem found in the blocks and wires.
        """
        if overrides is not None and not isinstance(overrides, Mapping):
            raise InputError(f"a variant is a mapping {{parameter: value}}, as variants() lists them; got {overrides!r}")
        params = dict(self.params)
        for k, v in (overrides or {}).items():
            if k not in params:
                self._fail(f"no parameter {k!r} in 'params'{closest(k, params)}")
            params[k] = v
        settings = self._settings(params)
        self.check_block_budget()
        diagram = Diagram(self.name, source=str(self.path))
        problems = diagram.problems
        self.aliases = {}
        self._cut = set()  # inputs whose wire was left out because its other end has a problem
        self._broken = set()  # flat names of the blocks and subsystems that had a problem
        self._bad_ports = set()  # flat names of subsystem ports whose declaration had a problem
        self._expand(diagram, params, "", (self.path.resolve(),), "")
        problems += [self._at_block(p) for p in diagram.check() if p not in problems
                     and not any(p.startswith(f"input {ref} (") for ref in self._cut)]
        if self.data.get("inputs") and any("is not connected" in p for p in problems):
            problems.insert(0, f"{self.path} declares 'inputs': it is a subsystem, used from a diagram as "
                               "'{type: subsystem, file: ...}'; on its own its inputs are not wired")
        if problems:
            raise DiagramError(problems, str(self.path))
        diagram.problems = []
        for bname, pname in diagram.unwired_defaults():
            if diagram.blocks[bname].input_port(pname).optional:
                continue
            if (str(self.path), bname, pname) not in _SAID:  # once per process
                _SAID.add((str(self.path), bname, pname))
                _log.info("%s: input %s.%s is not wired: it takes its default %s", self.path, bname, pname,
                          list(diagram.blocks[bname].input_port(pname).default))
        if self.aliases:  # a subsystem's output named as 'sub.port' is the inner block's output
            settings["log"] = [self._alias(r) for r in settings["log"]]
            settings["signals"] = {k: self._alias(v) for k, v in settings["signals"].items()}
        widths = self._check_refs(diagram, settings)
        self._check_size(diagram, settings, widths)
        return diagram, settings

    def _at_block(self, problem):
        """``problem`` about an input ('input g.u (1 wide) is not connected') at the line of its block in
        this file (a subsystem's block: the subsystem's line), when it names one and has no place."""
        m = re.match(r"input ([^\s(]+)\.\w+ \(", problem)
        loc = self._locs("blocks").get(m.group(1).split(".")[0]) if m else None
        return f"{loc}: {problem}" if loc else problem

    def _alias(self, ref):
        """'ctrl.tau[1]' -> 'ctrl.sum.y[1]' when ctrl.tau is a subsystem's output."""
        base, bracket, rest = str(ref).partition("[")
        return self.aliases.get(base, base) + bracket + rest
