"""Advance a built diagram one communication step at a time: the engine of an exported FMU.

A :class:`DiagramStepper` holds one context of a system whose inputs are
:class:`ExternalInput` blocks (set from outside between steps, held over a
step: zero-order hold) and advances it with the diagram's own solver, rates
and events, hit by hit, as :class:`hybridsim.engine.simulator.Simulator` does:

1. at a time ``t`` the outputs of every block that is not discrete, and of the
   discrete blocks due at ``t``, are computed with the inputs set for ``t``;
2. the due discrete blocks update;
3. the continuous states are integrated to the next sample hit or to the end
   of the communication step, whichever is first.

Outputs read at ``t`` (before :meth:`DiagramStepper.step` from ``t``) are those
of step 1: a discrete block due at ``t`` shows its output for the inputs of
``t`` (direct feedthrough, as inside a hybridsim diagram).
"""
from fractions import Fraction

import numpy as np

from hybridsim.engine.block import Block
from hybridsim.engine.schedule import Schedule


class ExternalInput(Block):
    """A source whose value is set from outside the diagram (an exported FMU's input port).

    Parameters
    ----------
    name : str
    value : sequence of float
        The start value; its length is the port's width.
    """

    def __init__(self, name="input", value=(0.0,)):
        super().__init__(name)
        self.value = np.array(value, float).reshape(-1)
        self.declare_output("y", self.value.size, depends_on=())
        self.declare_output("dy", self.value.size, depends_on=())

    def output(self, t, x, u):
        return self.value, np.zeros_like(self.value)


class DiagramStepper:
    """One simulation of ``simulator.system``, advanced step by step.

    Parameters
    ----------
    simulator : hybridsim.engine.simulator.Simulator
        Built from the diagram (its solver and rates are used).
    inputs : dict
        ``{block name: start values}``: the constant blocks that stand for the
        input ports; they are replaced by :class:`ExternalInput` blocks.
    outputs : list of str
        ``block.port`` references read by :meth:`outputs`.
    """

    def __init__(self, simulator, inputs, outputs):
        self.sim = sim = simulator
        system = self.system = sim.system
        blocks = list(system.blocks)
        self.inputs = {}
        for name, start in inputs.items():
            i = next(k for k, b in enumerate(blocks) if b.name == name)
            blocks[i] = self.inputs[name] = ExternalInput(name, start)
        from hybridsim.engine.context import Context

        self.ctx = Context(system, blocks)
        self.session = sim.session(self.ctx)
        self.out_ports = [system.port_ref(r) for r in outputs]
        self.discrete = system.discrete
        self.sched = Schedule([(system.blocks[i].period, system.blocks[i].time_offset) for i in self.discrete])
        self.t = 0.0
        self._fresh = False

    # -- time grid -------------------------------------------------------------
    def _tick(self, t):
        """The tick at ``t`` (int) when ``t`` is a sample hit to 1e-9 of the base tick, else None."""
        base = self.sched.base
        k = round(Fraction(t) / base)
        return int(k) if abs(float(k * base) - t) <= 1e-9 * float(base) else None

    def _due(self, t):
        """The positions (in ``system.discrete``) of the discrete blocks due at ``t``."""
        n = self._tick(t)
        if n is None or not self.discrete:
            return []
        return self.sched.due(n)

    def _next_hit(self, t):
        """The first sample hit after ``t`` (inf without discrete blocks)."""
        if not self.discrete:
            return np.inf
        base = float(self.sched.base)
        n = int(np.floor(t / base + 1e-9)) + 1
        while not self.sched.due(n):
            n += 1
        return float(self.sched.time(n))

    # -- the FMU's view ----------------------------------------------------------
    def set_input(self, name, values):
        """Set input block ``name`` to ``values`` (held until it is set again)."""
        self.inputs[name].value[:] = values
        self._fresh = False

    def outputs(self):
        """The output ports at the present time for the inputs set now, as one flat array."""
        ctx = self.ctx
        if not self._fresh:
            due = frozenset(self.discrete[j] for j in self._due(self.t))
            self.system.plan.outputs(ctx, self.t, ctx.xc, due)
            self._fresh = True
        return np.concatenate([ctx.y[i][o] for i, o in self.out_ports]) if self.out_ports else np.zeros(0)

    def step(self, t, h):
        """Advance from ``t`` (the present time) by ``h`` s: a hit at ``t`` and at every sample hit
        inside, the states integrated between (the simulator's stepping core, as in a run).

        Raises :class:`~hybridsim.errors.StopRequest` when a block ends the run
        (the state is then that of the stop) and
        :class:`~hybridsim.errors.SimulationError` when the run diverges.
        """
        from hybridsim.engine import stepping
        from hybridsim.engine.timeline import window

        due_at = lambda tt: self._due(tt)  # noqa: E731
        due_at.next_after = self._next_hit
        tl = window(self.system, t, t + h, due_at)
        code = self.session.walk(tl)
        self._fresh = False
        if code == stepping.STOPPED and self.session.stop is not None:
            stop = self.session.stop
            self.session.keeper.stop = None
            self.t = stop.t
            raise stop
        if code != stepping.OK:
            self.session.fail(code)
        self.t = t + h

    def release(self):
        """Free what the blocks hold (FMU instances inside the diagram)."""
        for b in self.ctx.blocks:
            b.release()


def fed_by(system, ref, inputs):
    """The input ports (``{block name: port}`` of ``inputs``) that output ``ref`` depends on
    directly: followed back along the blocks' feedthrough."""
    found, seen, todo = set(), set(), [system.port_ref(ref)]
    while todo:
        b, o = todo.pop()
        if (b, o) in seen:
            continue
        seen.add((b, o))
        name = system.blocks[b].name
        if name in inputs:
            found.add(inputs[name])
            continue
        todo += [system.sources[b][k] for k in system.blocks[b].feedthrough(o)]
    return found
