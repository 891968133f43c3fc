"""YAML diagrams: plain data in, a checked Diagram out, errors with file:line.

The format (see docs/diagram-format.md)::

    name: fig9
    params:            # named values; '$name' anywhere below refers to one
      rate: 60
    blocks:
      pid: {type: position_pid, rate: $rate, Kp: [460, 1650]}
      ...
    wires:
      - fk.X -> dx.u2            # or [fk.X, dx.u2]
      ctrl: {type: subsystem, file: sub.yaml, Kp: 2}   # a diagram file as one block
    simulation: {t_end: 4.0, solver: rk4, step: 1.0e-4, log_period: 0.0005}
    log: [ft.CF, fk.X]
    signals: {force: ft.CF[0], force_desired: fd.y[0]}   # roles for plots/metrics
    metrics: {step_time: 1.0}
    variants: {rate: [60, 80, 120]}                       # a grid of runs

Nothing in a file is evaluated; '$name' substitution is the only indirection.
"""
import copy
import logging
import math
import os
import re
import itertools
import stat
from pathlib import Path

import yaml

from .diagram import Diagram
from .errors import DiagramError, LoaderError, ParameterError, RateError
from .registry import closest, lookup, parameters, types
from . import limits

TOP_KEYS = ["extends", "name", "description", "params", "blocks", "wires", "simulation", "log",
            "signals", "metrics", "variants", "plot", "analysis", "inputs", "outputs"]
_BAD_NAME = re.compile(r"[.\[\]\s:=]")  # a '.' separates a subsystem's name from its blocks' names
SIM_KEYS = ["t_end", "solver", "step", "rtol", "atol", "max_step", "log_period", "max_state", "fused", "compiled",
            "locate_switches"]
SOLVERS = ["rk4", "heun", "radau", "bdf", "lsoda", "rk45", "rk23", "dop853"]
METRIC_KEYS = ["step_time", "ss_window", "error_window", "filter_cutoff"]
PLOT_KEYS = ["title", "position_label", "force_label", "surface_label"]  # the figure's title and axis names
# the analysis section (hybridsim.analysis and hybridsim.report read it)
ANALYSIS_KEYS = ["set", "points", "rate_param", "rates", "gains", "scales", "cases", "hand_mode_hz", "at",
                 "compare", "step"]
SIGNAL_ROLES = ["force", "force_desired", "position", "position_desired", "contact",
                "surface", "hand", "oscillation"]


class _Dict(dict):
    """A mapping that remembers its file and the line of each key (1-based)."""

    line = None
    lines = None
    file = None


class _List(list):
    line = None
    lines = None


class NumberLoader(yaml.SafeLoader):
    """Safe YAML that reads 9.0e5 and 1e-4 as numbers (YAML 1.1 makes them strings)."""


class _Loader(NumberLoader):
    source_path = None


NumberLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"""^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?(?:[eE][-+]?[0-9]+)$"""),
    list("-+0123456789"),
)


def _construct_mapping(loader, node):
    own = {}
    for knode, _ in node.value:  # keys written in this mapping (merged '<<' keys may repeat)
        if knode.tag == "tag:yaml.org,2002:merge":
            continue
        key = loader.construct_object(knode, deep=True)
        try:
            hash(key)
        except TypeError:
            raise LoaderError("a mapping key must be a plain value", line=knode.start_mark.line + 1) from None
        if key in own:
            raise LoaderError(f"duplicate key {key!r} (first given on line {own[key]}); "
                              "each key may appear once in a mapping", line=knode.start_mark.line + 1)
        own[key] = knode.start_mark.line + 1
    loader.flatten_mapping(node)
    d = _Dict()
    d.line, d.lines, d.file = node.start_mark.line + 1, {}, loader.source_path
    d.locs = {}
    for knode, vnode in node.value:
        key = loader.construct_object(knode, deep=True)
        try:
            hash(key)
        except TypeError:
            raise LoaderError("a mapping key must be a plain value", line=knode.start_mark.line + 1) from None
        d[key] = loader.construct_object(vnode, deep=True)
        d.lines[key] = vnode.start_mark.line + 1
        d.locs[key] = f"{loader.source_path}:{d.lines[key]}"
    return d


def _construct_sequence(loader, node):
    lst = _List(loader.construct_object(n, deep=True) for n in node.value)
    lst.line = node.start_mark.line + 1
    lst.lines = [n.start_mark.line + 1 for n in node.value]
    lst.locs = [f"{loader.source_path}:{ln}" for ln in lst.lines]
    return lst


_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)
_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_SEQUENCE_TAG, _construct_sequence)


