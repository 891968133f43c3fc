"""The compiled glue's source: a diagram's equations written out for numba from its blocks' kernels.

:func:`glue_source` writes the functions of :class:`~hybridsim.engine.records.Glue` (the hit's
output pass, the updates, the right-hand side, the event functions and actions, the log path)
over the run's flat arrays, the output pass, updates and log path as one function ``hit`` (they
run only at hits and log points; compiled together, they link their kernels once), and the
method's Runge-Kutta steps (``steps``), the stages in one loop with the right-hand side's body
(``rhs_body``; a long one calls ``rhs_part`` functions) inlined there once and its blocks' params
(``rhs_params``) built once per call (the
compiled core takes every step and restep through ``steps``; its ``rhs`` is not called);
:mod:`hybridsim.engine.compiled` compiles and caches them. Inside the right-hand side every
signal element is a local float. Each kernel is a call of its own compiled version (cached
across diagrams; LLVM inlines the small ones). The blocks' numbers are rebuilt from the flat
``pf`` / ``pi`` arrays (:class:`~hybridsim.engine.params.ParamLayout`). The functions take their
arrays as data pointers and view them with the sizes known here.
"""
import functools
import hashlib
import inspect
import re

from hybridsim.engine import rk_code
from hybridsim.engine.fused import event_sizes
from hybridsim.engine.fused_code import offsets
from hybridsim.engine.kernels import marked


class _Writer:
    """Builds the glue's source: per block, its params, inputs and state as expressions."""

    def __init__(self, system, layout, env):
        self.sysm, self.layout, self.env = system, layout, env
        self.yoff, self.zoff = offsets(system)

    def params(self, i):
        return f"P{i}"

    def param_lines(self, blocks, pad="    "):
        return [f"{pad}P{i} = {self.layout.expression(i, self.env)}" for i in sorted(set(blocks))]

    def state(self, i, xname="x"):
        s = self.sysm.xslices[i]
        if s is not None:
            return _tuple(f"{xname}[{j}]" for j in range(s.start, s.stop))
        n, a = self.sysm.blocks[i].n_discrete, self.zoff[i]
        return _tuple(f"z[{a + j}]" for j in range(n)) if n else "()"

    def port(self, a, o, local=None):
        """An output port's elements: the locals of a block computed in this function, else y."""
        w = self.sysm.blocks[a].outputs[o].width
        if local is not None and a in local:
            return _tuple(f"y{a}_{o}_{j}" for j in range(w))
        return _tuple(f"y[{self.yoff[a][o] + j}]" for j in range(w))

    def inputs(self, i, local=None):
        return _tuple(self.port(a, o, local) for a, o in self.sysm.sources[i])

    def kernel(self, i, what):
        """The name of block ``i``'s kernel ``what`` in the source: a call of its own compiled version."""
        f = getattr(self.sysm.blocks[i].kernels, what)
        name = f"{what[:3]}{i}"
        self.env[name] = ("njit", f)
        return name

    def evaluate(self, i, pad, local, xname="x", store=False):
        """Lines computing block ``i``'s outputs into locals (and into y when ``store``; a kernel that
        writes its outputs, ``output_into``, writes them into y itself, its own elements there)."""
        b = self.sysm.blocks[i]
        if not b.outputs:
            return []
        into = self.sysm.blocks[i].kernels.output_into is not None
        f = self.kernel(i, "output_into" if into else "output")
        ports = "" if not into else ", " + _tuple(f"y[{a}:{a + p.width}]" for a, p in zip(self.yoff[i], b.outputs))
        lines = [f"{pad}r{i} = {f}(P{i}, t, {self.state(i, xname)}, {self.inputs(i, local)}{ports})"]
        for o, port in enumerate(b.outputs):
            for j in range(port.width):
                lines.append(f"{pad}y{i}_{o}_{j} = r{i}[{o}][{j}]")
                if store and not into:
                    lines.append(f"{pad}y[{self.yoff[i][o] + j}] = y{i}_{o}_{j}")
        local.add(i)
        return lines

    def check(self, i, pad):
        """``return i`` when one of block ``i``'s outputs is not finite (unless it may be)."""
        b = self.sysm.blocks[i]
        if not b.outputs or b.may_be_nonfinite:
            return []
        names = [f"y{i}_{o}_{j}" for o, p in enumerate(b.outputs) for j in range(p.width)]
        return [f"{pad}if not ({' and '.join(f'math.isfinite({n})' for n in names)}):", f"{pad}    return {i}"]


