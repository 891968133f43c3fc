"""The fused path's generated Python: a diagram's equations on float locals, kernels written in place.

:class:`StageWriter` writes one Runge-Kutta stage's right-hand side (the
blocks on the path, then the derivatives) for
:func:`~hybridsim.engine.rk_code.inlined_lines`; :func:`hit_source` writes a
sample hit's output pass, :func:`update_source` its discrete updates. Each
writes a block's kernel in place where :mod:`hybridsim.engine.inline` can and
calls it where it cannot (numpy); the params' numbers and the held inputs are
locals read once per call of the generated function
(:meth:`BlockWriter.hoist`). :func:`probe_kept` checks, before a run, that the
kernels called give on tuples of floats what their blocks give on arrays.
"""
import re

from hybridsim.engine import floatcode, inline
from hybridsim.engine.block import Block
from hybridsim.engine.rk_code import tuple_source


_MATH = re.compile(r"\bmath\.(\w+)\(")


class BlockWriter:
    """What both writers share: the blocks' params as trees of hoisted locals, and
    :meth:`write`, a block's kernel in place or called. ``inlined`` / ``called`` name the blocks."""

    def __init__(self, sysm, env, blocks, params=None):
        self.sysm, self.env = sysm, env
        params = [b.params for b in sysm.blocks] if params is None else params
        self.hoists = {}  # local -> the expression it holds
        self.floats = set()  # hoisted locals that hold Python floats
        self.trees = {}
        for i in blocks:
            out = []
            p = params[i]
            whole = f"P[{i}]"
            self.trees[i] = floatcode.param_tree(p, whole, f"P{i}", out, self.floats)
            self.hoists.update(out)
            self.hoists[f"P_{i}"] = whole  # the whole params, for a kept call
        self.inlined, self.called = set(), set()
        self.kept = set()  # (block, kernel) that probe_kept checks: the calls kept, the blocks with own methods
        self.failed = set()  # (block, kernel) not written in place

    def hoist(self, lines, pad="    "):
        """The lines setting the hoisted locals that ``lines`` read (``lines`` call ``math.f`` as
        ``math_f``, a local: one name lookup less per call)."""
        for k, line in enumerate(lines):
            for f in set(_MATH.findall(line)):
                self.hoists[f"math_{f}"] = f"math.{f}"
            lines[k] = _MATH.sub(r"math_\1(", line)
        read = set().union(*(floatcode.names_in(line) for line in lines)) if lines else set()
        for name, expr in reversed(list(self.hoists.items())):  # an array's elements read its list
            if name in read:
                read |= floatcode.names_in(expr)
        return [f"{pad}{name} = {expr}" for name, expr in self.hoists.items() if name in read]

    def inliner(self, floats=()):
        """An inliner whose known floats are the hoisted ones and ``floats``."""
        count = iter(range(10 ** 9))
        inl = inline.Inliner(lambda: f"v{next(count)}", self.env)
        inl.floats |= self.floats | set(floats)
        return inl

    def write(self, inl, i, what, t, state, inputs, widths):
        """Block ``i``'s kernel ``what`` at ``t`` on the trees ``state`` and ``inputs``, written in
        place, else called: the tree of its result (one tuple per port for ``output``, a tuple of
        ``widths`` numbers otherwise)."""
        mark = len(inl.out)
        r = self._write(inl, i, what, t, state, inputs, widths)
        floatcode.own(inl.out[mark:], i)
        if what == "output":  # as a wire holds them: floats (an int or a bool output, rounded)
            return tuple(tuple(inl.as_float(v) for v in port) for port in r)
        return r

    def _write(self, inl, i, what, t, state, inputs, widths):
        kern = self.sysm.blocks[i].kernels
        f = getattr(kern, what)
        mark, memo = len(inl.out), dict(inl.memo)
        inl.count = 0  # each kernel's own budget
        into = getattr(kern, what + "_into", None) if f is None else None
        if (f is not None or into is not None) and (i, what) not in self.failed:  # a kernel that failed once fails again
            try:
                args = [self.trees[i], t, state, inputs]
                if into is not None:  # the arrays it writes, as elements
                    args.append(tuple(floatcode.Out(w) for w in widths) if what == "output" else floatcode.Out(widths))
                r = inl.call(f or into, args)
                if _fits(r, widths):
                    self.inlined.add(i)
                    if getattr(type(self.sysm.blocks[i]), what) is not getattr(Block, what):
                        self.kept.add((i, what))  # its own method is the reference: probed too
                    return r
            except floatcode.NotInlinable:
                pass
            del inl.out[mark:]
            inl.memo, inl.count = memo, 0
        self.called.add(i)
        self.kept.add((i, what))
        self.failed.add((i, what))
        name = inl.fresh()
        arrays = ""
        if f is None:  # output_into / update_into: the arrays it fills, as Block.output / update give them
            f = into
            arrays = ", " + (tuple_source(f"empty({w})" for w in widths) if what == "output" else f"empty({widths})")
        fname = f"{what[:3]}{i}"
        self.env[fname] = f
        call = f"{fname}(P_{i}, {t}, {floatcode.source(state)}, {floatcode.source(inputs)}{arrays})"
        inl.out.append(floatcode.Assign(name, call))
        if what == "output":
            return tuple(tuple(inl.simple(f"{name}[{o}][{j}]") for j in range(w)) for o, w in enumerate(widths))
        return tuple(inl.simple(f"{name}[{j}]") for j in range(widths))


