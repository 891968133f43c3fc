"""The numbers of one run: time, states and the values on every wire.

A :class:`Context` belongs to one :class:`~hybridsim.engine.system.System`; several
contexts of the same system can run side by side (blocks hold no run data).

* ``xc``: every continuous state in one flat vector (block slices in
  ``system.xslices``);
* ``xd[i]``: discrete state of block ``i``, a view of the flat ``z``;
* ``y[i][o]``: output ``o`` of block ``i``, a view of the flat ``ywire`` (every
  output element of the diagram, in block order: what the stepping core and
  the compiled glue read and write);
* ``u[i]``: the list of buffers that are block ``i``'s inputs. These are the
  very arrays of ``y`` (no copying on the way), built once;
* ``events``, ``stopped``: the run's events and, when a block ended it early,
  its :class:`~hybridsim.errors.StopRequest`;
* ``blocks``: the blocks whose equations this run uses - the system's, or
  copies with other parameters (:meth:`~hybridsim.engine.block.Block.with_params`)
  for a run with parameters given at run time; ``params`` their numbers.
"""
import numpy as np

from hybridsim.engine.block import Block


class Context:
    """Holds the state and signal values of one simulation of a system."""

    def __init__(self, system, blocks=None, outputs=None):
        """``outputs(ctx, t, due)``: computes every block's outputs at ``t`` (the discrete blocks
        where ``due``) as :meth:`evaluate` would, returning False when it did not (a compiled
        output pass); default: the blocks' methods."""
        self.system = system
        self._outputs = outputs
        self.blocks = list(blocks) if blocks is not None else list(system.blocks)
        self.params = tuple(b.params for b in self.blocks)
        self.t = 0.0
        # (a block's copy with other params has the structure of the system's: with_params)
        self.ywire, self.z = ywire, z = np.zeros(system.n_y), np.zeros(system.n_z)
        self.y = [[ywire[s] for s in ports] for ports in system.yslices]
        y = self.y
        self.u = [[y[a][o] for (a, o) in ins] for ins in system.sources]
        self.xc = np.zeros(system.n_x)
        self.xd = [z[s] for s in system.zslices]
        self.events = None   # the run's located and time events (hybridsim.engine.events.EventSet)
        self.stopped = None  # a block's StopRequest that ended the run
        self._initialize()

    def _initialize(self):
        late = []
        for i, b in enumerate(self.blocks):
            if b.init_needs_inputs:
                late.append(i)
            elif b.n_continuous or b.n_discrete or type(b).initial_state is not Block.initial_state:
                self._set_initial(i, b.initial_state(None))
        if not late:
            return
        # provisional outputs at t = 0 (the discrete blocks not due then hold theirs), then the blocks
        # that need inputs; again while one such block's start depends on another's (a filter on a
        # pre-loaded spring), in any order
        due = np.zeros(len(self.system.discrete), bool)
        due[self.system.schedule.due(0)] = True
        for _ in range(len(late)):
            self._start_outputs(due)
            for i in late:
                self._set_initial(i, self.blocks[i].initial_state(self.u[i]))
            if len(late) == 1:
                break
        self._balance(late, due)

    def _start_outputs(self, due):
        """Every block's outputs at t = 0, the discrete ones where ``due`` (over ``system.discrete``)."""
        if not self.outputs(0.0, due):
            kind, holds = self.system.kind, set(np.asarray(self.system.discrete)[~due].tolist())
            with np.errstate(all="ignore"):  # a non-finite output is reported by the run, naming its block
                self.evaluate([i for i in range(len(self.blocks)) if i not in holds or kind[i] != "discrete"],
                              0.0, self.xc)

    def _balance(self, late, due):
        """Start the blocks of ``late`` (each starts from its inputs) in balance with them where the
        passes did not (an input that depends on the block's own output, or on another's that
        depends on it): x0 = initial_state(u(x0)), solved (scipy's root); left as the passes gave
        them, with a warning, where no such start is found."""
        import logging

        from scipy.optimize import root

        def state(i):
            s = self.system.xslices[i]
            return self.xc[s] if s is not None else self.xd[i]

        cuts = np.cumsum([0] + [state(i).size for i in late])

        def gap(z):
            for k, i in enumerate(late):
                self._set_initial(i, z[cuts[k]:cuts[k + 1]])
            self._start_outputs(due)
            with np.errstate(all="ignore"):
                return z - np.concatenate([np.asarray(self.blocks[i].initial_state(self.u[i]), float).reshape(-1)
                                           for i in late])

        def off(z, g):  # the entries not in balance
            return ~(np.abs(g) <= 1e-12 * (1 + np.max(np.abs(z))))

        z0 = np.concatenate([np.array(state(i), float).reshape(-1) for i in late])
        g0 = gap(z0)
        if not off(z0, g0).any() or not np.all(np.isfinite(g0)):  # settled; or not finite: the run says where
            return
        with np.errstate(all="ignore"):
            sol = root(gap, z0)  # its own success flag is strict: the residual decides
        if np.all(np.isfinite(sol.x)) and not off(sol.x, gap(sol.x)).any():
            return
        bad = off(z0, gap(z0))
        logging.getLogger("hybridsim").warning(
            "block(s) %s start from their inputs, which depend on their own outputs: no start in balance "
            "was found (%s); they start from the inputs one pass gave: give them an 'initial'",
            ", ".join(repr(self.blocks[i].name) for k, i in enumerate(late) if bad[cuts[k]:cuts[k + 1]].any()),
            sol.message.rstrip("."))

    def _set_initial(self, i, x0):
        s = self.system.xslices[i]
        if s is not None:
            self.xc[s] = x0
        elif self.blocks[i].n_discrete:
            self.xd[i][:] = np.array(x0, dtype=float).reshape(self.blocks[i].n_discrete)

    def flat(self):
        """``(ywire, z)``, first putting back into ``z`` a discrete state that was replaced
        rather than written in place (``ctx.xd[i] = ...``)."""
        k = 0
        for i, x in enumerate(self.xd):
            n = x.size
            if n and not np.shares_memory(x, self.z):
                self.z[k:k + n] = x
                self.xd[i] = self.z[k:k + n]
            k += n
        return self.ywire, self.z

    def block_state(self, i, xc):
        """The state a block's functions see: a view of ``xc`` or its discrete state."""
        s = self.system.xslices[i]
        return xc[s] if s is not None else self.xd[i]

    def outputs(self, t, due):
        """Every block's outputs at (t, ``xc``), the discrete ones where ``due`` (a bool per block of
        ``system.discrete``), by the compiled output pass this context was given; False when there
        is none or it did not (a non-finite output on the way: :meth:`evaluate` then computes them,
        as the generic path does)."""
        return self._outputs is not None and self._outputs(self, t, due)

    def evaluate(self, path, t, xc):
        """Compute the outputs of the blocks in ``path`` (in order) at (t, xc)."""
        blocks, y, u = self.blocks, self.y, self.u
        for i in path:
            outs = blocks[i].output(t, self.block_state(i, xc), u[i])
            for buf, v in zip(y[i], outs):
                buf[:] = v
