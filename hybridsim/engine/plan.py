"""The plan of a run: what happens at a sample hit, written once.

Every path follows this one definition: the generic loop executes it
(:mod:`hybridsim.engine.simulator`), the code generators translate it
(:mod:`hybridsim.engine.fused`, :mod:`hybridsim.engine.compiled`), and the linearization
differentiates it (:mod:`hybridsim.analysis.linearize`).

At a hit with the set ``due`` of discrete blocks due:

1. *outputs*: every block that is not discrete, and the due discrete blocks,
   compute their outputs in dependency order (:meth:`Plan.hit_sequence`,
   :meth:`Plan.hit_pass`); the other discrete blocks hold theirs;
2. logged signals are recorded;
3. *updates*: the due discrete blocks compute their new states from the
   inputs of this hit, in block order (:meth:`Plan.update_order`); a state
   that is not finite stops the run (:meth:`Plan.check_discrete`);
4. between hits the held ports (:meth:`Plan.held_ports`) are constant and the
   continuous states are integrated; a state that is not finite or exceeds
   ``max_state`` stops the run (:meth:`Plan.check_continuous`).
"""
import numpy as np

from hybridsim.errors import SimulationError


class Plan:
    """The hit semantics of one :class:`~hybridsim.engine.system.System`."""

    def __init__(self, system):
        self.system = system
        self._passes = {}

    def hit_sequence(self):
        """``[(block, is_discrete)]`` in evaluation order: a hit evaluates the
        non-discrete blocks and the discrete ones that are due."""
        kind = self.system.kind
        return [(i, kind[i] == "discrete") for i in range(len(kind))]

    def hit_pass(self, due):
        """The blocks whose outputs a hit with discrete blocks ``due`` computes, in order."""
        key = frozenset(due)
        if key not in self._passes:
            self._passes[key] = [i for i, disc in self.hit_sequence() if not disc or i in key]
        return self._passes[key]

    def hit_checked(self, due):
        """:meth:`checked_outputs` of :meth:`hit_pass` (kept per set of due blocks)."""
        key = ("checked", frozenset(due))
        if key not in self._passes:
            self._passes[key] = self.checked_outputs(self.hit_pass(due))
        return self._passes[key]

    def update_order(self, due):
        """The due discrete blocks in the order their updates run."""
        return sorted(due)

    def held_ports(self):
        """``[(block, output)]`` of held values (discrete and piecewise-constant
        blocks) that the right-hand side reads: constant between hits."""
        sysm = self.system
        held = []
        for i in sorted(set(sysm.rhs_path) | set(sysm.stateful)):
            for a, o in sysm.sources[i]:
                if sysm.kind[a] in ("discrete", "constant") and (a, o) not in held:
                    held.append((a, o))
        return held

    # -- executed by the generic loop and the linearization -----------------------
    def outputs(self, ctx, t, xc, due, after=None):
        """Step 1 on ``ctx``; ``after(i)`` is called after block ``i`` computed its outputs."""
        if after is None:
            ctx.evaluate(self.hit_pass(due), t, xc)
            return
        for i in self.hit_pass(due):
            ctx.evaluate((i,), t, xc)
            after(i)

    def updates(self, ctx, t, due):
        """Step 3: ``[(block, new discrete state)]`` (copies, not yet stored)."""
        blocks = ctx.blocks
        return [(i, np.array(blocks[i].update(t, ctx.xd[i], ctx.u[i]), float).reshape(blocks[i].n_discrete))
                for i in self.update_order(due)]

    def check_discrete(self, i, x, t):
        """Raise :class:`SimulationError` when block ``i``'s new discrete state is not finite."""
        if not np.all(np.isfinite(x)):
            raise SimulationError(f"simulation diverged at t={t:.6g} s: discrete state of block "
                                  f"{self.system.blocks[i].name!r} is not finite")

    def check_discrete_bound(self, z, k, t, max_state):
        """Raise :class:`SimulationError` for element ``k`` of the discrete states ``z`` (the flat
        vector, blocks in order), beyond ``max_state``."""
        start = 0
        for b in self.system.blocks:
            if start <= k < start + b.n_discrete:
                raise SimulationError(
                    f"simulation diverged at t={t:.6g} s: discrete state {k - start} of block {b.name!r} "
                    f"is {z[k]:.3g} (limit {max_state:g}). The closed loop may be unstable at these "
                    "gains and rates.")
            start += b.n_discrete
        raise SimulationError(f"simulation diverged at t={t:.6g} s: discrete state {k} is beyond {max_state:g}")

    def checked_outputs(self, path):
        """The blocks of ``path`` whose outputs :meth:`check_outputs` checks (those that do not
        declare ``may_be_nonfinite``)."""
        blocks = self.system.blocks
        return [i for i in path if blocks[i].outputs and not blocks[i].may_be_nonfinite]

    def check_outputs(self, ctx, checked, t):
        """Raise :class:`SimulationError` naming the first block of ``checked`` (see
        :meth:`checked_outputs`) whose output at ``t`` is NaN or infinite."""
        y = ctx.y
        if not checked or np.isfinite(np.concatenate([v for i in checked for v in y[i]])).all():
            return
        for i in checked:
            for o, v in enumerate(y[i]):
                if not np.isfinite(v).all():
                    b = self.system.blocks[i]
                    raise SimulationError(
                        f"block {b.name!r} ({b.type_label}) gave a non-finite output at t={t:.9g} s: "
                        f"{b.outputs[o].name} = {np.array2string(v, precision=4)} (a division by zero, the "
                        "log of a negative number, an overflow?)")

    def blame(self, ctx, t, x):
        """The first block on the right-hand side whose output at (t, x) is not finite although
        its inputs and state are: raises its :class:`SimulationError` (else returns)."""
        sysm = self.system
        for i in sysm.rhs_path:
            b = ctx.blocks[i]
            ctx.evaluate((i,), t, x)
            own = ctx.block_state(i, x)
            fine_in = all(np.isfinite(v).all() for v in ctx.u[i]) and np.isfinite(own).all()
            if fine_in and not b.may_be_nonfinite:
                self.check_outputs(ctx, [i], t)

    def blame_step(self, ctx, t0, x0, f0, h):
        """:meth:`blame` at the later stages of a fixed step from (t0, x0) with derivative ``f0``, to
        first order: x0 + theta h f0 at theta 1/2 and 1 (RK4's second stage exactly)."""
        for theta in (0.5, 1.0):
            self.blame(ctx, t0 + theta * h, x0 + theta * h * f0)

    def check_continuous(self, x, t, max_state, ctx=None):
        """Raise :class:`SimulationError` when a continuous state is not finite or beyond
        ``max_state`` (with ``ctx``: naming the block whose output made it so, when one did)."""
        bad = ~np.isfinite(x) | ((np.abs(x) > max_state) & self.system.x_bounded)
        if bad.any():
            k = int(np.argmax(bad))
            if ctx is not None and not np.isfinite(x[k]):
                with np.errstate(all="ignore"):
                    self.blame(ctx, t, x)
            name, j = self.system.state_owner(k)
            why = ("Not a number: a value it was computed from went NaN (a block's output between the "
                   "points where outputs are checked: hits, log points, step ends; or an event's action), "
                   "or the closed loop is unstable at these gains and rates." if np.isnan(x[k]) else
                   "The closed loop may be unstable at these gains and rates, or the solver step too large.")
            raise SimulationError(
                f"simulation diverged at t={t:.6g} s: state {j} of block {name!r} "
                f"is {x[k]:.3g} (limit {max_state:g}). {why}")