class StageWriter(BlockWriter):
    """One stage's right-hand side: ``self(t, xs)`` gives ``(lines, derivative names)``."""

    def __init__(self, sysm, held_index, env, params=None):
        super().__init__(sysm, env, sorted(set(sysm.rhs_path) | set(sysm.stateful)), params)
        self.held = {}
        for (a, o), k in held_index.items():
            w = sysm.blocks[a].outputs[o].width
            self.held[(a, o)] = tuple(f"H{k}_{j}" for j in range(w))
            self.hoists.update({f"H{k}_{j}": f"H[{k}][{j}]" for j in range(w)})

    def __call__(self, t, xs):
        sysm = self.sysm
        inl = self.inliner(list(xs) + [n for port in self.held.values() for n in port] + [t])
        outs, done = {}, set()
        on_path = set(sysm.rhs_path)

        def inputs(i):
            args = []
            for k, (a, o) in enumerate(sysm.sources[i]):
                if a in on_path and a in done:
                    args.append(outs[a][o])
                elif a in on_path:  # produced later: this output does not depend on it
                    args.append(("0.0",) * sysm.blocks[i].inputs[k].width)
                else:
                    args.append(self.held[(a, o)])
            return tuple(args)

        def state(i):
            s = sysm.xslices[i]
            return tuple(xs[s.start:s.stop]) if s is not None else ()

        for i in sorted(on_path):
            outs[i] = self.write(inl, i, "output", t, state(i), inputs(i), [p.width for p in sysm.blocks[i].outputs])
            done.add(i)
        done = on_path
        ds = []
        for i in sysm.stateful:
            ds += list(self.write(inl, i, "derivatives", t, state(i), inputs(i), sysm.blocks[i].n_continuous))
        ds = [d if floatcode.is_leaf(d) else inl.simple(d) for d in ds]
        kept, _ = floatcode.prune(inl.out, set(ds))
        return floatcode.lines(kept, ""), ds


def update_eligible(system):
    """True when every discrete block updates its state by its kernels (Block.update)."""
    return all(not b.n_discrete or (b.kernels is not None and type(b).update is Block.update
                                    and (b.kernels.update is not None or b.kernels.update_into is not None))
               for b in system.blocks)


