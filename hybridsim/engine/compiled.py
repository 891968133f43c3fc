"""The compiled path: a diagram's glue generated for numba, run by the compiled stepping core.

``compiled: true`` (YAML ``simulation``, CLI ``--compiled``, or
``Simulator(compiled=True)``) runs the stepping core compiled once per
machine (:mod:`hybridsim.engine.native`) with this diagram's glue: the
functions of :class:`~hybridsim.engine.stepping.Glue` (the hit's output pass,
the updates, the right-hand side, the event functions and actions, the log
path) generated as numba source from the blocks' kernels
(:mod:`hybridsim.engine.kernels`) and compiled as first-class functions. Inside
the right-hand side every signal element is a local float and the plant's
kernels are inlined; elsewhere the kernels are called as compiled functions
that numba caches on disk across diagrams. The blocks' numbers reach the
glue at run time as two flat arrays (:class:`ParamLayout`), so one compiled
glue serves every parameter value of a diagram's structure. Generated
modules live in ``HYBRIDSIM_CACHE`` (default ``~/.cache/hybridsim``), keyed by
their source and the kernels' source text.

Needs: a fixed-step Runge-Kutta solver, kernels in every block that computes
something (FMU blocks have none), events given as kernels, no time events
or step hooks. :func:`problems` says what a diagram lacks.
"""
import functools
import hashlib
import importlib.util
import inspect
import logging
import os
import re
import sys
import warnings

from hybridsim.engine import native, rk
from hybridsim.engine.fused import event_kernels, event_sizes, has_kernels
from hybridsim.engine.kernels import make_jitable, marked
from hybridsim.engine.params import ParamLayout, ParamStructureError
from hybridsim.engine.solvers import ExplicitRK
from hybridsim.errors import CompiledPathError, ParameterError

log = logging.getLogger(__name__)
_loaded = {}         # source hash -> the compiled glue (this process)
cache_dir = native.cache_dir


def problems(system, solver, located=None):
    """Why ``system`` cannot run compiled with ``solver`` (empty list: it can)."""
    located = system.action_events if located is None else located
    out = []
    if not isinstance(solver, ExplicitRK):
        out.append("the compiled path integrates with a fixed-step Runge-Kutta method (rk4, heun); "
                   f"this diagram's solver is {solver!r}")
    missing = [f"{b.name} ({type(b).__name__})" for b in system.blocks
               if (b.outputs or b.n_continuous or b.n_discrete) and not has_kernels(b)]
    if missing:
        out.append("these blocks have no kernels (hybridsim.engine.kernels) to compile: " + ", ".join(missing))
    timed = [system.blocks[i].name for i in system.time_events]
    if timed:
        out.append("time events (next_event_time) are not on the compiled path: " + ", ".join(timed))
    stepped = [system.blocks[i].name for i in system.after_step]
    if stepped:
        out.append("blocks told of every step (after_step) are not on the compiled path: " + ", ".join(stepped))
    no_events = [system.blocks[i].name for i in located if not event_kernels(system.blocks[i])]
    if no_events:
        out.append("these blocks give their events as methods, not kernels (zero_crossings, "
                   "event_action): " + ", ".join(no_events))
    try:
        ParamLayout(system.blocks)
    except ParamStructureError as exc:
        out.append(str(exc))
    return out


