"""Exception types, one family per exit status of the ``hybridsim`` command.

=========  ==========================================================
exit code  origin: exception (Python API)
=========  ==========================================================
0          success
2          bad input: :class:`InputError` and its subclasses: a bad diagram,
           sweep, option, parameter or output path (found before any run);
           another hybridsim writing into the same output folder
3          the model: :class:`SimulationError`, a run that diverged or whose
           solver failed
4          an FMU: :class:`FMUError`, an FMU that cannot be loaded or whose
           call failed
5          the environment: :class:`EnvironmentProblem`: disk full, no
           permission, a name too long, a file system that refuses the
           write, a missing dependency (its package and pip extra named);
           the operating system's message is shown
6          a plugin: :class:`PluginFault`: a block type from a plugin module
           that raised or broke its contract (the plugin, the block and
           what it did are named)
70         anything else: an internal error (a bug; ``--debug`` shows it)
130, 143   interrupted (Ctrl-C) or terminated (SIGTERM); earlier results kept
=========  ==========================================================

The CLI maps these to a one-paragraph message and the exit status; the Python
API lets them propagate so callers can catch exactly what they expect.
"""

#: (exit status, origin, what) of the ``hybridsim`` command (docs/settings.md shows it)
EXIT_CODES = [
    (0, "success", "the command did what was asked"),
    (2, "bad input", "a bad diagram, sweep, option, value or output path, found before any run; "
                     "another hybridsim writing into the same output folder"),
    (3, "the model", "a run diverged or its solver failed"),
    (4, "an FMU", "an FMU cannot be loaded or one of its calls failed"),
    (5, "the environment", "disk full, no permission, a name too long, a file system that refuses "
                           "the write, no memory, a missing package (named with its pip extra)"),
    (6, "a plugin", "a plugin module's import or one of its blocks raised or broke the block contract"),
    (70, "a bug", "an internal error of hybridsim: please report it with the output of --debug"),
    (130, "interrupted", "Ctrl-C; earlier results are left as they were"),
    (143, "terminated", "SIGTERM; earlier results are left as they were"),
]


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
        self.path, self.line, self.message = path, line, message
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


class LinearizationError(InputError):
    """A diagram or analysis setting that cannot be linearized as asked (exit 2)."""


class CompiledPathError(InputError):
    """The compiled path was asked for but cannot run this diagram (or numba is missing)."""


class PluginError(InputError):
    """A plugin module (``--plugin`` or the ``hybridsim.blocks`` entry points) cannot be found (exit 2)."""


class PluginFault(HybridsimError):
    """A plugin's code failed: its import raised, or one of its blocks raised or broke the block
    contract (exit 6). ``plugin`` is the module, ``block`` the block (or type) concerned."""

    exit_code = 6

    def __init__(self, message, plugin=None, block=None):
        self.plugin, self.block = plugin, block
        super().__init__(message)


class EnvironmentProblem(HybridsimError):
    """The machine refused: disk full, no permission, name too long, a missing dependency (exit 5)."""

    exit_code = 5


#: module -> (PyPI package, extra) of the dependencies hybridsim imports
DEPENDENCIES = {
    "numpy": ("numpy", None), "scipy": ("scipy", None), "control": ("control", None),
    "fmpy": ("fmpy", None), "matplotlib": ("matplotlib", None), "yaml": ("PyYAML", None),
    "tqdm": ("tqdm", None), "pandas": ("pandas", None), "pyarrow": ("pyarrow", None),
    "numba": ("numba", "fast"), "dask": ("dask[distributed]", "dask"), "distributed": ("dask[distributed]", "dask"),
    "pinocchio": ("pin", "robots"), "example_robot_data": ("example-robot-data", "robots"),
    "sphinx": ("sphinx", "docs"), "myst_parser": ("myst-parser", "docs"),
}


def missing_dependency(exc):
    """An :class:`EnvironmentProblem` for ImportError ``exc`` of a known dependency, else None."""
    name = (getattr(exc, "name", None) or "").split(".")[0]
    if name not in DEPENDENCIES:
        return None
    package, extra = DEPENDENCIES[name]
    how = f'pip install "hybridsim[{extra}]"' if extra else f"pip install {package} (a core dependency: reinstall hybridsim)"
    return EnvironmentProblem(f"the Python package {package!r} is missing (import {name!r} failed: {exc}); {how}")


def from_os_error(exc, what="writing"):
    """An :class:`EnvironmentProblem` with the operating system's message for OSError ``exc``."""
    import errno
    import os

    name = errno.errorcode.get(exc.errno, "") if exc.errno else ""
    where = f" {exc.filename!r}" if exc.filename else ""
    hint = {errno.ENOSPC: "free some space or write elsewhere (-o)",
            errno.EDQUOT: "free some space or write elsewhere (-o)",
            errno.EACCES: "no permission: choose another -o", errno.EPERM: "not permitted: choose another -o",
            errno.ENAMETOOLONG: "use a shorter name", errno.EROFS: "a read-only file system: choose another -o",
            }.get(exc.errno, "")
    msg = exc.strerror or os.strerror(exc.errno) if exc.errno else str(exc)
    return EnvironmentProblem(f"{what}{where}: {msg}{f' [{name}]' if name else ''}" + (f"; {hint}" if hint else ""))


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
