"""Reading YAML: plain data with the file and line of every value, within the limits.

Both diagram and sweep files (:func:`parse_file`) and ``--set`` values
(:func:`parse_value`) go through the same reader, so the same limits hold for
both: nesting depth, the number of values aliases expand to, recursive aliases,
characters YAML forbids. Nothing is evaluated; only YAML's plain types.
"""
import copy
import os
import re
import stat
from pathlib import Path

import yaml

from hybridsim import limits
from hybridsim.errors import InputError, LoaderError
from hybridsim.format import filekinds


class _Dict(dict):
    """A mapping that remembers its file and the line of each key (1-based)."""

    line = None
    lines = None
    key_lines = None
    file = None


def key_line(mapping, key):
    """The line where ``key`` of a parsed ``mapping`` is written (its value's line where unknown)."""
    return ((getattr(mapping, "key_lines", None) or {}).get(key)
            or (getattr(mapping, "lines", None) or {}).get(key))


def key_file(mapping, key, default):
    """The file that gave ``key`` of a parsed ``mapping`` (one a diagram extends may have), else ``default``."""
    loc = (getattr(mapping, "locs", None) or {}).get(key)
    if type(loc) is not str:  # unknown, or an override's (OverrideLoc)
        return default
    return loc.rpartition(":")[0] or default


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
        if key is None or isinstance(key, bool):  # YAML 1.1 reads on/off/yes/no/true/false/null/~ so
            raise LoaderError(f"the key {knode.value or '(empty)'!r} reads as {key!r} in YAML, not as a name; "
                              f"quote it ('{knode.value}') to use it as one", line=knode.start_mark.line + 1)
        if key in own:
            raise LoaderError(f"duplicate key {key!r} (first given on line {own[key]}); "
                              "each key may appear once in a mapping", line=knode.start_mark.line + 1)
        own[key] = knode.start_mark.line + 1
    loader.flatten_mapping(node)
    d = _Dict()
    d.line, d.lines, d.file = node.start_mark.line + 1, {}, loader.source_path
    d.locs, d.key_lines = {}, {}  # key_lines: where each key is written (a block mapping's value starts below)
    for knode, vnode in node.value:
        key = loader.construct_object(knode, deep=True)
        try:
            hash(key)
        except TypeError:
            raise LoaderError("a mapping key must be a plain value", line=knode.start_mark.line + 1) from None
        d[key] = loader.construct_object(vnode, deep=True)
        d.lines[key] = vnode.start_mark.line + 1
        d.key_lines[key] = knode.start_mark.line + 1
        d.locs[key] = f"{loader.source_path}:{d.lines[key]}"
    return d


def _construct_sequence(loader, node):
    lst = _List(loader.construct_object(n, deep=True) for n in node.value)
    lst.line = node.start_mark.line + 1
    lst.lines = [n.start_mark.line + 1 for n in node.value]
    lst.locs = [f"{loader.source_path}:{ln}" for ln in lst.lines]
    return lst


def _construct_int(loader, node):
    digits = sum(ch.isdigit() for ch in node.value)
    if digits > 308:  # beyond every float64 (1.8e308), and Python refuses past 4300 digits
        raise LoaderError(f"the integer {node.value[:12]}... ({digits} digits) is beyond the largest float64 "
                          "(1.8e308)", loader.source_path, node.start_mark.line + 1)
    return yaml.SafeLoader.construct_yaml_int(loader, node)


_Loader.add_constructor("tag:yaml.org,2002:int", _construct_int)
_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)
_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_SEQUENCE_TAG, _construct_sequence)


