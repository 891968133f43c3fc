"""The stepping core compiled by numba, once per machine.

:func:`core` returns the numba versions of :func:`hybridsim.engine.stepping.run`
and of the Runge-Kutta stepper (:mod:`hybridsim.engine.rk`), compiled with
explicit signatures in which a diagram's glue is a set of first-class
functions (:data:`GLUE`): every diagram's glue has these types, so the core is
compiled once and cached on disk (``HYBRIDSIM_CACHE``), and a new diagram
compiles only its glue (:mod:`hybridsim.engine.compiled`).
"""
import contextlib
import functools
import os
import warnings

import numpy as np

from hybridsim.engine import locating, rk, solvers, stepping


def cache_dir():
    """Where generated modules and numba's cache live (``HYBRIDSIM_CACHE``, default
    ``~/.cache/hybridsim``)."""
    from pathlib import Path

    root = os.environ.get("HYBRIDSIM_CACHE") or Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "hybridsim"
    return Path(root) / "compiled"


def use_cache_dir():
    """Point numba's cache at :func:`cache_dir` (unless the user set ``NUMBA_CACHE_DIR``)."""
    import numba

    if os.environ.get("NUMBA_CACHE_DIR"):
        return
    folder = cache_dir() / "numba"
    folder.mkdir(parents=True, exist_ok=True)
    numba.config.CACHE_DIR = str(folder)


@contextlib.contextmanager
def compiling(key):
    """Held while this process compiles (or loads) the machine code named ``key``: another process
    that wants the same code waits, then loads what this one wrote to the cache, instead of
    compiling it again at the same time (a sweep's workers, a test run's workers on a cold cache)."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX: each process compiles for itself
        yield
        return
    folder = cache_dir() / "locks"
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / f"{key}.lock", "a") as f:
        fcntl.flock(f, fcntl.LOCK_EX)  # released when the file closes, or the process ends
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def example_records(n=1, s=1, e=1, d=1, b=1):
    """Records of the core's argument types (their numba types are the signatures')."""
    f = lambda *shape: np.zeros(shape)  # noqa: E731
    tl = stepping.Timeline(f(2), np.zeros(2, np.int64), np.zeros((2, d), np.bool_), np.zeros(2, np.int64),
                           np.zeros(2, np.int64))
    lim = stepping.Limits(1e6, 1e-12, 1e-3, 10, 10, 10, 0, 10, 1e-6, 0, False, False, False)
    w = solvers.work(n, s, e, zb=np.zeros(d, np.bool_))  # the run's own constructor: the same types
    out = stepping.Out(f(1, 1), np.zeros(1, np.int64), np.zeros(1, np.int64), f(1), np.zeros((1, b), np.bool_),
                       np.zeros(1, np.int64), np.zeros(3, np.int64), f(1))
    rks = rk.RKState(f(s), f(8), f(8))
    return tl, lim, w, out, rks


@functools.lru_cache(maxsize=None)
def types():
    """The numba types of the glue, the stepper and the core: a dict."""
    from numba import typeof, types as nt
    from numba.core.types import FunctionType

    A, I, B, B2 = nt.float64[::1], nt.int64[::1], nt.boolean[::1], nt.boolean[:, ::1]
    f64, i64 = nt.float64, nt.int64
    F, N, T = nt.CPointer(f64), nt.CPointer(i64), nt.CPointer(nt.boolean)  # arrays as data (CORE_TAIL's glue_*)
    glue = {
        # the output pass, the updates and the log path: one function, told which by its first argument
        "outputs": FunctionType(i64(i64, f64, F, F, F, F, N, T, i64)),
        "rhs": FunctionType(nt.void(f64, F, F, i64, F, F, F, N)),
        "zc": FunctionType(nt.void(f64, F, F, F, F, F, N)),
        "act": FunctionType(i64(f64, F, F, T, F, F, F, N)),
        "next_time": FunctionType(f64(f64, F, F, F, F, N)),
        "timed": FunctionType(i64(f64, F, F, F, F, F, N)),
        "stepped": FunctionType(i64(f64, F, F, F, F, N)),
        "steps": FunctionType(f64(F, f64, F, F, F, F, F, F, F, F, N)),
    }
    glue["update"] = glue["observe"] = glue["outputs"]
    tl, lim, w, out, rks = (typeof(r) for r in example_records())
    # the glue reaches the core as its functions' addresses (Glue's order), made functions inside
    run = i64(tl, i64, i64, I, rks, lim, w, out, A, A, A, I)
    return {"glue": glue, "run": run, "array": A, "ints": I, "bools": B}


#: the core's functions that ``run`` calls (every function of stepping.py and locating.py but the two compiled with
#: nogil, and the stepper's), each compiled on its own (LLVM inlines the small ones; inlining them at
#: numba's level only cost compile time)
CALLED = tuple(name for m in (stepping, locating) for name, f in vars(m).items()
               if getattr(f, "__module__", None) == m.__name__ and callable(f) and not isinstance(f, type)
               and name not in ("run", "interval")) + (
    "rk_begin", "rk_step", "rk_steps", "rk_dense", "rk_restep", "rk_rewind")
#: of those, the ones inlined where they are called: a call passes each array of a record (every
#: array of ``Work``) as seven separate arguments, and the steps are called at every log point (a
#: batch) or every step (one at a time, with located events)
INLINED = ("rk_steps", "rk_step")

CORE_TAIL = """


