"""The fused path: one generated Python function steps the whole plant.

When every block the right-hand side evaluates has pure ``kernels``
(:mod:`hybridsim.engine.kernels`) and the solver is a fixed-step explicit
Runge-Kutta method (:class:`~hybridsim.engine.solvers.ExplicitRK`), the simulator
generates (once per system) functions that integrate between sample hits on
plain Python floats: kernels are called with tuples, wires are local
variables, the method's stages are written out element by element
(:mod:`hybridsim.engine.rk_code`), held inputs are tuples read once per interval.
No graph walking, buffers or small numpy arrays on the inner loop (when the
kernels themselves use none).

It performs exactly the operations of the generic path in the same order, so
both give the same numbers (a test checks it bit for bit); the generic path
remains the reference. Discontinuities are stepped over.
"""
import numpy as np

from hybridsim.engine.rk_code import tuple_source, unrolled_lines
from hybridsim.engine.solvers import ExplicitRK


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


def build(system, method, located=None):
    """Return ``((advance, advance_obs), held_ports)`` for ``method`` (an ExplicitRK).

    ``advance(t0, h, ka, kb, X, H, P)`` takes steps ``ka .. kb - 1`` of size
    ``h`` (step ``k`` starts at ``t0 + k h``) from state tuple ``X`` with held
    inputs ``H`` (tuple of tuples, one per port in ``held_ports``) and the
    blocks' params ``P`` (one per block: the run's, so parameters can change
    between runs); ``advance_obs`` also returns a state inside a step (see
    :func:`hybridsim.engine.rk_code.unrolled_lines`).
    """
    source, env, held = rk_source(system, method, params_arg=True, located=located)
    code = compile(source, f"<fused rhs of {system.name}>", "exec")
    exec(code, env)  # noqa: S102 - our own generated source, no user text in it
    env["advance"].source = source
    env["advance"].stages = env["step_stages"], env["dense_at"]
    env["advance"].zc = env.get("zc")  # the located events' functions, when all are kernels
    return (env["advance"], env["advance_obs"]), held


def rk_source(system, method, params_arg=False, located=None):
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
        lines.append(f"    o{i} = out{i}({params(i)}, t, {state(i)}, {tuple_source(args)})")
        done.add(i)
    done = on_path
    parts = []
    n = sysm.n_x
    for i in stateful:
        env[f"der{i}"] = sysm.blocks[i].kernels.derivatives
        args = [arg(i, a, o, k, done) for k, (a, o) in enumerate(sysm.sources[i])]
        lines.append(f"    d{i} = der{i}({params(i)}, t, {state(i)}, {tuple_source(args)})")
        parts += [f"d{i}[{j}]" for j in range(sysm.blocks[i].n_continuous)]
    lines.append(f"    return {tuple_source(parts)}")
    lines += [""] + unrolled_lines(method, n, "rhs", extra)
    located = sysm.action_events if located is None else located
    if located and all(event_kernels(sysm.blocks[i]) for i in located):
        outputs = [line for line in lines[1:] if line.startswith("    o")]
        lines += [""] + _event_lines(sysm, located, outputs, params, arg, state, env, extra)
    return "\n".join(lines), env, held


def event_kernels(block):
    """True when ``block`` gives its events as kernels: ``zero_crossings``, and
    ``event_action`` when it resets its state."""
    k = block.kernels
    return (k is not None and k.zero_crossings is not None
            and (k.event_action is not None or not block.has_event_action))


def event_sizes(system, located=None):
    """The number of event functions of each located block (evaluated once at the initial state)."""
    ctx = system.create_context()
    located = system.action_events if located is None else located
    return [len(system.blocks[i].zero_crossings(0.0, ctx.xc[system.xslices[i]], ctx.u[i])) for i in located]