class CompiledGlue:
    """The compiled glue of one system, and what a run of it needs."""

    def __init__(self, system, solver, log_path, located=None):
        self.located = system.action_events if located is None else located
        why = problems(system, solver, self.located)
        if why:
            raise CompiledPathError("cannot use the compiled path: " + "; ".join(why))
        try:
            import numba  # noqa: F401
        except ImportError:  # pragma: no cover - numba is in the test extra
            raise CompiledPathError(
                "the compiled path needs numba: pip install -e \".[fast]\" (or run without --compiled)"
            ) from None
        self.system, self.solver = system, solver
        self.layout = ParamLayout(system.blocks)
        self.source, env = glue_source(system, log_path, self.located, self.layout)
        self.glue = _load(self.source, env, system.name, system)
        try:
            self.run_fn = native.core(type(solver))
        except OSError as exc:
            raise CompiledPathError(f"cannot write numba's cache to {cache_dir()}: {exc} "
                                    "(set HYBRIDSIM_CACHE to a writable folder)") from None
        self.run = _entry(self.run_fn)
        self.state = rk.rk_state(solver)

    def machinery(self, ctx):
        """``(glue, ops, state, pf, pi)`` for a run of ``ctx`` (its blocks' numbers flattened)."""
        try:
            pf, pi = self.layout.flatten(ctx.params)
        except ParamStructureError as exc:
            raise ParameterError("params", f"{exc}: rebuild the diagram for that") from None
        s = self.state._replace(num=self.state.num.copy())  # one per run: runs may share threads
        return self.glue, None, s, pf, pi


def _entry(run_fn):
    """``run`` as :func:`~hybridsim.engine.stepping.run` takes its arguments, through the compiled
    core's entry point for its one signature (no dispatch on argument types; the stepper is
    compiled in, so ``ops`` is not passed)."""
    entry = run_fn.overloads[run_fn.signatures[0]].entry_point

    def run(tl, k0, k1, glue, ops, s, lim, w, out, y, z, pf, pi):
        return entry(tl, k0, k1, glue, s, lim, w, out, y, z, pf, pi)

    return run


# -- the generated source -------------------------------------------------------------------
class _Writer:
    """Builds the glue's source: per block, its params, inputs and state as expressions."""

    def __init__(self, system, layout, env):
        self.sysm, self.layout, self.env = system, layout, env
        b = system.blocks
        self.yoff, k = [], 0
        for blk in b:
            self.yoff.append([])
            for p in blk.outputs:
                self.yoff[-1].append(k)
                k += p.width
        self.zoff, k = [], 0
        for blk in b:
            self.zoff.append(k)
            k += blk.n_discrete

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

    def kernel(self, i, what, inline):
        """The name of block ``i``'s kernel ``what`` in the source (inlined or a compiled call)."""
        f = getattr(self.sysm.blocks[i].kernels, what)
        name = f"{what[:3]}{i}" + ("" if inline else "_c")
        self.env[name] = f if inline else ("njit", f)
        return name

    def evaluate(self, i, pad, local, inline, xname="x", store=False):
        """Lines computing block ``i``'s outputs into locals (and into y when ``store``)."""
        b = self.sysm.blocks[i]
        if not b.outputs:
            return []
        f = self.kernel(i, "output", inline)
        lines = [f"{pad}r{i} = {f}(P{i}, t, {self.state(i, xname)}, {self.inputs(i, local)})"]
        for o, port in enumerate(b.outputs):
            for j in range(port.width):
                lines.append(f"{pad}y{i}_{o}_{j} = r{i}[{o}][{j}]")
                if store:
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