# -- compiled with numba (this file is generated: stepping.py and {method}'s steps, then this) -------
from numba import njit as _njit  # noqa: E402
import numpy as _np  # noqa: E402

from hybridsim.engine.pointers import function_at  # noqa: E402

NO_DUE = _np.zeros((1, 1), _np.bool_)

def copy_into(dst, src):  # element by element: a slice assignment may allocate (no NRT here)
    for i in range(dst.size):
        dst[i] = src[i]


# the glue's calls: each array passed as its data pointer (a first-class function's array argument
# is numba's seven-field struct, eight of them in every call of the right-hand side)
# (the compiled glue's outputs, update and observe are one function, ``hit``, told which by ``op``)
def glue_outputs(gl, t, x, y, z, pf, pi, due, row):
    return gl.outputs(0, t, x.ctypes, y.ctypes, z.ctypes, pf.ctypes, pi.ctypes, due.ctypes, row)


def glue_update(gl, t, x, y, z, pf, pi, due, row):
    return gl.update(1, t, x.ctypes, y.ctypes, z.ctypes, pf.ctypes, pi.ctypes, due.ctypes, row)


def glue_rhs(gl, t, x, dx, at, y, z, pf, pi):
    gl.rhs(t, x.ctypes, dx.ctypes, at, y.ctypes, z.ctypes, pf.ctypes, pi.ctypes)


def glue_zc(gl, t, x, g, y, z, pf, pi):
    gl.zc(t, x.ctypes, g.ctypes, y.ctypes, z.ctypes, pf.ctypes, pi.ctypes)


def glue_act(gl, t, x, xn, fired, y, z, pf, pi):
    return gl.act(t, x.ctypes, xn.ctypes, fired.ctypes, y.ctypes, z.ctypes, pf.ctypes, pi.ctypes)


def glue_observe(gl, t, x, y, z, pf, pi):  # no hit: any row of bools serves as ``due`` (not read)
    return gl.observe(2, t, x.ctypes, y.ctypes, z.ctypes, pf.ctypes, pi.ctypes, NO_DUE.ctypes, 0)


def glue_next_time(gl, t, x, y, z, pf, pi):
    return gl.next_time(t, x.ctypes, y.ctypes, z.ctypes, pf.ctypes, pi.ctypes)


def glue_timed(gl, t, x, xn, y, z, pf, pi):
    return gl.timed(t, x.ctypes, xn.ctypes, y.ctypes, z.ctypes, pf.ctypes, pi.ctypes)


