"""Generated Python on float locals: the values and statements :mod:`hybridsim.engine.inline` writes.

A value is a *tree*: a float is a local's name or a literal (a string), a tuple
a Python tuple of trees, a block's params a :class:`Record` of hoisted locals,
an array param an :class:`Opaque` local. Statements are :class:`Assign` and
:class:`If`; :func:`prune` drops what nothing reads, :func:`lines` writes them.
"""
import ast
import math
import re

_WORD = re.compile(r"[A-Za-z_]\w*")


class NotInlinable(Exception):
    """A kernel uses something the inliner does not write; the caller keeps the call."""


class Record:
    """A namedtuple's fields as trees (a block's params): read by name, index or unpacking."""

    __slots__ = ("names", "items")

    def __init__(self, names, items):
        self.names, self.items = tuple(names), tuple(items)

    def field(self, name):
        if name not in self.names:
            raise NotInlinable(f"no field {name!r}")
        return self.items[self.names.index(name)]


class Opaque:
    """A value the inliner does not look into (an array param): only a kept call may take it."""

    __slots__ = ("expr",)

    def __init__(self, expr):
        self.expr = expr


class Assign:
    __slots__ = ("target", "expr")

    def __init__(self, target, expr):
        self.target, self.expr = target, expr


class If:
    __slots__ = ("cond", "then", "orelse")

    def __init__(self, cond, then, orelse):
        self.cond, self.then, self.orelse = cond, then, orelse


class Array:
    """A float64 or bool array param of at most :data:`SMALL` elements: its ``shape`` and its
    elements as a nested tuple of hoisted locals (``rows``)."""

    __slots__ = ("shape", "rows")

    def __init__(self, shape, rows):
        self.shape, self.rows = shape, rows


class Out:
    """An array a kernel writes (``output_into``'s ports, ``update_into``'s state): its elements'
    trees so far, ``None`` where not yet written."""

    __slots__ = ("items",)

    def __init__(self, width):
        self.items = [None] * width

    def value(self):
        if any(v is None for v in self.items):
            raise NotInlinable("an element of an output array left unwritten")
        return tuple(self.items)


#: the largest array param whose elements are written as locals
SMALL = 64


def is_leaf(tree):
    return isinstance(tree, str)


def snapshot(tree):
    """``tree`` with each :class:`Out` replaced by the tuple it holds now (a returned value)."""
    if isinstance(tree, Out):
        return tree.value()
    if isinstance(tree, tuple):
        return tuple(snapshot(t) for t in tree)
    return tree


def source(tree):
    """Python source building ``tree`` (tuples as displays)."""
    if isinstance(tree, str):
        return tree
    if isinstance(tree, Opaque):
        return tree.expr
    if isinstance(tree, Record):
        raise NotInlinable("a record passed whole")
    return "(" + "".join(f"{source(t)}, " for t in tree) + ")"


def param_tree(value, expr, name, out):
    """The tree of a param ``value`` read as ``expr``: its numbers hoisted into locals named from
    ``name`` (``out`` collects ``(local, expression)``)."""
    while any(n.startswith(name) for n, _ in out):  # a field named like another's element
        name += "_"
    if isinstance(value, tuple) and hasattr(value, "_fields"):
        return Record(value._fields, (param_tree(v, f"{expr}.{f}", f"{name}_{f}", out)
                                      for f, v in zip(value._fields, value)))
    if isinstance(value, tuple):
        return tuple(param_tree(v, f"{expr}[{k}]", f"{name}_{k}", out) for k, v in enumerate(value))
    out.append((name, expr))
    if isinstance(value, (bool, int, float)) or type(value).__module__ == "numpy" and getattr(value, "ndim", 1) == 0:
        return name
    if _small(value):  # its elements as Python numbers (tolist: the same values), read once
        out[-1] = (name, f"{expr}.tolist()")

        def rows(prefix, shp):
            if len(shp) == 1:
                return tuple(f"{prefix}_{k}" for k in range(shp[0]))
            return tuple(rows(f"{prefix}_{k}", shp[1:]) for k in range(shp[0]))

        for idx in _indices(value.shape):
            out.append((f"{name}_" + "_".join(map(str, idx)), name + "".join(f"[{k}]" for k in idx)))
        return Array(value.shape, rows(name, value.shape))
    return Opaque(name)


