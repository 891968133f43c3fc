"""The compiled path: a diagram's glue generated for numba, run by the compiled stepping core.

``compiled: true`` (YAML ``simulation``, CLI ``--compiled``, or
``Simulator(compiled=True)``) runs the stepping core compiled once per
machine (:mod:`hybridsim.engine.native`) with this diagram's glue: the
functions of :class:`~hybridsim.engine.stepping.Glue` (the hit's output pass,
the updates, the right-hand side, the event functions and actions, the log
path) generated as numba source from the blocks' kernels
(:mod:`hybridsim.engine.kernels`) and compiled as first-class functions, with
the method's steps (``Glue.steps``: the right-hand side inlined in the loop over the
stages, :func:`~hybridsim.engine.rk_code.glue_steps_lines`). Inside the right-hand side
every signal element is a local float; the kernels are
called as compiled functions that numba caches on disk across diagrams. The
blocks' numbers reach the glue at run time as two flat arrays (:class:`ParamLayout`), so one compiled
glue serves every parameter value of a diagram's structure. Generated
modules live in ``HYBRIDSIM_CACHE`` (default ``~/.cache/hybridsim``), keyed by
their source and the kernels' source text.

Needs: a fixed-step Runge-Kutta solver, kernels in every block that computes
something (FMU blocks have none), events given as kernels, no time events
or step hooks. :func:`problems` says what a diagram lacks.
"""
import contextlib
import ctypes
import functools
import hashlib
import importlib.util
import inspect
import logging
import os
import re
import sys
import threading
import warnings

import numpy as np

from hybridsim.engine import native, rk
from hybridsim.engine.codegen import HIT_OPS, glue_source
from hybridsim.engine.context import Context
from hybridsim.engine.fused import event_kernels, has_kernels
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
    missing = [b for b in system.blocks if (b.outputs or b.n_continuous or b.n_discrete) and not has_kernels(b)]
    if missing:
        types = sorted({getattr(type(b), "type_name", None) for b in missing} - {None})
        out.append("these blocks have no kernels (hybridsim.engine.kernels) to compile, in this configuration: "
                   + ", ".join(f"{b.name} ({b.type_label})" for b in missing)
                   + (f" (`hybridsim blocks {' '.join(types)}` says which configurations have them)" if types else ""))
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
    big = [(b, what) for b in system.blocks for items, what in [_widest(b)] if items >= MAX_TUPLE]
    if big:
        out.append(f"numba takes tuples of fewer than {MAX_TUPLE} items, and the glue hands a block its state "
                   "and each port as one: " + ", ".join(f"{b.name} ({b.type_label}: {what})" for b, what in big))
    try:
        ParamLayout(system.blocks)
    except ParamStructureError as exc:
        out.append(str(exc))
    return out


#: numba's limit on a tuple's length (its message: "Tuple length must be smaller than 1000")
MAX_TUPLE = 1000


def _widest(block):
    """(items, what) of the block's largest tuple in the glue: its state, or its widest port."""
    sizes = [(block.n_continuous, f"{block.n_continuous} continuous states"),
             (block.n_discrete, f"{block.n_discrete} discrete states")]
    sizes += [(p.width, f"input {p.name!r} {p.width} wide") for p in block.inputs]
    sizes += [(p.width, f"output {p.name!r} {p.width} wide") for p in block.outputs]
    return max(sizes, key=lambda s: s[0])


_catching = threading.local()
_LAYOUTS_LOCK = threading.Lock()  # run_batch's threads may meet a new layout at once


def _unraisable(info, previous=sys.unraisablehook):
    """``sys.unraisablehook`` once a compiled run has caught: what a thread's run catches goes to its
    list (:func:`caught_unraisable`); the rest as before."""
    box = getattr(_catching, "box", None)
    if box is None:
        return previous(info)
    box.append(info)