def glue_source(system, log_path, located, layout):
    """The generated module's source and the names it needs: ``(source, env)``."""
    sysm = system
    env = {}
    wr = _Writer(sysm, layout, env)
    due_col = {i: c for c, i in enumerate(sysm.discrete)}
    sig = "(t, x, y, z, pf, pi, due, row)"
    fns = []

    # the hit: outputs of every block not discrete and of the due discrete ones
    hit = [i for i, _ in sysm.plan.hit_sequence()]
    L = [f"def outputs{sig}:"] + wr.param_lines(hit)
    local = set()
    for i, disc in sysm.plan.hit_sequence():
        if disc:
            body = wr.evaluate(i, "        ", local, False, store=True) + wr.check(i, "        ")
            local.discard(i)  # held when not due: later blocks read it from y
            if body:
                L += [f"    if due[row, {due_col[i]}]:"] + body
        else:
            L += wr.evaluate(i, "    ", local, False, store=True) + wr.check(i, "    ")
    L.append("    return -1")
    fns.append(L)

    # updates of the due discrete blocks, after every output of the hit
    upd = [i for i in sysm.plan.update_order(sysm.discrete) if sysm.blocks[i].n_discrete]
    L = [f"def update{sig}:"] + wr.param_lines(upd)
    for i in upd:
        n, a = sysm.blocks[i].n_discrete, wr.zoff[i]
        f = wr.kernel(i, "update", False)
        L += [f"    if due[row, {due_col[i]}]:",
              f"        s{i} = {f}(P{i}, t, {wr.state(i)}, {wr.inputs(i)})"]
        L += [f"        z[{a + j}] = s{i}[{j}]" for j in range(n)]
        L += [f"        if not ({' and '.join(f'math.isfinite(z[{a + j}])' for j in range(n))}):",
              f"            return {i}"]
    L.append("    return -1")
    fns.append(L)

    # the right-hand side: the plant's kernels inlined, every signal a local
    path = sorted(set(sysm.rhs_path))

    def rhs_outputs(pad="    "):
        local = set()
        lines = []
        for i in path:
            lines += wr.evaluate(i, pad, local, True)
        return lines, local

    lines, local = rhs_outputs()
    L = ["def rhs(t, x, dx, at, y, z, pf, pi):"] + wr.param_lines(path + list(sysm.stateful)) + lines
    for i in sysm.stateful:
        s = sysm.xslices[i]
        f = wr.kernel(i, "derivatives", True)
        L.append(f"    d{i} = {f}(P{i}, t, {wr.state(i)}, {wr.inputs(i, local)})")
        L += [f"    dx[at + {s.start + j}] = d{i}[{j}]" for j in range(s.stop - s.start)]
    fns.append(L)

    # located events: their functions and actions
    sizes = event_sizes(sysm, located) if located else []
    lines, local = rhs_outputs()
    L = ["def zc(t, x, g, y, z, pf, pi):"] + wr.param_lines(path + list(located)) + lines
    c = 0
    for i, m in zip(located, sizes):
        f = wr.kernel(i, "zero_crossings", False)
        L.append(f"    e{i} = {f}(P{i}, t, {wr.state(i)}, {wr.inputs(i, local)})")
        L += [f"    g[{c + j}] = e{i}[{j}]" for j in range(m)]
        c += m
    if not located:
        L.append("    pass")
    fns.append(L)
    L = ["def act(t, x, xn, fired, y, z, pf, pi):"] + wr.param_lines(path + list(located)) + lines
    L += [f"    for k in range({sysm.n_x}):", "        xn[k] = x[k]"]
    c = 0
    for i, m in zip(located, sizes):
        s = sysm.xslices[i]
        if sysm.blocks[i].kernels.event_action is None or s is None:  # a switch: it only restarts
            c += m
            continue
        f = wr.kernel(i, "event_action", False)
        fired = _tuple(f"fired[{c + j}]" for j in range(m))
        L += [f"    if {' or '.join(f'fired[{c + j}]' for j in range(m))}:",
              f"        a{i} = {f}(P{i}, t, {wr.state(i)}, {wr.inputs(i, local)}, {fired})"]
        L += [f"        xn[{s.start + j}] = a{i}[{j}]" for j in range(s.stop - s.start)]
        c += m
    L.append("    return 0")
    fns.append(L)

    # the log path, at a log point between hits (its outputs stored for the log's columns)
    L = ["def observe(t, x, y, z, pf, pi):"] + wr.param_lines(log_path)
    local = set()
    for i in log_path:
        L += wr.evaluate(i, "    ", local, False, store=True) + wr.check(i, "    ")
    L.append("    return -1")
    fns.append(L)
    fns.append(["def next_time(t, x, y, z, pf, pi):", "    return np.inf"])
    fns.append(["def timed(t, x, xn, y, z, pf, pi):", "    return 0"])
    fns.append(["def stepped(t, x, y, z, pf, pi):", "    return 0"])

    body = "\n\n\n".join("\n".join(f if len(f) > 1 else f + ["    pass"]) for f in fns)
    kernels = [f[1] if isinstance(f, tuple) else f for f in env.values() if callable(f) or isinstance(f, tuple)]
    stamp = _stamp(reachable(k for k in kernels if callable(k)))
    names = "".join(f"#   {n} = {_describe(f)}\n" for n, f in sorted(env.items()))
    head = (f"# generated by hybridsim.engine.compiled for diagram {sysm.name!r}; kernels {stamp}\n{names}"
            "import math\n\nimport numpy as np\n\n\n")
    return head + body + "\n", env


