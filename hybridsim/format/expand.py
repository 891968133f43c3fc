"""Expanding a diagram file into blocks and wires: subsystems flattened, every block constructed.

:func:`count_blocks` counts the blocks a file stands for before anything is
expanded (each subsystem file read once), so a hierarchy that doubles at
every level is refused in milliseconds, not after exponential work.
"""
import re
from pathlib import Path

from hybridsim import limits
from hybridsim.errors import FMUError, LoaderError, ParameterError, RateError
from hybridsim.engine.registry import closest, lookup, parameters, types
from hybridsim.format import tables
from hybridsim.format.kinds import MapOf
from hybridsim.format.values import _has_nan, _is_subsystem, _references, note, subsystem_path

_BAD_NAME = re.compile(r"[.\[\]\s:=]")  # a '.' separates a subsystem's name from its blocks' names

_WIRING = re.compile(r"(inputs?|outputs?|in|out|u\d*|y\d*|from|to|src|source|connect\w*|ports?)$")
_SIGNAL = re.compile(r"^[\w.]+\.\w+(\[\d+\])?$")  # block.port, sub.block.port[i]


def _wiring_hints(problems, unknown, cls, kwargs, bname):
    """Add to each message of an ``unknown`` parameter that is one of the block's input ports, or is
    named like a wire (``input``, ``from``), where its signal is connected (the block's real ports)."""
    if not unknown:
        return
    ports = None  # None: the block cannot be built to show its ports
    for given in (kwargs, {}):  # the block as written, else with its defaults
        try:
            ports = [port.name for port in cls(name=bname, **given).inputs]
            break
        except Exception:  # noqa: BLE001 - only for the hint
            continue
    for pname, i, value in unknown:
        source = value if isinstance(value, str) and _SIGNAL.match(value) else "block.output"
        if ports and pname in ports:
            problems[i] += (f" ({pname!r} is an input port: connect it in the 'wires:' section, "
                            f"'- {source} -> {bname}.{pname}')")
        elif _WIRING.match(str(pname)) and ports:
            problems[i] += (f" (signals are connected in the 'wires:' section, '- {source} -> "
                            f"{bname}.{ports[0]}'; its inputs: {', '.join(ports)})")
        elif _WIRING.match(str(pname)):
            problems[i] += (" (signals are connected in the 'wires:' section; this block has no inputs)"
                            if ports is not None else " (signals are connected in the 'wires:' section)")


def _port_hint(key, value, inputs, bname):
    """The wires hint for a subsystem block's key that is one of its file's declared ``inputs`` or is
    named like a wire, else ''."""
    ports = [str(k) for k in inputs] if isinstance(inputs, dict) else []
    source = value if isinstance(value, str) and _SIGNAL.match(value) else "block.output"
    if key in ports:
        return f" ({key!r} is an input port: connect it in the 'wires:' section, '- {source} -> {bname}.{key}')"
    if _WIRING.match(str(key)):
        return (f" (signals are connected in the 'wires:' section, '- {source} -> {bname}.{ports[0]}'; its inputs: "
                f"{', '.join(ports)})" if ports else " (signals are connected in the 'wires:' section; it declares "
                "no inputs)")
    return ""


