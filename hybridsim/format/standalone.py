"""A subsystem file run on its own: staged as a closed diagram that uses it.

A subsystem file (one with ``inputs:``) never runs by itself: a diagram uses it
as ``{type: subsystem, file: ...}``. To check it, or to export it as an FMU, the
file and every file it reads are copied into a folder, its ``simulation:``
section (the exported FMU's solver; dead where a diagram uses it) is blanked
in the copies and lifted to a wrapper diagram that holds each input at its
start value (0) and logs each output. Errors raised from the copies are given
back in the user's paths (:func:`unstaged`).
"""
import json
import logging
import os
import re
import shutil
from pathlib import Path

from hybridsim.errors import InputError

WRAPPER = "hybridsim_fmu.yaml"  # the wrapper's name in the staged folder (and in an exported FMU)
OWN_KEYS = ("type", "file")  # a subsystem block's own keys: no parameter of that name can be set through it


def files(path, seen=None):
    """``(f, paths)``: the :class:`DiagramFile` of ``path`` and, resolved, it, every file it extends and
    every subsystem file it uses, nested ones included."""
    from hybridsim.format.diagram_file import DiagramFile
    from hybridsim.format.values import _is_subsystem, subsystem_path

    seen = [] if seen is None else seen
    f = DiagramFile(path)
    for p in f.files or [Path(path).resolve()]:
        if Path(p).resolve() not in seen:
            seen.append(Path(p).resolve())
    for spec in (f.data.get("blocks") or {}).values():
        if _is_subsystem(spec):
            sub = subsystem_path(spec, Path(path).parent).resolve()
            if sub not in seen:
                files(sub, seen)
    return f, seen


def is_subsystem(f):
    """Whether DiagramFile ``f`` declares ports (``inputs:`` or ``outputs:``)."""
    return bool(f.data.get("inputs") or f.data.get("outputs"))


def ports(f):
    """(inputs, outputs) of subsystem file ``f``: [(name, width, start)], [(name, 'sub.port', width)]."""
    from hybridsim.engine.diagram import Diagram

    d = Diagram(f.name, source=str(f.path))
    f.aliases, f._cut, f._broken, f._bad_ports = {}, set(), set(), set()
    ins, outs = f._expand(d, dict(f.params), "", (f.path.resolve(),), "")
    if d.problems:  # each names its file and line
        raise InputError("; ".join(d.problems[:3]))
    for name in list(ins) + list(outs):  # a name that no wire can write ('u->') is no port
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", str(name)):
            section = "inputs" if name in ins else "outputs"
            where = f._locs(section).get(name, str(f.path))
            raise InputError(f"{where}: {section[:-1]} {name!r}: a port's name is letters, digits and _ "
                             "(not starting with a digit)")
    inputs = []
    for name, refs in ins.items():
        widths = {r: d.blocks[r.rsplit(".", 1)[0]].input_port(r.rsplit(".", 1)[1]).width for r in refs}
        if len(set(widths.values())) > 1:  # one outer input cannot feed both
            where = f._locs("inputs").get(name, str(f.path))
            raise InputError(f"{where}: input {name!r} feeds ports of different widths: "
                             + ", ".join(f"{r} ({w} wide)" for r, w in widths.items()))
        width = widths[refs[0]]
        inputs.append((name, width, [0.0] * width))
    outputs = []
    for name, ref in outs.items():
        b, p = ref.rsplit(".", 1)
        outputs.append((name, f"sub.{name}", d.blocks[b].output_port(p).width))
    return inputs, outputs


def blank_section(path, key):
    """Blank the lines of top-level ``key`` in the YAML file ``path`` (the other lines keep their numbers)."""
    import yaml

    text = path.read_text()
    try:
        node = yaml.compose(text)
    except yaml.YAMLError:
        return  # the build that follows says what is wrong
    if not isinstance(node, yaml.MappingNode):
        return
    lines = text.splitlines(keepends=True)
    for k, v in node.value:
        if k.value == key:
            first, last = k.start_mark.line, v.end_mark.line - (v.end_mark.column == 0)
            for n in range(first, min(last, len(lines) - 1) + 1):
                lines[n] = "\n"
    path.write_text("".join(lines))


