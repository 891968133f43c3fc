"""hybridsim: block diagrams and FMUs for robot force control.

The engine (block API, diagram, system, scheduler, solvers, simulator) knows
no particular block; the block library is :mod:`hybridsim.blocks`, the plant
FMU's sources :mod:`hybridsim.fmus` and the shipped diagrams
``hybridsim.diagrams`` (the repository keeps them in its top-level ``blocks/``,
``fmus/`` and ``diagrams/`` folders). Start with :func:`simulate` or the
``hybridsim`` command.
"""
import os as _os

# In a source checkout that is not installed, find blocks/, fmus/ and diagrams/ beside this
# package (an install maps them into it: pyproject.toml's package-dir).
_root = _os.path.dirname(_os.path.dirname(_os.path.abspath(__file__)))
if _os.path.isfile(_os.path.join(_root, "pyproject.toml")) and _os.path.isdir(_os.path.join(_root, "blocks")):
    __path__.append(_root)  # noqa: F821 - a package's __path__
del _os, _root

from hybridsim.api import analyze, build, check, load, run, simulate, write_outputs
from hybridsim.engine.block import Block
from hybridsim.engine.diagram import Diagram
from hybridsim.errors import (CompiledPathError, DiagramError, FMUError, HybridsimError, InputError,
                     LoaderError, OutputError, ParameterError, PluginError, RateError, SimulationError)
from hybridsim.analysis.interop import from_control
from hybridsim.engine.registry import register
from hybridsim.engine import registry
from hybridsim.engine.simulator import Simulator
from hybridsim.engine.solvers import RK4, ExplicitRK, Heun, ScipySolver
from hybridsim.engine.cvode import CVode
from hybridsim.runs.variants import run_experiment
from hybridsim.checking import check_file

# The wing over the generic layers: force control's signal roles, metrics, figure layout and hand
# mode register themselves; the picture module lets Jupyter show a Diagram.
from hybridsim import forcecontrol  # noqa: E402,F401
from hybridsim.report import picture as _picture  # noqa: E402,F401

__all__ = ["registry", "Block", "Diagram", "Simulator", "RK4", "Heun", "ExplicitRK", "ScipySolver", "CVode", "register", "simulate", "analyze", "load",
           "build", "check", "check_file", "from_control", "run", "run_experiment", "write_outputs", "HybridsimError", "InputError",
           "DiagramError", "LoaderError", "RateError", "ParameterError", "OutputError",
           "CompiledPathError", "PluginError", "SimulationError", "FMUError"]
from hybridsim.version import __version__  # noqa: E402
