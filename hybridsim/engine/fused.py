"""The fused path: one generated Python function steps the whole plant.

When every block the right-hand side evaluates has pure ``kernels``
(:mod:`hybridsim.engine.kernels`) and the solver is a fixed-step explicit
Runge-Kutta method (:class:`~hybridsim.engine.solvers.ExplicitRK`), the simulator
generates (once per system) functions that integrate between sample hits on
plain Python floats: the method's stages are written out element by element
(:mod:`hybridsim.engine.rk_code`), each stage's right-hand side is the blocks'
kernels written in place on float locals where they can be, called where not
(:mod:`hybridsim.engine.fused_code`, :mod:`hybridsim.engine.inline`), wires
are local variables, params and held inputs are read once per interval. When
every block has kernels, a hit's output pass is generated the same way. No
graph walking, buffers or small numpy arrays on the inner loop (when the
kernels themselves use none).

It performs exactly the operations of the generic path in the same order, so
both give the same numbers (a test checks it bit for bit); the generic path
remains the reference. Discontinuities are stepped over.
"""
import collections
import linecache
import logging
import math

import numpy as np

from hybridsim.engine import stepping
from hybridsim.engine.kernels import gives
from hybridsim.engine.fused_code import (StageWriter, hit_eligible, hit_source, probe_kept, update_eligible,
                                         update_source)
from hybridsim.engine.finite import all_finite
from hybridsim.engine.glue import first_bad_block
from hybridsim.engine.floatcode import shape
from hybridsim.engine.rk_code import inlined_lines, tuple_source
from hybridsim.engine.solvers import ExplicitRK

_log = logging.getLogger(__name__)


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
    return (gives(k, "output") and (not block.n_continuous or k.derivatives is not None)
            and (not block.n_discrete or gives(k, "update")))


def build(system, method, located=None, params=None):
    """The generated functions of ``system`` for ``method`` (an ExplicitRK): a :class:`Fused`
    (``params``: the blocks' params whose shapes the source reads, default the system's), or None
    when a kernel the generated code calls does not give on tuples what it gives on arrays."""
    params = tuple(b.params for b in system.blocks) if params is None else tuple(params)
    source, env, held, stage = rk_source(system, method, located=located, block_params=params)
    hit = update = None
    if hit_eligible(system):
        text, hit = hit_source(system, env, params)
        source += "\n\n\n" + text
    text, update = update_source(system, env, params) if update_eligible(system) else (None, None)
    if text is not None:
        source += "\n\n\n" + text
    kept = set().union(*(w.kept for w in (stage, hit, update) if w is not None))
    bad = probe_kept(system, kept)
    if bad:
        _log.info("the fused path is not used: block(s) %s give other numbers when their kernels are called "
                  "on tuples of floats than on arrays", ", ".join(repr(system.blocks[i].name) for i in bad))
        return None
    global _BUILDS
    _BUILDS += 1
    filename = f"<fused {system.name} {_BUILDS}>"
    linecache.cache[filename] = (len(source), None, source.splitlines(True), filename)  # tracebacks show it
    _SHOWN.append(filename)
    if len(_SHOWN) > 256:  # a long sweep builds many: the oldest sources leave the cache
        linecache.cache.pop(_SHOWN.popleft(), None)
    env["__blocks__"] = system.blocks  # a line's "# b<i>" names the block whose code it is
    code = compile(source, filename, "exec")
    exec(code, env)  # noqa: S102 - our own generated source, no user text in it
    return Fused(system, method, env, held, source, stage, hit, located, params)


_BUILDS = 0  # generated modules so far (each its own file name)
_SHOWN = collections.deque()  # their file names in linecache, oldest first


def raised_in_generated_code(exc):
    """True when ``exc`` was raised while the fused path's generated code ran (by it, or by a
    kernel it called)."""
    tb = exc.__traceback__
    while tb is not None:
        if "__blocks__" in tb.tb_frame.f_globals:
            return True
        tb = tb.tb_next
    return False


