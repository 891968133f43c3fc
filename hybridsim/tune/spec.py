"""The tune file: one declarative table of what is searched, measured and required.

::

    diagram: ../examples/msd_pid.yaml        # relative to this file
    set: {simulation.t_end: 4.0}              # fixed for every point
    variants: {rate: [60, 80, 120]}           # optional: every point runs each; worst case counts
    parameters:
      pid.Kp: {low: 1, high: 200, scale: log}
      pid.N:  {values: [10, 20, 40]}
      delay_ticks: {low: 0, high: 2, integer: true}
    objectives:
      - {name: settling, metric: settling_time_s, of: plant.y, goal: minimize}
    constraints:
      - {metric: overshoot_pct, of: plant.y, max: 5}
      - {analysis: phase_margin_deg, loop: force, min: 45}
    method: {name: differential_evolution, seed: 1, maxiter: 8, popsize: 5}

A quantity is a run's metric (``metric: NAME``: :func:`hybridsim.analysis.metrics.compute`
from the diagram's ``signals``), a step-response measure of a logged signal
(``metric: NAME, of: SIGNAL``: :func:`control.step_info`), or one of the
linearized closed loop (``analysis: NAME``, with ``loop:`` for margins). Over
several runs (variants) it is reduced to its worst case: the largest for a
minimised objective or an upper bound, the smallest otherwise (``reduce:``
max, min or mean says otherwise). Every mistake is an InputError naming the
file and line.
"""
import itertools
import logging
import math
from pathlib import Path

from hybridsim import limits
from hybridsim.engine.registry import closest
from hybridsim.errors import InputError, LoaderError, RateError
from hybridsim.format import parse_file
from hybridsim.format.identity import given_once
from hybridsim.format.filekinds import refuse_kind
from hybridsim.format.yamlio import as_path, key_line, not_a_file
from hybridsim.runs.sweep import INSIDE
from hybridsim.tune.space import SCALES, Parameter

TUNE_KEYS = ("diagram", "set", "variants", "parameters", "objectives", "constraints", "method", "compiled")
PARAM_KEYS = ("low", "high", "scale", "integer", "values", "repeat")
QUANTITY_KEYS = ("name", "metric", "of", "analysis", "loop", "goal", "max", "min", "reduce", "after",
                 "reference", "final", "settling")
#: measures of a step response (control.step_info's keys) and of the linearized loop
STEP_MEASURES = {"rise_time_s": "RiseTime", "settling_time_s": "SettlingTime", "overshoot_pct": "Overshoot",
                 "undershoot_pct": "Undershoot", "peak": "Peak", "peak_time_s": "PeakTime",
                 "steady_state": "SteadyStateValue", "steady_error": None}
ANALYSIS_MEASURES = ("largest_abs_z", "gain_margin_db", "phase_margin_deg", "gain_crossover_hz",
                     "phase_crossover_hz")
METHODS = {"differential_evolution": ("seed", "maxiter", "popsize", "tol"),
           "nelder_mead": ("maxiter",),
           "tpe": ("seed", "trials"),
           "nsga2": ("seed", "trials", "population")}
GOALS = {"minimize": "min", "min": "min", "maximize": "max", "max": "max"}
REDUCE = ("max", "min", "mean")


def _lines_of(mapping, line):
    """``at(key)``: the line where ``key`` of a parsed ``mapping`` is written, else ``line``."""
    return lambda key: key_line(mapping, key) or line


