"""YAML diagrams: plain data in, a checked Diagram out, errors with file:line.

The format (see docs/diagram-format.md and docs/settings.md)::

    name: fig9
    params:            # named values; '$name' anywhere below refers to one
      rate: 60
    blocks:
      pid: {type: position_pid, rate: $rate, Kp: [460, 1650]}
      ctrl: {type: subsystem, file: sub.yaml, Kp: 2}   # a diagram file as one block
    wires:
      - fk.X -> dx.u2            # or [fk.X, dx.u2]
    simulation: {t_end: 4.0, solver: rk4, step: 1.0e-4, log_period: 0.0005}
    log: [ft.CF, fk.X]
    signals: {force: ft.CF[0], force_desired: fd.y[0]}   # roles for plots/metrics
    metrics: {step_time: 1.0}
    variants: {rate: [60, 80, 120]}                       # a grid of runs

Nothing in a file is evaluated; '$name' substitution is the only indirection.
The work is done by the :mod:`hybridsim.format` package; this module keeps
the names other code imports.
"""
from .format.diagram_file import TOP_KEYS, DiagramFile
from .format.extends import read_merged as _read
from .format.overrides import SIM_KEYS
from .format.paths import ParamPath
from .format.tables import SIGNAL_ROLES, SOLVERS, keys as _keys, ANALYSIS, METRICS, PLOT
from .format.values import _plain, subsystem_path
from .format.yamlio import NumberLoader, _Dict, _List, parse_file, parse_value, read_text

METRIC_KEYS = _keys(METRICS)
PLOT_KEYS = _keys(PLOT)
ANALYSIS_KEYS = _keys(ANALYSIS)

