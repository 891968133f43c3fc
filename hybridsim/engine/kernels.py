"""Block equations as pure functions: the form every path can run.

A block that sets ``kernels = Kernels(output=f, derivatives=g, update=h)``
writes its equations once, as functions ``f(p, t, x, u)`` of

* ``p``: the block's numbers, the tuple (or namedtuple) ``block.params``;
* ``t``: time, s;
* ``x``: its state, an indexable sequence of floats (a tuple or 1-D array);
* ``u``: its inputs, one indexable sequence of floats per input port;

returning what the block method would (outputs: one sequence per port;
derivatives and update: one sequence). A block whose outputs are arrays of any
width gives ``output_into(p, t, x, u, out)`` instead of ``output``: it writes
each port into the 1-D float array ``out[k]`` it is given and returns ``out``
(compiled, the arrays are the run's own wire vector: no array is allocated
per call); ``update_into(p, t, x, u, new)`` likewise writes the new discrete
state into ``new`` (compiled, the run's own discrete state vector). :class:`~hybridsim.engine.block.Block` calls
them with ``self.params`` on the generic path; :mod:`hybridsim.engine.fused` calls
them from its generated Python RK4; :mod:`hybridsim.engine.compiled` compiles them
with numba into one loop. So a kernel keeps to what numba's nopython mode
accepts: arithmetic, ``math``, small numpy operations, indexing, other
functions marked :func:`kernel` - no attributes of blocks, no ``None``
values in ``p``.
"""
from typing import Callable, NamedTuple, Optional

_MARKED = []  # every function marked @kernel (numba may compile any of them)

try:  # loop over a tuple whose items differ in type (arrays and tuples of floats)
    from numba import literal_unroll as unroll
except ImportError:  # pragma: no cover - numba is optional; in Python the tuple itself
    def unroll(items):
        """``items`` itself: numba's ``literal_unroll`` outside numba."""
        return items


class Kernels(NamedTuple):
    """The pure functions of a block; a missing one means the block has none.

    ``zero_crossings(p, t, x, u)`` returns the block's event functions (a
    sequence of floats); ``event_action(p, t, x, u, fired)`` the state after
    the events ``fired`` (a tuple of bools, one per event function). A kernel
    whose Python body calls a library numba cannot compile (Pinocchio) names
    the numba twin compiled in its place as its ``compiled`` attribute.
    """

    output: Optional[Callable] = None
    derivatives: Optional[Callable] = None
    update: Optional[Callable] = None
    zero_crossings: Optional[Callable] = None
    event_action: Optional[Callable] = None
    output_into: Optional[Callable] = None  # (p, t, x, u, out) -> out: the outputs written into out
    update_into: Optional[Callable] = None  # (p, t, x, u, new) -> new: the new discrete state written into new


def gives(k, what):
    """True when the kernels ``k`` compute ``what`` ("output", "update"): as a value or ``_into``."""
    return getattr(k, what) is not None or getattr(k, what + "_into", None) is not None


def kernel(fn):
    """Mark ``fn`` as a kernel or a helper that kernels call.

    The function is returned unchanged (plain Python); the compiled path
    registers every marked function with numba before compiling.
    """
    _MARKED.append(fn)
    return fn


def marked():
    """The functions marked with :func:`kernel` so far."""
    return list(_MARKED)


_JITABLE = set()  # functions registered with numba (once each: a second registration is ambiguous)


def make_jitable(functions=None):
    """Register ``functions`` (default: every :func:`kernel` so far) with numba, so compiled code
    may call them; each once. Each kernel is compiled on its own, once per machine where it has a
    file (numba's cache), and called: a diagram's glue compiles only itself, and LLVM still inlines
    the small kernels where the glue calls them (inlining at numba's level cost compile time for no
    measurable speed: benchmarks/RESULTS.md, 2026-12-04). A kernel with a numba twin
    (``f.compiled``) is skipped: calls of it compile to the twin."""
    import os

    from numba.extending import register_jitable

    for f in marked() if functions is None else functions:
        if f in _JITABLE or hasattr(f, "compiled"):
            continue
        code = getattr(f, "__code__", None)
        register_jitable(inline="never", cache=bool(code and os.path.isfile(code.co_filename)),
                         no_cpython_wrapper=True, no_cfunc_wrapper=True)(f)  # only compiled code calls it
        _JITABLE.add(f)
