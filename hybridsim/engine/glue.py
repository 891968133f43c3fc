"""The generic path's glue: a diagram's equations for the stepping core, through the blocks' methods.

:func:`generic_glue` returns a :class:`~hybridsim.engine.stepping.Glue` of
closures over one context: they call each block's ``output``,
``derivatives``, ``update``, ``zero_crossings`` and ``event_action`` in the
order of the system's plan (:mod:`hybridsim.engine.plan`), on the context's
buffers. This is the reference the fused and compiled glue are tested
against, and the only glue that runs blocks without kernels (FMUs, plugins
with methods only).
"""
import numpy as np

from hybridsim.engine.events import EventSet
from hybridsim.engine.finite import all_finite
from hybridsim.engine.stepping import GO, STEP_EVENT, STOP, Glue
from hybridsim.errors import StopRequest


def rhs_closures(system, ctx):
    """``(outputs(t, x), derivatives(t, x, dx))`` of the right-hand side over ``ctx``."""
    blocks = ctx.blocks
    y, u, xd = ctx.y, ctx.u, ctx.xd
    steps = [(blocks[i].output, system.xslices[i], u[i], y[i], i) for i in system.rhs_path]
    ders = [(blocks[i].derivatives, system.xslices[i], u[i]) for i in system.stateful]

    def outputs(t, x):
        for out, s, ui, yi, i in steps:
            vals = out(t, x[s] if s is not None else xd[i], ui)
            for buf, v in zip(yi, vals):
                buf[:] = v

    def derivatives(t, x, dx):
        outputs(t, x)
        for der, s, ui in ders:
            dx[s] = der(t, x[s], ui)

    if not steps and len(ders) == 1 and ders[0][1] == slice(0, system.n_x):
        der, _, ui = ders[0]

        def one_block(t, x, dx):  # one block holds every state, nothing on the path (an FMU alone)
            dx[:] = der(t, x, ui)

        return outputs, one_block
    return outputs, derivatives


def state_derivatives(system, ctx):
    """``f(t, x)``: the derivatives of the continuous states (an array) over ``ctx``, its held
    outputs as they are; what linearization and standalone solvers differentiate."""
    _, derivatives = rhs_closures(system, ctx)

    def f(t, x):
        dx = np.empty(system.n_x)
        derivatives(t, np.asarray(x, float), dx)
        return dx

    return f


def first_bad_block(ctx, checked):
    """The first block of ``checked`` with an output that is not finite, or -1."""
    if all_finite(ctx.ywire):  # every output finite (the usual case): one check
        return -1
    y = ctx.y
    for i in checked:
        for v in y[i]:
            if not np.isfinite(v).all():
                return i
    return -1


class GenericGlue:
    """The glue of one context (see the module docstring); ``names`` holds the blocks acting at
    time and step events, by event number, and ``stop`` a block's request to end the run."""

    def __init__(self, system, ctx, located, log_path, nev):
        self.system, self.ctx, self.nev = system, ctx, nev
        self.outputs_rhs, self.derivatives = rhs_closures(system, ctx)
        self.events = EventSet(system, ctx, self.outputs_rhs, located)
        self.plan = system.plan
        self.log_path = log_path
        self.log_checked = system.plan.checked_outputs(log_path)
        self.names = {}
        self.stop = None
        self._due = {}

    def due(self, row):
        key = row.tobytes()
        got = self._due.get(key)
        if got is None:
            discrete = self.system.discrete
            got = self._due[key] = frozenset(discrete[j] for j in np.flatnonzero(row))
        return got

    def glue(self):
        """The :class:`~hybridsim.engine.stepping.Glue` of these closures."""
        ctx, plan, ev = self.ctx, self.plan, self.events

        def outputs(t, x, y, z, pf, pi, due, k):
            d = self.due(due[k])
            ctx.evaluate(plan.hit_pass(d), t, x)
            return first_bad_block(ctx, plan.hit_checked(d))

        def update(t, x, y, z, pf, pi, due, k):
            for i, new in plan.updates(ctx, t, self.due(due[k])):
                ctx.xd[i][:] = new
                if not np.isfinite(new).all():
                    return i
            return -1

        derivatives = self.derivatives

        def rhs(t, x, dx, at, y, z, pf, pi):
            derivatives(t, x, dx if at == 0 and dx.size == x.size else dx[at:at + x.size])

        def zc(t, x, g, y, z, pf, pi):
            ev.g(t, x, g)

        def act(t, x, xn, fired, y, z, pf, pi):
            try:
                names = ev.act(t, x, fired, xn)
            except StopRequest as stop:
                return self._stopped(stop, x)
            if names:
                self.names.setdefault(int(self.nev[0]) - 1, set()).update(names)
            return GO

        def observe(t, x, y, z, pf, pi):
            ctx.evaluate(self.log_path, t, x)
            return first_bad_block(ctx, self.log_checked)

        def next_time(t, x, y, z, pf, pi):
            return ev.next_time(t, x)

        def timed(t, x, xn, y, z, pf, pi):
            try:
                names = ev.act_timed(t, x, xn)
            except StopRequest as stop:
                return self._stopped(stop, x)
            self.names.setdefault(int(self.nev[0]) - 1, set()).update(names)
            return GO

        def stepped(t, x, y, z, pf, pi):
            try:
                return STEP_EVENT if ev.after_step(t, x) else GO
            except StopRequest as stop:
                return self._stopped(stop, x)

        return Glue(outputs, update, rhs, zc, act, observe, next_time, timed, stepped)

    def _stopped(self, stop, x):
        stop.x = np.array(x, float)
        self.stop = stop
        return STOP
