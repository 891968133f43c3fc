"""Graph work on a checked diagram: evaluation order and algebraic loops.

Block B must be evaluated after block A when a wire runs from A into an input
of B that some output of B depends on directly (feedthrough). A cycle of such
edges is an algebraic loop: no evaluation order exists.
"""


def feedthrough_edges(blocks, sources):
    """Edges (a, b, wire-index info) of the direct-feedthrough graph.

    ``sources[b][k]`` is ``(a, o)``: input ``k`` of block ``b`` is driven by
    output ``o`` of block ``a``.
    """
    edges = {i: [] for i in range(len(blocks))}
    for b, blk in enumerate(blocks):
        direct = set()
        for o in range(len(blk.outputs)):
            direct.update(blk.feedthrough(o))
        for k in sorted(direct):
            a, o = sources[b][k]
            edges[a].append((b, o, k))
    return edges


def sort_blocks(blocks, sources):
    """Return (order, loops): a topological order, and loops found.

    ``loops`` is a list of cycles, each a list of strings describing the wires
    around it port by port; ``order`` is only valid when ``loops`` is empty.
    """
    n = len(blocks)
    edges = feedthrough_edges(blocks, sources)
    state = [0] * n  # 0 new, 1 on stack, 2 done
    order, loops = [], []
    seen_cycles = set()

    def visit(root):
        # iterative DFS that keeps the path so a back edge yields the cycle
        stack = [(root, iter(edges[root]))]
        path = [root]
        via = {}
        state[root] = 1
        while stack:
            node, it = stack[-1]
            nxt = next(it, None)
            if nxt is None:
                stack.pop()
                path.pop()
                state[node] = 2
                order.append(node)
                continue
            b, o, k = nxt
            if state[b] == 1:
                start = path.index(b)
                cyc = path[start:] + [b]
                key = frozenset(cyc)
                if key not in seen_cycles:
                    seen_cycles.add(key)
                    hops = []
                    for u, v in zip(cyc, cyc[1:]):
                        oo, kk = via.get((u, v), (o, k))
                        hops.append(
                            f"{blocks[u].name}.{blocks[u].outputs[oo].name} -> "
                            f"{blocks[v].name}.{blocks[v].inputs[kk].name}"
                        )
                    loops.append(hops)
            elif state[b] == 0:
                via[(node, b)] = (o, k)
                state[b] = 1
                path.append(b)
                stack.append((b, iter(edges[b])))
            via.setdefault((node, b), (o, k))

    for i in range(n):
        if state[i] == 0:
            visit(i)
    order.reverse()
    return order, loops


def needed_blocks(start, blocks, sources, skip):
    """Blocks whose outputs must be evaluated so those of ``start`` are current.

    Walks back from the blocks in ``start`` through inputs their outputs depend
    on directly; blocks for which ``skip(i)`` is true (held or piecewise
    constant values) are neither included nor walked through.
    """
    need, stack = set(), list(start)
    while stack:
        j = stack.pop()
        if j in need or skip(j):
            continue
        need.add(j)
        blk = blocks[j]
        direct = set()
        for o in range(len(blk.outputs)):
            direct.update(blk.feedthrough(o))
        stack.extend(sources[j][k][0] for k in direct)
    return need
