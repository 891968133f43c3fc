"""The blocks' numbers as two flat arrays, and the source that rebuilds them.

Kernels take a block's ``params``: a tuple or namedtuple of floats, ints,
bools, contiguous numpy arrays and nested tuples of those. Compiled glue has
one signature for every diagram, so the numbers of a run travel as one float
array and one integer array; :class:`ParamLayout` says where each number
lies (:meth:`~ParamLayout.flatten`) and writes the expression that rebuilds a
block's params inside the glue (:meth:`~ParamLayout.expression`), the same
types the kernels see on the other paths.
"""
import numpy as np


class ParamStructureError(ValueError):
    """A block's params are of a kind the compiled path cannot carry, or changed their layout."""


_INTS = (np.int64, np.int32, np.uint64, np.uint32, np.int16, np.uint16, np.int8, np.uint8, np.bool_)


class ParamLayout:
    """Where every number of every block's params lies in the flat arrays ``pf`` and ``pi``."""

    def __init__(self, blocks, params=None):
        """The layout of ``blocks``' params (or of ``params``, one per block: a run's own numbers)."""
        self.nf = self.ni = 0
        self._fast = None  # flatten's generated copy (_flattener), made at its first call
        self.names = [b.name for b in blocks]
        self.specs = []
        for b, v in zip(blocks, [b.params for b in blocks] if params is None else params):
            try:
                self.specs.append(self._spec(v))
            except ParamStructureError as exc:
                raise ParamStructureError(f"block {b.name!r} ({b.type_label}): its params hold {exc}, "
                                          "which compiled kernels cannot take") from None

    def _spec(self, v):
        if isinstance(v, (bool, np.bool_)):
            self.ni += 1
            return ("b", self.ni - 1)
        if isinstance(v, (int, np.integer)):
            self.ni += 1
            return ("i", self.ni - 1)
        if isinstance(v, (float, np.floating)):
            self.nf += 1
            return ("f", self.nf - 1)
        if isinstance(v, np.ndarray):
            if v.dtype == np.float64:
                self.nf += v.size
                return ("af", self.nf - v.size, v.shape)
            if v.dtype in _INTS:
                self.ni += v.size
                return ("ai", self.ni - v.size, v.shape, v.dtype.name)
            raise ParamStructureError(f"an array of {v.dtype}")
        if isinstance(v, tuple):
            items = tuple(self._spec(x) for x in v)
            if hasattr(v, "_fields"):
                return ("n", type(v), items)
            return ("t", items)
        raise ParamStructureError(f"a {type(v).__name__}")

    def flatten(self, params):
        """``(pf, pi)`` of a run's params (one per block, in the system's order); raises
        :class:`ParamStructureError` when one does not have this layout."""
        pf, pi = np.zeros(self.nf), np.zeros(self.ni, np.int64)
        if self._fast is None:
            self._fast = _flattener(self.specs)
        try:  # the layout's straight-line copy; anything unexpected: the checked walk below says what
            self._fast(params, pf, pi)
            return pf, pi
        except Exception:
            pass
        for name, spec, v in zip(self.names, self.specs, params):
            try:
                _fill(spec, v, pf, pi)
            except (ParamStructureError, TypeError, ValueError, IndexError) as exc:
                raise ParamStructureError(f"block {name!r}: its params changed their layout ({exc})") from None
        return pf, pi

    def expression(self, i, env):
        """The source rebuilding block ``i``'s params from ``pf`` and ``pi`` (a matrix from ``pf_p``, pf's
        data pointer; classes put in ``env``)."""
        return _expr(self.specs[i], env, f"{i}")


