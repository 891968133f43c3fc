"""The signal roles of force control, and the settings of its metrics, figure and analysis.

Added to the generic tables of :mod:`hybridsim.format.tables` when imported, so a
diagram's ``signals``, ``metrics``, ``plot`` and ``analysis`` sections are checked,
documented (docs/settings.md) and given a JSON Schema like every other key.
"""
from hybridsim.format.kinds import ListOf, Number, Signal, Text
from hybridsim.format.tables import Setting, extend

#: the cutoff of the display filter (Hz): the paper draws force after a 12 Hz low-pass
DISPLAY_CUTOFF_HZ = 12.0

ROLES = [
    Setting("force", Signal(), None, "the measured force (N)"),
    Setting("force_desired", Signal(), None, "the commanded force (N)"),
    Setting("position", Signal(), None, "the position along the position-controlled axis (m)"),
    Setting("position_desired", Signal(), None, "the commanded position (m)"),
    Setting("contact", Signal(), None, "1 while the hand touches the surface, else 0"),
    Setting("surface", Signal(), None, "the position of the surface (m)"),
    Setting("hand", Signal(), None, "the position of the hand along the surface normal (m)"),
    Setting("oscillation", Signal(), None, "a force whose ringing frequency is measured (N)"),
]

METRICS = [
    Setting("step_time", Number(0, unit="s"), None,
            "when the force command steps (without it: no rise time or overshoot)", in_run="instant"),
    Setting("ss_window", Number(0, low_open=True, unit="s"), 0.5, "the span at the end of a run taken as steady state",
            in_run="span"),
    Setting("error_window", ListOf(Number(0, unit="s"), exact=2, increasing=True), None,
            "[t0, t1]: the span of the force tracking error", in_run="window"),
    Setting("filter_cutoff", Number(0, low_open=True, unit="Hz"), DISPLAY_CUTOFF_HZ, "cutoff of the display filter"),
]

PLOT = [
    Setting("position_label", Text(), "position", "name of the position panel"),
    Setting("force_label", Text(), "force", "name of the force panel"),
    Setting("surface_label", Text(), "surface", "name of the surface trace"),
]

ANALYSIS = [
    Setting("hand_mode_hz", Number(0, low_open=True, unit="Hz"), None, "report the plant mode nearest this"),
]

for _section, _rows in (("signals", ROLES), ("metrics", METRICS), ("plot", PLOT), ("analysis", ANALYSIS)):
    extend(_section, _rows, __name__.rpartition(".")[0])