def _compose_node(self, parent, index):
    """The composer's recursion, with limits on depth and on the number of values (refused, not a crash)."""
    self.depth = getattr(self, "depth", 0) + 1
    self.nodes = getattr(self, "nodes", 0) + 1
    try:
        if self.nodes > limits.get("MAX_YAML_VALUES"):
            mark = self.peek_event().start_mark
            raise LoaderError(f"more than {limits.get('MAX_YAML_VALUES')} values in one file",
                              line=mark.line + 1)
        if self.depth > limits.get("MAX_YAML_DEPTH"):
            mark = self.peek_event().start_mark
            raise LoaderError(f"values nested deeper than {limits.get('MAX_YAML_DEPTH')} levels",
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


def not_a_file(path):
    """What keeps ``path`` from being read as a file: "no such file", "a folder", "not a regular file
    (a device, FIFO or socket)"; None for a regular file."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return "no such file"
    except OSError as exc:
        return f"cannot read: {exc.strerror}"
    if stat.S_ISREG(mode):
        return None
    return "a folder" if stat.S_ISDIR(mode) else "not a regular file (a device, FIFO or socket)"


def as_path(path, what="a file"):
    """``path`` as a Path; TypeError naming ``what`` when it is not a str or path-like."""
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"{what} is a path (str or pathlib.Path), got {path!r}")
    return Path(path)


def read_text(path, budget=None):
    """The text of a diagram or sweep file: a regular UTF-8 file of at most ``budget`` bytes."""
    as_path(path)
    budget = limits.get("MAX_FILE_BYTES") if budget is None else budget
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
                          f"extends may hold {limits.get('MAX_FILE_BYTES') / 2**20:.0f} MiB together", path)
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


#: files parsed, by path and text: a file read again (an analysis builds its diagram for every case and
#: gain scale) is copied, not parsed again; its text is read every time, so an edit is never missed
_PARSED = {}
_PARSED_MAX = 64


def parse_file(path, budget=None, what="a diagram file must be a mapping with a 'blocks' section"):
    """The YAML mapping in ``path`` with file/line tracking, and its size in bytes; or LoaderError.

    Refused before anything is built: files that are not regular or too large,
    characters YAML forbids (NUL), nesting deeper than ``MAX_YAML_DEPTH``,
    aliases that expand to more than ``MAX_YAML_VALUES`` values, duplicate keys.
    """
    try:
        text = read_text(path, budget)
    except LoaderError:
        kind = filekinds.binary_kind(path)  # a zip archive (an FMU, a Simulink model), whatever its name
        if kind:
            raise LoaderError(filekinds.NOT_YAML[kind], path) from None
        raise
    if text.startswith("PK\x03\x04"):
        raise LoaderError(filekinds.NOT_YAML[filekinds.binary_kind(path) or "zip"], path)
    key = (str(path), text)
    parsed = _PARSED.pop(key, None)
    if parsed is None:
        head = text.lstrip("\ufeff \t\r\n")
        if head.startswith("<"):
            raise LoaderError(filekinds.NOT_YAML["urdf" if "<robot" in head[:4096] else "xml"], path, 1)
        try:
            parsed = _load_text(text, str(path)), len(text.encode("utf-8"))
        except LoaderError as exc:
            hint = filekinds.text_hint(path, text)
            if not hint:
                raise
            raise LoaderError(str(exc).split(": ", 1)[-1] + hint, path, exc.line) from None
    _PARSED[key] = parsed  # the most recent last
    while len(_PARSED) > _PARSED_MAX:
        del _PARSED[next(iter(_PARSED))]
    if not isinstance(parsed[0], dict):
        raise LoaderError(what + filekinds.text_hint(path, text), path, 1)
    filekinds.refuse_other(parsed[0], path)
    return copy.deepcopy(parsed[0]), parsed[1]


def _load_text(text, source):
    """The document in ``text`` checked as :func:`parse_file` checks a file (errors raise LoaderError)."""
    loader = None
    try:
        loader = _Loader(text)
        loader.source_path = source
        node = loader.get_single_node()
        if node is None:
            return None
        size = _expanded_size(node, {})
        if size > limits.get("MAX_YAML_VALUES"):
            raise LoaderError(f"the YAML expands to {size} values (its aliases repeat values); "
                              f"at most {limits.get('MAX_YAML_VALUES')} are read"
                              + limits.raise_hint("MAX_YAML_VALUES"), source)
        return loader.construct_document(node)
    except LoaderError as exc:
        raise LoaderError(str(exc).split(": ", 1)[-1], source, exc.line) from None
    except yaml.reader.ReaderError as exc:
        line = text.count("\n", 0, max(exc.position, 0)) + 1
        raise LoaderError(f"character {exc.character!r} is not allowed in YAML text "
                          "(a NUL byte or a binary file?)", source, line) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        problem = getattr(exc, "problem", None) or str(exc)
        raise LoaderError(f"YAML syntax error: {problem}", source,
                          mark.line + 1 if mark else None) from None
    except RecursionError:
        raise LoaderError("values nested too deeply", source) from None
    finally:
        if loader is not None:
            loader.dispose()


def parse_value(text, where):
    """One ``--set`` value read as YAML under the limits of a file (``where`` names it in errors).

    Returns plain Python data (no line tracking). Raises InputError for a value
    too long, nested too deep, an alias bomb or a recursive alias, bad syntax.
    """
    if len(text) > limits.get("MAX_SET_CHARS"):
        raise InputError(f"{where}: the value is longer than {limits.get('MAX_SET_CHARS')} characters"
                         + limits.raise_hint("MAX_SET_CHARS"))
    try:
        data = _load_text(text, where)
    except LoaderError as exc:
        msg = str(exc).split(": ", 1)[-1]
        raise InputError(f"{where}: cannot read value {text[:60]!r}: {msg}") from None
    return plain(data)


def plain(v):
    """Strip the line-tracking types (for deep copies and user-facing values)."""
    if isinstance(v, dict):
        return {k: plain(x) for k, x in v.items()}
    if isinstance(v, list):
        return [plain(x) for x in v]
    return v