def _fill(spec, v, pf, pi):
    kind = spec[0]
    if kind == "f":
        pf[spec[1]] = float(v)
    elif kind in ("i", "b"):
        if isinstance(v, (float, np.floating)):
            raise ParamStructureError("a whole number became a float")
        pi[spec[1]] = int(v)
    elif kind == "af":
        a = np.asarray(v, float)
        if a.shape != spec[2]:
            raise ParamStructureError(f"an array of shape {spec[2]} became {a.shape}")
        pf[spec[1]:spec[1] + a.size] = a.ravel()
    elif kind == "ai":
        a = np.asarray(v)
        if a.shape != spec[2]:
            raise ParamStructureError(f"an array of shape {spec[2]} became {a.shape}")
        pi[spec[1]:spec[1] + a.size] = a.astype(spec[3]).ravel().view(np.int64) if a.dtype.itemsize == 8 \
            else a.ravel().astype(np.int64)
    else:
        items = spec[-1]
        if len(v) != len(items):
            raise ParamStructureError(f"{len(items)} values became {len(v)}")
        for s, x in zip(items, v):
            _fill(s, x, pf, pi)


def _whole(v):
    """``int(v)`` of a whole number (a float in its place changed the layout)."""
    if isinstance(v, (float, np.floating)):
        raise ParamStructureError("a whole number became a float")
    return int(v)


def _flattener(specs):
    """``copy(params, pf, pi)``: :func:`_fill` of every block written out as straight-line Python for
    this layout (no call per number); it raises on any params of another layout."""
    lines, names = ["def copy(params, pf, pi):"], iter(range(1 << 62))

    def leaf(spec, v):
        kind = spec[0]
        if kind == "f":
            lines.append(f"    pf[{spec[1]}] = float({v})")
        elif kind in ("i", "b"):
            lines.append(f"    pi[{spec[1]}] = whole({v})")
        elif kind == "af":
            a, size = spec[1], int(np.prod(spec[2]))
            lines.append(f"    a = asarray({v}, float)")
            lines.append(f"    if a.shape != {spec[2]!r}:\n        raise ValueError")
            lines.append(f"    pf[{a}:{a + size}] = a.ravel()")
        elif kind == "ai":
            lines.append(f"    fill({spec!r}, {v}, pf, pi)")
        else:
            items = spec[-1]
            parts = [f"v{next(names)}" for _ in items]
            lines.append(f"    if len({v}) != {len(items)}:\n        raise ValueError")
            if parts:
                lines.append(f"    {', '.join(parts)}, = {v}")
            for s, p in zip(items, parts):
                leaf(s, p)

    lines.append(f"    if len(params) != {len(specs)}:\n        raise ValueError")
    for i, spec in enumerate(specs):
        leaf(spec, f"params[{i}]")
    env = {"whole": _whole, "asarray": np.asarray, "fill": _fill}
    exec(compile("\n".join(lines) + "\n", "<hybridsim.engine.params flatten>", "exec"), env)  # noqa: S102
    return env["copy"]


def _expr(spec, env, tag):
    kind = spec[0]
    if kind == "f":
        return f"pf[{spec[1]}]"
    if kind == "i":
        return f"pi[{spec[1]}]"
    if kind == "b":
        return f"(pi[{spec[1]}] != 0)"
    if kind == "af":
        a, shape = spec[1], spec[2]
        size = int(np.prod(shape)) if shape else 1
        if len(shape) == 1:  # a slice is already that vector (reshape calls numba's C helper)
            return f"pf[{a}:{a + size}]"
        if len(shape) > 1:  # a view from the data pointer (hybridsim.engine.pointers)
            return f"carray(offset(pf_p, {a}), {tuple(shape)!r})"
        return f"pf[{a}:{a + size}].reshape({tuple(shape)!r})"
    if kind == "ai":
        a, shape, dtype = spec[1], spec[2], spec[3]
        size = int(np.prod(shape)) if shape else 1
        view = "" if dtype == "int64" else (f".view(np.{dtype})" if np.dtype(dtype).itemsize == 8
                                             else f".astype(np.{dtype})")
        return f"pi[{a}:{a + size}]{view}.reshape({tuple(shape)!r})"
    items = [_expr(s, env, f"{tag}_{k}") for k, s in enumerate(spec[-1])]
    if kind == "n":
        name = f"NT{tag}"
        env[name] = spec[1]
        return f"{name}({', '.join(items)})"
    return "(" + "".join(f"{x}, " for x in items) + ")" if items else "()"