def update_source(system, env, params=None):
    """Source of ``update(t, X, Z, Y, D, P)``: the new discrete states after a hit (``Z``, a list,
    updated in place), as ``plan.updates`` computes them: each due block's update from its state
    and the outputs ``Y`` the hit left; ``(None, None)`` when no block has a discrete state."""
    sysm = system
    due = [i for i in sysm.plan.update_order(sysm.discrete) if sysm.blocks[i].n_discrete]
    if not due:
        return None, None
    w = BlockWriter(sysm, env, due, params)
    inl = w.inliner([f"Z_{j}" for j in range(sum(b.n_discrete for b in sysm.blocks))] + ["t"])
    yoff, zoff = offsets(sysm)
    col = {i: c for c, i in enumerate(sysm.discrete)}
    for i in due:
        b = sysm.blocks[i]
        outer, memo = inl.out, dict(inl.memo)
        inl.out = []
        inputs = tuple(tuple(_read(inl, f"Y[{yoff[a][o] + j}]") for j in range(sysm.blocks[a].outputs[o].width))
                       for a, o in sysm.sources[i])
        state = tuple(f"Z_{zoff[i] + j}" for j in range(b.n_discrete))
        r = w.write(inl, i, "update", "t", state, inputs, b.n_discrete)
        inl.out += [floatcode.Assign(f"Z[{zoff[i] + j}]", v) for j, v in enumerate(r)]
        branch, inl.out, inl.memo = inl.out, outer, memo
        outer.append(floatcode.If(f"D[{col[i]}]", branch, []))
    body = floatcode.lines(floatcode.prune(inl.out, (), lambda target: target.startswith("Z["))[0], "    ")
    n_z = sum(b.n_discrete for b in sysm.blocks)
    head = ["def update(t, X, Z, Y, D, P):"] + w.hoist(body)
    head.append("    " + ", ".join(f"Z_{j}" for j in range(n_z)) + ", = Z")
    return "\n".join(head + body + ["    return Z"]), w


def offsets(sysm):
    """Where each block's outputs start in the flat outputs, and its discrete state in the flat state."""
    yoff, k = [], 0
    for b in sysm.blocks:
        yoff.append([])
        for p in b.outputs:
            yoff[-1].append(k)
            k += p.width
    zoff, k = [], 0
    for b in sysm.blocks:
        zoff.append(k)
        k += b.n_discrete
    return yoff, zoff


def _read(inl, expr):
    """A fresh local holding ``expr`` now (a value another statement may change later)."""
    name = inl.fresh()
    inl.out.append(floatcode.Assign(name, expr))
    inl.floats.add(name)  # Y and Z are lists of the wires' floats
    return name


def hit_eligible(system):
    """True when every block of the hit computes its outputs by its kernels (Block.output)."""
    return all(not b.outputs or (b.kernels is not None and type(b).output is Block.output
                                 and (b.kernels.output is not None or b.kernels.output_into is not None))
               for b in system.blocks)


def hit_source(system, env, params=None):
    """Source of ``hit(t, X, Z, Y, D, P)``: a hit's output pass, as ``ctx.evaluate(plan.hit_pass(due))``
    computes it, on floats: ``X`` the continuous state (a sequence), ``Z`` the discrete state,
    ``Y`` the outputs (a list, updated in place), ``D`` the due row (a discrete block computes its
    outputs when due, else keeps them), ``P`` the blocks' params."""
    sysm = system
    w = BlockWriter(sysm, env, [i for i, _ in sysm.plan.hit_sequence()], params)
    inl = w.inliner([f"X_{j}" for j in range(sysm.n_x)] + [f"Z_{j}" for j in range(sum(b.n_discrete for b in sysm.blocks))]
                    + ["t"])
    yoff, zoff = offsets(sysm)
    current = {}  # (block, port) -> the tree of its value now (a port not yet read: Y)
    col = {i: c for c, i in enumerate(sysm.discrete)}

    def read(a, o):
        if (a, o) not in current:
            width = sysm.blocks[a].outputs[o].width
            current[(a, o)] = tuple(_read(inl, f"Y[{yoff[a][o] + j}]") for j in range(width))
        return current[(a, o)]

    def state(i):
        s = sysm.xslices[i]
        if s is not None:
            return tuple(f"X_{j}" for j in range(s.start, s.stop))
        return tuple(f"Z_{zoff[i] + j}" for j in range(sysm.blocks[i].n_discrete))

    for i, disc in sysm.plan.hit_sequence():
        b = sysm.blocks[i]
        if not b.outputs:
            continue
        inputs = tuple(read(a, o) for a, o in sysm.sources[i])
        outer, memo = inl.out, dict(inl.memo)
        if disc:
            inl.out = []
        r = w.write(inl, i, "output", "t", state(i), inputs, [p.width for p in b.outputs])
        for o, port in enumerate(r):
            for j, v in enumerate(port):
                inl.out.append(floatcode.Assign(f"Y[{yoff[i][o] + j}]", v))
            current[(i, o)] = port
        if disc:  # computed when due; later blocks read what Y then holds
            branch, inl.out, inl.memo = inl.out, outer, memo
            outer.append(floatcode.If(f"D[{col[i]}]", branch, []))
            for o in range(len(b.outputs)):
                current.pop((i, o))
    n_x, n_z = sysm.n_x, sum(b.n_discrete for b in sysm.blocks)
    body = floatcode.lines(floatcode.prune(inl.out, (), lambda target: target.startswith("Y["))[0], "    ")
    head = ["def hit(t, X, Z, Y, D, P):"] + w.hoist(body)
    if n_x:
        head.append("    " + ", ".join(f"X_{j}" for j in range(n_x)) + ", = X")
    if n_z:
        head.append("    " + ", ".join(f"Z_{j}" for j in range(n_z)) + ", = Z")
    return "\n".join(head + body + ["    return Y"]), w