class Quantity:
    """A measured quantity: an objective (``goal``) or a constraint (``upper``/``lower`` bounds)."""

    def __init__(self, **kw):
        self.name = kw["name"]
        self.metric, self.signal, self.analysis, self.loop = kw.get("metric"), kw.get("of"), kw.get("analysis"), \
            kw.get("loop")
        self.goal, self.upper, self.lower = kw.get("goal"), kw.get("max"), kw.get("min")
        self.after = float(kw.get("after") or 0.0)
        self.reference, self.final, self.settling = kw.get("reference"), kw.get("final"), kw.get("settling")
        self.reduce = kw.get("reduce") or self._worst()
        self.line = kw.get("line")

    def _worst(self):
        if self.goal is not None:
            return "max" if self.goal == "min" else "min"
        return "max" if self.upper is not None else "min"

    @property
    def source(self):
        """'analysis', 'step' (a measure of a logged signal) or 'metric' (a run's metrics)."""
        return "analysis" if self.analysis else ("step" if self.signal else "metric")

    def violation(self, value):
        """How far ``value`` is outside the bounds, relative to the bound (0 inside; inf for no value)."""
        if value is None or (isinstance(value, float) and math.isnan(value)):
            return math.inf
        out = 0.0
        if self.upper is not None and value > self.upper:
            out += (value - self.upper) / max(abs(self.upper), 1e-12)
        if self.lower is not None and value < self.lower:
            out += (self.lower - value) / max(abs(self.lower), 1e-12)
        return out

    def describe(self):
        """A short text: 'settling_time_s of plant.y (worst max)'."""
        what = self.analysis or self.metric
        where = f" of {self.signal}" if self.signal else (f" at loop {self.loop}" if self.loop else "")
        return f"{what}{where}"


