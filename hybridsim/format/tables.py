"""One declarative table per section of the file formats: key, kind (type and range), default, doc.

The same tables drive validation (:func:`problems`, with file:line and "did
you mean"), the JSON Schema (:mod:`hybridsim.format.schema`), the Python API's
defaults (:func:`defaults`), ``hybridsim --help`` and ``docs/settings.md``
(:func:`markdown`).

The generic tables name only what the generic layers read. A wing adds its own
keys to a section with :func:`extend` when it is imported: the signal roles of
``signals`` (none are generic), the settings of its metrics, figures and
analysis results (:mod:`hybridsim.forcecontrol` adds those of force control).
"""
import copy
from dataclasses import dataclass, replace

from hybridsim import limits
from hybridsim.engine.registry import closest
from hybridsim.format.kinds import REF_SCHEMA, Bool, Choice, Either, Kind, ListOf, MapOf, Number, PathText, Port, Signal, Text
from hybridsim.format.yamlio import key_file, key_line

# documented: the tables and functions (Setting's fields would shadow other names in the API pages)
__all__ = ["SIMULATION", "SIGNALS", "METRICS", "PLOT", "ANALYSIS", "ANALYSIS_STEP", "SWEEP", "SWEEP_RANDOM", "DIAGRAM",
           "BLOCK_SETTINGS", "SECTIONS", "SOLVERS", "Record", "extend", "keys", "defaults", "check_values", "problems",
           "section_schema", "markdown", "help_text"]

SOLVERS = ["rk4", "heun", "radau", "bdf", "lsoda", "rk45", "rk23", "dop853", "cvode"]
FIXED_STEP_SOLVERS = ("rk4", "heun")
#: MATLAB / Simulink solver names and what to give here
MATLAB_SOLVERS = {
    "ode45": "rk45 (Dormand-Prince 5(4), as ode45) or dop853", "ode23": "rk23 (Bogacki-Shampine, as ode23)",
    "ode113": "lsoda (Adams while not stiff)", "ode15s": "cvode or bdf (variable-order BDF, as ode15s)",
    "ode15i": "cvode", "ode23s": "radau (implicit, for stiff problems)", "ode23t": "radau", "ode23tb": "radau",
    "ode1": "heun or rk4 (fixed steps; there is no Euler)", "ode2": "heun (as ode2)", "ode3": "heun or rk4",
    "ode4": "rk4 (as ode4)", "ode5": "rk4, or dop853 with steps chosen by tolerance", "ode8": "dop853",
    "ode14x": "radau or bdf (implicit; there are no fixed-step implicit solvers)", "daessc": "cvode",
    "euler": "heun or rk4 (fixed steps; there is no Euler)",
}


@dataclass(frozen=True)
class Setting:
    """One key of a section: its kind (type and range), default and a one-line doc.

    ``owner``: the package that added the key with :func:`extend` ("" for the generic ones).
    ``in_run``: a time the run must reach: ``"instant"`` (before ``t_end``), ``"span"`` (no longer
    than the run) or ``"window"`` (``[t0, t1]`` inside it); checked against ``simulation.t_end``.
    """

    key: str
    kind: Kind
    default: object
    doc: str
    required: bool = False
    owner: str = ""
    in_run: str = ""


class Record(Kind):
    """A mapping with its own table of settings (checked by :func:`check_values`)."""

    def __init__(self, table, name, text=None):
        self.table, self.name = table, name
        self.text = text or f"a mapping of {name} settings"

    def problem(self, v):
        if not isinstance(v, dict):
            return self._got(v)
        got = check_values(self.table, v, self.name)
        return "; ".join(msg for msg, _ in got) or None

    def schema(self):
        return section_schema(self.table)


_POS = Number(0, low_open=True)
_TIME = Number(0, low_open=True, unit="s")
_OVERRIDES = MapOf(Kind(), keys=PathText(), what="parameter path")