@contextlib.contextmanager
def caught_unraisable(box):
    """The exceptions that compiled code reports as unraisable in this thread (a kernel that raises:
    numba prints it as "ignored" and the loop goes on), into ``box`` instead of stderr."""
    if sys.unraisablehook is not _unraisable:
        sys.unraisablehook = _unraisable
    before = getattr(_catching, "box", None)
    _catching.box = box
    try:
        yield box
    finally:
        _catching.box = before


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
        self.system, self.solver, self.log_path = system, solver, log_path
        self.layout = ParamLayout(system.blocks)
        self.source, env = glue_source(system, log_path, self.located, self.layout, type(solver))
        self.glue = _load(self.source, env, system.name, system)
        self._layouts = {}  # a run's params of other sizes (a longer table): their layout and glue
        try:
            self.run_fn = native.core(type(solver))
        except OSError as exc:
            raise CompiledPathError(f"cannot write numba's cache to {cache_dir()}: {exc} "
                                    "(set HYBRIDSIM_CACHE to a writable folder)") from None
        self.run = _entry(self.run_fn)
        self.state = rk.rk_state(solver)

    def numbers(self, params):
        """``(glue, pf, pi)``: a run's params (one per block) flattened, and the glue of their layout."""
        try:
            return (self.glue, *self.layout.flatten(params))
        except ParamStructureError:  # an array of another size (a table's points): that layout's glue
            return self._other_layout(params)

    def context(self, params=None):
        """``(ctx, numbers)``: a fresh context of the system (``params``: ``{"block.param": value}``)
        whose provisional outputs at t = 0 the glue computes, and its :meth:`numbers`."""
        sysm = self.system
        blocks = sysm.blocks_with(params) if params else sysm.blocks
        numbers = self.numbers(tuple(b.params for b in blocks))

        def outputs(ctx, t, due):
            return self.evaluate(numbers, t, ctx, due)

        return Context(sysm, blocks, outputs), numbers

    def evaluate(self, numbers, t, ctx, due=None):
        """Every block's outputs at ``t`` into ``ctx`` (``due``: a bool per discrete block, those that
        do not hold theirs; None: every one holds), by
        the glue's output pass; False when it did not (a state not a contiguous float array) or
        stopped at a non-finite output or a kernel raised: the caller then evaluates the blocks'
        Python, as the generic path does (which raises the kernel's error, or goes on past NaN)."""
        xc = ctx.xc
        if not (xc.dtype == np.float64 and xc.flags.c_contiguous):
            return False
        glue, pf, pi = numbers
        call = _callers.get(glue.outputs.address)
        if call is None:
            call = _callers[glue.outputs.address] = _OUTPUTS(glue.outputs.address)
        due = np.zeros((1, len(self.system.discrete)), bool) if due is None else \
            np.ascontiguousarray(due, bool).reshape(1, -1)
        y, z = ctx.flat()
        raised = []
        with caught_unraisable(raised):
            code = call(0, t, xc.ctypes.data, y.ctypes.data, z.ctypes.data, pf.ctypes.data, pi.ctypes.data,
                        due.ctypes.data, 0)
        return code < 0 and not raised

    def machinery(self, ctx, numbers=None):
        """``(glue, ops, state, pf, pi)`` for a run of ``ctx`` (``numbers``: :meth:`numbers` of its
        params, when already flattened)."""
        glue, pf, pi = numbers or self.numbers(ctx.params)
        s = self.state._replace(num=self.state.num.copy(), tmp=self.state.tmp.copy())  # one per run: runs may share threads
        return glue, None, s, pf, pi

    def _other_layout(self, params):
        """``(glue, pf, pi)`` for params whose arrays have other sizes than the diagram's: the glue
        of their layout, compiled once (and cached like any glue)."""
        try:
            layout = ParamLayout(self.system.blocks, params)
        except ParamStructureError as exc:
            raise ParameterError("params", str(exc)) from None
        key = repr(layout.specs)
        if key not in self._layouts:
            with _LAYOUTS_LOCK:
                if key not in self._layouts:
                    source, env = glue_source(self.system, self.log_path, self.located, layout, type(self.solver))
                    self._layouts[key] = (layout, _load(source, env, self.system.name, self.system))
        layout, glue = self._layouts[key]
        pf, pi = layout.flatten(params)
        return glue, pf, pi


#: the glue's output pass (``hit``, op 0) called from Python: arrays as data addresses
_OUTPUTS = ctypes.CFUNCTYPE(ctypes.c_int64, ctypes.c_int64, ctypes.c_double, *[ctypes.c_void_p] * 6, ctypes.c_int64)
_callers = {}  # the address of a glue's hit -> its ctypes caller


def _entry(run_fn):
    """``run`` as :func:`~hybridsim.engine.stepping.run` takes its arguments, through the compiled
    core's entry point for its one signature (no dispatch on argument types; the stepper is
    compiled in, so ``ops`` is not passed; the glue goes as its functions' addresses)."""
    entry = run_fn.overloads[run_fn.signatures[0]].entry_point

    def run(tl, k0, k1, glue, ops, s, lim, w, out, y, z, pf, pi):
        return entry(tl, k0, k1, addresses(glue), s, lim, w, out, y, z, pf, pi)

    return run


_addresses = {}  # the address of a glue's steps -> the addresses of all its functions


def addresses(glue):
    """The addresses of ``glue``'s compiled functions, in :class:`~.stepping.Glue`'s order (int64)."""
    a = _addresses.get(glue.steps.address)
    if a is None:
        a = _addresses[glue.steps.address] = np.array([f.address for f in glue], np.int64)
    return a


# -- compiling and loading ----------------------------------------------------------------------
_jitted = {}  # kernel -> its numba dispatcher (compiled once per signature, cached on disk)


def _dispatcher(f):
    """``f`` compiled on its own (numba caches it on disk across diagrams); a kernel that calls a
    Python library compiles its numba twin (``f.compiled``) instead."""
    from numba import njit

    if f not in _jitted:
        # only the glue calls it: no wrapper to call it from Python or C
        _jitted[f] = njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)(getattr(f, "compiled", f))
    return _jitted[f]