def glue_stepped(gl, t, x, y, z, pf, pi):
    return gl.stepped(t, x.ctypes, y.ctypes, z.ctypes, pf.ctypes, pi.ctypes)


def glue_steps(gl, num, t_lim, x, xn, kk, xs, xm, y, z, pf, pi):
    return gl.steps(num.ctypes, t_lim, x.ctypes, xn.ctypes, kk.ctypes, xs.ctypes, xm.ctypes, y.ctypes, z.ctypes,
                    pf.ctypes, pi.ctypes)


# no reference counting (_nrt=False): the core allocates nothing, and counting the arrays of the records
# it passes around (atomic operations, 21 arrays in Work) cost more than the steps between log points
# (and the functions only the core calls need no wrapper to be called from Python or C)
_INNER = dict(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
for _name in {called!r} + tuple("glue_" + f for f in {glue!r}):
    globals()[_name] = _njit(globals()[_name], **_INNER, **(dict(inline="always") if _name in {inlined!r} else {{}}))
interval = _njit(interval, nogil=True, **_INNER)
stepping_run = _njit(run, nogil=True, **_INNER)


def run_rk(tl, k0, k1, ga, s, lim, w, out, y, z, pf, pi):
    gl = Glue({made})
    return stepping_run(tl, k0, k1, gl, 0, s, lim, w, out, y, z, pf, pi)
"""


@functools.lru_cache(maxsize=None)
def core(method_class):
    """The compiled core for one Runge-Kutta method (compiled or loaded from the cache):
    ``run(tl, k0, k1, glue, rk_state, limits, work, out, y, z, pf, pi)``, which is
    :func:`hybridsim.engine.stepping.run` with the method's steps compiled in."""
    import hashlib
    import importlib.util
    import inspect
    import re
    import sys

    from numba import njit
    from numba.core.errors import NumbaExperimentalFeatureWarning

    from hybridsim.engine import rk_code

    use_cache_dir()
    # the stepper's calls name its functions (calls through a record of functions would make the
    # compiled code hold Python objects, which numba's cache cannot store)
    # and its calls of the glue go through the adapters that pass arrays as pointers (CORE_TAIL)
    def compiled_calls(text):
        return re.sub(r"\bgl\.(\w+)\(", r"glue_\1(gl, ", re.sub(r"\bops\.(\w+)\(", r"rk_\1(", text))

    # stepping.py, then locating.py: its functions replace the ones stepping.py imported by name
    core_text = compiled_calls(inspect.getsource(stepping) + "\n\n" + inspect.getsource(locating))
    source = (f"# generated by hybridsim.engine.native from stepping.py, locating.py and rk_code.array_source({method_class.name})\n"
              + core_text + "\n\n# -- the Runge-Kutta steps " + "-" * 60 + "\n"
              + compiled_calls(rk_code.array_source(method_class, glue_steps=True).replace("import math\n", ""))
              + CORE_TAIL.format(method=method_class.name, called=CALLED, inlined=INLINED,
                                 glue=stepping.Glue._fields, made=", ".join(
                                     f"function_at(ga[{k}], T_{f})" for k, f in enumerate(stepping.Glue._fields))))
    stamp = hashlib.sha256(source.encode()).hexdigest()[:16]
    folder = cache_dir()
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"core_{method_class.name}_{stamp}.py"
    if not path.exists():
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(source)
        os.replace(tmp, path)
    spec = importlib.util.spec_from_file_location(f"hybridsim_core_{stamp}", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # numba's cache finds the module by name
    spec.loader.exec_module(module)
    glue = types()["glue"]
    for f in stepping.Glue._fields:  # the types function_at makes of the glue's addresses
        setattr(module, f"T_{f}", glue[f])
    with warnings.catch_warnings(), compiling(f"core_{method_class.name}_{stamp}"):
        warnings.simplefilter("ignore", NumbaExperimentalFeatureWarning)
        return njit(types()["run"], cache=True, nogil=True, _nrt=False)(module.run_rk)