SIMULATION = [
    Setting("t_end", _TIME, 1.0, "end time of a run"),
    Setting("solver", Choice(SOLVERS, MATLAB_SOLVERS), "rk4", "integrator: fixed-step rk4/heun, a scipy solve_ivp method, or cvode (SUNDIALS BDF)"),
    Setting("step", _TIME, 1e-4, "fixed step of rk4 and heun"),
    Setting("rtol", _POS, 1e-8, "relative tolerance of the scipy solvers"),
    Setting("atol", Either(_POS, ListOf(_POS)), 1e-10,
            "absolute tolerance of the scipy solvers and cvode: one per state, or a number (every state's "
            "when given, a block's own tighter ones kept; unset, blocks' own tolerances stand for their states)"),
    Setting("max_step", Number(0, low_open=True, inf=True, unit="s"), float("inf"),
            "largest step of the scipy solvers"),
    Setting("log_period", _TIME, 0.0005, "interval of the logged rows"),
    Setting("scan", _TIME, 1e-3, "longest stretch between two checks of the event functions inside one step "
            "(a function that crosses and crosses back between two checks is missed); raise it for long runs"),
    Setting("max_state", _POS, 1e6, "a state larger than this in magnitude ends the run as diverged"),
    Setting("fused", Bool(), True, "evaluate the continuous blocks as one generated function"),
    Setting("compiled", Bool(), False, "run the whole loop compiled with numba (rk4; blocks need kernels)"),
    Setting("locate_switches", Bool(), False, "locate the switches of piecewise blocks within a step"),
]

#: the signal roles: ``signals: {role: signal}`` names the signals that figures and metrics read
SIGNALS = []

#: the settings of the metrics (:mod:`hybridsim.analysis.metrics`; a wing adds those of its own)
METRICS = []

PLOT = [
    Setting("title", Text(), None, "the figure's title (default: the description, else the name)"),
]

ANALYSIS_STEP = [
    Setting("input", Signal(), None, "the input of the step (a source's output)", required=True),
    Setting("output", Signal(), None, "the signal whose response is shown", required=True),
    Setting("size", Number(), 1.0, "size of the step (units of the input)"),
    Setting("ticks", Number(1, 100_000, integer=True), 40, "sample periods shown"),
    Setting("set", _OVERRIDES, {}, "overrides of the nonlinear run that make the same step"),
]

ANALYSIS = [
    Setting("set", _OVERRIDES, {}, "the branch to linearize on: {parameter path: value}"),
    Setting("points", MapOf(Signal()), {}, "loop openings: {name: signal}"),
    Setting("rate_param", Text(nonempty=True), "rate", "the name in 'params' that sets the servo rate"),
    Setting("rates", ListOf(Number(0, low_open=True, unit="Hz")), [30, 45, 60, 80, 120, 240, 480],
            "servo rates of the rate sweep"),
    Setting("gains", MapOf(PathText(blocks_only=True)), {}, "gains of the gain sweep: {name: block parameter path}"),
    Setting("scales", ListOf(_POS), [0.125, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0], "factors of the gain sweep"),
    Setting("cases", MapOf(_OVERRIDES), {}, "other branches: {name: {parameter path: value}}"),
    Setting("at", Number(0, unit="s", text="a time in seconds >= 0"), None, "linearize about the state at this time (default: the initial)"),
    Setting("compare", MapOf(_OVERRIDES), {}, "the report's other settings: {name: {parameter path: value}}"),
    Setting("step", Record(ANALYSIS_STEP, "analysis.step"), None,
            "the report's linear vs nonlinear closed-loop step"),
]

SWEEP_RANDOM = [
    Setting("n", Number(1, limits.MAX_RUNS, integer=True), 10, "points drawn"),
    Setting("seed", Number(0, integer=True), 0, "seed of numpy's generator"),
    Setting("ranges", MapOf(ListOf(Number(), exact=2), keys=PathText(), what="parameter path"), None,
            "{parameter path: [low, high]}, uniform", required=True),
]

SWEEP = [
    Setting("diagram", Text(nonempty=True), None, "the diagram file, relative to the sweep file", required=True),
    Setting("set", _OVERRIDES, {}, "overrides fixed for every point"),
    Setting("grid", MapOf(ListOf(Kind()), keys=PathText(), what="parameter path"), {},
            "full factorial: {parameter path: [values]}"),
    Setting("scale", MapOf(ListOf(Number()), keys=PathText(), what="parameter path"), {},
            "multiples of a parameter's value: {parameter path: [factors]}"),
    Setting("random", Record(SWEEP_RANDOM, "random"), None, "seeded uniform samples"),
    Setting("traces", Bool(), False, "also keep each run's CSV"),
    Setting("stability", Bool(), False, "also the linearized closed loop's largest |z|"),
]