def _load(source, env, name, system=None):
    """Compile (or load from the cache) the glue in ``source``: a :class:`~.stepping.Glue` of cfuncs."""
    from numba import cfunc, njit
    from numba.core.errors import NumbaError, NumbaExperimentalFeatureWarning, NumbaIRAssumptionWarning
    from hybridsim.engine.stepping import Glue

    key = hashlib.sha256(source.encode()).hexdigest()[:24]
    if key in _loaded:
        return _loaded[key]
    make_jitable(set(marked()) | {v for v in env.values() if callable(v) and not inspect.isclass(v)})
    folder = cache_dir()
    path = folder / f"glue_{key}.py"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        native.use_cache_dir()  # before any kernel's dispatcher: numba picks its cache folder then
        if not path.exists():
            log.info("compiling %r with numba (once: later runs load it from %s)", name, folder)
            tmp = path.with_suffix(f".{os.getpid()}.tmp")
            tmp.write_text(source)
            os.replace(tmp, path)
    except OSError as exc:
        raise CompiledPathError(f"cannot write the compiled module to {folder}: {exc} "
                                "(set HYBRIDSIM_CACHE to a writable folder)") from None
    resolved = {n: (_dispatcher(v[1]) if isinstance(v, tuple) else v) for n, v in env.items()}
    spec = importlib.util.spec_from_file_location(f"hybridsim_glue_{key}", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # numba's cache finds the module by name
    spec.loader.exec_module(module)
    vars(module).update(resolved)  # the kernels, by the names the source uses
    # the right-hand side's params and body, called by the glue's steps (inlined there, where the
    # params it reads are then the values built once per call)
    inner = dict(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
    module.rhs_params = njit(inline="always", **inner)(module.rhs_params)
    module.rhs_body = njit(inline="always", **inner)(module.rhs_body)
    # a long diagram's parts (codegen.HIT_PART), called, not inlined; with numba's reference counting,
    # which the array views they pass to kernels that return them need
    for part in [n for n in vars(module) if re.fullmatch(r"(hit|path|zc|act|rhs)_part\d+", n)]:
        setattr(module, part, njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)(getattr(module, part)))
    types = native.types()["glue"]
    try:
        with warnings.catch_warnings(), native.compiling(f"glue_{key}"):
            # numba's inliner trips an internal "pedantic" SSA check on some kernels;
            # the results are checked bit for bit against the generic path (tests)
            warnings.simplefilter("ignore", NumbaIRAssumptionWarning)
            warnings.simplefilter("ignore", NumbaExperimentalFeatureWarning)
            # the output pass, updates and log path are one function, compiled once (codegen.HIT_OPS)
            names = {k: "hit" if k in HIT_OPS else k for k in Glue._fields}
            made = {n: cfunc(types[k].signature, cache=True)(getattr(module, n)) for k, n in names.items()
                    if (k == n or k == HIT_OPS[0]) and hasattr(module, n)}
            made.update({k: f for k, f in _stubs().items() if k not in made})
            glue = Glue(*(_Address(made[names[k]]) for k in Glue._fields))
    except NumbaError as exc:
        raise CompiledPathError(_compile_failure(exc, name, system)) from None
    _loaded[key] = glue
    return glue


@functools.lru_cache(maxsize=None)
def _stubs():
    """:mod:`~hybridsim.engine.glue_stubs` compiled (once per machine, then from numba's cache)."""
    from numba import cfunc
    from hybridsim.engine import glue_stubs

    native.use_cache_dir()
    types = native.types()["glue"]
    return {k: cfunc(types[k].signature, cache=True)(getattr(glue_stubs, k)) for k in glue_stubs.FIELDS}


class _Address:
    """A compiled glue function: its cfunc (which keeps the machine code alive) and the address
    the core calls (:func:`addresses`)."""

    __slots__ = ("cfunc", "address")

    def __init__(self, cfunc):
        self.cfunc, self.address = cfunc, cfunc.address


def _compile_failure(exc, name, system):
    """What to tell a user whose kernels numba cannot compile: the blocks the message names."""
    text = re.sub(r"\x1b\[[0-9;]*m", "", str(exc))  # numba colours its messages
    blocks = system.blocks if system is not None else []
    culprits = sorted({f"{b.name} ({b.type_label})" for b in blocks if b.kernels is not None
                       for f in b.kernels if callable(f) and f.__name__ in text})
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    why = ("Untyped global", "Unknown attribute", "Cannot", "not supported", "unsupported", "Invalid use")
    first = next((line for line in lines if any(w in line for w in why)), lines[0] if lines else "")
    return (f"numba cannot compile the kernels of diagram {name!r}"
            + (f"; the message names block(s) {', '.join(culprits)}" if culprits else "")
            + f": {first} (kernels must keep to numba's nopython subset, see hybridsim.engine.kernels; "
              "or run without compiled)")
