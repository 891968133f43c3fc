"""The settings sections of a diagram file, checked against their tables, and the budgets of a run.

Every section (simulation, metrics, plot, analysis, signals, log) is checked
here, with its '$name' references resolved first; signals that name outputs
(log, signals, the analysis's loop points and step) are checked against the
built diagram, elements in range; the size of the run (and of the analysis's
linearisation horizon) is checked before any work starts.
"""

from hybridsim import limits
from hybridsim.errors import DiagramError, LoaderError
from hybridsim.engine.registry import closest, parameters
from hybridsim.format import tables
from hybridsim.format.kinds import SIGNAL
from hybridsim.format.paths import SETTING_SECTIONS, OverrideLoc, ParamPath
from hybridsim.format.values import _plain, note
from hybridsim.format.yamlio import _Dict, _List, key_file




def horizon_problems(diagram_blocks, sim, t_end, log_width=0, what="t_end"):
    """Budget problems of simulating to ``t_end`` with settings ``sim`` (see :mod:`hybridsim.limits`)."""
    step = sim.get("step", 1e-4) if sim.get("solver", "rk4") in tables.FIXED_STEP_SOLVERS else sim.get("max_step")
    periods = [float(b.period) for b in diagram_blocks if getattr(b, "period", None)]
    events = any(getattr(b, "event_directions", None) for b in diagram_blocks)
    why = limits.run_size_problems(float(t_end), periods, float(sim.get("log_period", 0.0005)),
                                   None if step is None else float(step), log_width, sim.get("solver", "rk4"),
                                   float(sim.get("scan", tables.defaults(tables.SIMULATION)["scan"]))
                                   if events else None)
    if why and what != "t_end":
        why[0] = f"{what} {float(t_end):g} s: {why[0]}"
    return why