#: the top-level sections of a diagram file (the kind checks only the shape; each has its own check)
DIAGRAM = [
    Setting("extends", Text(nonempty=True), None, "a diagram file this one starts from (relative to it)"),
    Setting("name", Text(), None, "the diagram's name (default: the file's stem)"),
    Setting("description", Text(), "", "one line shown in figures and reports"),
    Setting("params", MapOf(), {}, "named values; '$name' anywhere below refers to one"),
    Setting("blocks", MapOf(nonempty=True), None, "{name: {type: ..., parameter: value}}", required=True),
    Setting("wires", ListOf(Kind(), min_len=0), [], "'a.out -> b.in' or [a.out, b.in]"),
    Setting("simulation", Record(SIMULATION, "simulation"), {}, "how a run is integrated and logged"),
    Setting("log", ListOf(Signal(), min_len=0), [], "signals logged"),
    Setting("signals", Record(SIGNALS, "signals", "a mapping {role: a signal 'block.port[i]'}"), {}, "roles for figures and metrics: {role: signal}"),
    Setting("metrics", Record(METRICS, "metrics"), {}, "settings of the figures of merit"),
    Setting("variants", MapOf(ListOf(Kind())), {}, "a grid of runs: {name in params: [values]}"),
    Setting("plot", Record(PLOT, "plot"), {}, "the figure's title and panel names"),
    Setting("analysis", Record(ANALYSIS, "analysis"), {}, "settings of analyze and report"),
    Setting("inputs", MapOf(Either(Port(), ListOf(Port()))), {},
            "a subsystem's inputs: {name: inner input or [inputs]}"),
    Setting("outputs", MapOf(Port()), {}, "a subsystem's outputs: {name: inner output}"),
]

#: the sections read where a file is used as a subsystem; the others only where it runs on its own
SUBSYSTEM_SECTIONS = ("extends", "name", "description", "params", "blocks", "wires", "inputs", "outputs")

_VEC = Either(Number(), ListOf(Number()))
_NONNEG_VEC = Either(Number(0), ListOf(Number(0)))
_ROBOT = [
    Setting("urdf", Text(nonempty=True), None, "a robot model file (relative: to the working folder)"),
    Setting("robot", Text(nonempty=True), None, "a shipped robot by name (ur5, panda, ...: the robot_arm block's docs list them)"),
    Setting("frame", Text(nonempty=True), None, "the tool frame (default: the model's last frame)"),
]

#: parameters of the shipped FMU and robot block types, checked before the block is built
BLOCK_SETTINGS = {
    "fmu": [
        Setting("path", Text(nonempty=True), None, "the .fmu file (relative: to the working folder)", required=True),
        Setting("mode", Choice(["cs", "me"]), "cs", "Co-Simulation (needs rate or period) or Model Exchange"),
        Setting("parameters", MapOf(what="variable name"), None, "start values to set: {variable name: value} "
                "(checked by the block against the FMU's variables; --set BLOCK.parameters.NAME=VALUE sets one)"),
        Setting("rate", Number(0, low_open=True, unit="Hz"), None, "sample rate of a Co-Simulation FMU"),
        Setting("period", Number(0, low_open=True, unit="s"), None, "sample period of a Co-Simulation FMU"),
    ],
    "robot_arm": _ROBOT + [
        Setting("q0", _VEC, None, "initial joint positions (rad or m; default the neutral pose)"),
        Setting("qd0", _VEC, None, "initial joint speeds"),
        Setting("damping", _NONNEG_VEC, 0.0, "viscous joint damping (scalar or one per joint)"),
        Setting("friction", Bool(), False, "joint friction on"),
        Setting("tau_c", _NONNEG_VEC, 0.0, "Coulomb friction per joint"),
        Setting("tau_s", _NONNEG_VEC, 0.0, "static friction per joint"),
        Setting("stick_band", Number(0, low_open=True), 1e-4, "Karnopp capture band (rad/s or m/s)"),
        Setting("stick_time", Number(0, low_open=True, unit="s"), 1e-3, "time constant of a stuck joint"),
        Setting("gravity", ListOf(Number(), exact=3), [0.0, 0.0, -9.81], "gravity in the base frame (m/s^2)"),
        Setting("start_position", ListOf(Number(), exact=3), None, "start with the tool frame's origin here (m)"),
        Setting("friction_model", Choice(["karnopp", "stribeck", "lugre"]), "karnopp", "the friction law"),
        Setting("stribeck_velocity", Either(_POS, ListOf(_POS)), 1e-3, "speed scale of the Stribeck decay"),
        Setting("bristle_stiffness", _POS, 1e5, "LuGre sigma0"),
        Setting("bristle_damping", Number(0), None, "LuGre sigma1 (default critical)"),
    ],
    "robot_kinematics": list(_ROBOT),
    "gravity_torque": _ROBOT[:2] + [
        Setting("gravity", ListOf(Number(), exact=3), [0.0, 0.0, -9.81], "gravity in the base frame (m/s^2)")],
}

