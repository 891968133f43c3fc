"""What hybridsim refuses before any work starts, and why.

Every limit here is checked by ``hybridsim check`` and by every command
before it runs, with a message that says what the input would need. They
keep a mistyped number (``t_end: 1e9``, ``rate: 1e12``, ``step: 1e-15``) or a
hostile file (an alias bomb, ``/dev/zero``) from exhausting memory or hanging.
"""

#: bytes of one diagram or sweep file and of everything it extends, together
MAX_FILE_BYTES = 4 * 2**20
#: files in one ``extends`` chain
MAX_EXTENDS = 32
#: levels of nested YAML lists and mappings
MAX_YAML_DEPTH = 64
#: values a YAML document stands for once its aliases are expanded
MAX_YAML_VALUES = 100_000
#: suffixes of files ``extends`` may name
YAML_SUFFIXES = (".yaml", ".yml")
#: stops of one run (sample hits and log points), each a row of the hit table
MAX_STOPS = 20_000_000
#: fixed solver steps of one run
MAX_STEPS = 1_000_000_000
#: bytes of the log of one run
MAX_LOG_BYTES = 2 * 2**30
#: variants of one diagram file (each is built and checked by ``check``)
MAX_VARIANTS = 1_000
#: points of a sweep
MAX_RUNS = 100_000


def _size(n_bytes):
    return f"{n_bytes / 2**30:.3g} GiB" if n_bytes >= 2**30 else f"{n_bytes / 2**20:.3g} MiB"


def run_size_problems(t_end, periods, log_period, step=None, log_width=0, solver="rk4"):
    """Problems (strings) with the size of one run, or an empty list.

    Parameters
    ----------
    t_end : float
        End time, s.
    periods : list of float
        Sample periods of the discrete blocks, s.
    log_period : float
        Log interval, s.
    step : float, optional
        Fixed solver step (RK4) or largest step (scipy solvers), s.
    log_width : int
        Logged values per row (without time).
    solver : str
        Solver name (for the message).
    """
    out = []
    stops = sum(t_end / p for p in periods) + t_end / log_period
    if stops > MAX_STOPS:
        rates = ", ".join(f"{1 / p:.4g} Hz" for p in sorted(set(periods)))
        out.append(f"t_end {t_end:g} s at these rates ({rates or 'none'}) and a log period of "
                   f"{log_period:g} s makes {stops:.3g} sample hits and log points; at most "
                   f"{MAX_STOPS:.0e} fit one run: shorten t_end, lower the rates or log less often")
    rows = t_end / log_period + 1
    need = rows * (8 * (log_width + 1) + 100)
    if need > MAX_LOG_BYTES:
        out.append(f"logging {log_width} values every {log_period:g} s for {t_end:g} s needs about "
                   f"{_size(need)} ({rows:.3g} rows); at most {_size(MAX_LOG_BYTES)}: raise "
                   "simulation.log_period or log fewer signals")
    if step is not None:
        steps = t_end / step
        if steps > MAX_STEPS:
            out.append(f"{solver} step {step:g} s over t_end {t_end:g} s is {steps:.3g} steps; at "
                       f"most {MAX_STEPS:.0e} are run (that alone would take hours): use a larger step")
    return out
