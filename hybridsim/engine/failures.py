"""What went wrong in a failed walk: the stepping core's status code turned into a message.

Each failure names the time and the state, block or events concerned (the
block API's checks in :class:`~hybridsim.engine.plan.Plan` word most of them);
a run that slides along a switch, or whose solver crawls or fails right at
one, says so and what to do.
"""
import numpy as np

from hybridsim.engine import events as _events
from hybridsim.engine import rk, stepping
from hybridsim.engine.glue import state_derivatives
from hybridsim.engine.solvers import ExplicitRK
from hybridsim.errors import SimulationError


def explain(run, code):
    """Raise the :class:`SimulationError` of status ``code`` of ``run`` (a
    :class:`~hybridsim.engine.simulator.Session`), naming the state, block or events."""
    ctx, out, sim = run.ctx, run.out, run.sim
    plan = sim.system.plan
    index, t = int(out.status[1]), float(out.tfail[0])
    if code == stepping.DIVERGED:
        if isinstance(sim.solver, ExplicitRK) and not np.isfinite(ctx.xc).all():
            _blame_stages(run, t)
        plan.check_continuous(ctx.xc, t, sim.max_state, ctx)
    elif code == stepping.BAD_OUTPUT:
        plan.check_outputs(ctx, [index], t)
    elif code == stepping.BAD_UPDATE:
        plan.check_discrete(index, ctx.xd[index], t)
    elif code == stepping.BIG_UPDATE:
        plan.check_discrete_bound(ctx.z, index, t, sim.max_state)
    elif code in (stepping.ZENO, stepping.STALLED, stepping.CHATTER):
        log = run.event_log()
        names = list(log[-1][1]) if log else []
        if code == stepping.CHATTER:
            raise _events.chatter_error(t, names)
        raise _events.zeno_error(t, names, code == stepping.ZENO, index,
                                 " ".join(dict.fromkeys(a for a in map(_advice_of(run), names) if a)) or None)
    elif code == stepping.CRAWLING:
        message = (f"solver {sim.solver.name}: its steps shrank below {_events.SLIDE_STEP:g} s on average over "
                   f"{_events.CRAWL_STEPS} steps before t={t:.9g} s")
        hint = _sliding_hint(run, t, after_event=False)
        raise SimulationError(message + (hint or ": the system is stiff there (use radau, bdf or cvode) or its "
                                         "right-hand side is discontinuous (a switch without an event function)"))
    elif code == stepping.SLIDING:
        name = function_owner(run, index)
        raise _events.sliding_error(t, name, run.w.muted.sum() > 1, _advice_of(run)(name))
    elif code == stepping.MISSED:
        raise SimulationError(
            f"solver {sim.solver!r} stepped over a crossing of block {function_owner(run, index)!r}'s event "
            f"function before t={t:.9g} s without reporting it (events piling up, or two crossings in one "
            "step); a fixed-step RK solver (rk4, heun) or scipy's locate every crossing")
    elif code == stepping.FAILED:
        seen = getattr(run.s, "seen", None)
        if seen:  # the block whose output was not finite, when one was
            with np.errstate(all="ignore"):
                plan.blame(ctx, *seen[0])
        message = getattr(run.s, "message", None) or f"the solver failed at t={t:.9g} s"
        hint = _sliding_hint(run, t, after_event=True)
        raise SimulationError(message.rstrip(".") + hint if hint else message)
    raise SimulationError(f"simulation failed at t={t:.6g} s (status {code})")


def _sliding_hint(run, t, after_event):
    """'. Block ... ; the state may slide along it. <advice>' when the run failed on a switch: one muted as
    sliding, one that switched just before (``after_event``), or one nearest its surface; else ''."""
    advice = _advice_of(run)
    muted = np.flatnonzero(run.w.muted)
    if muted.size:
        more = " (and others)" if muted.size > 1 else ""
        name = function_owner(run, muted[0])
        return (f". Block {name!r}{more} had switched more than {_events.MAX_REPEATS} "
                f"times before it: the state slides along that switch. {advice(name) or _events.SLIDING_ADVICE}")
    log = run.event_log() if after_event else []
    if log and 0.0 <= t - log[-1][0] <= 1e-6:
        names = list(log[-1][1])
        own = " ".join(dict.fromkeys(a for a in map(advice, names) if a))
        return (f". It failed just after {', '.join(names)} switched at t={log[-1][0]:.9g} s; the state "
                f"may slide along that switch. {own or _events.SLIDING_ADVICE}")
    near = switch_near_zero(run)
    if near is not None:
        return (f". Block {near!r} is on or near its switch there; the state may slide along it. "
                f"{advice(near) or _events.SLIDING_ADVICE}")
    return ""


def _advice_of(run):
    """name -> the block's own advice for a state sliding along its switch (None: the general one)."""
    system = run.sim.system
    return lambda name: getattr(system.blocks[system.index[name]], "sliding_advice", None) if name in system.index else None


def switch_near_zero(run, near=1e-3):
    """The block of the switch function (one without an action) nearest its surface at the last accepted
    step, if one is within ``near`` of it; else None."""
    w = run.w
    if not w.switch.any():
        return None
    g = np.where(w.switch, np.abs(w.g), np.inf)
    k = int(np.argmin(g))
    return function_owner(run, k) if g[k] <= near else None


def function_owner(run, index):
    """The name of the block that owns located event function ``index``."""
    return run.sim.system.blocks[run.sim.located[int(run.w.owner[index])]].name


def _blame_stages(run, t):
    """A fixed step whose state came out not finite: the block whose output went non-finite, with its
    inputs finite, at one of the step's stages (raises its SimulationError), if one did."""
    sim, ctx = run.sim, run.ctx
    h = float(run.s.num[rk.H])
    x0 = np.array(run.w.xo, float)
    if not (h > 0 and np.isfinite(x0).all()):
        return
    with np.errstate(all="ignore"):
        f0 = state_derivatives(sim.system, ctx)(t - h, x0)
        if not np.isfinite(f0).all():
            return
        sim.system.plan.blame_step(ctx, t - h, x0, f0, h)
