"""Exception types. Each kind of bad input has its own class and exit code.

The CLI maps these to a one-paragraph message and a non-zero exit status; the
Python API lets them propagate so callers can catch exactly what they expect.
"""


class HybridsimError(Exception):
    """Base class of every error hybridsim reports to a user."""

    exit_code = 1


class DiagramError(HybridsimError):
    """A diagram that cannot be built: lists *all* problems found at once."""

    exit_code = 2

    def __init__(self, problems, source=None):
        self.problems = list(problems)
        self.source = source
        head = f"{source}: " if source else ""
        lines = [f"{head}diagram has {len(self.problems)} problem(s):"]
        lines += [f"  - {p}" for p in self.problems]
        super().__init__("\n".join(lines))


class LoaderError(HybridsimError):
    """A YAML diagram file that is malformed, with file and line."""

    exit_code = 2

    def __init__(self, message, path=None, line=None):
        self.path, self.line = path, line
        where = str(path) if path else "<diagram>"
        if line is not None:
            where += f":{line}"
        super().__init__(f"{where}: {message}")


class RateError(HybridsimError):
    """Sample periods that are not positive or not commensurate."""

    exit_code = 2


class SimulationError(HybridsimError):
    """A run that diverged or whose solver failed."""

    exit_code = 3


class FMUError(HybridsimError):
    """An FMU that cannot be loaded or whose call failed."""

    exit_code = 4


class CompiledPathError(HybridsimError):
    """The compiled path was asked for but cannot run this diagram (or numba is missing)."""

    exit_code = 2