SECTIONS = {"diagram": DIAGRAM, "simulation": SIMULATION, "signals": SIGNALS, "metrics": METRICS, "plot": PLOT,
            "analysis": ANALYSIS, "analysis.step": ANALYSIS_STEP, "sweep": SWEEP, "random": SWEEP_RANDOM}


def outside_run(table, values, t_end, times=None):
    """``[(key, why)]`` for the times in ``values`` (a section's settings) that the run does not reach,
    by the ``in_run`` of each row of ``table`` (``times``: the run's logged times, which a window
    must hold one of)."""
    out = []
    for row in table:
        v = values.get(row.key)
        if not row.in_run or v is None:
            continue
        if row.in_run == "instant" and not float(v) < t_end:
            out.append((row.key, f"{v:g} s is not before the end of the run (t_end {t_end:g} s)"))
        elif row.in_run == "span" and float(v) > t_end:
            out.append((row.key, f"{v:g} s is longer than the run (t_end {t_end:g} s)"))
        elif row.in_run == "window" and (float(v[0]) >= t_end or float(v[1]) > t_end):
            out.append((row.key, f"[{float(v[0]):g}, {float(v[1]):g}] s does not lie within the run "
                                 f"(t_end {t_end:g} s)"))
        elif row.in_run == "window" and times is not None and not any(v[0] <= t <= v[1] for t in times):
            out.append((row.key, f"[{float(v[0]):g}, {float(v[1]):g}] s holds no logged time (widen it, "
                                 "or log more often: simulation.log_period)"))
    return out


def extend(section, settings, owner):
    """Add ``settings`` (:class:`Setting` rows) to the table of ``section`` (a key of :data:`SECTIONS`).

    Parameters
    ----------
    section : str
        e.g. ``"signals"``, ``"metrics"``, ``"plot"``, ``"analysis"``.
    settings : list of Setting
        The new keys; a key the section has already is refused, unless it is the same row
        (importing a wing twice adds nothing).
    owner : str
        The package that adds them (``__name__``), shown in ``docs/settings.md``.
    """
    table = SECTIONS[section]
    for s in settings:
        s = replace(s, owner=owner)
        old = next((t for t in table if t.key == s.key), None)
        if old == s:
            continue
        if old is not None:
            raise ValueError(f"{owner}: {section} setting {s.key!r} is {old.owner or 'generic'}'s already")
        table.append(s)


def keys(table):
    return [s.key for s in table]


def defaults(table):
    """``{key: default}`` of a table (the Python API's defaults)."""
    return {s.key: copy.deepcopy(s.default) for s in table}


def _shown(value):
    """A default as a file writes it."""
    return "[]" if value == [] else "{}" if value == {} else ".inf" if value == float("inf") else \
        str(value).lower() if isinstance(value, bool) else f"{value:g}" if isinstance(value, float) else repr(value)


def check_values(table, data, section, lines=None):
    """Problems of mapping ``data`` against ``table``: a list of (message, key).

    Unknown keys (with the closest known one), missing required keys and
    values of the wrong kind or out of range.
    """
    by_key = {s.key: s for s in table}
    out = []
    for key, value in data.items():
        s = by_key.get(key)
        if s is not None and value is None and not s.required:
            if s.default is not None:  # read as the default it was not (a file undoes its base's with null)
                out.append((f"{section} setting {key!r} is empty (null): give {s.kind.text}, or leave the key "
                            f"out (default: {_shown(s.default)})", key))
            continue
        if s is None:
            out.append((f"unknown {section} setting {key!r}{closest(key, by_key)}; settings: "
                        f"{', '.join(by_key)}", key))
            continue
        why = s.kind.problem(value)
        if why and isinstance(s.kind, Choice) and isinstance(value, (str, int, float)):  # a word misspelled
            hint = s.kind.hints.get(str(value).lower())
            out.append((f"unknown {s.key} {value!r}"
                        + (f" (here: {hint})" if hint else closest(str(value).lower(), s.kind.options))
                        + f"; {s.key}s: {', '.join(s.kind.options)}", key))
        elif why:
            out.append((f"{section} setting {key!r} {why}" if why.startswith("must") else
                        f"{section} setting {key!r}: {why}", key))
    for s in table:
        if s.required and s.key not in data:
            out.append((f"{section} needs {s.key!r} ({s.doc})", None))
    return out