class ExpandMixin:
    """The expansion methods of :class:`~.diagram_file.DiagramFile`."""

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
            if not isinstance(bname, str) or not bname or _BAD_NAME.search(bname):
                problems.append(f"{context}{here}: block name {bname!r} may not be empty or contain '.', '[', "
                                "']', ':', '=' or spaces (a '.' separates a subsystem from its blocks)")
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
                if dsts is not None:  # its source has a problem of its own: not this input's
                    self._cut.update(dsts)
                continue
            if any(self._dead(r) for r in srcs + dsts):
                self._cut.update(dsts)  # a block at one end already has a problem: not this input's
                ends = [(r, "output") for r in srcs] + [(r, "input") for r in dsts]
                problems += [why for r, kind in ends if not self._dead(r)  # the other end's own problem
                             for why in [diagram.port(r, kind, f"{context}{line}" if context else line)[1]] if why]
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
                    if got is not None and ref.split(".")[0] not in subs:  # a block of this file: its port
                        why = self._port_problem(diagram, ref, prefix, section[:-1])
                        if why:
                            problems.append(f"{where}: {section[:-1]} {name!r}: {why}")
                            self._bad_ports.add(prefix + name)  # the wires to it are not blamed again
                            got = None
                    if got is not None:
                        flat += got
                if flat:
                    target[name] = flat if section == "inputs" else flat[0]
        for name, ref in outs.items():
            self.aliases[prefix + name] = ref
        return ins, outs

    def _port_problem(self, diagram, ref, prefix, kind):
        """Why the 'block.port' ``ref`` of this file is not one of its blocks' ``kind`` ports ("input",
        "output"), or None (a block that had a problem of its own is not blamed again)."""
        bname, pname = ref.split(".")
        if "[" in pname:  # wires join whole ports
            return f"{ref!r} is one element; a subsystem's port is a whole port (a demux block splits one)"
        block = diagram.blocks.get(prefix + bname)
        if block is None:
            if self._dead(prefix + ref):
                return None
            return f"no block {bname!r}{closest(bname, self.data['blocks'])}"
        names = [p.name for p in (block.outputs if kind == "output" else block.inputs)]
        if pname in names:
            return None
        return (f"block {bname!r} ({block.type_label}) has no {kind} {pname!r}{closest(pname, names)}; "
                f"its {kind}s: {', '.join(names) or 'none'}")

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
        if pname not in table and prefix + ref in self._bad_ports:  # its declaration had the problem
            return None
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
        if rel is None or rel == "":
            problems.append(f"{context}{here}: subsystem {bname!r} needs 'file', the diagram file it uses")
            return None
        if not isinstance(rel, str):
            problems.append(f"{context}{spec.locs.get('file', here)}: subsystem {bname!r}: 'file' is one file name "
                            f"(the diagram file it uses), got {rel!r}")
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
        if len(chain) > limits.get("MAX_EXTENDS"):
            problems.append(f"{context}{where}: subsystems nest more than {limits.get('MAX_EXTENDS')} deep")
            return None
        overrides = {}
        try:
            for key, value in spec.items():
                if key not in ("type", "file"):
                    overrides[key] = self._resolve(value, spec.locs[key], params)
            sub = type(self)(shown)
        except LoaderError as exc:
            problems.append(f"{context}{where}: in subsystem {bname!r}: {exc}")
            return None
        for key in overrides:
            first = str(key).split(".")[0]
            if "." not in str(key) and key not in sub.params:
                problems.append(f"{context}{spec.locs[key]}: subsystem {bname!r} ({rel}) has no parameter {key!r}"
                                f"{closest(key, sub.params)}; its parameters: {', '.join(sub.params) or 'none'}"
                                + _port_hint(key, overrides[key], sub.data.get("inputs"), bname))
                return None
            if "." in str(key) and first not in sub.data["blocks"]:
                problems.append(f"{context}{spec.locs[key]}: subsystem {bname!r} ({rel}) has no block {first!r}"
                                f"{closest(first, sub.data['blocks'])}")
                return None
        try:
            sub.apply(overrides, cancelling=False)
            sub.command_line = False  # its overrides come from this subsystem block
            for key in overrides:  # an inner block's error names where the value came from
                if "." in str(key):
                    first, rest = str(key).split(".", 1)
                    sub.data["blocks"][first].locs[rest] = spec.locs[key]
        except LoaderError as exc:
            problems.append(f"{context}{spec.locs.get(next(iter(overrides), 'type'), here)}: in subsystem {bname!r}: {exc}")
            return None
        unread = [k for k in sub.data if k not in tables.SUBSYSTEM_SECTIONS]
        dead = [k for k in unread if k != "simulation"]  # (the solver of an FMU exported from it: noted)
        if dead and sub.data.get("inputs"):  # it never runs on its own: those sections are dead
            k = dead[0]
            loc = (getattr(sub.data, "locs", None) or {}).get(k) or f"{shown}:{sub.data.lines.get(k)}"
            problems.append(f"{context}{where}: in subsystem {bname!r}: {loc}: section "
                            f"{k!r} has no effect in a subsystem file that declares inputs (it never runs on its "
                            f"own); only {', '.join(tables.SUBSYSTEM_SECTIONS)} are read")
            return None
        if "simulation" in unread and sub.data.get("inputs"):  # an exported FMU's solver: checked all the same
            try:
                sub.check_section("simulation")
            except LoaderError as exc:
                problems.append(f"{context}{where}: in subsystem {bname!r}: {exc}")
                return None
        if unread:
            note("%s: %s: %s ignored where it is used as a subsystem (only %s are read there)", where,
                         shown, ", ".join(repr(k) for k in unread), ", ".join(tables.SUBSYSTEM_SECTIONS))
        # one table of each for the whole hierarchy
        sub.aliases, sub._cut, sub._broken, sub._bad_ports = self.aliases, self._cut, self._broken, self._bad_ports
        inner = f"{context}in subsystem {prefix}{bname} ({where}): "
        ins, outs = sub._expand(diagram, dict(sub.params), f"{prefix}{bname}.", chain + (path,), inner)
        if self.files is not None:
            self.files.extend(f for f in sub.files if f not in self.files)
        return ins, outs, where

    def _set_origin(self, value, where=None):
        """' (the value of $k, from --set k)' where ``value`` refers to parameters set by an override,
        ' (the value of $k, from child.yaml:3)' where by a file other than ``where``'s (file:line)."""
        refs = sorted(_references(value))
        overrides = getattr(self, "overrides", {}) if getattr(self, "command_line", True) else {}
        out = "".join(f" (the value of ${n}, from {self.origin} {n})" for n in refs if n in overrides)
        locs = getattr(self.data.get("params"), "locs", None) or {}
        here = str(where or "").rpartition(":")[0]
        return out + "".join(f" (the value of ${n}, from {locs[n]})" for n in refs
                             if n not in overrides and n in locs and here and str(locs[n]).rpartition(":")[0] != here)

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
        if not isinstance(tname, str) or not tname:
            problems.append(f"{context}{spec.locs['type']}: block {bname!r}: 'type' is a block type name such as "
                            f"gain or integrator (hybridsim blocks lists them), got {tname!r}")
            return
        cls = lookup(tname)
        if cls is None:
            problems.append(f"{context}{spec.locs['type']}: block {bname!r}: unknown block type "
                            f"{tname!r}{closest(tname, types() + ['subsystem'])}")
            return
        required, optional = parameters(cls)
        kwargs = {}
        bad = False
        table = tables.BLOCK_SETTINGS.get(str(tname)) if str(cls.__module__).startswith("hybridsim.") else None
        unknown = []  # (parameter, its message's place in problems): a wiring hint is added below
        for pname, pval in spec.items():
            if pname == "type":
                continue
            if pname not in required + optional:
                valid = required + optional
                unknown.append((pname, len(problems), pval))
                problems.append(
                    f"{context}{spec.locs[pname]}: block {bname!r} ({tname}) has no parameter {pname!r}"
                    f"{closest(pname, valid)}; its parameters: {', '.join(valid) or 'none'}"
                    + "".join(f" (an entry of its mapping {r.key!r} is set as {bname}.{r.key}.{pname})"
                              for r in table or ()
                              if isinstance(r.kind, MapOf) and not _WIRING.match(str(pname))))
                bad = True
                continue
            try:
                kwargs[pname] = self._resolve(pval, spec.locs[pname], params)
            except LoaderError as exc:
                problems.append(f"{context}{exc}")
                bad = True
                continue
            by_key = {t.key: t for t in table or ()}
            if pname in by_key and kwargs[pname] is not None:
                why = by_key[pname].kind.problem(kwargs[pname])
                if why:
                    problems.append(f"{context}{spec.locs[pname]}: block {bname!r} ({tname}): parameter {pname!r} "
                                    + (why if why.startswith("must") else f"must be {by_key[pname].kind.text}: {why}")
                                    + self._set_origin(pval, spec.locs[pname]))
                    bad = True
                    continue
            if _has_nan(kwargs[pname]):
                problems.append(f"{context}{spec.locs[pname]}: block {bname!r} ({tname}): parameter "
                                f"{pname!r} is not a number (NaN)" + self._set_origin(pval, spec.locs[pname]))
                bad = True
        _wiring_hints(problems, unknown, cls, kwargs, bname)
        for r in required:
            if r not in kwargs and not bad:
                problems.append(f"{here}: block {bname!r} ({tname}) needs parameter {r!r}")
                bad = True
        if bad:
            return
        try:
            diagram.add(cls(name=prefix + bname, **kwargs))
        except RateError as exc:
            key = next((k for k in ("rate", "period") if k in spec), None)
            where = spec.locs[key] if key else blocks.locs[bname]
            problems.append(f"{context}{where}: block {bname!r} ({tname}): bad rate: {exc}"
                            + (self._set_origin(spec[key], where) if key else ""))
        except ParameterError as exc:
            problems.append(f"{context}{spec.locs.get(exc.param, blocks.locs[bname])}: block {bname!r} ({tname}): {exc}"
                            + self._set_origin(spec.get(exc.param), spec.locs.get(exc.param)))
        except (ValueError, TypeError, ArithmeticError) as exc:
            problems.append(f"{here}: block {bname!r} ({tname}): {exc}")
        except FMUError as exc:  # an FMU that is missing or cannot serve: at the block's path (exit 4 still)
            raise FMUError(f"{context}{spec.locs.get('path', blocks.locs[bname])}: block {bname!r} ({tname}): "
                           f"{exc}") from None
        except Exception as exc:  # noqa: BLE001 - a plugin's constructor may raise anything: its fault
            from hybridsim.errors import PluginFault
            from hybridsim.engine.registry import _is_ours

            if _is_ours(cls.__module__):
                raise
            raise PluginFault(f"plugin {cls.__module__!r}: block {prefix + bname!r} ({tname}): its constructor "
                              f"raised {type(exc).__name__}: {exc}", cls.__module__, prefix + bname) from None


