"""What a :class:`~hybridsim.engine.simulator.Simulator` is given, checked before it is built or
runs: the system, solver, log and ``max_state``, and the size of a run against the budgets of
:mod:`hybridsim.limits`. Each names what goes there, as a file's tables do for a diagram."""
import numpy as np

from hybridsim import limits
from hybridsim.engine.result import parse_signal
from hybridsim.engine.solvers import ExplicitRK, Solver
from hybridsim.errors import DiagramError, InputError


def checked(system, solver, log):
    """``log`` as a list; InputError for a system, solver or log of the wrong kind."""
    from hybridsim.engine.system import System

    if not isinstance(system, System):
        hint = " (call its .build() first)" if hasattr(system, "build") else ""
        raise InputError(f"Simulator takes a built System{hint}, got {type(system).__name__}")
    if solver is not None and not isinstance(solver, Solver):
        raise InputError(f"solver is a Solver object such as RK4(1e-4), Heun(1e-4), ScipySolver('Radau') or "
                         f"CVode(), got {solver!r}")
    if isinstance(log, str) or not hasattr(log, "__iter__"):
        raise InputError(f"log is a list of signals such as ['plant.y', 'pid.u[0]'], got {log!r}")
    log = list(log)
    if not all(isinstance(r, str) for r in log):
        raise InputError(f"log is a list of signals such as ['plant.y', 'pid.u[0]'], got {log!r}")
    return log


def flag(name, value):
    """``value`` as a bool: True, False, numpy's bools or the integers 0 and 1 (a string such as
    ``'no'`` is true to Python, and read so it silently turned a path or a bar on)."""
    if isinstance(value, (bool, np.bool_)) or (isinstance(value, (int, np.integer)) and value in (0, 1)):
        return bool(value)
    raise InputError(f"{name} is True or False, got {value!r}")


def aliases(value):
    """``value`` (None or a mapping of alias to signal name) as a dict of strings."""
    if value is None:
        return {}
    if not hasattr(value, "items") or not all(isinstance(k, str) and isinstance(v, str)
                                               for k, v in value.items()):
        raise InputError(f"aliases is a mapping of names to signals such as {{'F': 'sensor.y[0]'}}, "
                         f"got {value!r}")
    return dict(value)


def max_state(value):
    """``value`` as the largest ``|state|`` before a run counts as diverging: > 0, inf allowed (nan, 0 or a
    negative one made every run diverge at its first step)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = np.nan
    if not v > 0:
        raise InputError(f"max_state is the largest |state| before a run counts as diverging (> 0, or inf), "
                         f"got {value!r}")
    return v


def log_refs(system, log):
    """The ports a run logs: those of ``log`` (each once; an element logs its whole port) and the inputs
    of blocks that log theirs. DiagramError for a port the system lacks or an element past one."""
    refs, indexed = [], []
    for ref in log:
        try:
            base, index = parse_signal(ref)
        except ValueError:
            raise InputError(f"log: {ref!r} is not a signal 'block.port' or 'block.port[i]'") from None
        if base not in refs:
            refs.append(base)
        if index is not None:
            indexed.append((ref, base, index))
    for i, b in enumerate(system.blocks):
        if b.log_inputs:
            for a, o in system.sources[i]:
                r = f"{system.blocks[a].name}.{system.blocks[a].outputs[o].name}"
                if r not in refs:
                    refs.append(r)
    for r in refs:
        try:
            system.port_ref(r)
        except (KeyError, AttributeError, ValueError):
            raise DiagramError([f"cannot log {r!r}: no such output"], system.source) from None
    for ref, base, index in indexed:  # an element past its port was dropped, and reading it failed
        i, o = system.port_ref(base)
        width = system.blocks[i].outputs[o].width
        if not 0 <= index < width:
            raise DiagramError([f"cannot log {ref!r}: {base} has {width} element(s)"], system.source)
    return refs


def check_size(sim, t_end):
    """InputError when a run of Simulator ``sim`` to ``t_end`` exceeds the budgets (sample hits, log
    rows, steps): checked before any array is made."""
    solver = sim.solver
    step = solver.step if isinstance(solver, ExplicitRK) else getattr(solver, "max_step", None)
    periods = [float(p) for p, _ in sim.system.schedule.timings if p]
    why = limits.run_size_problems(t_end, periods, float(sim.log_period),
                                   step if step is not None and np.isfinite(step) else None,
                                   int(sim._log_columns.size), type(solver).__name__,
                                   getattr(solver, "scan", None) if sim.located else None)
    if why:
        raise InputError(f"a run to t_end = {t_end:g} s: " + "; ".join(why))
