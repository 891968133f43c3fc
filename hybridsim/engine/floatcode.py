"""Generated Python on float locals: the values and statements :mod:`hybridsim.engine.inline` writes.

A value is a *tree*: a float is a local's name or a literal (a string), a tuple
a Python tuple of trees, a block's params a :class:`Record` of hoisted locals,
an array param an :class:`Array` of locals (or an :class:`Opaque` one), an
array a kernel fills an :class:`Out`. Statements are :class:`Assign` and
:class:`If`; a :class:`Writer` collects them, :func:`prune` drops what nothing
reads and nothing could raise, :func:`lines` writes them, each marked with the
block whose code it is.
"""
import ast
import math
import re

_WORD = re.compile(r"[A-Za-z_]\w*")


#: the most statements one kernel may write (a branch taking the rest of a function doubles it)
MAX_STATEMENTS = 4000
_SIMPLE = re.compile(r"[A-Za-z_]\w*|\d[\d.e+-]*|\(-\d[\d.e+-]*\)")


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
    """``target = expr``; ``owner`` the block whose code it is (a comment on its line)."""

    __slots__ = ("target", "expr", "owner")

    def __init__(self, target, expr, owner=None):
        self.target, self.expr, self.owner = target, expr, owner


class If:
    __slots__ = ("cond", "then", "orelse", "owner")

    def __init__(self, cond, then, orelse, owner=None):
        self.cond, self.then, self.orelse, self.owner = cond, then, orelse, owner


def own(stmts, owner):
    """Mark the statements in ``stmts`` that have no owner as ``owner``'s."""
    for st in stmts:
        if st.owner is None:
            st.owner = owner
        if isinstance(st, If):
            own(st.then, owner)
            own(st.orelse, owner)


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


def param_tree(value, expr, name, out, floats=None):
    """The tree of a param ``value`` read as ``expr``: its numbers hoisted into locals named from
    ``name`` (``out`` collects ``(local, expression)``, ``floats`` the locals that hold a Python float)."""
    floats = set() if floats is None else floats
    while any(n.startswith(name) for n, _ in out):  # a field named like another's element
        name += "_"
    if isinstance(value, tuple) and hasattr(value, "_fields"):
        return Record(value._fields, (param_tree(v, f"{expr}.{f}", f"{name}_{f}", out, floats)
                                      for f, v in zip(value._fields, value)))
    if isinstance(value, tuple):
        return tuple(param_tree(v, f"{expr}[{k}]", f"{name}_{k}", out, floats) for k, v in enumerate(value))
    out.append((name, expr))
    if isinstance(value, (bool, int, float)) or type(value).__module__ == "numpy" and getattr(value, "ndim", 1) == 0:
        if type(value) is float:
            floats.add(name)
        return name
    if _small(value):  # its elements as locals (numpy's float64: the kernel's own arithmetic)

        def rows(prefix, shp):
            if len(shp) == 1:
                return tuple(f"{prefix}_{k}" for k in range(shp[0]))
            return tuple(rows(f"{prefix}_{k}", shp[1:]) for k in range(shp[0]))

        for idx in _indices(value.shape):
            out.append((f"{name}_" + "_".join(map(str, idx)), f"{name}[{', '.join(map(str, idx))}]"))
        return Array(value.shape, rows(name, value.shape))
    return Opaque(name)


def narrow(value):
    """True when ``value`` (a param) holds a numpy number narrower than float64 (float32, complex):
    with it, a kernel's arithmetic on Python floats rounds otherwise than on float64 arrays."""
    if isinstance(value, tuple):
        return any(narrow(v) for v in value)
    kind = getattr(getattr(value, "dtype", None), "kind", None)
    return kind == "c" or kind == "f" and value.dtype.itemsize < 8


def _small(value):
    return (type(value).__module__ == "numpy" and getattr(value, "ndim", 0) in (1, 2)
            and value.size <= SMALL and value.dtype == "float64")


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
    if (not _LITERAL_ONLY.fullmatch(expr) or "e" in expr.replace("e-", "").replace("e+", "")
            or "**" in expr or "<<" in expr):  # powers and shifts: no telling how big
        return expr
    try:
        v = eval(expr, {"__builtins__": {}})  # noqa: S307 - digits and operators only (checked above)
    except (ArithmeticError, ValueError, OverflowError):
        return expr  # raises at run time as it would have
    if isinstance(v, bool):
        return repr(v)
    if isinstance(v, int):
        return expr if abs(v) > 2 ** 53 else repr(v) if v >= 0 else f"({v!r})"
    if isinstance(v, float) and math.isfinite(v):
        return repr(v) if v > 0 or (v == 0 and math.copysign(1, v) > 0) else f"({v!r})"
    return expr


_OWNER = re.compile(r"# b(\d+)\s*$")


def owner_of(line):
    """The block index a generated ``line`` marks as its code's (:func:`lines`), or None."""
    m = _OWNER.search(line or "")
    return int(m.group(1)) if m else None


def names_in(expr):
    return set(_WORD.findall(expr))


_MAY_RAISE = re.compile(r"/|%|\*\*|<<|>>|[\w)\]]\(")  # division, powers, shifts, calls


def is_float(expr, floats):
    """True when ``expr`` surely gives a Python float (``floats``: locals that hold one): a float
    literal, such a local, arithmetic with one, a math function that returns floats, float()."""
    try:
        node = ast.parse(expr, mode="eval").body
    except SyntaxError:
        return False
    return _floaty(node, floats)