class SettingsMixin:
    """The settings methods of :class:`~.diagram_file.DiagramFile`."""

    def _section(self, name, params):
        """Section ``name`` with '$' references resolved, its lines, and its table's problems."""
        raw = self.data.get(name) or _Dict()
        lines = getattr(raw, "lines", None) or {}
        locs = getattr(raw, "locs", None) or {}
        resolved = {k: self._resolve(v, locs.get(k, str(self.path)), params) for k, v in raw.items()}
        written = {**lines, **(getattr(raw, "key_lines", None) or {})}  # where each key is written
        shown = {**written, **{k: loc for k, loc in locs.items() if isinstance(loc, OverrideLoc)}}
        got = tables.problems(tables.SECTIONS[name], resolved, name, self.path, shown,
                              getattr(raw, "line", None), parsed=raw)
        return {k: v for k, v in resolved.items() if v is not None}, lines, got  # null: the default

    def _raise(self, problems):
        if problems:
            first, rest = problems[0], problems[1:]
            where, _, msg = first.partition(": ")
            path, sep, line = where.rpartition(":")
            if not sep:
                path, line = where, ""
            extra = "".join(f"\n  also: {p}" for p in rest)
            if line.isdigit():
                raise LoaderError(msg + extra, path, int(line))
            if line:
                raise LoaderError(f"{line}: {msg}{extra}", path)
            raise LoaderError(msg + extra, where or self.path)

    def _override_problems(self, overrides, where, what):
        """Problems of an overrides mapping (analysis set, cases, compare): every path names something."""
        out = []
        for key in overrides:
            path = ParamPath.parse(key)  # the table has checked the form
            if path.kind == "param" and path.name not in self.params:
                out.append(f"{where}: {what}: no parameter {path.name!r} in 'params'{closest(path.name, self.params)}")
            elif path.kind in SETTING_SECTIONS and path.name not in tables.keys(tables.SECTIONS[path.kind]):
                out.append(f"{where}: {what}: unknown {path.kind} setting {path.name!r}"
                           f"{closest(path.name, tables.keys(tables.SECTIONS[path.kind]))}")
            elif path.kind == "block" and path.block not in self.data["blocks"]:
                out.append(f"{where}: {what}: no block {path.block!r}{closest(path.block, self.data['blocks'])}")
        return out

    def check_section(self, name):
        """Check section ``name`` (``simulation``, ``metrics``, ...) against its table with this file's
        params; raises LoaderError at the file and line of its first problem."""
        self._raise(self._section(name, dict(self.params))[2])

    def analysis_settings(self, params=None):
        """The ``analysis`` section checked against its table, '$' resolved, over the defaults.

        Raises LoaderError (file:line) for an unknown key, a value of the wrong
        kind or range, or a path that names no parameter, block or setting.
        """
        params = dict(self.params) if params is None else params
        cfg, lines, problems = self._section("analysis", params)
        locs = self._locs("analysis")
        if not problems:
            line = lambda k: locs.get(k, str(self.path))  # noqa: E731
            for key in ("set", "cases", "compare"):
                groups = {"": cfg.get(key, {})} if key == "set" else cfg.get(key, {})
                entries = self._locs("analysis", key)
                for name, ov in groups.items():
                    where = entries.get(name, line(key)) if name else line(key)
                    problems += self._override_problems(ov, where, f"analysis {key} {name}".rstrip())
            if isinstance(cfg.get("step"), dict):
                problems += self._override_problems(cfg["step"].get("set", {}),
                                                    self._locs("analysis", "step").get("set", line("step")),
                                                    "analysis step set")
            for gname, ref in cfg.get("gains", {}).items():
                path = ParamPath.parse(ref)
                if path.kind != "block" or path.block not in self.data["blocks"]:
                    problems.append(f"{line('gains')}: analysis gain {gname!r}: {ref!r} is not a block parameter "
                                    f"of this diagram{closest(path.block or ref, self.data['blocks'])}")
            if "rate_param" in cfg and cfg["rate_param"] not in self.params:
                problems.append(f"{line('rate_param')}: analysis rate_param {cfg['rate_param']!r} is not a "
                                f"name in 'params'{closest(cfg['rate_param'], self.params)}")
        self._raise(problems)
        out = tables.defaults(tables.ANALYSIS)
        out.update({k: v for k, v in cfg.items() if v is not None})
        if isinstance(out.get("step"), dict):
            out["step"] = {**tables.defaults(tables.ANALYSIS_STEP), **out["step"]}
        out["_lines"], out["_locs"] = lines, locs
        return out

    def _locs(self, *keys):
        """``{key: "file:line"}`` of the keys of the mapping at ``keys`` (``"analysis", "step"``: the
        step's keys), each in the file that gave it (this one or one it extends)."""
        raw = self.data
        for k in keys:
            raw = raw.get(k) if isinstance(raw, dict) else None
        if not isinstance(raw, dict):
            return {}
        lines = getattr(raw, "lines", None) or {}
        locs = getattr(raw, "locs", None) or {}
        return {k: str(locs.get(k) or f"{self.path}:{lines.get(k)}") for k in raw}

    def _check_refs(self, diagram, settings):
        """Every log entry, signal and analysis signal names an output (and an element in range).

        Returns the total logged width (for the size check)."""
        log = self.data.get("log") or _List()
        items = [(ref, (log.locs[k] if getattr(log, "locs", None) else str(self.path)), "log entry")
                 for k, ref in enumerate(settings["log"])]
        sig_locs = self._locs("signals")
        items += [(ref, sig_locs.get(role, str(self.path)), f"signal {role!r}")
                  for role, ref in settings["signals"].items()]
        an = settings.get("analysis") or {}
        an_locs = an.get("_locs", {})
        point_locs, step_locs = self._locs("analysis", "points"), self._locs("analysis", "step")
        items += [(self._alias(ref), point_locs.get(name, an_locs.get("points", str(self.path))),
                   f"analysis point {name!r}") for name, ref in (an.get("points") or {}).items()]
        if isinstance(an.get("step"), dict):
            items += [(self._alias(an["step"][k]), step_locs.get(k, an_locs.get("step", str(self.path))),
                       f"analysis step {k}") for k in ("input", "output") if k in an["step"]]
        problems, logged = [], {}
        for gname, ref in (an.get("gains") or {}).items():  # a gain names a parameter of a built block
            bname, _, pname = str(ref).rpartition(".")
            block = diagram.blocks.get(bname)
            where = (f"{self._locs('analysis', 'gains').get(gname, an_locs.get('gains', self.path))}: "
                     f"analysis gain {gname!r} {ref!r}")
            if block is None:
                problems.append(f"{where}: no block {bname!r}{closest(bname, diagram.blocks)}")
                continue
            names = [n for group in parameters(type(block)) for n in group]
            if pname not in names:
                problems.append(f"{where}: block {bname!r} has no parameter {pname!r}{closest(pname, names)}; "
                                f"its parameters: {', '.join(names) or 'none'}")
                continue
            try:
                self.param_value(ref)  # a gain is scaled: a number
            except LoaderError as exc:
                problems.append(f"{where}: {exc.message}")
        for ref, where, what in items:
            m = SIGNAL.match(ref)
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
            if what.startswith("analysis"):
                continue
            logged[f"{bname}.{pname}"] = port.width
        if problems:
            raise DiagramError(problems, str(self.path))
        return sum(logged.values())

    def _check_size(self, diagram, settings, log_width):
        """Refuse a run too large for memory or time before it starts (see :mod:`hybridsim.limits`)."""
        sim = settings["simulation"]
        why = horizon_problems(diagram.blocks.values(), sim, sim["t_end"], log_width)
        lines = getattr(self.data.get("simulation"), "lines", None) or {}
        if why:
            locs = getattr(self.data.get("simulation"), "locs", None) or {}
            given = [locs[k] for k in ("t_end", "step", "max_step", "log_period", "scan", "solver")
                     if isinstance(locs.get(k), OverrideLoc)]  # the values an override gave: named
            raise LoaderError("; ".join(why) + (f" (from {', '.join(given)})" if given else ""), self.path,
                              lines.get("t_end"))
        at = (settings.get("analysis") or {}).get("at")
        if at:
            why = horizon_problems(diagram.blocks.values(), sim, at, 0, "analysis at")
            where = settings["analysis"]["_locs"].get("at", str(self.path))
            if why:
                raise LoaderError("; ".join(why), where)
            if at > sim["t_end"]:
                note("%s: analysis at %g s is past t_end %g s: each linearization of analyze and "
                     "report (one per rate, gain and case) simulates %g s first", where, at, sim["t_end"], at)

    def _settings(self, params):
        simr, sim_lines, problems = self._section("simulation", params)
        metrics, _, more = self._section("metrics", params)
        metrics = {**{k: v for k, v in tables.defaults(tables.METRICS).items() if v is not None}, **metrics}
        problems += more
        plot, _, more = self._section("plot", params)
        problems += more
        signals = self.data.get("signals") or _Dict()
        roles = tables.keys(tables.SIGNALS)
        for role, ref in signals.items():
            where = f"{key_file(signals, role, self.path)}:{signals.lines[role]}"
            if role not in roles:
                problems.append(f"{where}: unknown signal role {role!r}"
                                f"{closest(role, roles)}; roles: {', '.join(roles) or 'none are registered'}")
            elif not isinstance(ref, str):
                problems.append(f"{where}: signal {role!r} must be a signal 'block.port[i]', got {ref!r}")
        log = self.data.get("log") or _List()
        for k, ref in enumerate(log):
            if not isinstance(ref, str):
                where = log.locs[k] if getattr(log, "locs", None) else str(self.path)
                problems.append(f"{where}: log entry must be a signal 'block.port[i]', got {ref!r}")
        self._raise(problems)
        analysis = self.analysis_settings(params)
        simr.setdefault("t_end", 1.0)
        simr.setdefault("solver", "rk4")
        simr["solver"] = simr["solver"].lower()
        step = simr.get("step") if simr["solver"] in tables.FIXED_STEP_SOLVERS else None
        if step is not None and step > simr["t_end"]:
            note("%s: the step %g s is longer than t_end %g s: %s takes one step of %g s",
                         self.path, step, simr["t_end"], simr["solver"], simr["t_end"])
        return {
            "simulation": simr,
            "log": [str(x) for x in log],
            "signals": {k: str(v) for k, v in signals.items()},
            "signal_lines": dict(signals.lines or {}),
            "metrics": metrics,
            "plot": _plain(plot),
            "params": _plain(params),
            "analysis": analysis,
        }
