"""The fused path: one generated Python function steps the whole plant.

When every block the right-hand side evaluates has pure ``kernels``
(:mod:`hybridsim.kernels`) and the solver is a fixed-step explicit
Runge-Kutta method (:class:`~hybridsim.solvers.ExplicitRK`), the simulator
generates (once per system) functions that integrate between sample hits on
plain Python floats: kernels are called with tuples, wires are local
variables, the method's stages are written out element by element
(:mod:`hybridsim.rk_code`), held inputs are tuples read once per interval.
No graph walking, buffers or small numpy arrays on the inner loop (when the
kernels themselves use none).

It performs exactly the operations of the generic path in the same order, so
both give the same numbers (a test checks it bit for bit); the generic path
remains the reference. Discontinuities are stepped over.
"""
from .rk_code import unrolled_lines
from .solvers import ExplicitRK, steps, steps_between  # noqa: F401 - steps re-exported


def eligible(system, solver):
    """True when ``system`` can run on the fused path with ``solver``."""
    if not isinstance(solver, ExplicitRK) or not system.n_x:
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


def build(system, method):
    """Return ``(advance, held_ports)`` for ``method`` (an ExplicitRK).

    ``advance(t0, h, k0, k1, X, H, kobs, w, P)`` takes steps ``k0 .. k1 - 1``
    of size ``h`` (step ``k`` starts at ``t0 + k h``) from state tuple ``X``
    with held inputs ``H`` (tuple of tuples, one per port in ``held_ports``)
    and the blocks' params ``P`` (one per block: the run's, so parameters can
    change between runs); returns ``(X_end, X_obs, X_dense)`` (see
    :func:`hybridsim.rk_code.unrolled_lines`).
    """
    source, env, held = rk_source(system, method, params_arg=True)
    code = compile(source, f"<fused rhs of {system.name}>", "exec")
    exec(code, env)  # noqa: S102 - our own generated source, no user text in it
    env["advance"].source = source
    return env["advance"], held


def rk_source(system, method, params_arg=False):
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
    held = sysm.plan.held_ports()
    held_index = {port: k for k, port in enumerate(held)}
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
        return f"H[{held_index[(a, o)]}]"  # a held port (plan.held_ports)

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
    lines += [""] + unrolled_lines(method, n, "rhs", extra)
    return "\n".join(lines), env, held