def _tuple(items):
    items = list(items)
    return "(" + "".join(f"{x}, " for x in items) + ")" if items else "()"


def glue_source(system, log_path, located, layout, method):
    """The generated module's source and the names it needs: ``(source, env)``; ``method`` is the
    Runge-Kutta method whose steps the glue takes itself (:func:`~.rk_code.glue_steps_lines`)."""
    sysm = system
    env = {}
    wr = _Writer(sysm, layout, env)
    due_col = {i: c for c, i in enumerate(sysm.discrete)}
    sig = "(t, x, y, z, pf, pi, due, row)"
    fns = []

    # the hit's output pass (op 0) and the log path (op 2) in one body (:func:`_pass_lines`); a long
    # one in parts of HIT_PART blocks, each a function of its own called in turn
    seq = sysm.plan.hit_sequence()
    logged = set(log_path)
    parts = [seq[k:k + HIT_PART] for k in range(0, len(seq), HIT_PART)] or [[]]
    helpers = []  # the parts' functions (taking the hit's arguments)
    if len(parts) == 1:
        L = [f"def outputs{sig}:"] + wr.param_lines([i for i, _ in seq]) + _pass_lines(wr, seq, logged, due_col)
    else:
        L = [f"def outputs{sig}:"]
        for c, part in enumerate(parts):
            helpers.append([f"def hit_part{c}(op, {sig[1:-1]}):"] + wr.param_lines([i for i, _ in part])
                           + _pass_lines(wr, part, logged, due_col) + ["    return -1"])
            L += [f"    r = hit_part{c}(op, t, x_p, y_p, z_p, pf_p, pi_p, due_p, row)", "    if r >= 0:",
                  "        return r"]
    L.append("    return -1")
    fns.append(L)

    # updates of the due discrete blocks, after every output of the hit
    upd = [i for i in sysm.plan.update_order(sysm.discrete) if sysm.blocks[i].n_discrete]
    L = [f"def update{sig}:"] + wr.param_lines(upd)
    for i in upd:
        n, a = sysm.blocks[i].n_discrete, wr.zoff[i]
        if sysm.blocks[i].kernels.update_into is not None:  # written into its own part of z
            f = wr.kernel(i, "update_into")
            L += [f"    if due[row, {due_col[i]}]:",
                  f"        {f}(P{i}, t, {wr.state(i)}, {wr.inputs(i)}, z[{a}:{a + n}])"]
        else:
            f = wr.kernel(i, "update")
            L += [f"    if due[row, {due_col[i]}]:",
                  f"        s{i} = {f}(P{i}, t, {wr.state(i)}, {wr.inputs(i)})"]
            L += [f"        z[{a + j}] = s{i}[{j}]" for j in range(n)]
        L += [f"        if not ({' and '.join(f'math.isfinite(z[{a + j}])' for j in range(n))}):",
              f"            return {i}"]
    L.append("    return -1")
    fns.append(L)

    # the right-hand side: every signal a local
    path = sorted(set(sysm.rhs_path))

    def rhs_outputs(pad="    "):
        local = set()
        lines = []
        for i in path:
            lines += wr.evaluate(i, pad, local)
        return lines, local

    # the right-hand side: its blocks' params built once per call of the steps (``rhs_params``), then
    # every signal a local in ``rhs_body`` (inlined into the steps; not viewed: it takes arrays)
    def derivative_lines(blocks, local):
        out = []
        for i in blocks:
            s = sysm.xslices[i]
            out.append(f"    d{i} = {wr.kernel(i, 'derivatives')}(P{i}, t, {wr.state(i)}, {wr.inputs(i, local)})")
            out += [f"    dx[at + {s.start + j}] = d{i}[{j}]" for j in range(s.stop - s.start)]
        return out

    def unpack(blocks):
        return ", ".join(f"P{i}" for i in blocks) + ("," if len(blocks) == 1 else "")

    used = sorted(set(path + list(sysm.stateful)))
    units = [(i, False) for i in path] + [(i, True) for i in sysm.stateful]
    rhs_parts = []
    if len(units) <= HIT_PART:
        lines, local = rhs_outputs()
        held = unpack(used)
        fns.append(["def rhs_params(pf, pi):"] + wr.param_lines(used) + [f"    return ({held})"])
        L = ["def rhs_body(t, x, dx, at, y, z, PP):"] + ([f"    {held} = PP"] if used else []) + lines
        L += derivative_lines(sysm.stateful, local)
    else:  # a long one in parts of HIT_PART blocks (outputs, then derivatives), each called with its
        # own params (PP[c]); a part stores its outputs in y, where the later parts read them
        chunks = [units[k:k + HIT_PART] for k in range(0, len(units), HIT_PART)]
        L = ["def rhs_body(t, x, dx, at, y, z, PP):"]
        own = []
        for c, chunk in enumerate(chunks):
            blocks = sorted({i for i, _ in chunk})
            done = set()
            body = [ln for i, d in chunk if not d for ln in wr.evaluate(i, "    ", done, store=True)]
            body += derivative_lines([i for i, d in chunk if d], done)
            rhs_parts.append([f"def rhs_part{c}(t, x, dx, at, y, z, PP):", f"    {unpack(blocks)} = PP"] + body
                             + ["    return 0"])
            L.append(f"    rhs_part{c}(t, x, dx, at, y, z, PP[{c}])")
            own.append(f"({unpack(blocks)})")
        fns.append(["def rhs_params(pf, pi):"] + wr.param_lines(used) + [f"    return ({', '.join(own)},)"])
    rhs_fn = L + ["    pass"]
    # the compiled core takes every step, restep included, through ``steps`` and never calls ``rhs``
    # (compiling it would cost a copy of the right-hand side): NaN, should anything call it
    fns.append(["def rhs(t, x, dx, at, y, z, pf, pi):", f"    for k in range({sysm.n_x}):",
                "        dx[at + k] = math.nan"])
    fns.append(rk_code.glue_steps_lines(method, "rhs_body", "rhs_params(pf_p, pi_p)"))

    # located events: their functions and actions; with many blocks, in parts of HIT_PART blocks (the
    # path's outputs stored in y by path_part functions, the functions and actions reading them there)
    sizes = event_sizes(sysm, located) if located else []
    starts = [sum(sizes[:k]) for k in range(len(sizes))]
    long = bool(located) and len(path) + len(located) > HIT_PART
    if long:
        lines, local = [], set()
        for c, k in enumerate(range(0, len(path), HIT_PART)):
            part, done = path[k:k + HIT_PART], set()
            body = [ln for i in part for ln in wr.evaluate(i, "    ", done, store=True)]
            helpers.append([f"def path_part{c}(t, x, y, z, pf, pi):"] + wr.param_lines(part) + body + ["    return 0"])
            lines.append(f"    path_part{c}(t, x_p, y_p, z_p, pf_p, pi_p)")
    else:
        lines, local = rhs_outputs() if located else ([], set())  # no located events: nothing to compute
    groups = ([list(range(k, min(k + HIT_PART, len(located)))) for k in range(0, len(located), HIT_PART)]
              if long else [list(range(len(located)))])

    def zc_lines(group):
        out = []
        for n in group:
            i, m, c = located[n], sizes[n], starts[n]
            out.append(f"    e{i} = {wr.kernel(i, 'zero_crossings')}(P{i}, t, {wr.state(i)}, {wr.inputs(i, local)})")
            out += [f"    g[{c + j}] = e{i}[{j}]" for j in range(m)]
        return out

    def act_lines(group):
        out = []
        for n in group:
            i, m, c = located[n], sizes[n], starts[n]
            s = sysm.xslices[i]
            if sysm.blocks[i].kernels.event_action is None or s is None:  # a switch: it only restarts
                continue
            fired = _tuple(f"fired[{c + j}]" for j in range(m))
            out += [f"    if {' or '.join(f'fired[{c + j}]' for j in range(m))}:",
                    f"        a{i} = {wr.kernel(i, 'event_action')}(P{i}, t, {wr.state(i)}, {wr.inputs(i, local)}, {fired})"]
            out += [f"        xn[{s.start + j}] = a{i}[{j}]" for j in range(s.stop - s.start)]
        return out

    def in_parts(name, args, call, lines_of):
        """The located blocks' lines in place, or, in a long diagram, calls of ``name``_part functions
        of HIT_PART blocks each."""
        if not long:
            return lines_of(groups[0])
        out = []
        for c, group in enumerate(groups):
            body = lines_of(group)
            if body:
                helpers.append([f"def {name}_part{c}({args}):"] + wr.param_lines([located[n] for n in group])
                               + body + ["    return 0"])
                out.append(f"    {name}_part{c}({call})")
        return out

    head = wr.param_lines(path + list(located)) if located and not long else []
    if located:  # without, the shared stub (glue_stubs.zc)
        fns.append(["def zc(t, x, g, y, z, pf, pi):"] + head + lines
                   + in_parts("zc", "t, x, g, y, z, pf, pi", "t, x_p, g_p, y_p, z_p, pf_p, pi_p", zc_lines))
    fns.append(["def act(t, x, xn, fired, y, z, pf, pi):"] + head + lines
               + [f"    for k in range({sysm.n_x}):", "        xn[k] = x[k]"]
               + in_parts("act", "t, x, xn, fired, y, z, pf, pi", "t, x_p, xn_p, fired_p, y_p, z_p, pf_p, pi_p", act_lines)
               + ["    return 0"])

    # no time events or step hooks on this path: next_time, timed and stepped are glue_stubs'

    # the output pass, the updates and the log path as one function told which by ``op`` (HIT_OPS):
    # called only at hits and log points, and compiled once they link their kernels once, not thrice
    named = {f[0][len("def "):f[0].index("(")]: f for f in fns}
    # the blocks' params once, before the ops (each op built those it uses: the same lines compiled
    # up to three times); one with an array reshaped stays in the ops that use it (a reshape is a
    # call numba makes even where its result is not used)
    def hoisted(line):
        return _PARAM_LINE.match(line) and ".reshape(" not in line

    params = {line for name in _HIT_FUNCTIONS for line in named[name][1:] if hoisted(line)}
    hit = [f"def hit(op, {sig[1:-1]}):"] + sorted(params, key=lambda line: int(_PARAM_LINE.match(line).group(1)))
    hit += [f"    if op == {HIT_OPS.index('update')}:"] + ["    " + line for line in named["update"][1:]
                                                           if not hoisted(line)]
    hit += [line for line in named["outputs"][1:] if not hoisted(line)]
    fns = [f for name, f in named.items() if name not in _HIT_FUNCTIONS] + [hit]
    # the core passes each array as its data pointer (one word, not numba's seven-field array
    # struct); the glue views it with the sizes known here
    n_y = sum(p.width for b in sysm.blocks for p in b.outputs)
    n_z = sum(b.n_discrete for b in sysm.blocks)
    n_e = sum(sizes)
    n_x, stages = sysm.n_x, len(method.c)
    shapes = {"num": "(8,)", "kk": f"({stages * n_x},)", "xs": f"({n_x},)", "xm": f"({n_x},)",
              "x": f"({sysm.n_x},)", "xn": f"({sysm.n_x},)", "dx": f"(at + {sysm.n_x},)", "y": f"({n_y},)",
              "z": f"({n_z},)", "pf": f"({layout.nf},)", "pi": f"({layout.ni},)", "g": f"({n_e},)",
              "fired": f"({n_e},)", "due": f"(row + 1, {len(sysm.discrete)})"}
    fns = rhs_parts + [rhs_fn] + [_viewing(f, shapes) for f in helpers + fns]
    body = "\n\n\n".join("\n".join(f if len(f) > 1 else f + ["    pass"]) for f in fns)
    kernels = [f[1] if isinstance(f, tuple) else f for f in env.values() if callable(f) or isinstance(f, tuple)]
    stamp = _stamp(reachable(k for k in kernels if callable(k)))
    names = "".join(f"#   {n} = {_describe(f)}\n" for n, f in sorted(env.items()))
    head = (f"# generated by hybridsim.engine.compiled for diagram {sysm.name!r}; kernels {stamp}\n{names}"
            "import math\n\nimport numpy as np\nfrom numba import carray\n\n"
            "from hybridsim.engine.pointers import offset\n\n\n")
    return head + body + "\n", env