def _describe(f):
    if isinstance(f, tuple):
        f = f[1]
    if inspect.isclass(f):
        return f"{f.__module__}.{f.__qualname__} (params)"
    return f"{f.__module__}.{f.__qualname__}"


# -- compiling and loading ----------------------------------------------------------------------
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


_jitted = {}  # kernel -> its numba dispatcher (compiled once per signature, cached on disk)


def _dispatcher(f):
    """``f`` compiled on its own (numba caches it on disk across diagrams); a kernel that calls a
    Python library compiles its numba twin (``f.compiled``) instead."""
    from numba import njit

    if f not in _jitted:
        _jitted[f] = njit(cache=True)(getattr(f, "compiled", f))
    return _jitted[f]


def _load(source, env, name, system=None):
    """Compile (or load from the cache) the glue in ``source``: a :class:`~.stepping.Glue` of cfuncs."""
    from numba import cfunc
    from numba.core.errors import NumbaError, NumbaExperimentalFeatureWarning, NumbaIRAssumptionWarning
    from hybridsim.engine.stepping import Glue

    key = hashlib.sha256(source.encode()).hexdigest()[:24]
    if key in _loaded:
        return _loaded[key]
    make_jitable(set(marked()) | {v for v in env.values() if callable(v) and not inspect.isclass(v)})
    resolved = {n: (_dispatcher(v[1]) if isinstance(v, tuple) else v) for n, v in env.items()}
    folder = cache_dir()
    path = folder / f"glue_{key}.py"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        native.use_cache_dir()
        if not path.exists():
            log.info("compiling %r with numba (once: later runs load it from %s)", name, folder)
            tmp = path.with_suffix(f".{os.getpid()}.tmp")
            tmp.write_text(source)
            os.replace(tmp, path)
    except OSError as exc:
        raise CompiledPathError(f"cannot write the compiled module to {folder}: {exc} "
                                "(set HYBRIDSIM_CACHE to a writable folder)") from None
    spec = importlib.util.spec_from_file_location(f"hybridsim_glue_{key}", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # numba's cache finds the module by name
    spec.loader.exec_module(module)
    vars(module).update(resolved)  # the kernels, by the names the source uses
    types = native.types()["glue"]
    try:
        with warnings.catch_warnings():
            # numba's inliner trips an internal "pedantic" SSA check on some kernels;
            # the results are checked bit for bit against the generic path (tests)
            warnings.simplefilter("ignore", NumbaIRAssumptionWarning)
            warnings.simplefilter("ignore", NumbaExperimentalFeatureWarning)
            glue = Glue(*(cfunc(types[k].signature, cache=True)(getattr(module, k)) for k in Glue._fields))
    except NumbaError as exc:
        raise CompiledPathError(_compile_failure(exc, name, system)) from None
    _loaded[key] = glue
    return glue


def _compile_failure(exc, name, system):
    """What to tell a user whose kernels numba cannot compile: the blocks the message names."""
    text = re.sub(r"\x1b\[[0-9;]*m", "", str(exc))  # numba colours its messages
    blocks = system.blocks if system is not None else []
    culprits = sorted({f"{b.name} ({type(b).__name__})" for b in blocks if b.kernels is not None
                       for f in b.kernels if callable(f) and f.__name__ in text})
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    why = ("Untyped global", "Unknown attribute", "Cannot", "not supported", "unsupported", "Invalid use")
    first = next((line for line in lines if any(w in line for w in why)), lines[0] if lines else "")
    return (f"numba cannot compile the kernels of diagram {name!r}"
            + (f"; the message names block(s) {', '.join(culprits)}" if culprits else "")
            + f": {first} (kernels must keep to numba's nopython subset, see hybridsim.engine.kernels; "
              "or run without compiled)")