def _fits(tree, widths):
    """True when ``tree`` has the shape of a kernel's result: a tuple of ``widths[k]`` numbers per
    port (``widths`` a list), or of ``widths`` numbers (an int)."""
    if isinstance(widths, int):
        return isinstance(tree, tuple) and len(tree) == widths and all(floatcode.is_leaf(v) for v in tree)
    return (isinstance(tree, tuple) and len(tree) == len(widths)
            and all(_fits(port, w) for port, w in zip(tree, widths)))


def probe_kept(system, kept):
    """The blocks of ``kept`` (``(block, "output" | "derivatives" | "update")``) whose kernels,
    called as the generated code calls them (tuples of floats in, one sequence of the port's
    width per port out), do not give what the block's method gives on arrays at the initial
    state (as the wires hold it; to 1e-9 where the block has a method of its own), or break the
    shape the generated code reads; and every block
    whose params hold a number narrower than float64 (:func:`~.floatcode.narrow`)."""
    import numpy as np

    bad = [i for i, b in enumerate(system.blocks) if floatcode.narrow(b.params)]
    if bad or not kept:
        return bad
    ctx = system.create_context()
    for i, what in sorted(kept):
        b = system.blocks[i]
        s = system.xslices[i]
        x = ctx.xc[s] if s is not None else ctx.xd[i]
        u = ctx.u[i]
        widths = [p.width for p in b.outputs] if what == "output" else \
            [b.n_continuous] if what == "derivatives" else [b.n_discrete]
        try:
            with np.errstate(all="ignore"):  # a probe at the initial wires (0/0 is the run's to report)
                want = getattr(b, what)(0.0, x.copy(), [a.copy() for a in u])
            want = [np.broadcast_to(np.asarray(v, float), (w,)) for v, w in zip(want if what == "output" else [want], widths)]
        except Exception:  # noqa: BLE001 - the method raises here: the run tells, on either path
            continue
        k = b.kernels
        f = getattr(k, what) or getattr(k, what + "_into")
        args = [b.params, 0.0, tuple(x.tolist()), tuple(tuple(a.tolist()) for a in u)]
        if getattr(k, what) is None:
            args.append(tuple(np.empty(w) for w in widths) if what == "output" else np.empty(widths[0]))
        # a block with its own method besides its kernel (a robot's: numpy, Pinocchio) agrees to
        # rounding: the kernel is its equations in another order
        own = getattr(type(b), what) is not getattr(Block, what)
        rtol = 1e-9 if own else 0.0
        try:
            with np.errstate(all="ignore"):
                got = f(*args)
            got = got if what == "output" else [got]
            same = len(got) == len(widths) and all(
                len(port) == w and np.allclose(np.array([float(port[j]) for j in range(w)]), v, rtol=rtol,
                                               atol=rtol * 1e-3, equal_nan=True)
                for port, w, v in zip(got, widths, want))
        except Exception:  # noqa: BLE001 - raises on tuples but not on arrays
            same = False
        if not same:
            bad.append(i)
    return bad