class TuneSpec:
    """A parsed tune file (see the module doc); raises LoaderError with file and line."""

    def __init__(self, path):
        self.path = as_path(path, "a tune file")
        data, _ = parse_file(self.path, what="a tune file is a mapping with 'diagram', 'parameters' and "
                                             "'objectives'")
        refuse_kind(data, "tune", self.path)
        self.text = self.path.read_text()
        lines = data.lines
        for key in data:
            if key not in TUNE_KEYS:
                self._fail(f"unknown tune key {key!r}{closest(key, TUNE_KEYS)}; keys: {', '.join(TUNE_KEYS)}",
                           key_line(data, key))
        for key in data:  # read as absent it was a default the file did not give (objectives: a crash)
            if data[key] is None:
                self._fail(f"tune key {key!r} is empty (null): give its value"
                           + ("" if key in ("diagram", "parameters", "objectives") else ", or leave the key out"),
                           key_line(data, key))
        for key in ("diagram", "parameters", "objectives"):
            if key not in data:
                self._fail(f"a tune file needs {key!r}", 1)
        if not isinstance(data["diagram"], str) or not data["diagram"]:
            self._fail(f"'diagram' must be a file name, got {data['diagram']!r}", lines["diagram"])
        self.diagram = (self.path.parent / data["diagram"]).resolve()
        why = not_a_file(self.diagram)
        if why:
            self._fail(f"'diagram' {data['diagram']!r}: {why}", lines["diagram"])
        for key in ("set", "variants", "parameters", "method"):
            if data.get(key) is not None and not isinstance(data[key], dict):
                self._fail(f"'{key}' must be a mapping", lines[key])
        for key in ("objectives", "constraints"):
            if data.get(key) is not None and not isinstance(data[key], list):
                self._fail(f"'{key}' must be a list of mappings", lines[key])
        if "compiled" in data and not isinstance(data["compiled"], bool):
            self._fail(f"'compiled' must be true or false, got {data['compiled']!r}", lines["compiled"])
        self.fixed = {str(k): v for k, v in (data.get("set") or {}).items()}
        if data.get("compiled"):
            self.fixed["simulation.compiled"] = True
        self.variants = self._variants(data.get("variants") or {}, lines.get("variants"))
        self._variant_lines = getattr(data.get("variants"), "lines", None) or {}
        given_once(self.path, [(k, data.get(k)) for k in ("set", "variants", "parameters")])
        self.parameters = self._parameters(data["parameters"], lines["parameters"])
        self.objectives = self._quantities(data["objectives"], lines["objectives"], objective=True)
        self.constraints = self._quantities(data.get("constraints") or [], lines.get("constraints"), objective=False)
        if not 1 <= len(self.objectives) <= 2:
            self._fail(f"give one or two objectives, got {len(self.objectives)}", lines["objectives"])
        names = [q.name for q in self.objectives + self.constraints]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            self._fail(f"quantity names must differ: {dup} (give each a 'name')", lines["objectives"])
        self.method, self.options = self._method(data.get("method") or {}, lines.get("method", 1))
        if len(self.objectives) == 2 and self.method not in ("tpe", "nsga2"):
            self._fail(f"two objectives need method tpe or nsga2 (Optuna), not {self.method!r}",
                       lines.get("method", lines["objectives"]))
        if len(self.objectives) == 1 and self.method == "nsga2":
            logging.getLogger("hybridsim").warning(
                "%s:%s: nsga2 with one objective is a plain genetic search (no front to find); tpe or "
                "differential_evolution usually need fewer runs", self.path, lines.get("method", 1))

    def _fail(self, message, line=None):
        raise LoaderError(message, self.path, line)

    def _variants(self, spec, line):
        for k, v in spec.items():
            if not isinstance(v, list) or not v:
                self._fail(f"variants {k!r}: give a non-empty list of values", spec.lines[k])
        combos = [dict(zip(spec, c)) for c in itertools.product(*spec.values())] if spec else [{}]
        if len(combos) > limits.MAX_VARIANTS:
            self._fail(f"'variants' makes {len(combos)} runs per point; at most {limits.MAX_VARIANTS}", line)
        return combos

    def _parameters(self, spec, line):
        if not spec:
            self._fail("'parameters' is empty: name at least one parameter to search", line)
        out = []
        for path, p in spec.items():
            ln = spec.lines[path]
            if not isinstance(p, dict):
                self._fail(f"parameter {path!r}: give a mapping such as {{low: 1, high: 10}}", ln)
            at = _lines_of(p, ln)
            bad = [k for k in p if k not in PARAM_KEYS]
            if bad:
                self._fail(f"parameter {path!r}: unknown key {bad[0]!r}{closest(bad[0], PARAM_KEYS)}; keys: "
                           f"{', '.join(PARAM_KEYS)}", at(bad[0]))
            rep = p.get("repeat")
            if rep is not None and (isinstance(rep, bool) or not isinstance(rep, int) or rep < 1):
                self._fail(f"parameter {path!r}: repeat must be a whole number >= 1, got {rep!r}", at("repeat"))
            if "values" in p:
                if set(p) & {"low", "high", "scale", "integer"}:
                    self._fail(f"parameter {path!r}: give either 'values' or bounds, not both", ln)
                if not isinstance(p["values"], list) or not p["values"]:
                    self._fail(f"parameter {path!r}: 'values' must be a non-empty list", at("values"))
                out.append(Parameter(str(path), values=list(p["values"]), repeat=rep))
                continue
            lo, hi = p.get("low"), p.get("high")
            if not (_finite(lo) and _finite(hi) and lo < hi):
                self._fail(f"parameter {path!r}: give finite bounds low < high, got low={lo!r}, high={hi!r}", ln)
            scale = p.get("scale", "linear")
            if scale not in SCALES:
                self._fail(f"parameter {path!r}: scale must be one of {', '.join(SCALES)}, got {scale!r}"
                           f"{closest(scale, SCALES)}", at("scale"))
            if scale == "log" and lo <= 0:
                self._fail(f"parameter {path!r}: a log scale needs low > 0, got {lo!r}", ln)
            integer = p.get("integer", False)
            if not isinstance(integer, bool):
                self._fail(f"parameter {path!r}: integer must be true or false, got {integer!r}", at("integer"))
            if integer and (lo != int(lo) or hi != int(hi)):
                self._fail(f"parameter {path!r}: an integer parameter needs whole-number bounds", ln)
            out.append(Parameter(str(path), float(lo), float(hi), scale, integer, repeat=rep))
        return out

    def _quantities(self, items, line, objective):
        out = []
        for k, q in enumerate(items):
            ln = items.lines[k] if getattr(items, "lines", None) else line
            if not isinstance(q, dict):
                self._fail("each objective and constraint is a mapping such as {metric: overshoot_pct, max: 5}", ln)
            at = _lines_of(q, ln)
            bad = [k for k in q if k not in QUANTITY_KEYS]
            if bad:
                self._fail(f"unknown key {bad[0]!r}{closest(bad[0], QUANTITY_KEYS)}; keys: "
                           f"{', '.join(QUANTITY_KEYS)}", at(bad[0]))
            if ("metric" in q) == ("analysis" in q):
                self._fail("give exactly one of 'metric' (a run's) or 'analysis' (the linearized loop's)", ln)
            kw = {k2: v for k2, v in q.items()}
            if "analysis" in q:
                if q["analysis"] not in ANALYSIS_MEASURES:
                    self._fail(f"analysis {q['analysis']!r}{closest(q['analysis'], ANALYSIS_MEASURES)}: one of "
                               f"{', '.join(ANALYSIS_MEASURES)}", at("analysis"))
                if q["analysis"] != "largest_abs_z" and not q.get("loop"):
                    self._fail(f"analysis {q['analysis']!r} needs 'loop' (a name in the diagram's "
                               "analysis.points, or a signal)", ln)
                if "of" in q:
                    self._fail("'of' (a signal) goes with 'metric', not 'analysis'", ln)
            elif "of" in q and q["metric"] not in STEP_MEASURES:
                self._fail(f"metric {q['metric']!r} of a signal{closest(q['metric'], STEP_MEASURES)}: one of "
                           f"{', '.join(STEP_MEASURES)}", at("metric"))
            for key in ("max", "min", "after", "final", "settling"):
                if key in q and not _finite(q[key]):
                    self._fail(f"{key!r} must be a finite number, got {q[key]!r}", at(key))
            if "settling" in q and not 0 < q["settling"] < 1:
                self._fail(f"'settling' is the band as a fraction of the step (0.02 for 2 %), above 0 and "
                           f"below 1, got {q['settling']!r}", at("settling"))
            if "after" in q and q["after"] < 0:
                self._fail(f"'after' is when the step is applied, s (0 or later), got {q['after']!r}", at("after"))
            if objective:
                if q.get("goal") not in GOALS:
                    self._fail(f"an objective needs goal: minimize or maximize, got {q.get('goal')!r}"
                               f"{closest(q['goal'], GOALS) if 'goal' in q else ''}", at("goal"))
                if "max" in q or "min" in q:
                    self._fail("bounds ('max', 'min') go under 'constraints'", ln)
                kw["goal"] = GOALS[q["goal"]]
            else:
                if "goal" in q:
                    self._fail("a constraint has bounds ('max', 'min'), not a goal", ln)
                if "max" not in q and "min" not in q:
                    self._fail("a constraint needs 'max' or 'min'", ln)
                if "max" in q and "min" in q and q["min"] > q["max"]:
                    self._fail(f"a constraint's min ({q['min']!r}) exceeds its max ({q['max']!r}): no point "
                               "can meet it", ln)
            if "reduce" in q and q["reduce"] not in REDUCE:
                self._fail(f"reduce must be one of {', '.join(REDUCE)}, got {q['reduce']!r}"
                           f"{closest(q['reduce'], REDUCE)}", at("reduce"))
            kw.setdefault("name", q.get("analysis") or (f"{q['metric']}:{q['of']}" if "of" in q else q["metric"]))
            kw["line"] = ln
            out.append(Quantity(**kw))
        return out

    def _method(self, spec, line):
        name = spec.get("name", "differential_evolution")
        if name not in METHODS:
            self._fail(f"method {name!r}{closest(name, METHODS)}: one of {', '.join(METHODS)}",
                       spec.lines.get("name", line)
                       if hasattr(spec, "lines") else line)
        opts = {k: v for k, v in spec.items() if k != "name"}
        for k, v in opts.items():
            if k not in METHODS[name]:
                self._fail(f"method {name}: unknown option {k!r}{closest(k, ('name',) + METHODS[name])}; options: "
                           f"name, {', '.join(METHODS[name])}", key_line(spec, k))
            if k == "tol":
                if not (_finite(v) and v > 0):
                    self._fail(f"method {name}: tol must be a number > 0, got {v!r}", spec.lines[k])
            elif isinstance(v, bool) or not isinstance(v, int) or v < (0 if k == "seed" else 1) \
                    or v > limits.MAX_RUNS:
                self._fail(f"method {name}: {k} must be a whole number from {0 if k == 'seed' else 1} to "
                           f"{limits.MAX_RUNS}, got {v!r}", spec.lines[k])
        return name, opts

    def quantity_line(self, q):
        """'file:line' of a quantity, for messages."""
        return f"{self.path}:{q.line}" if q.line else str(self.path)

    def validate(self):
        """Check the diagram with ``set``, every variant and both ends (or every choice) of each parameter
        as a run would (:func:`hybridsim.format.build.check`), before any point runs."""
        from hybridsim.format.build import check, load
        from hybridsim.format.overrides import overrides_from

        try:
            with overrides_from("the tune file's"):
                f = load(self.diagram, **self.fixed)
                check(f)
        except InputError as exc:  # at the line of 'set' where there is one
            data, _ = parse_file(self.path)
            line = data.lines.get("set") if hasattr(data, "lines") and "set" in data else None
            named = next((k for k in self.fixed if f"the tune file's {k}:" in str(exc)), None)  # its own line
            if named is not None and isinstance(data.get("set"), dict):
                line = key_line(data["set"], named) or line
            raise LoaderError(f"the diagram{' with set' if line else ''}: {exc}", self.path, line) from None
        self._check_signals(*f.build(), alias=f._alias)
        for v in self.variants:
            try:
                with overrides_from("the tune file's"):
                    check(load(self.diagram, **{**self.fixed, **v}))
            except InputError as exc:  # at the line of the value the message names, else the first's
                key = next((k for k in v if f"the tune file's {k}:" in str(exc)), next(iter(v), None))
                raise LoaderError(f"variant {v}: {exc}", self.path, self._variant_lines.get(key)) from None
        for p in self.parameters:
            for value in [*p.ends(), p.from_unit(INSIDE)]:  # a value inside: a sample rate there is rarely
                try:  # commensurate
                    with overrides_from("the tune file's"):
                        check(load(self.diagram, **{**self.fixed, p.path: p.as_override(value)}))
                except InputError as exc:
                    hint = (" (a parameter that sets a sample rate needs whole values, integer: true, or a list, "
                            "values: [...])" if isinstance(exc, RateError) else "")
                    raise LoaderError(f"parameter {p.path} = {value!r}: {exc}{hint}", self.path,
                                      self._param_line(p)) from None
        together = {p.path: p.as_override(p.from_unit(INSIDE)) for p in self.parameters}
        try:  # all at once: one that a value using another sets (kp and pid.Kp = $kp) cancels it
            with overrides_from("the tune file's"):
                load(self.diagram, **{**self.fixed, **together})
        except InputError as exc:
            p = next((p for p in self.parameters if f"the tune file's {p.path}:" in str(exc)), self.parameters[0])
            raise LoaderError(f"the parameters together: {exc}", self.path, self._param_line(p)) from None

    def _check_signals(self, diagram, settings, alias=str):
        """Each step measure's signal (``of``, ``reference``) a logged output element of the diagram, and
        its ``after`` within the run (what a run would find only after it ran)."""
        from hybridsim.format.kinds import SIGNAL

        logged = {str(ref).split("[")[0] for ref in settings["log"]}
        t_end = float(settings["simulation"]["t_end"])
        measured = _metric_names(settings, t_end)
        points = (settings.get("analysis") or {}).get("points") or {}
        from hybridsim.analysis.linearize import hidden_state

        hidden = hidden_state(diagram.blocks.values())
        for q in self.objectives + self.constraints:
            if q.source == "analysis" and hidden:  # what a linearization would say, before any point runs
                self._fail(f"analysis {q.analysis!r}: {hidden}", q.line)
            if q.source == "analysis" and q.loop is not None:
                why = _port_problem(diagram, alias(str(points.get(q.loop, q.loop))))
                if why == "no such output":
                    why = (f"neither a name in {self.diagram.name}'s analysis.points ({', '.join(points) or 'none'}) "
                           "nor an output block.port[i] of it")
                if why:
                    self._fail(f"loop {q.loop!r}: {why}", q.line)
            if q.source == "metric" and measured is not None and q.metric not in measured:
                self._fail(f"metric {q.metric!r}: the runs of {self.diagram.name} measure "
                           f"{', '.join(sorted(measured)) or 'no metric'} (its signals and metrics sections say "
                           "which; a signal's step measure takes 'of')", q.line)
            if q.source != "step":
                continue
            if q.after >= t_end:
                self._fail(f"'after' {q.after:g} s is not before the run's end ({t_end:g} s)", q.line)
            for key, ref in (("of", q.signal), ("reference", q.reference)):
                if ref is None:
                    continue
                why = _port_problem(diagram, alias(str(ref)))  # a subsystem's port: its inner output
                if why == "no such output":
                    why = f"no output of that name in {self.diagram.name} (block.port or block.port[i])"
                if why:
                    self._fail(f"{key} {ref!r}: {why}", q.line)
                m = SIGNAL.match(alias(str(ref)))
                if logged and f"{m.group(1)}.{m.group(2)}" not in logged:
                    self._fail(f"{key} {ref!r}: not logged by {self.diagram.name} (add it to its 'log')", q.line)

    def _param_line(self, p):
        data, _ = parse_file(self.path)
        return data["parameters"].lines.get(p.path)