#: the most blocks one generated function holds (the hit's output pass, the event functions, the
#: actions): numba's compile time grows faster than a function's length, so a longer one is cut
#: into functions of this many blocks, called in turn (a part reads the ones before it from y)
HIT_PART = 32


def _pass_lines(wr, seq, logged, due_col):
    """The output pass (op 0) and the log path (op 2) over ``seq`` (``[(block, is_discrete)]``): the log
    path's blocks run in both, the others only in op 0 (the due discrete ones only when due); a block
    run only in op 0 is read from y after its group, where op 2 finds the value it holds between hits."""
    L, local, group = [], set(), None  # group: the blocks of the open ``if op == 0:``
    for i, disc in seq:
        if i in logged:
            if group is not None:
                local -= group
                group = None
            L += wr.evaluate(i, "    ", local, store=True) + wr.check(i, "    ")
            continue
        pad = "            " if disc else "        "
        body = wr.evaluate(i, pad, local, store=True) + wr.check(i, pad)
        if not body:
            continue
        if group is None:
            L.append("    if op == 0:")
            group = set()
        if disc:
            local.discard(i)  # held when not due: later blocks read it from y
            L += [f"        if due[row, {due_col[i]}]:"] + body
        else:
            group.add(i)
            L += body
    return L


#: what ``hit`` does, by its argument ``op`` (0, 1, 2): the output pass, the updates, the log path
HIT_OPS = ("outputs", "update", "observe")
#: the generated functions ``hit`` is written from (the output pass holds the log path)
_HIT_FUNCTIONS = ("outputs", "update")
#: a line building block i's params at a function's top level (``_Writer.param_lines``)
_PARAM_LINE = re.compile(r"^    P(\d+) = ")


