"""hybridsim: block diagrams and FMUs for robot force control.

The engine (block API, diagram, system, scheduler, solvers, simulator) knows
no particular block; the block library lives in the top-level ``blocks``
package. Start with :func:`simulate` or the ``hybridsim`` command.
"""
from .api import build, check, load, run_experiment, simulate, write_outputs
from .block import Block
from .diagram import Diagram
from .errors import (CompiledPathError, DiagramError, FMUError, HybridsimError, InputError,
                     LoaderError, OutputError, ParameterError, RateError, SimulationError)
from .interop import from_control
from .registry import register
from . import registry
from .simulator import Simulator
from .solvers import RK4, ExplicitRK, Heun, ScipySolver

__all__ = ["registry", "Block", "Diagram", "Simulator", "RK4", "Heun", "ExplicitRK", "ScipySolver", "register", "simulate", "load",
           "build", "check", "from_control", "run_experiment", "write_outputs", "HybridsimError", "InputError",
           "DiagramError", "LoaderError", "RateError", "ParameterError", "OutputError",
           "CompiledPathError", "SimulationError", "FMUError"]
__version__ = "0.1.0"