def _port_problem(diagram, ref):
    """What is wrong with signal ``ref`` (``block.port`` or ``block.port[i]``) of the built diagram:
    "no such output", its element out of range, or None."""
    from hybridsim.format.kinds import SIGNAL

    m = SIGNAL.match(ref)
    block = diagram.blocks.get(m.group(1)) if m else None
    port = next((p for p in block.outputs if p.name == m.group(2)), None) if block else None
    if port is None:
        return "no such output"
    if m.group(3) is not None and int(m.group(3)) >= port.width:
        return f"{m.group(1)}.{m.group(2)} has {port.width} element(s)"
    return None


def _finite(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def load_tune(path):
    """Parse and check a tune file; returns a :class:`TuneSpec` (LoaderError/InputError on a bad one)."""
    spec = TuneSpec(path)
    spec.validate()
    return spec


def _metric_names(settings, t_end):
    """The names of the metrics a run of a diagram with these settings gives (from its signal roles, on
    a stand-in run of zeros), or None when that cannot be told without running."""
    import numpy as np

    from hybridsim.analysis import metrics
    from hybridsim.engine.result import Result

    t = np.linspace(0.0, t_end, 201)
    stand_in = Result(t, {ref: np.zeros((t.size, 1)) for ref in settings["signals"].values()}, {})
    try:
        with np.errstate(all="ignore"):
            return set(metrics.compute(stand_in, settings["signals"], settings["metrics"])) | {"wall_time_s"}
    except Exception:  # noqa: BLE001 - a metric set that needs real numbers: the run will say
        return None