def _viewing(lines, shapes):
    """A generated function taking its arrays as pointers (``x_p``), viewed as arrays by their old names."""
    head, rest = lines[0], lines[1:]
    name, params = head[len("def "):-len("):")].split("(")
    params = [a.strip() for a in params.split(",")]
    views = [f"    {a} = carray({a}_p, {shapes[a]})" for a in params if a in shapes]
    params = [f"{a}_p" if a in shapes else a for a in params]
    return [f"def {name}({', '.join(params)}):"] + views + rest


def _describe(f):
    if isinstance(f, tuple):
        f = f[1]
    if inspect.isclass(f):
        return f"{f.__module__}.{f.__qualname__} (params)"
    return f"{f.__module__}.{f.__qualname__}"


def reachable(functions):
    """``functions`` and every :func:`~hybridsim.engine.kernels.kernel` they call, directly or not.

    What generated glue's machine code depends on: its cache key, so defining or
    editing an unrelated kernel recompiles nothing.
    """
    kernels = {id(f): f for f in marked()}
    seen, todo = {}, list(functions)
    while todo:
        f = todo.pop()
        if id(f) in seen:
            continue
        seen[id(f)] = f
        code = getattr(f, "__code__", None)
        if code is None:
            continue
        names = set(code.co_names)
        for const in code.co_consts:  # nested functions' names too
            if hasattr(const, "co_names"):
                names |= set(const.co_names)
        glb = getattr(f, "__globals__", {})
        todo += [glb[n] for n in names if n in glb and id(glb[n]) in kernels]
    return frozenset(seen.values())


@functools.lru_cache(maxsize=None)
def _stamp(functions):
    """A hash of the kernels' source text (a kernel edited means a new module)."""
    def text(f):
        try:
            return inspect.getsource(f)
        except (OSError, TypeError):  # defined at a prompt: its byte code then
            return f.__code__.co_code.hex() + repr(f.__code__.co_consts)

    key = lambda f: (f.__module__, f.__qualname__)  # noqa: E731
    return hashlib.sha256("".join(text(f) for f in sorted(functions, key=key)).encode()).hexdigest()[:16]
