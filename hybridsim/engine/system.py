"""A built diagram: sorted, classified, with its state layout and paths.

Each block falls in one of four classes:

* ``discrete``: has a sample period; outputs computed at its hits and held
  (zero-order hold) in between;
* ``continuous``: has continuous state, integrated by the solver;
* ``constant``: stateless, not time-varying, fed only by discrete or constant
  blocks: its outputs change only at sample hits;
* ``direct``: any other stateless block (sources, kinematics of plant
  signals): evaluated whenever its outputs are needed.

From this the system precomputes, once, the short list of blocks to evaluate
inside the right-hand side (``rhs_path``) and for logging, so the integrator's
inner loop never walks the graph.
"""
import pickle

import numpy as np

from hybridsim.engine.context import Context
from hybridsim.errors import DiagramError
from hybridsim.engine.graph import needed_blocks, sort_blocks
from hybridsim.engine.schedule import Schedule


class System:
    """The checked, runnable form of a :class:`~hybridsim.engine.diagram.Diagram`."""

    def __init__(self, diagram):
        self.name = diagram.name
        self.source = diagram.source
        blocks = list(diagram.blocks.values())
        index = {b.name: i for i, b in enumerate(blocks)}
        sources = [[None] * len(b.inputs) for b in blocks]
        for w in diagram.wires:
            sb, sp = w.src.rsplit(".", 1)  # a block in a subsystem is 'sub.block'
            db, dp = w.dst.rsplit(".", 1)
            a, b = index[sb], index[db]
            sources[b][blocks[b].input_port(dp).index] = (a, blocks[a].output_port(sp).index)

        order, loops = sort_blocks(blocks, sources)
        if loops:
            where = {w.dst: w.where for w in diagram.wires if w.where}  # file:line of each wire
            at = lambda hop: hop + (f" ({where[hop.split(' -> ')[1]]})" if hop.split(" -> ")[1] in where else "")  # noqa: E731
            raise DiagramError(
                [
                    "algebraic loop: " + " -> ".join(h.split(" -> ")[0] for h in hops)
                    + f" -> {hops[0].split(' -> ')[0]}\n      wires: " + "; ".join(map(at, hops))
                    + "\n      " + (_at_once(blocks, index, hops) or "every output on this cycle depends "
                                     "directly on its input;")
                    + " insert a delay or a rate transition (a discrete block) in the loop"
                    for hops in loops
                ],
                diagram.source,
            )
        # renumber everything in evaluation order
        old_to_new = {old: new for new, old in enumerate(order)}
        self.blocks = [blocks[i] for i in order]
        self.sources = [
            [(old_to_new[a], o) for (a, o) in sources[i]] for i in order
        ]
        self.index = {b.name: i for i, b in enumerate(self.blocks)}
        self._classify()
        self._layout()
        self.schedule = Schedule(
            [(self.blocks[i].period, self.blocks[i].time_offset) for i in self.discrete],
            [self.blocks[i].name for i in self.discrete],
        )
        held = lambda j: self.kind[j] in ("discrete", "constant")  # noqa: E731
        stateful = [i for i, k in enumerate(self.kind) if k == "continuous"]
        inputs_of = {self.sources[i][k][0] for i in stateful for k in range(len(self.blocks[i].inputs))}
        self.events = [i for i, b in enumerate(self.blocks) if self.kind[i] != "discrete" and b.has_zero_crossings]
        #: blocks whose events reset their state: every solver locates these
        self.action_events = [i for i in self.events if self.blocks[i].has_event_action]
        #: blocks that ask for stops at times of their own
        self.time_events = [i for i, b in enumerate(self.blocks) if b.has_time_events]
        #: blocks told of every accepted integrator step (``after_step``)
        self.after_step = [i for i, b in enumerate(self.blocks) if b.has_after_step]
        for i in self.action_events + self.time_events + self.after_step:
            if self.kind[i] != "continuous":
                raise DiagramError([f"block {self.blocks[i].name!r}: events with a reset, time events or "
                                    "step events need a block with continuous state"], diagram.source)
        inputs_of |= {self.sources[i][k][0] for i in self.events for k in range(len(self.blocks[i].inputs))}
        self.rhs_path = sorted(needed_blocks(inputs_of, self.blocks, self.sources, held))
        self.stateful = stateful
        from hybridsim.engine.plan import Plan

        self.plan = Plan(self)

    def _classify(self):
        kind = []
        for b in self.blocks:
            if b.is_discrete:
                kind.append("discrete")
            elif b.n_continuous:
                kind.append("continuous")
            elif b.time_varying:
                kind.append("direct")
            else:
                kind.append("constant")
        changed = True
        while changed:  # demote 'constant' blocks fed by anything that varies
            changed = False
            for i, b in enumerate(self.blocks):
                if kind[i] == "constant" and any(
                    kind[a] in ("continuous", "direct") for a, _ in self.sources[i]
                ):
                    kind[i] = "direct"
                    changed = True
        self.kind = kind
        self.discrete = [i for i, k in enumerate(kind) if k == "discrete"]

    def _layout(self):
        self.xslices = [None] * len(self.blocks)
        atol, bounded, held, n = [], [], [], 0

        def per_state(b, name, default):
            own = getattr(b, name, None)
            return own if own is not None and len(own) == b.n_continuous else np.full(b.n_continuous, default)

        for i, b in enumerate(self.blocks):
            if self.kind[i] == "continuous":
                self.xslices[i] = slice(n, n + b.n_continuous)
                n += b.n_continuous
                atol.append(b.atol if b.atol is not None else np.full(b.n_continuous, np.nan))
                bounded.append(per_state(b, "continuous_bounded", True))
                held.append(per_state(b, "continuous_held", False))
        self.n_x = n
        self.atol = np.concatenate(atol) if atol else np.zeros(0)
        #: which continuous states ``max_state`` bounds (a count or a time grows by design)
        self.x_bounded = np.concatenate(bounded).astype(bool) if bounded else np.zeros(0, bool)
        #: which continuous states only events change (modes, counts): no dynamics to linearize
        self.x_held = np.concatenate(held).astype(bool) if held else np.zeros(0, bool)
        # every output in one wire vector, every discrete state in one vector: each block's slices
        self.yslices, k = [], 0
        for b in self.blocks:
            self.yslices.append([slice(k + 0, k := k + p.width) for p in b.outputs])
        self.n_y = k
        self.zslices, k = [], 0
        for b in self.blocks:
            self.zslices.append(slice(k + 0, k := k + b.n_discrete))
        self.n_z = k

    # -- queries -------------------------------------------------------------
    def block(self, name):
        """The block named ``name``."""
        return self.blocks[self.index[name]]

    def port_ref(self, ref):
        """(block index, output index) of an output reference 'block.port'."""
        b, p = ref.rsplit(".", 1)
        i = self.index[b]
        return i, self.blocks[i].output_port(p).index

    def state_owner(self, k):
        """Name of the block owning continuous state ``k`` and the local index."""
        for i, s in enumerate(self.xslices):
            if s is not None and s.start <= k < s.stop:
                return self.blocks[i].name, k - s.start
        return "?", k

    def evaluation_path(self, wanted):
        """Sorted blocks to evaluate so the given block indices' outputs are current."""
        held = lambda j: self.kind[j] in ("discrete", "constant")  # noqa: E731
        return sorted(needed_blocks(wanted, self.blocks, self.sources, held))

    def __getstate__(self):  # the last blocks_with's blocks stay here
        return {k: v for k, v in self.__dict__.items() if k != "_last_with"}

    def create_context(self, params=None):
        """A fresh :class:`Context` with every block's initial state.

        ``params``: ``{"block.param": value}`` for this context only (the
        blocks named are rebuilt with :meth:`~hybridsim.engine.block.Block.with_params`;
        their structure must not change).
        """
        return Context(self, self.blocks_with(params) if params else None)

    def blocks_with(self, params):
        """The system's blocks, those named in ``{"block.param": value}`` rebuilt with the values."""
        from hybridsim.errors import InputError
        from hybridsim.engine.registry import closest

        changes = {}
        for key, value in params.items():
            bname, _, pname = str(key).rpartition(".")  # 'ctrl.pid.Kp': block ctrl.pid
            if bname not in self.index or not pname:
                raise InputError(f"run-time parameter {key!r}: give it as 'block.param' with a block of "
                                 f"this diagram{closest(bname, self.index)}")
            changes.setdefault(bname, {})[pname] = value
        try:  # the last call's blocks again for the same values (a sweep checks a point's, then runs it)
            tag = pickle.dumps(changes, protocol=5)
        except Exception:  # noqa: BLE001 - a value pickle cannot take: built afresh
            tag = None
        last = self.__dict__.get("_last_with")
        if tag is not None and last is not None and last[0] == tag:
            return list(last[1])
        blocks = list(self.blocks)
        for bname, kw in changes.items():
            i = self.index[bname]
            blocks[i] = self.blocks[i].with_params(**kw)
        if tag is not None:
            self._last_with = (tag, tuple(blocks))
        return blocks


def _at_once(blocks, index, hops):
    """Why a block-level cycle (wires ``hops``, 'a.out -> b.in') is no loop port by port, if it is
    not: a block on it whose leaving output does not depend on the input it is entered by, but
    that computes all its outputs at once (an FMU)."""
    for into, out in zip(hops, hops[1:] + hops[:1]):
        name, inp = into.split(" -> ")[1].rsplit(".", 1)
        b = blocks[index[name]]
        leaving = out.split(" -> ")[0].rsplit(".", 1)[1]
        k, o = b.input_port(inp).index, b.output_port(leaving).index
        if k not in b.feedthrough(o):
            others = [p.name for j, p in enumerate(b.outputs) if k in b.feedthrough(j)]
            return (f"block {name!r} computes its outputs together: {leaving!r} does not depend on {inp!r}, "
                    f"but {', '.join(map(repr, others))} does, so {inp!r} is needed before {leaving!r} is;")
    return None