def _small(value):
    return (type(value).__module__ == "numpy" and getattr(value, "ndim", 0) in (1, 2)
            and value.size <= SMALL and value.dtype.kind in "fb" and value.dtype.itemsize in (1, 8))


def _indices(shape):
    if len(shape) == 1:
        return [(k,) for k in range(shape[0])]
    return [(i, j) for i in range(shape[0]) for j in range(shape[1])]


def shape(value):
    """What :func:`param_tree` depends on: field names, tuple lengths, scalar, small array or not."""
    if isinstance(value, tuple):
        return (getattr(value, "_fields", None), tuple(shape(v) for v in value))
    if _small(value):
        return (value.shape, value.dtype.kind)
    return isinstance(value, (bool, int, float)) or type(value).__module__ == "numpy" and getattr(value, "ndim", 1) == 0


_LITERAL_ONLY = re.compile(r"[\d.e+\-*/%()<>=! ]+|True|False|\(-?\d[\d.e+-]*\)")


def literal(expr):
    """The value of ``expr`` when it is a literal (an int, a bool, a float), else None."""
    if expr in ("True", "False"):
        return expr == "True"
    try:
        v = ast.literal_eval(expr)
    except (ValueError, SyntaxError, TypeError):
        return None
    return v if isinstance(v, (int, float, bool)) else None


def fold(expr):
    """``expr`` computed now when it has no name in it (``k > 0`` with ``k`` a loop's count):
    Python computes it the same now as at run time."""
    if not _LITERAL_ONLY.fullmatch(expr) or "e" in expr.replace("e-", "").replace("e+", ""):
        return expr
    try:
        v = eval(expr, {"__builtins__": {}})  # noqa: S307 - digits and operators only (checked above)
    except (ArithmeticError, ValueError, OverflowError):
        return expr  # raises at run time as it would have
    if isinstance(v, bool) or isinstance(v, int):
        return repr(v) if v >= 0 or isinstance(v, bool) else f"({v!r})"
    if isinstance(v, float) and math.isfinite(v):
        return repr(v) if v > 0 or (v == 0 and math.copysign(1, v) > 0) else f"({v!r})"
    return expr


def names_in(expr):
    return set(_WORD.findall(expr))


def prune(stmts, live, keep=None):
    """``stmts`` without the assignments nothing in ``live`` (names read later) needs, except
    those to targets ``keep(target)`` is true of; returns ``(kept, names read by kept)``."""
    kept = []
    live = set(live)
    for st in reversed(stmts):
        if isinstance(st, Assign):
            if st.target not in live and not (keep and keep(st.target)):
                continue
            live.discard(st.target)
            live |= names_in(st.expr)
            kept.append(st)
        else:
            then, la = prune(st.then, live, keep)
            orelse, lb = prune(st.orelse, live, keep)
            if not then and not orelse:
                continue
            live = la | lb | names_in(st.cond)
            kept.append(If(st.cond, then, orelse))
    kept.reverse()
    return kept, live


def lines(stmts, pad):
    """The source lines of ``stmts`` indented by ``pad``."""
    out = []
    for st in stmts:
        if isinstance(st, Assign):
            out.append(f"{pad}{st.target} = {st.expr}")
        else:
            out.append(f"{pad}if {st.cond}:")
            out += lines(st.then, pad + "    ") or [pad + "    pass"]
            if st.orelse:
                out.append(f"{pad}else:")
                out += lines(st.orelse, pad + "    ")
    return out
