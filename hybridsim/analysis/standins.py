"""Linear stand-ins: blocks that analysis linearizes in another block's place.

A block whose dynamics a linearization by differences cannot see (a transport
delay keeps its dead time in a buffer sampled at events) offers a linear block
with the same ports (:meth:`Block.linear_standin
<hybridsim.engine.block.Block.linear_standin>`: the delay's Pade
approximation); :func:`linear_standins` builds the system with them.
"""


def linear_standins(system, context=None):
    """``(system, context)`` with each block's linear stand-in (:meth:`Block.linear_standin
    <hybridsim.engine.block.Block.linear_standin>`: a transport delay's Pade approximation) in its
    place, or as given when no block has one. The context's numbers are carried over block by block;
    a stand-in's state is the one whose output is the block's there, for its input there
    (``state_for``)."""
    from hybridsim.engine.context import Context
    from hybridsim.engine.diagram import Diagram
    from hybridsim.engine.system import System
    from hybridsim.errors import DiagramError, LinearizationError

    blocks = context.blocks if context is not None else system.blocks
    standins = {i: s for i, b in enumerate(blocks) if (s := b.linear_standin()) is not None}
    if not standins:
        return system, context
    d = Diagram(system.name, system.source)
    new = [standins.get(i, b) for i, b in enumerate(blocks)]
    for b in new:
        d.add(b)
    for i, ins in enumerate(system.sources):
        for k, (a, o) in enumerate(ins):
            d.connect(f"{new[a].name}.{new[a].outputs[o].name}", f"{new[i].name}.{new[i].inputs[k].name}")
    try:
        lin = System(d)
    except DiagramError as exc:  # the stand-in feeds through where the block did not: a loop
        names = ", ".join(repr(blocks[i].name) for i in standins)
        raise LinearizationError(f"block(s) {names} cannot be replaced by their linear stand-in for analysis: "
                                 f"{exc}") from None
    if context is None:
        return lin, None
    ctx = Context(lin)
    ctx.t = context.t
    for j, b in enumerate(lin.blocks):
        i = system.index[b.name]
        for o in range(len(b.outputs)):
            ctx.y[j][o][:] = context.y[i][o]
        if i in standins:  # its state: one whose output is the block's there, for its input there
            ctx.xc[lin.xslices[j]] = b.state_for(ctx.u[j][0], context.y[i][0])
            continue
        if lin.xslices[j] is not None:
            ctx.xc[lin.xslices[j]] = context.xc[system.xslices[i]]
        if b.n_discrete:
            ctx.xd[j][:] = context.xd[i]
    return lin, ctx
