"""What hybridsim refuses before any work starts, and why.

Every limit here is checked by ``hybridsim check`` and by every command
before it runs, with a message that says what the input would need and how
to raise the limit. They keep a mistyped number (``t_end: 1e9``,
``rate: 1e12``, ``step: 1e-9``) or a hostile file (an alias bomb,
``/dev/zero``, subsystems that double at every level) from exhausting memory
or hanging.

Each limit can be raised (or lowered) for one command with an environment
variable named after it: ``HYBRIDSIM_MAX_STEPS=5e9 hybridsim run d.yaml``.
The table :data:`LIMITS` lists them (``docs/settings.md`` shows it).
"""
import math
import os

#: name -> (default, what it bounds); the environment variable is ``HYBRIDSIM_`` + name
LIMITS = {
    "MAX_FILE_BYTES": (4 * 2**20, "bytes of one diagram or sweep file and of everything it extends, together"),
    "MAX_EXTENDS": (32, "files in one 'extends' chain, and levels of nested subsystems"),
    "MAX_YAML_DEPTH": (64, "levels of nested YAML lists and mappings (files and --set values)"),
    "MAX_YAML_VALUES": (100_000, "values one YAML document (a file or a --set value) stands for once its "
                                 "aliases are expanded"),
    "MAX_SET_CHARS": (10_000, "characters of one --set value"),
    "MAX_BLOCKS": (20_000, "blocks of one diagram once every subsystem is expanded (counted before expanding)"),
    "MAX_STOPS": (20_000_000, "sample hits and log points of one run (each a row of the hit table)"),
    "MAX_STEPS": (100_000_000, "fixed solver steps of one run (RK4, Heun), or largest-step intervals of the "
                               "scipy solvers"),
    "MAX_LOG_BYTES": (2 * 2**30, "bytes of the log of one run"),
    "MAX_VARIANTS": (1_000, "variants of one diagram file (each is built and checked by 'check')"),
    "MAX_RUNS": (100_000, "points of a sweep"),
    "MAX_PLOT_POINTS": (20_000, "points of one line in a figure (longer logs are decimated, with a note)"),
    "MAX_PLOT_LINES": (64, "lines in one panel of a figure (more are left out, with a note)"),
}

MAX_FILE_BYTES = LIMITS["MAX_FILE_BYTES"][0]
MAX_EXTENDS = LIMITS["MAX_EXTENDS"][0]
MAX_YAML_DEPTH = LIMITS["MAX_YAML_DEPTH"][0]
MAX_YAML_VALUES = LIMITS["MAX_YAML_VALUES"][0]
MAX_STOPS = LIMITS["MAX_STOPS"][0]
MAX_STEPS = LIMITS["MAX_STEPS"][0]
MAX_LOG_BYTES = LIMITS["MAX_LOG_BYTES"][0]
MAX_VARIANTS = LIMITS["MAX_VARIANTS"][0]
MAX_RUNS = LIMITS["MAX_RUNS"][0]
#: suffixes of files ``extends`` and ``file:`` may name
YAML_SUFFIXES = (".yaml", ".yml")


def env_name(name):
    """The environment variable that sets limit ``name`` (``HYBRIDSIM_MAX_STEPS``)."""
    return f"HYBRIDSIM_{name}"


def get(name):
    """The value of limit ``name``: its environment variable when set, else the module's value.

    Raises
    ------
    hybridsim.errors.InputError
        When the environment variable is not a positive number.
    """
    text = os.environ.get(env_name(name))
    if text is None or not text.strip():
        return globals().get(name, LIMITS[name][0])
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        from hybridsim.errors import InputError

        raise InputError(f"environment variable {env_name(name)}={text!r}: give a positive number")
    return max(1, int(value))


def raise_hint(name):
    """'; to allow more, set HYBRIDSIM_NAME (now N)' for a message."""
    return f" (to allow more: {env_name(name)}=N, now {get(name):.4g})"


def _size(n_bytes):
    return f"{n_bytes / 2**30:.3g} GiB" if n_bytes >= 2**30 else f"{n_bytes / 2**20:.3g} MiB"


def run_size_problems(t_end, periods, log_period, step=None, log_width=0, solver="rk4", scan=None):
    """Problems (strings) with the size of one run, or an empty list.

    Parameters
    ----------
    t_end : float
        End time, s.
    periods : list of float
        Sample periods of the discrete blocks, s (each distinct period counts once).
    log_period : float
        Log interval, s.
    step : float, optional
        Fixed solver step (RK4) or largest step (scipy solvers), s.
    log_width : int
        Logged values per row (without time).
    solver : str
        Solver name (for the message).
    scan : float, optional
        Longest stretch between two checks of the event functions, s (where there are any).
    """
    out = []
    periods = set(periods)  # blocks of one rate share their hits
    stops = sum(t_end / p for p in periods) + t_end / log_period
    if stops > get("MAX_STOPS"):
        rates = ", ".join(f"{1 / p:.4g} Hz" for p in sorted(set(periods)))
        out.append(f"t_end {t_end:g} s at these rates ({rates or 'none'}) and a log period of "
                   f"{log_period:g} s makes {stops:.3g} sample hits and log points; at most "
                   f"{get('MAX_STOPS'):.3g} fit one run: shorten t_end, lower the rates or log less often"
                   + raise_hint("MAX_STOPS"))
    rows = t_end / log_period + 1
    need = rows * (8 * (log_width + 1) + 100)
    if need > get("MAX_LOG_BYTES"):
        out.append(f"logging {log_width} values every {log_period:g} s for {t_end:g} s needs about "
                   f"{_size(need)} ({rows:.3g} rows); at most {_size(get('MAX_LOG_BYTES'))}: raise "
                   "simulation.log_period or log fewer signals" + raise_hint("MAX_LOG_BYTES"))
    if step is not None and step > 0:
        steps = t_end / step
        if steps > get("MAX_STEPS"):
            out.append(f"{solver} step {step:g} s over t_end {t_end:g} s is {steps:.3g} steps; at "
                       f"most {get('MAX_STEPS'):.3g} are run: use a larger step or a shorter t_end"
                       + raise_hint("MAX_STEPS"))
    if scan is not None and scan > 0 and t_end / scan > get("MAX_STEPS"):
        out.append(f"scan {scan:g} s over t_end {t_end:g} s is {t_end / scan:.3g} checks of the event "
                   f"functions; at most {get('MAX_STEPS'):.3g} are made: raise simulation.scan or shorten t_end"
                   + raise_hint("MAX_STEPS"))
    return out