def rk_source(system, method, located=None, block_params=None):
    """Source of ``rhs`` and ``advance`` for ``system``: ``(source, env, held_ports, stage)``
    (``stage`` the :class:`~.fused_code.StageWriter` that wrote the steps: which blocks it wrote
    in place).

    ``env`` maps the names the source uses to the kernels (``out3``, ``der5``); the functions take
    the params of every block as their last argument ``P`` (indexed by block).
    """
    sysm = system
    path = sorted(set(sysm.rhs_path))
    stateful = sysm.stateful
    on_path = set(path)
    held = sysm.plan.held_ports()
    held_index = {port: k for k, port in enumerate(held)}
    env = {"empty": np.empty, "math": math}
    extra = ", P"
    lines = [f"def rhs(t, X, H{extra}):"]

    def params(i):
        return f"P[{i}]"

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
        kern = sysm.blocks[i].kernels
        env[f"out{i}"] = kern.output_into or kern.output
        args = [arg(i, a, o, k, done) for k, (a, o) in enumerate(sysm.sources[i])]
        into = "" if kern.output_into is None else \
            ", " + tuple_source(f"empty({p.width})" for p in sysm.blocks[i].outputs)  # arrays it fills
        lines.append(f"    o{i} = out{i}({params(i)}, t, {state(i)}, {tuple_source(args)}{into})")
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
    stage = StageWriter(sysm, held_index, env, block_params)
    lines += [""] + inlined_lines(method, n, stage, stage.hoist, extra)
    located = sysm.action_events if located is None else located
    if located and all(event_kernels(sysm.blocks[i]) for i in located):
        outputs = [line for line in lines[1:] if line.startswith("    o")]
        lines += [""] + _event_lines(sysm, located, outputs, params, arg, state, env, extra)
    return "\n".join(lines), env, held, stage


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


class Fused:
    """The generated functions of one system: the stepper and event glue of the fused path.

    :meth:`machinery` gives the stepping core, for one context, the
    :class:`~hybridsim.engine.stepping.Ops` of the generated steps (plain floats in
    tuples; the core's arrays are read and written at their edges) and the generic
    glue with the right-hand side's event functions and actions replaced by the
    generated ones (when every located block gives them as kernels).
    """

    def __init__(self, system, method, env, held, source, stage, hit_writer, located, params):
        self.system, self.method, self.env, self.held, self.source = system, method, env, held, source
        self.stage, self.hit_writer, self.located = stage, hit_writer, located
        self.advance, self.step_stages, self.dense_at = env["advance"], env["step_stages"], env["dense_at"]
        self.zc, self.act, self.hit, self.update = env.get("zc"), env.get("act"), env.get("hit"), env.get("update")
        self.shape = shape(params)
        self._other = {}  # params of another shape (tuple lengths, fields): their own build

    def machinery(self, ctx, glue):
        """``(glue, ops, state)`` for a run of ``ctx``; ``glue`` the generic glue it completes."""
        key = shape(ctx.params)
        if key != self.shape:  # the source reads the params by their shape
            if key not in self._other:
                self._other[key] = build(self.system, self.method, self.located, ctx.params)
            if self._other[key] is None:  # those params' kernels: the generic path
                ops, s = self.method.stepper()
                return glue, ops, s
            return self._other[key].machinery(ctx, glue)
        s = FusedState(self, ctx)
        discrete = self.system.discrete
        if self.hit is not None:
            hit, plan, checked = self.hit, self.system.plan, {}

            def outputs_glue(t, x, y, z, pf, pi, due, k):
                row = due[k]
                ctx.ywire[:] = hit(t, x.tolist(), ctx.z.tolist(), ctx.ywire.tolist(), row.tolist(), s.P)
                key = row.tobytes()
                if key not in checked:
                    checked[key] = plan.hit_checked(frozenset(discrete[j] for j in np.flatnonzero(row)))
                return first_bad_block(ctx, checked[key])

            glue = glue._replace(outputs=outputs_glue)
        if self.update is not None:
            update, order = self.update, self.system.plan.update_order

            def update_glue(t, x, y, z, pf, pi, due, k):
                row = due[k]
                ctx.z[:] = update(t, x.tolist(), ctx.z.tolist(), ctx.ywire.tolist(), row.tolist(), s.P)
                if all_finite(ctx.z):
                    return -1
                for i in order(discrete[j] for j in np.flatnonzero(row)):  # the first, as the generic path
                    if not np.isfinite(ctx.xd[i]).all():
                        return i
                return -1

            glue = glue._replace(update=update_glue)
        if self.zc is not None:
            zc, act = self.zc, self.act

            def zc_glue(t, x, g, y, z, pf, pi):
                g[:] = zc(t, tuple(x.tolist()), s.H, s.P)

            def act_glue(t, x, xn, fired, y, z, pf, pi):
                xn[:] = act(t, tuple(x.tolist()), s.H, tuple(bool(f) for f in fired), s.P)
                return 0

            glue = glue._replace(zc=zc_glue, act=act_glue)
        return glue, FUSED_OPS, s