def _compose_node(self, parent, index):
    """The composer's recursion, with limits on depth and on the number of values (refused, not a crash)."""
    self.depth = getattr(self, "depth", 0) + 1
    self.nodes = getattr(self, "nodes", 0) + 1
    try:
        if self.nodes > limits.MAX_YAML_VALUES:
            mark = self.peek_event().start_mark
            raise LoaderError(f"more than {limits.MAX_YAML_VALUES} values in one file",
                              line=mark.line + 1)
        if self.depth > limits.MAX_YAML_DEPTH:
            mark = self.peek_event().start_mark
            raise LoaderError(f"values nested deeper than {limits.MAX_YAML_DEPTH} levels",
                              line=mark.line + 1)
        return yaml.composer.Composer.compose_node(self, parent, index)
    finally:
        self.depth -= 1


_Loader.compose_node = _compose_node

_BUSY = object()


def _expanded_size(node, memo):
    """How many values ``node`` stands for once every alias is expanded (cycles refused)."""
    key = id(node)
    got = memo.get(key)
    if got is _BUSY:
        raise LoaderError("a YAML alias refers to the value that contains it (a recursive structure)",
                          line=node.start_mark.line + 1)
    if got is not None:
        return got
    memo[key] = _BUSY
    if isinstance(node, yaml.SequenceNode):
        n = 1 + sum(_expanded_size(c, memo) for c in node.value)
    elif isinstance(node, yaml.MappingNode):
        n = 1 + sum(_expanded_size(k, memo) + _expanded_size(v, memo) for k, v in node.value)
    else:
        n = 1
    memo[key] = n
    return n