def _event_lines(sysm, located, outputs, params, arg, state, env, extra):
    """Source of ``zc(t, X, H{extra})`` (every action block's event functions, one flat
    tuple) and ``act(t, X, H, F{extra})`` (the state after the events ``F``, a tuple of bools)."""
    sizes = event_sizes(sysm, located)
    on_path = set(sysm.rhs_path)
    lines = [f"def zc(t, X, H{extra}):"] + outputs
    parts = []
    for i, m in zip(located, sizes):
        env[f"zcf{i}"] = sysm.blocks[i].kernels.zero_crossings
        args = [arg(i, a, o, k, on_path) for k, (a, o) in enumerate(sysm.sources[i])]
        lines.append(f"    z{i} = zcf{i}({params(i)}, t, {state(i)}, {tuple_source(args)})")
        parts += [f"z{i}[{j}]" for j in range(m)]
    lines.append(f"    return {tuple_source(parts)}")
    lines += ["", f"def act(t, X, H, F{extra}):"] + outputs
    new = [f"X[{j}]" for j in range(sysm.n_x)]
    c = 0
    for i, m in zip(located, sizes):
        s = sysm.xslices[i]
        if sysm.blocks[i].kernels.event_action is None:  # a switch without a reset
            c += m
            continue
        env[f"actf{i}"] = sysm.blocks[i].kernels.event_action
        args = [arg(i, a, o, k, on_path) for k, (a, o) in enumerate(sysm.sources[i])]
        fired = tuple_source(f"F[{c + j}]" for j in range(m))
        # element by element: an action may return a tuple or an array (numba unifies floats only)
        names = [f"a{i}_{j - s.start}" for j in range(s.start, s.stop)]
        lines += [f"    if {' or '.join(f'F[{c + j}]' for j in range(m))}:",
                  f"        a{i} = actf{i}({params(i)}, t, {state(i)}, {tuple_source(args)}, {fired})"]
        lines += [f"        {n} = a{i}[{k}]" for k, n in enumerate(names)]
        lines.append("    else:")
        lines += [f"        {n} = X[{j}]" for n, j in zip(names, range(s.start, s.stop))]
        for j, n in zip(range(s.start, s.stop), names):
            new[j] = n
        c += m
    lines.append(f"    return {tuple_source(new)}")
    return lines


class FusedStepper:
    """The generated ``advance`` functions behind :class:`hybridsim.engine.solvers.Steps`' interface.

    :func:`hybridsim.engine.events.integrate` calls ``advance_to_event``, which is the
    method's own (:meth:`~hybridsim.engine.solvers.ExplicitRK.advance_to_event`) with
    these steps: the same steps, dense outputs and bisection, the numbers bit for
    bit those of the generic path. States are tuples of floats here.
    """

    def __init__(self, method, advance, H, P):
        self.method, (self.advance, self.advance_obs), self.H, self.P = method, advance, H, P

    def advance_to_event(self, f, t0, t1, x, t_out, g, directions, check=None):
        """See :meth:`hybridsim.engine.solvers.ExplicitRK.advance_to_event` (``f`` is not used; ``g``
        is replaced by the generated event functions when there are some: the same numbers)."""
        zc = self.advance.zc
        if g is not None and zc is not None:
            H, P = self.H, self.P
            g = lambda t, x: np.array(zc(t, tuple(x.tolist()), H, P))  # noqa: E731
        return self.method.advance_to_event(f, t0, t1, x, t_out, g, directions, steps_with=self, check=check)

    def first(self, x):
        """The state in this stepper's form (a tuple of floats)."""
        import numpy as np

        return tuple(np.asarray(x, float).tolist())

    def array(self, X):
        """A state of this stepper's form as a numpy array."""
        import numpy as np

        return np.array(X)

    def step(self, t0, h, k, X):
        """Step ``k`` of size ``h`` from ``t0`` with the generated code: ``(X_next, stages)``."""
        return self.advance.stages[0](t0 + k * h, h, X, self.H, self.P)

    def dense(self, t0, h, k, X, stages, theta):
        """The state at ``theta`` (0..1) inside step ``k``, from its stages (the generated dense output)."""
        return self.array(self.advance.stages[1](X, stages, h, self.method.dense_weights(theta)))

    def restep(self, t, hh, X):
        """One step of size ``hh`` from ``t`` (to land on an event)."""
        return self.advance(t, hh, 0, 1, X, self.H, self.P)
