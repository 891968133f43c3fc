"""Overrides of a parsed diagram file: ``--set``, ``variants``, run-time parameters.

Every override key is read as one :class:`~.paths.ParamPath`.
"""
import contextlib
import contextvars
import dataclasses
import itertools
import json
import math

import numpy as np

from hybridsim import limits
from hybridsim.errors import LoaderError
from hybridsim.engine.registry import closest, default, lookup
from hybridsim.format import tables
from hybridsim.format.kinds import MapOf
from hybridsim.format.paths import SETTING_SECTIONS, OverrideLoc, ParamPath
from hybridsim.format.values import _is_subsystem, _references, subsystem_path
from hybridsim.format.yamlio import _Dict


#: what messages call an override's source: "override" (a keyword of the Python API), ``--set`` on
#: the command line; a sweep or tune file's checks name theirs (:func:`overrides_from`)
ORIGIN = contextvars.ContextVar("override_origin", default="override")


@contextlib.contextmanager
def overrides_from(origin):
    """Within: diagram files parsed with overrides name ``origin`` as their source (``"the sweep's"``)."""
    token = ORIGIN.set(origin)
    try:
        yield
    finally:
        ORIGIN.reset(token)


class OverridesMixin:
    """The override methods of :class:`~.diagram_file.DiagramFile`."""

    def _path(self, key, what=None):
        try:
            return ParamPath.parse(str(key))
        except ValueError as exc:
            self._fail(f"{what or self.origin} {key}: {exc}")

    def apply(self, overrides, cancelling=True):
        """Apply ``{path: value}`` overrides in place (see class docstring).

        A bare simulation setting (``t_end``) is ``simulation.t_end``, unless the file has a
        parameter of that name. Setting a parameter that ``variants`` sweeps fixes it: that sweep ends.
        A path with an element index (``g.K[1]``) changes that element of the
        parameter's current value (from the file, else the block's default).
        A parameter set together with every value that uses it is refused: it
        would change nothing (unless ``cancelling`` is False: a subsystem block
        passes its file's parameters on whether or not a user set the values
        that use them).
        """
        if overrides:
            self.layers.append(dict(overrides))
        used = _references({k: v for k, v in self.data.items() if k != "params"})
        replaced = {}  # parameter -> the overrides that replaced a value using it
        for key, value in overrides.items():
            self.overrides[key] = value
            path = self._path(key)
            if path.kind == "param" and path.name not in self.params and path.name in tables.keys(tables.SIMULATION):
                path = ParamPath.parse(f"simulation.{path}")  # t_end: simulation.t_end, unless a parameter
            blocks = self.data.get("blocks") if isinstance(self.data.get("blocks"), dict) else {}
            if path.index is not None and path.kind == "block" and len(path.parts) == 3 \
                    and self._mapping(blocks.get(path.block), path.parts[1]):
                self._entry_set(blocks[path.block], path, value, key)  # fmu.parameters.b[1]: the FMU's 'b[1]'
                continue
            if path.index is not None:
                value = self._element_set(path, value, key)
                path = path.without_index()
            if path.kind == "param":
                name = path.name
                if name not in self.params:
                    self._fail(f"{self.origin} {key}: no parameter {name!r} in 'params'"
                               f"{closest(name, self.params)}")
                self.params[name] = value
                if isinstance(self.data.get("variants"), dict):
                    self.data["variants"].pop(name, None)  # a fixed value ends that sweep
            elif path.kind in SETTING_SECTIONS:
                section, known = path.kind, tables.keys(tables.SECTIONS[path.kind])
                if path.name not in known:
                    self._fail(f"{self.origin} {key}: unknown {section} setting {path.name!r}"
                               f"{closest(path.name, known)}; settings: {', '.join(known)}")
                if not isinstance(self.data.get(section), dict):
                    self.data[section] = _Dict()
                    self.data[section].lines, self.data[section].locs = {}, {}
                for n in _references(self.data[section].get(path.name)):
                    replaced.setdefault(n, []).append(str(key))
                self.data[section][path.name] = value
                getattr(self.data[section], "locs", {})[path.name] = OverrideLoc(f"{self.origin} {key}")
            else:
                bname, blocks = path.block, self.data["blocks"]
                if _is_subsystem(blocks.get(bname)) and len(path.parts) >= 2:
                    pname = path.inner  # ctrl.pid.Kp: the subsystem passes pid.Kp on
                elif bname not in blocks:
                    near = closest(bname, list(blocks) + list(SETTING_SECTIONS))  # simulaton.step: the section
                    self._fail(f"{self.origin} {key}: no block {bname!r}{near}")
                elif len(path.parts) == 3 and self._mapping(blocks[bname], path.parts[1]):
                    self._entry_set(blocks[bname], path, value, key)  # fmu.parameters.NAME
                    continue
                elif len(path.parts) > 2:
                    self._fail(f"{self.origin} {key}: block {bname!r} is not a subsystem; "
                               f"its parameters are set as {bname}.<parameter>")
                else:
                    pname = path.name
                if not isinstance(blocks[bname], dict):
                    self._fail(f"{self.origin} {key}: block {bname!r} has no parameters to set")
                for n in _references(blocks[bname].get(pname)):
                    replaced.setdefault(n, []).append(str(key))
                blocks[bname][pname] = value
                blocks[bname].lines[pname] = None
                blocks[bname].locs[pname] = OverrideLoc(f"{self.origin} {key}")
        self.replaced_uses |= set(replaced)
        left = _references({k: v for k, v in self.data.items() if k != "params"})
        for key in overrides:
            name = str(key)
            if cancelling and name in replaced and name in used and name not in left:
                self._fail(f"{self.origin} {key}: changes nothing: every value that uses ${name} is set too "
                           f"({', '.join(replaced[name])}); give one of them")

    @staticmethod
    def _mapping(spec, pname):
        """Whether parameter ``pname`` of the block ``spec`` is a mapping (its table says so)."""
        rows = tables.BLOCK_SETTINGS.get(str(spec.get("type"))) if isinstance(spec, dict) else None
        return any(r.key == pname and isinstance(r.kind, MapOf) for r in rows or ())

    def _entry_set(self, spec, path, value, key):
        """Set the entry ``path.parts[2]`` of the block's mapping parameter ``path.parts[1]``."""
        pname, entry = path.parts[1], path.parts[2] + (f"[{path.index}]" if path.index is not None else "")
        current = spec.get(pname)
        if current is None:
            current = {}
        elif not isinstance(current, dict):
            self._fail(f"{self.origin} {key}: {path.parts[0]}.{pname} is {current!r}, not a mapping")
        current = dict(current)
        current[entry] = value
        spec[pname] = current
        spec.lines[pname] = None
        spec.locs[pname] = OverrideLoc(f"{self.origin} {key}")

    def _element_set(self, path, value, key):
        """The whole value of ``path`` (no index) with its element ``path.index`` set to ``value``."""
        if path.kind != "block":
            current = self.params.get(path.name) if path.kind == "param" else None
            if not isinstance(current, list):
                self._fail(f"{self.origin} {key}: an element index needs a list-valued parameter")
        else:
            spec = self.data["blocks"].get(path.block)
            raw = spec.get(path.inner if _is_subsystem(spec) else path.name) if isinstance(spec, dict) else None
            if isinstance(raw, list) and not any(isinstance(v, (list, dict)) for v in raw):
                current = list(raw)  # as written: the other elements keep their $references
            else:
                try:
                    current = self.param_value(path.without_index().key).tolist()
                except (LoaderError, KeyError, TypeError, ValueError) as exc:
                    self._fail(f"{self.origin} {key}: {exc}")
        flat = np.ravel(np.asarray(current, dtype=object)).tolist() if not isinstance(current, list) \
            else list(current)
        if not 0 <= path.index < len(flat):
            self._fail(f"{self.origin} {key}: index {path.index} is out of range; the parameter has "
                       f"{len(flat)} element(s), 0..{len(flat) - 1}")
        flat[path.index] = value
        return flat

    def param_value(self, ref):
        """Current value of the block parameter ``ref`` ('block.param', 'sub.block.param') as an array.

        From the file, else from the subsystem's file, else the block's default.
        """
        path = ParamPath.parse(ref) if not isinstance(ref, ParamPath) else ref
        if path.index is not None:  # an element: of the whole value
            whole = np.atleast_1d(self.param_value(dataclasses.replace(path, index=None)))
            if not 0 <= path.index < whole.size:
                raise LoaderError(f"{ref!r}: index {path.index} is past the {whole.size} element(s) of "
                                  f"{str(ref).rsplit('[', 1)[0]!r}", self.path)
            return whole[path.index]
        if path.kind != "block":
            if path.kind == "param" and path.name in self.params:
                return self._number(ref, self._resolve(self.params[path.name], str(self.path), self.params))
            raise LoaderError(f"{ref!r}: not a block parameter ('block.param')", self.path)
        bname, pname = path.block, path.inner
        spec = self.data["blocks"].get(bname)
        if not isinstance(spec, dict) or "type" not in spec or not pname:
            raise LoaderError(f"{ref!r}: no block {bname!r} with parameter {pname!r}"
                              f"{closest(bname, self.data['blocks'])}", self.path)
        if _is_subsystem(spec):
            if pname in spec:  # the subsystem block sets it
                return self._number(ref, self._resolve(spec[pname], str(self.path), self.params))
            sub = type(self)(subsystem_path(spec, "."))  # the subsystem's own file, parsed alike
            sub.apply({k: self._resolve(v, str(self.path), self.params) for k, v in spec.items()
                       if k not in ("type", "file")}, cancelling=False)
            return sub.param_value(pname)
        if "." in pname:
            raise LoaderError(f"{ref!r}: block {bname!r} is not a subsystem", self.path)
        if pname in spec:
            return self._number(ref, self._resolve(spec[pname], str(self.path), self.params))
        cls = lookup(str(spec["type"]))
        try:
            value = default(cls, pname)
        except (KeyError, AttributeError):
            raise LoaderError(f"{ref!r}: block {bname!r} ({spec['type']}) has no parameter {pname!r}",
                              self.path) from None
        return self._number(ref, value)

    def _number(self, ref, value):
        """``value`` of the parameter ``ref`` as a float array, or a LoaderError saying it is not one."""
        try:
            out = np.asarray(value, float)
        except (TypeError, ValueError):
            out = None
        if out is None or out.dtype != float:
            raise LoaderError(f"{ref!r} is {value!r}, not a number: only a numeric parameter can be "
                              "scaled, swept by a factor or used as a gain", self.path)
        return out

    def variants(self):
        """List of (label, overrides) for the grid in ``variants`` ([('', {})] if none)."""
        spec = self.data.get("variants") or {}
        if not spec:
            return [("", {})]
        names = list(spec)
        for n in names:
            if n not in self.params:
                how = ""
                if "." in str(n):  # g.K, simulation.solver: only a parameter is varied
                    head, _, tail = str(n).rpartition(".")
                    how = (f"; to vary {n}, give it a parameter: 'params: {{{tail}: ...}}', "
                           f"'{tail}: ${tail}' in {head!r}, 'variants: {{{tail}: [...]}}'")
                self._fail_at(spec, n, f"variant {n!r} is not a parameter in 'params'{closest(n, self.params)}{how}")
            if not isinstance(spec[n], list) or not spec[n]:
                self._fail_at(spec, n, f"variant {n!r} must be a non-empty list of values")
            seen = set()
            for v in spec[n]:  # the same run twice: one CSV written over by the other
                tag = json.dumps(v, sort_keys=True, default=str)
                if tag in seen:
                    self._fail_at(spec, n, f"variant {n!r} lists {v!r} twice")
                seen.add(tag)
        count = math.prod(len(spec[n]) for n in names)
        if count > limits.get("MAX_VARIANTS"):
            self._fail(f"'variants' makes {count} runs; at most {limits.get('MAX_VARIANTS')} (use a sweep file "
                       "for more points)" + limits.raise_hint("MAX_VARIANTS"), spec.line)
        out = []
        for combo in itertools.product(*(spec[n] for n in names)):
            label = ", ".join(f"{n}={v}" for n, v in zip(names, combo))
            out.append((label, dict(zip(names, combo))))
        return out

    def runtime_params(self, overrides, variant=None):
        """``overrides`` (as :meth:`apply` takes them) as run-time block parameters.

        Returns ``{"block.param": value}`` for :meth:`Simulator.run
        <hybridsim.engine.simulator.Simulator.run>`: a name in ``params`` becomes every
        block parameter that refers to it (resolved again), ``block.param``
        stays itself. Raises :class:`LoaderError` when an override cannot be
        given at run time: a simulation setting, a swept variant, or a name
        that the simulation, log, signals or metrics sections use.
        """
        params = {**self.params, **(variant or {})}
        named = {}
        out = {}
        for key, value in overrides.items():
            path = self._path(key, "run-time parameter")
            if path.index is not None:
                self._fail(f"{key!r}: an element index is not a run-time parameter (give the whole value)")
            if path.kind == "param":
                name = path.name
                if name not in self.params:
                    self._fail(f"no parameter {name!r} in 'params'{closest(name, self.params)}")
                if name in (self.data.get("variants") or {}):
                    self._fail(f"{name!r} is swept by 'variants': not a run-time parameter")
                named[name] = value
            elif path.kind in SETTING_SECTIONS:
                self._fail(f"{key!r} is a setting of '{path.kind}': not a run-time parameter")
            else:
                bname = path.block
                if bname not in self.data["blocks"] or (
                        len(path.parts) > 2 and not _is_subsystem(self.data["blocks"][bname])):
                    self._fail(f"{key!r}: no block {bname!r}{closest(bname, self.data['blocks'])}")
                out[path.key] = value  # ctrl.pid.Kp: the flattened block ctrl.pid
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