_FLOAT_MATH = {"sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "asinh",
               "acosh", "atanh", "exp", "expm1", "log", "log1p", "log2", "log10", "sqrt", "hypot", "copysign",
               "fabs", "fmod", "pow", "degrees", "radians", "erf", "erfc", "gamma", "lgamma", "ldexp", "cbrt",
               "exp2", "remainder"}


def _floaty(node, floats):
    if isinstance(node, ast.Constant):
        return type(node.value) is float
    if isinstance(node, ast.Name):
        return node.id in floats
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        return _floaty(node.operand, floats)
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Mod,
                                                            ast.FloorDiv)):
        return _floaty(node.left, floats) or _floaty(node.right, floats)
    if isinstance(node, ast.IfExp):
        return _floaty(node.body, floats) and _floaty(node.orelse, floats)
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
        name, args = node.func.id, node.args
        if name == "float" or name.startswith("math_") and name[5:] in _FLOAT_MATH:
            return True
        return name in ("abs", "min", "max") and bool(args) and all(_floaty(a, floats) for a in args)
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
        return getattr(node.func.value, "id", "") == "math" and node.func.attr in _FLOAT_MATH
    return False


def prune(stmts, live, keep=None):
    """``stmts`` without the assignments nothing in ``live`` (names read later) needs, except
    those to targets ``keep(target)`` is true of; returns ``(kept, names read by kept)``."""
    kept = []
    live = set(live)
    for st in reversed(stmts):
        if isinstance(st, Assign):
            if st.target not in live and not (keep and keep(st.target)) and not _MAY_RAISE.search(st.expr):
                continue  # read by nothing, and cannot raise (an error the generic path gives stays)
            live.discard(st.target)
            live |= names_in(st.expr)
            kept.append(st)
        else:
            then, la = prune(st.then, live, keep)
            orelse, lb = prune(st.orelse, live, keep)
            if not then and not orelse:
                continue
            live = la | lb | names_in(st.cond)
            kept.append(If(st.cond, then, orelse, st.owner))
    kept.reverse()
    return kept, live


def lines(stmts, pad):
    """The source lines of ``stmts`` indented by ``pad``, each ending in ``# b<owner>`` when it
    has one (:func:`owner_of` reads it back from a traceback's line)."""
    out = []
    for st in stmts:
        mark = "" if st.owner is None else f"  # b{st.owner}"
        if isinstance(st, Assign):
            out.append(f"{pad}{st.target} = {st.expr}{mark}")
        else:
            out.append(f"{pad}if {st.cond}:{mark}")
            out += lines(st.then, pad + "    ") or [pad + "    pass"]
            if st.orelse:
                out.append(f"{pad}else:")
                out += lines(st.orelse, pad + "    ")
    return out


class Writer:
    """Statements on float locals being written (``out``), with what they know: equal expressions
    share a local (``memo``), which locals hold Python floats (``floats``), how much was written
    (``count``, bounded by :data:`MAX_STATEMENTS`). ``fresh`` names the locals it makes (unique
    within one generated function); ``genv`` is the generated module's globals (constants go there).
    """

    def __init__(self, fresh, env):
        self.fresh, self.genv = fresh, env  # genv: the generated module's globals (constants go there)
        self.out = []
        self.memo = {}  # expression -> the local holding it (within the current branch)
        self.count = 0  # statements written and executed while writing (a bound on the work)
        self.branches = 0  # how deep in if-branches the writing is (no array writes there)
        self.floats = set()  # locals known to hold a Python float (a block's output needs no float())

    def tick(self, n=1):
        self.count += n
        if self.count > MAX_STATEMENTS:
            raise NotInlinable("too many statements")

    def emit(self, target, expr):
        self.tick()
        self.out.append(Assign(target, expr))
        if is_float(expr, self.floats):
            self.floats.add(target)

    def as_float(self, leaf):
        """``leaf`` as the float a wire holds (``float(leaf)`` unless known to be one already)."""
        if is_float(leaf, self.floats):
            return leaf
        v = literal(leaf)
        if v is not None and abs(v) <= 2 ** 53:
            return self.constant(float(v))
        return self.simple(f"float({leaf})")

    def simple(self, expr):
        """A local (or literal) holding the scalar ``expr``; equal expressions share one."""
        if _SIMPLE.fullmatch(expr):
            return expr
        if expr in self.memo:
            return self.memo[expr]
        name = self.fresh()
        self.emit(name, expr)
        self.memo[expr] = name
        return name

    def settle(self, tree):
        """``tree`` with every leaf a local or a literal."""
        if isinstance(tree, str):
            return self.simple(tree)
        if isinstance(tree, tuple):
            return tuple(self.settle(t) for t in tree)
        return tree

    def constant(self, v):
        """A number as a literal (plain bool, int up to 2**53, finite float), else as a name the
        generated module holds (numpy scalars keep their type, infinities their value)."""
        if type(v) is bool:
            return repr(v)
        if type(v) is int and abs(v) <= 2 ** 53 or type(v) is float and math.isfinite(v):
            return repr(v) if v >= 0 and not (type(v) is float and math.copysign(1, v) < 0) else f"({v!r})"
        if isinstance(v, (int, float)):
            name = f"_c{len(self.genv)}"
            self.genv[name] = v
            if type(v) is float:
                self.floats.add(name)
            return name
        raise NotInlinable(f"constant {v!r}")

    def branch(self, run):
        """Run ``run()`` writing into a branch of its own: ``(its statements, its result)``."""
        out, memo = self.out, self.memo
        self.out, self.memo = [], dict(memo)
        self.branches += 1
        try:
            result = run()
            return self.out, result
        finally:
            self.out, self.memo = out, memo
            self.branches -= 1