def problems(table, data, section, path, lines=None, line0=None, parsed=None):
    """:func:`check_values` as 'file:line: message' texts (the line of each key where known; ``parsed``:
    the mapping as read, with its lines, where ``data`` is its values resolved)."""
    parsed = data if parsed is None else parsed
    lines = lines if lines is not None else (getattr(data, "lines", None) or {})
    line0 = line0 if line0 is not None else getattr(data, "line", None)
    out = []
    known = {s.key for s in table}
    for msg, key in check_values(table, data, section):
        line = lines.get(key, line0) if key is not None else line0
        if key is not None and key not in known:  # an unknown key: where it is written
            line = key_line(parsed, key) or line
        if key is not None and isinstance(data, dict):
            line = _entry_line(parsed.get(key), msg) or _record_line(table, key, parsed.get(key)) or line
        out.append(f"{key_file(parsed, key, path)}{f':{line}' if line else ''}: {msg}")
    return out


def _record_line(table, key, value):
    """The line of the first key with a problem inside the setting ``key`` of ``table`` where its
    kind is a :class:`Record` (a sweep's ``random``), or None."""
    kind = next((s.kind for s in table if s.key == key), None)
    if not isinstance(kind, Record) or not isinstance(value, dict):
        return None
    inner = [k for _, k in check_values(kind.table, value, kind.name) if k is not None]
    return key_line(value, inner[0]) if inner else None


def _entry_line(value, msg):
    """The line of the deepest entry of a mapping-valued setting that ``msg`` names as ``'name':``,
    or None."""
    if not isinstance(value, dict):
        return None
    lines = getattr(value, "lines", None) or {}
    named = [k for k in value if f"{str(k)!r}:" in msg]
    for k in named:
        inner = _entry_line(value[k], msg)
        if inner:
            return inner
    return lines.get(named[0]) if named else None


def section_schema(table):
    """The JSON Schema of one section (closed: unknown keys are refused)."""
    props = {}
    for s in table:
        sch = s.kind.schema()
        kinds = [sch, REF_SCHEMA] + ([] if s.required else [{"type": "null"}])  # null: the default
        props[s.key] = {"anyOf": kinds} if sch else {}
        props[s.key]["description"] = s.doc
    return {"type": "object", "properties": props, "additionalProperties": False,
            "required": [s.key for s in table if s.required]}


def _default_text(v):
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "true" if v else "false"
    if v == float("inf"):
        return ".inf"
    return f"`{v}`" if not isinstance(v, str) else f"`{v!r}`"


def _rows(table):
    """A table's rows of the settings page."""
    out = ["| key | value | default | meaning |", "|---|---|---|---|"]
    for s in table:
        cells = [f"`{s.key}`" + (" (required)" if s.required else ""), s.kind.text, _default_text(s.default),
                 s.doc + (f" (from `{s.owner}`)" if s.owner else "")]
        out.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    return out + [""]


def markdown():
    """The text of ``docs/settings.md``: every table, and the limits."""
    out = ["# Settings", "",
           "Every section of a diagram file and of a sweep file, generated from the tables in",
           "`hybridsim/format/tables.py` and the keys the packages of a wing add to them",
           "(the same tables check a file, give the JSON Schema and the Python API's defaults).",
           "A test checks that this page is current.", ""]
    titles = {"diagram": "Sections of a diagram file", "simulation": "simulation", "signals": "signals (roles)",
              "metrics": "metrics", "plot": "plot", "analysis": "analysis", "analysis.step": "analysis: step",
              "sweep": "A sweep file", "random": "sweep: random"}
    for name, table in SECTIONS.items():
        out += [f"## {titles[name]}", ""] + _rows(table)
    for tname, table in BLOCK_SETTINGS.items():
        out += [f"## Block type {tname}", ""] + _rows(table)
    out += ["## Limits", "",
            "Checked before any work starts. Each can be changed for one command with its environment",
            "variable, e.g. `HYBRIDSIM_MAX_STEPS=1e9 hybridsim run d.yaml`.", "",
            "| variable | default | bounds |", "|---|---|---|"]
    for name, (value, doc) in limits.LIMITS.items():
        out.append(f"| `{limits.env_name(name)}` | {value:,} | {doc} |")
    from hybridsim.errors import EXIT_CODES

    out += ["", "## Exit status", "", "By origin (`hybridsim/errors.py`):", "",
            "| status | origin | when |", "|---|---|---|"]
    out += [f"| {code} | {origin} | {what} |" for code, origin, what in EXIT_CODES]
    out.append("")
    return "\n".join(out)


def help_text(table):
    """'t_end, solver, ...' for --help."""
    return ", ".join(keys(table))