def read_text(path, budget=limits.MAX_FILE_BYTES):
    """The text of a diagram or sweep file: a regular UTF-8 file of at most ``budget`` bytes."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise LoaderError("no such file", path) from None
    except OSError as exc:
        raise LoaderError(f"cannot read: {exc.strerror}", path) from None
    if not stat.S_ISREG(st.st_mode):
        what = "a folder" if stat.S_ISDIR(st.st_mode) else "not a regular file (a device, FIFO or socket)"
        raise LoaderError(f"is {what}; a diagram is a YAML file", path)
    if st.st_size > budget:
        raise LoaderError(f"file is {st.st_size / 2**20:.1f} MiB; a diagram and the files it "
                          f"extends may hold {limits.MAX_FILE_BYTES / 2**20:.0f} MiB together", path)
    try:
        with open(path, "rb") as fh:
            raw = fh.read(budget + 1)
    except OSError as exc:
        raise LoaderError(f"cannot read: {exc.strerror}", path) from None
    if len(raw) > budget:
        raise LoaderError(f"file grew past {budget} bytes while read", path)
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise LoaderError("not UTF-8 text (a binary file?)", path, line) from None


def parse_file(path, budget=limits.MAX_FILE_BYTES, what="a diagram file must be a mapping with a 'blocks' section"):
    """The YAML mapping in ``path`` with file/line tracking, or LoaderError.

    Refused before anything is built: files that are not regular or too large,
    characters YAML forbids (NUL), nesting deeper than
    ``limits.MAX_YAML_DEPTH``, aliases that expand to more than
    ``limits.MAX_YAML_VALUES`` values, duplicate keys.
    """
    text = read_text(path, budget)
    loader = None
    try:
        loader = _Loader(text)
        loader.source_path = str(path)
        node = loader.get_single_node()
        if node is None:
            raise LoaderError(what, path, 1)
        size = _expanded_size(node, {})
        if size > limits.MAX_YAML_VALUES:
            raise LoaderError(f"the YAML expands to {size} values (its aliases repeat values); "
                              f"at most {limits.MAX_YAML_VALUES} are read", path)
        data = loader.construct_document(node)
    except LoaderError as exc:
        raise LoaderError(str(exc).split(": ", 1)[-1], path, exc.line) from None
    except yaml.reader.ReaderError as exc:
        line = text.count("\n", 0, max(exc.position, 0)) + 1
        raise LoaderError(f"character {exc.character!r} is not allowed in YAML text "
                          "(a NUL byte or a binary file?)", path, line) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        problem = getattr(exc, "problem", None) or str(exc)
        raise LoaderError(f"YAML syntax error: {problem}", path,
                          mark.line + 1 if mark else None) from None
    except RecursionError:
        raise LoaderError("values nested too deeply", path) from None
    finally:
        if loader is not None:
            loader.dispose()
    if not isinstance(data, dict):
        raise LoaderError(what, path, 1)
    return data, len(text.encode("utf-8"))


def _read(path, chain=(), budget=None, files=None):
    """Parse ``path`` and merge it over the file it ``extends`` (if any).

    Merging: ``params``, ``simulation``, ``signals``, ``metrics``, ``plot``,
    ``variants`` and ``analysis`` are updated key by key; a block given again
    with a ``type`` replaces the base block, without one it updates the base
    block's parameters, and ``name: null`` removes it with its wires;
    ``wires`` and ``log`` are appended; other keys replace.
    """
    budget = limits.MAX_FILE_BYTES if budget is None else budget
    data, used = parse_file(path, budget)
    if files is not None:
        files.append(Path(path).resolve())
    base_name = data.get("extends")
    if base_name is None:
        return data
    line = data.lines["extends"]
    if not isinstance(base_name, str) or not base_name:
        raise LoaderError(f"'extends' must be a file name, got {base_name!r}", path, line)
    if Path(base_name).suffix.lower() not in limits.YAML_SUFFIXES:
        raise LoaderError(f"'extends': {base_name!r} is not a YAML file (it must end in "
                          f"{' or '.join(limits.YAML_SUFFIXES)})", path, line)
    base_path = (path.parent / base_name).resolve()
    if base_path in chain or base_path == path.resolve():
        raise LoaderError(f"'extends' forms a cycle through {base_name!r}", path, line)
    if not base_path.exists():
        raise LoaderError(f"'extends': no such file {base_name!r}", path, line)
    if len(chain) >= limits.MAX_EXTENDS:
        raise LoaderError(f"'extends' chains more than {limits.MAX_EXTENDS} files", path, line)
    base = _read(base_path, chain + (path.resolve(),), budget - used, files)
    merged = base
    for key, val in data.items():
        if key == "extends":
            continue
        cur = merged.get(key)
        if key == "blocks" and isinstance(cur, dict) and isinstance(val, dict):
            for bname, spec in val.items():
                if spec is None and bname in cur:  # 'name: null' removes a base block and its wires
                    del cur[bname]
                    _drop_wires(merged, bname)
                    continue
                if isinstance(spec, dict) and "type" not in spec and isinstance(cur.get(bname), dict):
                    cur[bname].update(spec)
                    cur[bname].lines.update(spec.lines)
                    cur[bname].locs.update(spec.locs)
                else:
                    cur[bname] = spec
                    cur.lines[bname] = val.lines[bname]
                    cur.locs[bname] = val.locs[bname]
        elif key in ("params", "simulation", "signals", "metrics", "plot", "variants", "analysis") \
                and isinstance(cur, dict) and isinstance(val, dict):
            cur.update(val)
            cur.lines.update(val.lines)
            cur.locs.update(val.locs)
        elif key in ("wires", "log") and isinstance(cur, list) and isinstance(val, list):
            cur.extend(val)
            cur.lines.extend(val.lines)
            cur.locs.extend(val.locs)
        else:
            merged[key] = val
        merged.lines[key] = data.lines[key]
    return merged


def _drop_wires(data, bname):
    """Remove the wires of ``data`` that touch block ``bname``."""
    wires = data.get("wires")
    if not isinstance(wires, list):
        return
    keep = [k for k, w in enumerate(wires)
            if not any(str(e).strip().split(".")[0] == bname
                       for e in (w.split("->") if isinstance(w, str) else w))]
    new = _List(wires[k] for k in keep)
    new.line, new.lines, new.locs = wires.line, [wires.lines[k] for k in keep], [wires.locs[k] for k in keep]
    data["wires"] = new
    log = data.get("log")
    if isinstance(log, list):
        keep = [k for k, r in enumerate(log) if str(r).split(".")[0] != bname]
        new = _List(log[k] for k in keep)
        new.line, new.lines, new.locs = log.line, [log.lines[k] for k in keep], [log.locs[k] for k in keep]
        data["log"] = new


_REF = re.compile(r"^([^\[\]\s]+)\.([^.\[\]\s]+)(?:\[(\d+)\])?$")  # block (may be sub.block).port[i]
_log = logging.getLogger("hybridsim")
_SAID = set()  # notes already given in this process


def subsystem_path(spec, fallback):
    """The file a subsystem spec names, relative to the file that wrote its ``file:`` line.

    A diagram that ``extends`` a base from another folder keeps the base's
    subsystem paths working; a ``file`` given by ``--set`` is relative to
    ``fallback`` (the working folder).
    """
    loc = (getattr(spec, "locs", None) or {}).get("file", "")
    base = Path(loc.rsplit(":", 1)[0]).parent if loc and not loc.startswith("--set") else Path(fallback)
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


def _plain(v):
    """Strip the line-tracking types (for deep copies and user-facing values)."""
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_plain(x) for x in v]
    return v


class DiagramFile:
    """A parsed diagram file. ``build(overrides)`` makes Diagram + settings.

    Parameters
    ----------
    path : str or Path
    overrides : dict, optional
        ``{"rate": 80, "arm.damping": [10, 100], "simulation.t_end": 1}``:
        a bare name sets ``params``; ``block.param`` a block parameter;
        ``simulation.key`` a setting.
    """

    def __init__(self, path, overrides=None):
        self.path = Path(path)
        self.files = []  # this file and every file it extends, resolved
        data = _read(self.path, files=self.files)
        self.data = data
        for key in data:
            if key not in TOP_KEYS:
                self._fail(f"unknown section {key!r}{closest(key, TOP_KEYS)}; "
                           f"sections: {', '.join(TOP_KEYS)}", data.lines[key])
        if "blocks" not in data:
            self._fail("missing required section 'blocks'", 1)
        for key, kind in (("params", dict), ("blocks", dict), ("simulation", dict),
                          ("signals", dict), ("metrics", dict), ("variants", dict),
                          ("wires", list), ("log", list), ("plot", dict), ("analysis", dict),
                          ("inputs", dict), ("outputs", dict)):
            if key in data and not isinstance(data[key], kind):
                self._fail(f"section {key!r} must be a {'mapping' if kind is dict else 'list'}",
                           data.lines[key])
        self.name = str(data.get("name", self.path.stem))
        self.description = str(data.get("description", ""))
        self.params = _Dict(data.get("params") or {})
        self.params.lines = getattr(data.get("params"), "lines", {}) or {}
        self.apply(overrides or {})

    def _fail(self, message, line=None):
        raise LoaderError(message, self.path, line)

    # -- overrides ---------------------------------------------------------
    def apply(self, overrides):
        """Apply ``{path: value}`` overrides in place (see class docstring).

        Setting a parameter that ``variants`` sweeps fixes it: that sweep ends.
        """
        for key, value in overrides.items():
            parts = str(key).split(".")
            if len(parts) == 1 or parts[0] == "params":
                name = parts[-1]
                if name not in self.params:
                    self._fail(f"--set {key}: no parameter {name!r} in 'params'"
                               f"{closest(name, self.params)}")
                self.params[name] = value
                if isinstance(self.data.get("variants"), dict):
                    self.data["variants"].pop(name, None)  # a fixed value ends that sweep
            elif parts[0] == "simulation" and len(parts) == 2:
                if parts[1] not in SIM_KEYS:
                    self._fail(f"--set {key}: unknown simulation setting{closest(parts[1], SIM_KEYS)}")
                if "simulation" not in self.data:
                    self.data["simulation"] = _Dict()
                    self.data["simulation"].lines = {}
                self.data["simulation"][parts[1]] = value
            else:
                bname = parts[1] if parts[0] == "blocks" else parts[0]
                pname = parts[-1]
                blocks = self.data["blocks"]
                rest = parts[2:] if parts[0] == "blocks" else parts[1:]
                if _is_subsystem(blocks.get(bname)) and len(rest) >= 1:
                    pname = ".".join(rest)  # ctrl.pid.Kp: the subsystem passes pid.Kp on
                    blocks[bname][pname] = value
                    blocks[bname].lines[pname] = None
                    blocks[bname].locs[pname] = f"--set {key}"
                    continue
                if bname not in blocks or len(parts) > (3 if parts[0] == "blocks" else 2):
                    self._fail(f"--set {key}: no block {bname!r}{closest(bname, blocks)}")
                if not isinstance(blocks[bname], dict) or not pname:
                    self._fail(f"--set {key}: block {bname!r} has no parameters to set")
                blocks[bname][pname] = value
                blocks[bname].lines[pname] = None
                blocks[bname].locs[pname] = f"--set {key}"

    def variants(self):
        """List of (label, overrides) for the grid in ``variants`` ([('', {})] if none)."""
        spec = self.data.get("variants") or {}
        if not spec:
            return [("", {})]
        names = list(spec)
        for n in names:
            if n not in self.params:
                self._fail(f"variant {n!r} is not a parameter in 'params'{closest(n, self.params)}",
                           spec.lines[n])
            if not isinstance(spec[n], list) or not spec[n]:
                self._fail(f"variant {n!r} must be a non-empty list of values", spec.lines[n])
        count = math.prod(len(spec[n]) for n in names)
        if count > limits.MAX_VARIANTS:
            self._fail(f"'variants' makes {count} runs; at most {limits.MAX_VARIANTS} (use a sweep file "
                       "for more points)", spec.line)
        out = []
        for combo in itertools.product(*(spec[n] for n in names)):
            label = ", ".join(f"{n}={v}" for n, v in zip(names, combo))
            out.append((label, dict(zip(names, combo))))
        return out

    # -- substitution ---------------------------------------------------------
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

    def runtime_params(self, overrides, variant=None):
        """``overrides`` (as :meth:`apply` takes them) as run-time block parameters.

        Returns ``{"block.param": value}`` for :meth:`Simulator.run
        <hybridsim.simulator.Simulator.run>`: a name in ``params`` becomes every
        block parameter that refers to it (resolved again), ``block.param``
        stays itself. Raises :class:`LoaderError` when an override cannot be
        given at run time: a simulation setting, a swept variant, or a name
        that the simulation, log, signals or metrics sections use.
        """
        params = {**self.params, **(variant or {})}
        named = {}
        out = {}
        for key, value in overrides.items():
            parts = str(key).split(".")
            if parts[0] == "params":
                parts = parts[1:]
            if len(parts) == 1:
                if parts[0] not in self.params:
                    self._fail(f"no parameter {parts[0]!r} in 'params'{closest(parts[0], self.params)}")
                if parts[0] in (self.data.get("variants") or {}):
                    self._fail(f"{parts[0]!r} is swept by 'variants': not a run-time parameter")
                named[parts[0]] = value
            elif parts[0] == "simulation":
                self._fail(f"{key!r} is a simulation setting: not a run-time parameter")
            else:
                if parts[0] == "blocks":
                    parts = parts[1:]
                bname = parts[0]
                if bname not in self.data["blocks"] or len(parts) < 2 or (
                        len(parts) > 2 and not _is_subsystem(self.data["blocks"][bname])):
                    self._fail(f"{key!r}: no block {bname!r}{closest(bname, self.data['blocks'])}")
                out[".".join(parts)] = value  # ctrl.pid.Kp: the flattened block ctrl.pid
        if not named:
            return out
        for section in ("simulation", "log", "signals", "metrics"):
            used = _references(self.data.get(section)) & set(named)
            if used:
                self._fail(f"{sorted(used)} used by '{section}': not a run-time parameter")
        params.update(named)
        for bname, spec in self.data["blocks"].items():
            if not isinstance(spec, dict):
                continue
            if _is_subsystem(spec) and _references(spec) & set(named):
                self._fail(f"{sorted(_references(spec) & set(named))} used by subsystem {bname!r}: not a "
                           "run-time parameter (give it with --set, which rebuilds the diagram)")
            for pname, raw in spec.items():
                if pname != "type" and _references(raw) & set(named) and f"{bname}.{pname}" not in out:
                    out[f"{bname}.{pname}"] = self._resolve(raw, spec.locs[pname], params)
        return out

    # -- building ---------------------------------------------------------------
    def build(self, overrides=None):
        """Return ``(diagram, settings)`` for this file with ``overrides`` applied.

        ``settings`` is a dict with keys simulation, log, signals, metrics, plot.
        Raises :class:`DiagramError` listing every problem found.
        """
        params = dict(self.params)
        for k, v in (overrides or {}).items():
            if k not in params:
                self._fail(f"no parameter {k!r} in 'params'{closest(k, params)}")
            params[k] = v
        diagram = Diagram(self.name, source=str(self.path))
        problems = diagram.problems
        self.aliases = {}
        self._cut = set()  # inputs whose wire was left out because its other end has a problem
        self._broken = set()  # flat names of the blocks and subsystems that had a problem
        self._expand(diagram, params, "", (self.path.resolve(),), "")
        problems += [p for p in diagram.check() if p not in problems
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
        settings = self._settings(params)
        if self.aliases:  # a subsystem's output named as 'sub.port' is the inner block's output
            settings["log"] = [self._alias(r) for r in settings["log"]]
            settings["signals"] = {k: self._alias(v) for k, v in settings["signals"].items()}
        widths = self._check_refs(diagram, settings)
        self._check_size(diagram, settings, widths)
        return diagram, settings

    def _alias(self, ref):
        """'ctrl.tau[1]' -> 'ctrl.sum.y[1]' when ctrl.tau is a subsystem's output."""
        base, bracket, rest = str(ref).partition("[")
        return self.aliases.get(base, base) + bracket + rest

    # -- blocks, wires and subsystems ---------------------------------------------
    def _expand(self, diagram, params, prefix, chain, context):
        """Add this file's blocks and wires to ``diagram``, names prefixed with ``prefix``.

        A block of ``type: subsystem`` adds its file's blocks as ``name.inner``,
        recursively. Returns ``(inputs, outputs)``: the file's declared ports as
        ``{name: [flat 'block.port', ...]}`` and ``{name: flat 'block.port'}``.
        Problems go to ``diagram.problems``, each led by ``context`` (the path
        through the hierarchy, with file:line at each level).
        """
        problems = diagram.problems
        blocks = self.data["blocks"]
        subs = {}
        for bname, spec in blocks.items():
            here = blocks.locs[bname]
            if not isinstance(bname, str) or _BAD_NAME.search(bname):
                problems.append(f"{context}{here}: block name {bname!r} may not contain '.', '[', ']', ':', "
                                "'=' or spaces (a '.' separates a subsystem from its blocks)")
                continue
            if _is_subsystem(spec):
                got = self._subsystem(diagram, bname, spec, params, prefix, chain, context)
                if got is not None:
                    subs[bname] = got
                else:
                    self._broken.add(prefix + bname)
                continue
            self._make_block(diagram, bname, spec, params, prefix, context)
            if prefix + bname not in diagram.blocks:
                self._broken.add(prefix + bname)
        wires = self.data.get("wires") or []
        for k, w in enumerate(wires):
            line = wires.locs[k]
            if isinstance(w, str) and "->" in w:
                src, dst = (s.strip() for s in w.split("->", 1))
            elif isinstance(w, list) and len(w) == 2 and all(isinstance(s, str) for s in w):
                src, dst = w
            else:
                problems.append(f"{context}{line}: a wire is 'a.out -> b.in' or [a.out, b.in], got {w!r}")
                continue
            srcs = self._endpoint(src, subs, prefix, 1, line, context, problems)
            dsts = self._endpoint(dst, subs, prefix, 0, line, context, problems)
            if srcs is None or dsts is None:
                continue
            if any(self._dead(r) for r in srcs + dsts):
                self._cut.update(dsts)  # a block at one end already has a problem: not this input's
                continue
            for d in dsts:
                diagram.connect(srcs[0], d, f"{context}{line}" if context else line)
        ins, outs = {}, {}
        for section, target in (("inputs", ins), ("outputs", outs)):
            spec = self.data.get(section) or {}
            for name, refs in spec.items():
                where = f"{context}{spec.locs[name]}"
                if not isinstance(name, str) or _BAD_NAME.search(name):
                    problems.append(f"{where}: {section[:-1]} name {name!r} may not contain '.', '[', ']' or spaces")
                    continue
                refs = refs if isinstance(refs, list) and section == "inputs" else [refs]
                flat = []
                for ref in refs:
                    got = self._endpoint(ref, subs, prefix, section == "outputs", spec.locs[name], context, problems)
                    if got is not None:
                        flat += got
                if flat:
                    target[name] = flat if section == "inputs" else flat[0]
        for name, ref in outs.items():
            self.aliases[prefix + name] = ref
        return ins, outs

    def _dead(self, ref):
        """Whether the flat 'block.port' ``ref`` belongs to a block (or inside a subsystem) that had a problem."""
        block = ref.rsplit(".", 1)[0]
        return any(block == b or block.startswith(b + ".") for b in self._broken)

    def _endpoint(self, ref, subs, prefix, output, line, context, problems):
        """The flat 'block.port' references a wire end names (a subsystem's port maps to its inner ones)."""
        if not isinstance(ref, str) or ref.count(".") != 1:
            problems.append(f"{context}{line}: {ref!r} is not of the form block.port")
            return None
        bname, pname = ref.split(".")
        if bname not in subs:
            return [prefix + ref]
        ins, outs, sub_where = subs[bname]
        table = outs if output else ins
        if pname not in table:
            kind = "output" if output else "input"
            problems.append(f"{context}{line}: subsystem {bname!r} ({sub_where}) has no {kind} {pname!r}"
                            f"{closest(pname, table)}; its {kind}s: {', '.join(table) or 'none'}")
            return None
        return [table[pname]] if output else list(table[pname])

    def _subsystem(self, diagram, bname, spec, params, prefix, chain, context):
        """Expand the subsystem block ``bname``; returns (inputs, outputs, its file) or None."""
        problems = diagram.problems
        here = spec.locs.get("type", str(self.path))
        rel = spec.get("file")
        if not isinstance(rel, str) or not rel:
            problems.append(f"{context}{here}: subsystem {bname!r} needs 'file', the diagram file it uses")
            return None
        shown = subsystem_path(spec, ".")  # relative to the file that names it, for messages too
        path = shown.resolve()
        where = spec.locs.get("file", here)
        if Path(rel).suffix.lower() not in limits.YAML_SUFFIXES:
            problems.append(f"{context}{where}: subsystem {bname!r}: {rel!r} is not a YAML file")
            return None
        if path in chain:
            problems.append(f"{context}{where}: subsystem {bname!r}: {rel!r} contains itself "
                            f"({' -> '.join(p.name for p in chain)} -> {path.name})")
            return None
        if len(chain) > limits.MAX_EXTENDS:
            problems.append(f"{context}{where}: subsystems nest more than {limits.MAX_EXTENDS} deep")
            return None
        overrides = {}
        try:
            for key, value in spec.items():
                if key not in ("type", "file"):
                    overrides[key] = self._resolve(value, spec.locs[key], params)
            sub = DiagramFile(shown)
        except LoaderError as exc:
            problems.append(f"{context}{where}: in subsystem {bname!r}: {exc}")
            return None
        for key in overrides:
            first = str(key).split(".")[0]
            if "." not in str(key) and key not in sub.params:
                problems.append(f"{context}{spec.locs[key]}: subsystem {bname!r} ({rel}) has no parameter {key!r}"
                                f"{closest(key, sub.params)}; its parameters: {', '.join(sub.params) or 'none'}")
                return None
            if "." in str(key) and first not in sub.data["blocks"]:
                problems.append(f"{context}{spec.locs[key]}: subsystem {bname!r} ({rel}) has no block {first!r}"
                                f"{closest(first, sub.data['blocks'])}")
                return None
        try:
            sub.apply(overrides)
            for key in overrides:  # an inner block's error names where the value came from
                if "." in str(key):
                    first, rest = str(key).split(".", 1)
                    sub.data["blocks"][first].locs[rest] = spec.locs[key]
        except LoaderError as exc:
            problems.append(f"{context}{spec.locs.get(next(iter(overrides), 'type'), here)}: in subsystem {bname!r}: {exc}")
            return None
        # one table of each for the whole hierarchy
        sub.aliases, sub._cut, sub._broken = self.aliases, self._cut, self._broken
        inner = f"{context}in subsystem {prefix}{bname} ({where}): "
        ins, outs = sub._expand(diagram, dict(sub.params), f"{prefix}{bname}.", chain + (path,), inner)
        if self.files is not None:
            self.files.extend(f for f in sub.files if f not in self.files)
        return ins, outs, where

    def _make_block(self, diagram, bname, spec, params, prefix, context):
        """Construct one block from its spec and add it as ``prefix + bname`` (problems noted)."""
        problems = diagram.problems
        blocks = self.data["blocks"]
        here = f"{context}{blocks.locs[bname]}"
        if not isinstance(spec, dict):
            problems.append(f"{here}: block {bname!r} must be a mapping with a 'type'")
            return
        if "type" not in spec:
            problems.append(f"{here}: block {bname!r} has no 'type' (required)")
            return
        tname = spec["type"]
        cls = lookup(str(tname))
        if cls is None:
            problems.append(f"{context}{spec.locs['type']}: block {bname!r}: unknown block type "
                            f"{tname!r}{closest(tname, types() + ['subsystem'])}")
            return
        required, optional = parameters(cls)
        kwargs = {}
        bad = False
        for pname, pval in spec.items():
            if pname == "type":
                continue
            if pname not in required + optional:
                valid = required + optional
                problems.append(
                    f"{context}{spec.locs[pname]}: block {bname!r} ({tname}) has no parameter {pname!r}"
                    f"{closest(pname, valid)}; its parameters: {', '.join(valid) or 'none'}")
                bad = True
                continue
            try:
                kwargs[pname] = self._resolve(pval, spec.locs[pname], params)
            except LoaderError as exc:
                problems.append(f"{context}{exc}")
                bad = True
                continue
            if _has_nan(kwargs[pname]):
                problems.append(f"{context}{spec.locs[pname]}: block {bname!r} ({tname}): parameter "
                                f"{pname!r} is not a number (NaN)")
                bad = True
        for r in required:
            if r not in kwargs and not bad:
                problems.append(f"{here}: block {bname!r} ({tname}) needs parameter {r!r}")
                bad = True
        if bad:
            return
        try:
            diagram.add(cls(name=prefix + bname, **kwargs))
        except RateError as exc:
            where = next((spec.locs[k] for k in ("rate", "period") if k in spec), blocks.locs[bname])
            problems.append(f"{context}{where}: block {bname!r} ({tname}): bad rate: {exc}")
        except ParameterError as exc:
            problems.append(f"{context}{spec.locs.get(exc.param, blocks.locs[bname])}: block {bname!r} ({tname}): {exc}")
        except (ValueError, TypeError, ArithmeticError) as exc:
            problems.append(f"{here}: block {bname!r} ({tname}): {exc}")


    def _check_metrics(self, metrics, lines):
        """The ``metrics`` section: known keys with finite numbers (see :mod:`hybridsim.metrics`)."""
        for key, v in metrics.items():
            if key not in METRIC_KEYS:
                self._fail(f"unknown metrics setting {key!r}{closest(key, METRIC_KEYS)}; "
                           f"settings: {', '.join(METRIC_KEYS)}", lines.get(key))
            if key == "error_window":
                ok = (isinstance(v, list) and len(v) == 2 and all(_number(x) for x in v) and v[0] < v[1])
                if not ok:
                    self._fail(f"metrics setting 'error_window' must be [t0, t1] with t0 < t1 (s), "
                               f"got {v!r}", lines.get(key))
            elif not (_number(v) and (v >= 0 if key == "step_time" else v > 0)):
                self._fail(f"metrics setting {key!r} must be a {'finite number >= 0' if key == 'step_time' else 'positive, finite number'}, "
                           f"got {v!r}", lines.get(key))

    def _check_refs(self, diagram, settings):
        """Every log entry and signal names an output (and an element in range).

        Returns the total logged width (for the size check)."""
        log = self.data.get("log") or _List()
        items = [(ref, (log.locs[k] if getattr(log, "locs", None) else str(self.path)), "log entry")
                 for k, ref in enumerate(settings["log"])]
        items += [(ref, f"{self.path}:{settings['signal_lines'].get(role)}", f"signal {role!r}")
                  for role, ref in settings["signals"].items()]
        problems, logged = [], {}
        for ref, where, what in items:
            m = _REF.match(ref)
            if not m:
                problems.append(f"{where}: {what} {ref!r} is not of the form block.port or block.port[i]")
                continue
            bname, pname, idx = m.group(1), m.group(2), m.group(3)
            block = diagram.blocks.get(bname)
            if block is None:
                problems.append(f"{where}: {what} {ref!r}: no block {bname!r}{closest(bname, diagram.blocks)}")
                continue
            port = next((p for p in block.outputs if p.name == pname), None)
            if port is None:
                names = [p.name for p in block.outputs]
                problems.append(f"{where}: {what} {ref!r}: block {bname!r} has no output {pname!r}"
                                f"{closest(pname, names)}; its outputs: {', '.join(names) or 'none'}")
                continue
            if idx is not None and not 0 <= int(idx) < port.width:
                problems.append(f"{where}: {what} {ref!r}: index {idx} is out of range; "
                                f"{bname}.{pname} has {port.width} element(s), 0..{port.width - 1}")
                continue
            logged[f"{bname}.{pname}"] = port.width
        if problems:
            raise DiagramError(problems, str(self.path))
        return sum(logged.values())

    def _check_size(self, diagram, settings, log_width):
        """Refuse a run too large for memory or time before it starts (see :mod:`limits`)."""
        sim = settings["simulation"]
        step = sim.get("step", 1e-4) if sim["solver"] in ("rk4", "heun") else sim.get("max_step")
        periods = [float(b.period) for b in diagram.blocks.values() if b.period]
        why = limits.run_size_problems(float(sim["t_end"]), periods, float(sim.get("log_period", 0.0005)),
                                       None if step is None else float(step), log_width, sim["solver"])
        if why:
            lines = getattr(self.data.get("simulation"), "lines", None) or {}
            raise LoaderError("; ".join(why), self.path, lines.get("t_end"))

    def _settings(self, params):
        data = self.data
        sim = data.get("simulation") or _Dict()
        lines = sim.lines or {}
        for key in sim:
            if key not in SIM_KEYS:
                self._fail(f"unknown simulation setting {key!r}{closest(key, SIM_KEYS)}", lines.get(key))
        locs = getattr(sim, "locs", None) or {}
        simr = {k: self._resolve(v, locs.get(k, str(self.path)), params) for k, v in sim.items()}
        simr.setdefault("t_end", 1.0)
        simr.setdefault("solver", "rk4")
        for key in ("t_end", "step", "rtol", "max_step", "log_period", "max_state", "atol"):
            if key in simr:
                v = simr[key]
                if key == "max_step" and v == math.inf:
                    continue
                vals = v if key == "atol" and isinstance(v, list) and v else [v]
                if not all(_positive_number(x) for x in vals):
                    self._fail(f"simulation setting {key!r} must be a positive, finite number, got {v!r}",
                               lines.get(key))
        for key in ("fused", "compiled", "locate_switches"):
            if key in simr and not isinstance(simr[key], bool):
                self._fail(f"simulation setting {key!r} must be true or false, got {simr[key]!r}",
                           lines.get(key))
        if not isinstance(simr["solver"], str) or simr["solver"].lower() not in SOLVERS:
            self._fail(f"unknown solver {simr['solver']!r}{closest(str(simr['solver']).lower(), SOLVERS)}; "
                       f"solvers: {', '.join(SOLVERS)}", lines.get("solver"))
        simr["solver"] = simr["solver"].lower()
        step = simr.get("step") if simr["solver"] in ("rk4", "heun") else None
        if step is not None and step > simr["t_end"]:
            _log.warning("%s: the step %g s is longer than t_end %g s: %s takes one step of %g s",
                         self.path, step, simr["t_end"], simr["solver"], simr["t_end"])
        signals = data.get("signals") or _Dict()
        for role in signals:
            if role not in SIGNAL_ROLES:
                self._fail(f"unknown signal role {role!r}{closest(role, SIGNAL_ROLES)}; "
                           f"roles: {', '.join(SIGNAL_ROLES)}", signals.lines[role])
        log = [str(x) for x in (data.get("log") or [])]
        metrics = self._resolve(data.get("metrics") or {}, str(self.path), params)
        self._check_metrics(metrics, getattr(data.get("metrics"), "lines", None) or {})
        for section, keys in (("plot", PLOT_KEYS), ("analysis", ANALYSIS_KEYS)):
            spec = data.get(section) or _Dict()
            for key in spec:
                if key not in keys:
                    self._fail(f"unknown {section} setting {key!r}{closest(key, keys)}; settings: {', '.join(keys)}",
                               (spec.lines or {}).get(key))
        at = (data.get("analysis") or {}).get("at")
        if at is not None and not (_number(at) and at >= 0):
            self._fail(f"analysis setting 'at' must be a time in seconds >= 0, got {at!r}",
                       (data["analysis"].lines or {}).get("at"))
        return {
            "simulation": simr,
            "log": log,
            "signals": {k: str(v) for k, v in signals.items()},
            "signal_lines": dict(signals.lines or {}),
            "metrics": metrics,
            "plot": _plain(data.get("plot") or {}),
            "params": _plain(params),
        }
