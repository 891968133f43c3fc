"""Exception types, one family per exit status of the ``hybridsim`` command.

=========  ==========================================================
exit code  exception (Python API)
=========  ==========================================================
2          :class:`InputError` and its subclasses: a bad diagram, sweep,
           option, parameter or output path (found before any run)
3          :class:`SimulationError`: a run that diverged or whose solver failed
4          :class:`FMUError`: an FMU that cannot be loaded or whose call failed
70         anything else: an internal error (a bug; ``--debug`` shows it)
=========  ==========================================================

The CLI maps these to a one-paragraph message and the exit status; the Python
API lets them propagate so callers can catch exactly what they expect.
"""


class HybridsimError(Exception):
    """Base class of every error hybridsim reports to a user (never raised itself)."""

    exit_code = 1


class InputError(HybridsimError):
    """Bad input of any kind: a file, an option, a value, an output path (exit 2)."""

    exit_code = 2


class DiagramError(InputError):
    """A diagram that cannot be built: lists *all* problems found at once."""

    def __init__(self, problems, source=None):
        self.problems = list(problems)
        self.source = source
        head = f"{source}: " if source else ""
        lines = [f"{head}diagram has {len(self.problems)} problem(s):"]
        lines += [f"  - {p}" for p in self.problems]
        super().__init__("\n".join(lines))


class LoaderError(InputError):
    """A YAML diagram or sweep file that is malformed, with file and line."""

    def __init__(self, message, path=None, line=None):
        self.path, self.line = path, line
        where = str(path) if path else "<diagram>"
        if line is not None:
            where += f":{line}"
        super().__init__(f"{where}: {message}")


class RateError(InputError):
    """Sample periods that are not positive or not commensurate."""


class ParameterError(InputError, ValueError):
    """A block parameter with a bad value; ``param`` names it (for its file:line)."""

    def __init__(self, param, message):
        self.param = param
        super().__init__(f"parameter {param!r} {message}")


class OutputError(InputError):
    """An output path hybridsim must not or cannot write (an existing file, no permission)."""


class CompiledPathError(InputError):
    """The compiled path was asked for but cannot run this diagram (or numba is missing)."""


class PluginError(InputError):
    """A plugin module (``--plugin`` or the ``hybridsim.blocks`` entry points) cannot be imported (exit 2)."""


class StopRequest(Exception):
    """A block asks the run to end at ``t`` (an FMU's terminateSimulation). Not an error:
    the simulator ends there cleanly, with every result so far and ``meta["stopped"]``."""

    def __init__(self, t, block, reason, x=None):
        self.t, self.block, self.reason, self.x = float(t), block, reason, x
        super().__init__(f"block {block!r} stopped the run at t={t:.9g} s ({reason})")


class SimulationError(HybridsimError):
    """A run that diverged or whose solver failed (exit 3)."""

    exit_code = 3


class FMUError(HybridsimError):
    """An FMU that cannot be loaded or whose call failed (exit 4)."""

    exit_code = 4