class FusedState:
    """Where the fused stepper is: the grid (``num`` as :class:`~hybridsim.engine.rk.RKState`'s),
    the last step's start and stages (tuples), the held inputs ``H`` and params ``P``."""

    def __init__(self, fused, ctx):
        from hybridsim.engine import rk
        from hybridsim.engine.rk import STEP

        self.f, self.ctx = fused, ctx
        self.c = np.zeros(len(fused.method.c))
        self.num = np.zeros(8)
        self.num[STEP] = fused.method.step
        self.P = ctx.params
        self.H = ()
        self.X = self.K = self.cache = self.saved = None
        self.grid = rk.ops(type(fused.method)).begin

    def held(self):
        y = self.ctx.y
        return tuple(tuple(y[a][o].tolist()) for a, o in self.f.held)


def _begin(s, t0, t1, x, times, j, j1):
    s.grid(s, t0, t1, x, times, j, j1)  # the step grid, as the core's steps cut it
    s.H = s.held()
    s.cache = None


def _state(s, x):
    return s.cache if s.cache is not None else tuple(x.tolist())


def _step(s, x, xn, w, gl, y, z, pf, pi):
    num = s.num
    k, h, n = int(num[3]), float(num[1]), int(num[2])   # Python floats: numpy scalars are slow
    X = _state(s, x)
    Xn, K = s.f.step_stages(float(num[4]) + k * h, h, X, s.H, s.P)
    s.X, s.K, s.cache = X, K, Xn
    xn[:] = Xn
    num[3] = k + 1
    return num[5] if k + 1 >= n else num[4] + (k + 1) * h


def _steps(s, t_lim, x, xn, w, gl, y, z, pf, pi):
    num = s.num
    k, h, n, t0 = int(num[3]), float(num[1]), int(num[2]), float(num[4])
    kb = k + 1
    while kb < n and t0 + (kb + 1) * h <= t_lim + 1e-9 * h:
        kb += 1
    X = _state(s, x)
    num[7] = k
    s.saved = X
    if kb - k > 1:
        X = s.f.advance(t0, h, k, kb - 1, X, s.H, s.P)
        num[3] = kb - 1
        s.cache = X
    return _step(s, x, xn, w, gl, y, z, pf, pi)


def _dense(s, t, x, w, xo):
    num = s.num
    h = num[1]
    ta = num[4] + (int(num[3]) - 1) * h
    xo[:] = s.f.dense_at(s.X, s.K, h, s.f.method.dense_weights((t - ta) / h))


def _restep(s, hh, x, w, gl, y, z, pf, pi, xr):
    num = s.num
    ta = float(num[4]) + (int(num[3]) - 1) * float(num[1])
    xr[:] = s.f.advance(ta, float(hh), 0, 1, s.X, s.H, s.P)
    return True


def _rewind(s):
    s.num[3] = s.num[7]
    s.cache = s.saved
    return True


FUSED_OPS = stepping.Ops(_begin, _step, _steps, _dense, _restep, _rewind)