def unstaged(message, stage, root, ports=None):
    """``message`` with the staged copies' paths as the user's files: the wrapper's own place dropped,
    or, where it stands for a wire to an input (``wire (<wrapper>:17)``), ``ports`` (the file:line of
    the subsystem's ``inputs:``); its block ``sub.`` named by the inner names alone."""
    wrapper = re.escape(str(stage / WRAPPER)) + r"(:\d+)?"
    message = re.sub(wrapper + r": (in subsystem 'sub': )?", "", message)
    message = re.sub(r"in subsystem sub \(" + wrapper + r"\): ", "", message)
    if ports:
        message = re.sub(wrapper, f"its inputs at {ports}", message)
    message = re.sub(r"(^|[\s'\"(,;])sub\.", r"\1", message)  # a name 'sub.g.y', not a file sub.yaml
    return message.replace(str(stage) + os.sep, str(root) + os.sep)


class Staged:
    """Diagram file ``path`` copied into folder ``stage`` with the files it reads.

    ``entry`` is the file to build there: the wrapper for a subsystem file
    (``inputs``/``outputs`` its ports, as :func:`ports` gives them), else the
    copy of ``path`` (no inputs, no outputs). ``params`` (name, value) are the
    wrapper's parameters, passed on to the subsystem's.
    """

    def __init__(self, path, stage, params=None):
        self.path = Path(path)
        self.file, self.paths = files(self.path)
        f = self.file
        self.params = list(f.params.items()) if params is None else list(params)
        self.subsystem = is_subsystem(f)
        if self.subsystem:  # its simulation section becomes the wrapper's: checked here, in its own file and line
            f.check_section("simulation")
        self.root = Path(os.path.commonpath([p.parent for p in self.paths]))
        self.stage = Path(stage)
        main = self.path.resolve().relative_to(self.root).as_posix()
        for p in self.paths:
            dst = self.stage / p.relative_to(self.root)
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy(p, dst)
        self.inputs, self.outputs = [], []
        if not self.subsystem:
            self.entry = main
            return
        for p in f.files:  # its simulation section (merged over what it extends) is the wrapper's
            blank_section(self.stage / Path(p).resolve().relative_to(self.root), "simulation")
        self.inputs, self.outputs = ports(f)
        blocks = {f"in_{n}": {"type": "constant", "value": start} for n, _, start in self.inputs}
        blocks["sub"] = {"type": "subsystem", "file": main,  # (a param named type or file keeps its value)
                         **{k: f"${k}" for k, _ in self.params if k not in OWN_KEYS}}
        sim = {k: v for k, v in (f.data.get("simulation") or {}).items() if k != "t_end"}
        wrapper = {"name": f.name, "params": dict(self.params), "blocks": blocks,
                   "wires": [f"in_{n}.y -> sub.{n}" for n, _, _ in self.inputs],
                   "log": [ref for _, ref, _ in self.outputs]}
        if sim:
            wrapper["simulation"] = sim
        (self.stage / WRAPPER).write_text(json.dumps(wrapper, indent=1))  # JSON is YAML
        self.entry = WRAPPER

    def unstaged(self, message):
        """:func:`unstaged` for this staging."""
        ports = self.file._locs().get("inputs") if self.subsystem else None
        return unstaged(message, self.stage, self.root, ports)

    def build(self, **overrides):
        """``api.build(entry, check_only=True)``: (system, simulator, settings); an InputError from the
        copies names the user's files."""
        from hybridsim.format import build as api

        log = logging.getLogger("hybridsim")
        mapped = _Unstaging(self)
        log.addFilter(mapped)
        try:
            return api.build(self.stage / self.entry, check_only=True, **overrides)
        except InputError as exc:
            raise InputError(self.unstaged(str(exc))) from None
        finally:
            log.removeFilter(mapped)


class _Unstaging(logging.Filter):
    """A filter that gives a warning about the staged copies in the user's paths."""

    def __init__(self, staged):
        super().__init__()
        self.staged = staged

    def filter(self, record):
        record.msg, record.args = self.staged.unstaged(record.getMessage()), ()
        return True