def count_blocks(f, memo=None, chain=None):
    """(blocks, files): how many blocks diagram file ``f`` stands for with every subsystem expanded,
    and every subsystem file it reads (with the files those extend), without expanding anything.

    Each subsystem file is parsed once, however often it is used; a file that
    cannot be read counts as one block (the expansion reports it).
    """
    memo = {} if memo is None else memo
    chain = (f.path.resolve(),) if chain is None else chain
    files = set()
    total = 0
    blocks = f.data.get("blocks")
    for spec in (blocks.values() if isinstance(blocks, dict) else ()):
        if not (_is_subsystem(spec) and isinstance(spec.get("file"), str) and spec["file"]
                and Path(spec["file"]).suffix.lower() in limits.YAML_SUFFIXES):
            total += 1
            continue
        path = subsystem_path(spec, ".").resolve()
        if path in chain or len(chain) > limits.get("MAX_EXTENDS"):
            total += 1  # a cycle or too deep: the expansion says so
            continue
        if path not in memo:
            try:
                sub = type(f)(path)
            except LoaderError:
                memo[path] = (1, set())
            else:
                n, inner = count_blocks(sub, memo, chain + (path,))
                memo[path] = (n, inner | {Path(p) for p in sub.files})
        n, inner = memo[path]
        total += n
        files |= inner
        if total > limits.get("MAX_BLOCKS"):
            break
    return total, files
