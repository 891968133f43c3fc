"""The fused RK4 path: one generated Python function steps the whole plant.

When every block the right-hand side evaluates has pure ``kernels``
(:mod:`hybridsim.kernels`), the simulator generates (once per system) a
function that integrates an interval between sample hits with classic RK4 on
plain Python floats: kernels are called with tuples, wires are local
variables, the RK4 stages are written out element by element, held inputs are
tuples read once per interval. No graph walking, buffers or small numpy
arrays on the inner loop (when the kernels themselves use none).

It performs exactly the operations of :class:`~hybridsim.solvers.RK4` in the
same order, so both give the same numbers (a test checks it bit for bit); the
generic path remains the reference. Discontinuities are stepped over, as in RK4.
"""
import math


def eligible(system, solver):
    """True when ``system`` can run on the fused path with ``solver``."""
    from .solvers import RK4

    if type(solver) is not RK4 or not system.n_x:
        return False
    return all(has_kernels(system.blocks[i]) for i in set(system.rhs_path) | set(system.stateful))


def has_kernels(block):
    """True when ``block`` gives the kernels it needs: ``output``, and
    ``derivatives`` / ``update`` when it has continuous / discrete state."""
    k = block.kernels
    if k is None:
        return False
    return (k.output is not None and (not block.n_continuous or k.derivatives is not None)
            and (not block.n_discrete or k.update is not None))


def build(system):
    """Return ``(advance, held_ports)``.

    ``advance(t0, t1, n, X, H)`` integrates ``n`` equal RK4 steps from ``t0`` to
    ``t1`` starting at state tuple ``X`` with held inputs ``H`` (tuple of
    tuples, one per port in ``held_ports``); returns the final state tuple.
    """
    source, env, held = rk4_source(system)
    code = compile(source, f"<fused rhs of {system.name}>", "exec")
    exec(code, env)  # noqa: S102 - our own generated source, no user text in it
    env["advance"].source = source
    return env["advance"], held


def rk4_source(system, params_arg=False):
    """Source of ``rhs`` and ``advance`` for ``system``: ``(source, env, held_ports)``.

    ``env`` maps the names the source uses to the kernels (``out3``, ``der5``)
    and, unless ``params_arg``, to the blocks' params (``P3``). With
    ``params_arg`` both functions take the params of every block as one more
    argument ``P`` (indexed by block), as the compiled path needs.
    """
    sysm = system
    path = sorted(set(sysm.rhs_path))
    stateful = sysm.stateful
    on_path = set(path)
    held, held_index = [], {}
    env = {}
    extra = ", P" if params_arg else ""
    lines = [f"def rhs(t, X, H{extra}):"]

    def params(i):
        if params_arg:
            return f"P[{i}]"
        env[f"P{i}"] = sysm.blocks[i].params
        return f"P{i}"

    def arg(i, a, o, k, done):
        if a in on_path and a in done:
            return f"o{a}[{o}]"
        if a in on_path:  # produced later: this output does not depend on it
            width = sysm.blocks[i].inputs[k].width
            return repr((0.0,) * width)
        if (a, o) not in held_index:
            held_index[(a, o)] = len(held)
            held.append((a, o))
        return f"H[{held_index[(a, o)]}]"

    def state(i):
        s = sysm.xslices[i]
        return f"X[{s.start}:{s.stop}]" if s is not None else "()"

    done = set()
    for i in path:
        env[f"out{i}"] = sysm.blocks[i].kernels.output
        args = [arg(i, a, o, k, done) for k, (a, o) in enumerate(sysm.sources[i])]
        lines.append(f"    o{i} = out{i}({params(i)}, t, {state(i)}, ({''.join(x + ', ' for x in args)}))")
        done.add(i)
    done = on_path
    parts = []
    n = sysm.n_x
    for i in stateful:
        env[f"der{i}"] = sysm.blocks[i].kernels.derivatives
        args = [arg(i, a, o, k, done) for k, (a, o) in enumerate(sysm.sources[i])]
        lines.append(f"    d{i} = der{i}({params(i)}, t, {state(i)}, ({''.join(x + ', ' for x in args)}))")
        parts += [f"d{i}[{j}]" for j in range(sysm.blocks[i].n_continuous)]
    lines.append(f"    return ({''.join(p + ', ' for p in parts)})")
    comb = lambda a, c, k: "(" + "".join(f"{a}[{j}] + {c} * {k}[{j}], " for j in range(n)) + ")"  # noqa: E731
    final = "(" + "".join(f"X[{j}] + h6 * (k1[{j}] + 2.0 * (k2[{j}] + k3[{j}]) + k4[{j}]), "
                          for j in range(n)) + ")"
    lines += [
        "",
        f"def advance(t0, t1, n, X, H{extra}):",
        "    h = (t1 - t0) / n",
        "    hh = 0.5 * h",
        "    h6 = h / 6.0",
        "    for k in range(n):",
        "        t = t0 + k * h",
        f"        k1 = rhs(t, X, H{extra})",
        f"        k2 = rhs(t + hh, {comb('X', 'hh', 'k1')}, H{extra})",
        f"        k3 = rhs(t + hh, {comb('X', 'hh', 'k2')}, H{extra})",
        f"        k4 = rhs(t + h, {comb('X', 'h', 'k3')}, H{extra})",
        f"        X = {final}",
        "    return X",
    ]
    return "\n".join(lines), env, held


def steps(t0, t1, step):
    """Number of equal RK4 steps no longer than ``step`` (as RK4 chooses it)."""
    return max(1, math.ceil((t1 - t0) / step - 1e-9))


def steps_between(times, step):
    """:func:`steps` from each of ``times`` to the next (an int64 array, one shorter)."""
    import numpy as np

    return np.maximum(1, np.ceil(np.diff(times) / step - 1e-9)).astype(np.int64)
