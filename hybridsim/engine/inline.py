"""Kernels written into the fused path's source: calls replaced by their bodies, on float locals.

A kernel (:mod:`hybridsim.engine.kernels`) called from generated Python costs a
call, a tuple per port and an attribute read per parameter. :class:`Inliner`
writes a kernel's body in place of the call instead, on the caller's locals:

* values are *trees*: a float is a local's name or a literal, a tuple a Python
  tuple of trees, a block's params a :class:`Record` of hoisted names;
  indexing, slicing, unpacking and ``p.field`` are resolved while writing, so
  no tuple is built at run time;
* ``math`` functions, ``abs``, ``min``, ``max``, ``float``, ``int``, ``bool``
  and the arithmetic, comparison and boolean operators are written as they
  are; another :func:`~hybridsim.engine.kernels.kernel` is inlined in turn;
* every assignment makes a new local (so equal expressions are computed once:
  a kernel's ``math.cos(q1)`` and the next one's share a local), ``if`` blocks
  merge what their branches assign, a ``return`` inside one takes the rest of
  the function into both branches.

* a ``for`` loop over something known while writing (``range`` of literals or
  widths, a tuple, an array param's rows, ``unroll(u)``) is written out turn
  by turn; an expression of literals only is computed while writing (so
  ``if k > 0`` on a loop's count picks its branch); small float array params
  (:class:`~hybridsim.engine.floatcode.Array`) and the arrays an ``_into``
  kernel writes (:class:`~hybridsim.engine.floatcode.Out`) are locals per element.

Anything else (numpy calls, ``while``, methods, keyword arguments, writing an
array inside a branch) raises :class:`NotInlinable` and the caller keeps the call. The operations are the
kernel's own in its own order, so the numbers are the call's bit for bit
(tests compare every block kernel this can write against its call).
"""
import ast
import builtins
import functools
import inspect
import math
import textwrap
import types

from hybridsim.engine.floatcode import (Array, Assign, If, NotInlinable, Out, Record, Writer, fold, is_float, literal,
                                         snapshot)
from hybridsim.engine.kernels import marked, unroll

#: the most turns of a loop written out
MAX_LOOP = 64
_DEPTH = 8
_BUILTINS = {abs: "abs", min: "min", max: "max", float: "float", int: "int", bool: "bool"}
_BINOPS = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.FloorDiv: "//", ast.Mod: "%",
           ast.Pow: "**", ast.BitAnd: "&", ast.BitOr: "|", ast.BitXor: "^", ast.LShift: "<<", ast.RShift: ">>"}
_UNARY = {ast.UAdd: "+", ast.USub: "-", ast.Not: "not ", ast.Invert: "~"}
_COMPARE = {ast.Eq: "==", ast.NotEq: "!=", ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">", ast.GtE: ">="}


_UNSET = object()  # a name assigned in one branch of an if only


@functools.lru_cache(maxsize=None)
def _parsed(fn):
    try:
        node = ast.parse(textwrap.dedent(inspect.getsource(fn))).body[0]
    except (OSError, TypeError, SyntaxError):
        raise NotInlinable(f"no source for {fn.__name__}") from None
    if not isinstance(node, ast.FunctionDef):
        raise NotInlinable(f"{fn.__name__} is not a plain def")
    a = node.args
    if a.vararg or a.kwarg or a.kwonlyargs or a.posonlyargs:
        raise NotInlinable(f"{fn.__name__} takes more than positional arguments")
    return node


class Inliner(Writer):
    """A :class:`~hybridsim.engine.floatcode.Writer` that writes kernel calls as statements:
    :meth:`call` returns the result's tree."""

    def __init__(self, fresh, env):
        super().__init__(fresh, env)
        self.kernels = {id(f) for f in marked()}

    def call(self, fn, args, depth=0):
        """Inline ``fn(*args)`` (trees); returns the result's tree."""
        if (id(fn) not in self.kernels or not isinstance(fn, types.FunctionType) or hasattr(fn, "compiled")
                or hasattr(fn, "__wrapped__")):  # a decorated kernel: its source is not what runs
            raise NotInlinable(f"{getattr(fn, '__name__', fn)!r} is not a plain kernel")
        if depth > _DEPTH:
            raise NotInlinable("kernels nested too deep")
        node = _parsed(fn)
        names = [a.arg for a in node.args.args]
        defaults = list(fn.__defaults__ or ())
        if len(args) > len(names) or len(args) < len(names) - len(defaults):
            raise NotInlinable(f"{fn.__name__} called with {len(args)} arguments")
        env = dict(zip(names, args))
        for n, v in zip(names[len(args):], defaults[len(defaults) - (len(names) - len(args)):]):
            env[n] = self.constant(v)
        frame = _Frame(self, fn, depth)
        kind, value = frame.block(node.body, env)
        if kind != "return":
            raise NotInlinable(f"{fn.__name__} can end without a return")
        return value


class _Frame:
    """One inlined call: its function's names and the inliner it writes with."""

    def __init__(self, inl, fn, depth):
        self.inl, self.fn, self.depth = inl, fn, depth
        self.closure = dict(zip(fn.__code__.co_freevars, fn.__closure__ or ()))  # name -> cell

    # -- statements --------------------------------------------------------------------------------
    def block(self, stmts, env):
        """Run ``stmts``: ``("return", tree)`` or ``("fall", env)``."""
        for k, st in enumerate(stmts):
            self.inl.tick()
            if isinstance(st, ast.Return):
                if st.value is None:
                    raise NotInlinable("a bare return")
                return "return", self.inl.settle(snapshot(self.value(st.value, env)))
            if isinstance(st, ast.Expr) and isinstance(st.value, ast.Constant):
                continue  # a docstring
            if isinstance(st, ast.Pass):
                continue
            if isinstance(st, ast.Assign):
                tree = self.value(st.value, env)
                for target in st.targets:  # a = b = 0.0: each name the same value
                    self.bind(target, tree, env)
            elif isinstance(st, ast.AugAssign):
                expr = ast.BinOp(_load(st.target), st.op, st.value)
                self.bind(st.target, self.scalar(expr, env), env)
            elif isinstance(st, ast.If):
                known = literal(self.scalar(st.test, env))
                if known is not None:  # decided while writing (a loop's index, a width)
                    stmts = list(st.body if known else st.orelse) + list(stmts[k + 1:])
                    return self.block(stmts, env)
                if _returns(st):
                    return self.split(st, stmts[k + 1:], env)
                env = self.merge(st, env)
            elif isinstance(st, ast.For):
                if st.orelse or any(isinstance(n, (ast.Break, ast.Continue, ast.Return)) for n in ast.walk(st)):
                    raise NotInlinable("a loop with break, continue, return or else")
                for item in self.items(st.iter, env):
                    self.bind(st.target, item, env)
                    kind, env = self.block(st.body, env)
            else:
                raise NotInlinable(f"{type(st).__name__} statement")
        return "fall", env

    def bind(self, target, tree, env):
        if isinstance(target, ast.Name):
            env[target.id] = self.inl.settle(tree)
        elif isinstance(target, ast.Subscript):  # an element of an array the kernel writes
            base = self.value(target.value, env)
            if not isinstance(base, Out) or self.inl.branches:
                raise NotInlinable("writing an item other than an output array's, or in a branch")
            k = self.index(target.slice, env, len(base.items))
            base.items[k] = self.inl.simple(self.scalar_of(tree))
        elif isinstance(target, ast.Tuple) and not any(isinstance(e, ast.Starred) for e in target.elts):
            items = tree.items if isinstance(tree, Record) else tree
            if not isinstance(items, tuple) or len(items) != len(target.elts):
                raise NotInlinable("unpacking a value of another length")
            for t, v in zip(target.elts, items):
                self.bind(t, v, env)
        else:
            raise NotInlinable("assignment to an item or attribute")

    def split(self, st, rest, env):
        """An ``if`` with a return in it: each branch runs the rest of the function."""
        cond = self.scalar(st.test, env)

        def run(body):
            def go():
                kind, value = self.block(list(body) + list(rest), dict(env))
                if kind != "return":
                    raise NotInlinable("a path without a return")
                return value
            return self.inl.branch(go)

        then, a = run(st.body)
        orelse, b = run(st.orelse)
        result = _join(self.inl, a, b, then, orelse)
        self.inl.out.append(If(cond, then, orelse))
        return "return", result

    def merge(self, st, env):
        """An ``if`` without returns: the names its branches set, merged into new locals."""
        cond = self.scalar(st.test, env)

        def run(body):
            def go():
                return self.block(body, dict(env))[1]
            return self.inl.branch(go)

        then, ea = run(st.body)
        orelse, eb = run(st.orelse)
        merged = dict(env)
        for name in set(ea) | set(eb):
            a, b = ea.get(name, _UNSET), eb.get(name, _UNSET)
            if a is b or (isinstance(a, str) and a == b):
                merged[name] = a
            elif a is _UNSET or b is _UNSET:
                merged[name] = _UNSET
            else:
                merged[name] = _join(self.inl, a, b, then, orelse)
        self.inl.out.append(If(cond, then, orelse))
        return merged

    # -- expressions ---------------------------------------------------------------------------------
    def lookup(self, name, env):
        if name in env:
            if env[name] is _UNSET:
                raise NotInlinable(f"{name!r} set on one branch only")
            return env[name]
        if name in self.closure:
            try:
                return self.object(self.closure[name].cell_contents)
            except ValueError:  # a cell never assigned
                raise NotInlinable(f"{name!r} has no value yet") from None
        if name in self.fn.__globals__:
            return self.object(self.fn.__globals__[name])
        if hasattr(builtins, name):
            return self.object(getattr(builtins, name))
        raise NotInlinable(f"unknown name {name!r}")

    def object(self, v):
        """A global or closure value as a tree (numbers), or the object itself (math, kernels)."""
        if isinstance(v, (bool, int, float)):
            return self.inl.constant(v)
        if v is math or callable(v):
            return _Object(v)
        raise NotInlinable(f"global {v!r}")

    def value(self, node, env):
        """``node``'s tree."""
        if isinstance(node, ast.Tuple):
            if any(isinstance(e, ast.Starred) for e in node.elts):
                raise NotInlinable("a starred item")
            return tuple(self.value(e, env) for e in node.elts)
        if isinstance(node, ast.Name):
            v = self.lookup(node.id, env)
            if isinstance(v, _Object):
                raise NotInlinable(f"{node.id!r} used as a value")
            return v
        if isinstance(node, ast.Subscript):
            return self.item(node, env)
        if isinstance(node, ast.Attribute):
            return self.attribute(node, env)
        if isinstance(node, ast.Call):
            return self.callee(node, env, False)
        return self.scalar(node, env)

    def attribute(self, node, env):
        if isinstance(node.value, ast.Name) and node.value.id not in env:
            obj = self.lookup(node.value.id, env)
            if isinstance(obj, _Object) and obj.v is math:
                v = getattr(math, node.attr, None)
                if isinstance(v, float):
                    return self.inl.constant(v)
                raise NotInlinable(f"math.{node.attr} as a value")
        base = self.value(node.value, env)
        if isinstance(base, Record):
            return base.field(node.attr)
        if isinstance(base, Array) and node.attr in ("shape", "size", "ndim"):
            size = 1
            for n in base.shape:
                size *= n
            return {"shape": tuple(map(repr, base.shape)), "size": repr(size), "ndim": repr(len(base.shape))}[node.attr]
        raise NotInlinable(f"attribute {node.attr!r}")

    def item(self, node, env):
        base = self.value(node.value, env)
        s = node.slice
        if isinstance(base, Array) and isinstance(s, ast.Tuple) and len(s.elts) == len(base.shape) == 2:
            i, j = (self.index(e, env, n) for e, n in zip(s.elts, base.shape))
            return base.rows[i][j]
        if isinstance(base, Out):
            v = base.items[self.index(s, env, len(base.items))]
            if v is None:
                raise NotInlinable("reading an output element not yet written")
            return v
        items = base.items if isinstance(base, Record) else base.rows if isinstance(base, Array) else base
        if not isinstance(items, tuple):
            raise NotInlinable("indexing a value that is not a tuple")
        if isinstance(s, ast.Slice):
            bounds = [None if b is None else self.whole(b, env) for b in (s.lower, s.upper, s.step)]
            return items[slice(*bounds)]
        return items[self.index(s, env, len(items))]

    def index(self, node, env, n):
        k = self.whole(node, env)
        if not -n <= k < n:
            raise NotInlinable("index out of range")
        return k

    def whole(self, node, env):
        """An integer known while writing: a literal, a loop's index, a width."""
        v = literal(self.scalar(node, env))
        if not isinstance(v, int) or isinstance(v, bool):
            raise NotInlinable("an index not known while writing")
        return v

    def items(self, node, env):
        """What a ``for`` loop runs over, known while writing: ``range`` of integers, a tuple, an
        array's rows, ``unroll(tuple)``."""
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and not node.keywords:
            fn = self.lookup(node.func.id, env)
            fn = fn.v if isinstance(fn, _Object) else None
            if fn is range:
                items = [repr(k) for k in range(*(self.whole(a, env) for a in node.args))]
                return _capped(items)
            if fn is unroll and len(node.args) == 1:
                node = node.args[0]
        tree = self.value(node, env)
        tree = tree.rows if isinstance(tree, Array) else tree.items if isinstance(tree, Record) else tree
        if not isinstance(tree, tuple):
            raise NotInlinable("a loop over a value not known while writing")
        return _capped(list(tree))

    def scalar_of(self, tree):
        if not isinstance(tree, str):
            raise NotInlinable("a tuple where a number is needed")
        return tree

    def callee(self, node, env, conditional):
        """A call: a kernel inlined (its tree), or the source of a math or builtin call."""
        if node.keywords:
            raise NotInlinable("keyword arguments")
        f = node.func
        if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name) and f.value.id not in env:
            obj = self.lookup(f.value.id, env)
            if isinstance(obj, _Object) and obj.v is math and callable(getattr(math, f.attr, None)):
                return f"math.{f.attr}(" + ", ".join(self.scalar(a, env, conditional) for a in node.args) + ")"
            raise NotInlinable("a method or a module other than math")
        if not isinstance(f, ast.Name):
            raise NotInlinable("calling an expression")
        obj = self.lookup(f.id, env)
        if not isinstance(obj, _Object):
            raise NotInlinable(f"calling {f.id!r}")
        fn = obj.v
        if getattr(fn, "__module__", None) == "math" and getattr(math, fn.__name__, None) is fn:
            return f"math.{fn.__name__}(" + ", ".join(self.scalar(a, env, conditional) for a in node.args) + ")"
        if fn is len and len(node.args) == 1:
            if conditional and _calls(node.args[0]):
                raise NotInlinable("a call inside a conditional expression")
            v = self.value(node.args[0], env)
            v = v.rows if isinstance(v, Array) else v.items if isinstance(v, (Record, Out)) else v
            if isinstance(v, (tuple, list)):
                return repr(len(v))
            raise NotInlinable("len of a number")
        if fn in _BUILTINS:  # of numbers only (min / max of a tuple: the call is kept)
            return f"{_BUILTINS[fn]}(" + ", ".join(self.scalar(a, env, conditional) for a in node.args) + ")"
        if conditional:
            raise NotInlinable("a kernel called inside a conditional expression")
        args = [self.inl.settle(self.value(a, env)) for a in node.args]
        return self.inl.call(fn, args, self.depth + 1)

    def scalar(self, node, env, conditional=False):
        """Source of the scalar ``node``, fully parenthesized; a math call outside a conditional part
        is put in a local first (shared by equal calls)."""
        sc = self.scalar
        if isinstance(node, ast.Constant):
            if isinstance(node.value, bool) or isinstance(node.value, (int, float)) and not isinstance(node.value, complex):
                return repr(node.value)
            raise NotInlinable(f"constant {node.value!r}")
        if isinstance(node, ast.BinOp):
            op = _BINOPS.get(type(node.op))
            if op is None:
                raise NotInlinable(f"operator {type(node.op).__name__}")
            return fold(f"({sc(node.left, env, conditional)} {op} {sc(node.right, env, conditional)})")
        if isinstance(node, ast.UnaryOp):
            return fold(f"({_UNARY[type(node.op)]}{sc(node.operand, env, conditional)})")
        if isinstance(node, ast.BoolOp):
            op = " and " if isinstance(node.op, ast.And) else " or "
            first = sc(node.values[0], env, conditional)
            return "(" + op.join([first] + [sc(v, env, True) for v in node.values[1:]]) + ")"
        if isinstance(node, ast.Compare):
            if any(type(o) not in _COMPARE for o in node.ops):
                raise NotInlinable("is / in comparisons")
            parts = [sc(node.left, env, conditional)]
            for k, (o, c) in enumerate(zip(node.ops, node.comparators)):  # a chain stops at the first False
                parts += [_COMPARE[type(o)], sc(c, env, conditional or k > 0)]
            return fold("(" + " ".join(parts) + ")")
        if isinstance(node, ast.IfExp):
            test = sc(node.test, env, conditional)
            return f"({sc(node.body, env, True)} if {test} else {sc(node.orelse, env, True)})"
        if isinstance(node, ast.Call):
            v = self.callee(node, env, conditional)
            if isinstance(v, str) and not conditional:
                return self.inl.simple(v)
        elif isinstance(node, (ast.Name, ast.Subscript, ast.Attribute)):
            if conditional and _calls(node):  # f(x)[0] in a branch of an expression: not written first
                raise NotInlinable("a call inside a conditional expression")
            v = self.value(node, env)
        else:
            raise NotInlinable(f"{type(node).__name__} expression")
        if not isinstance(v, str):
            raise NotInlinable("a tuple where a number is needed")
        return v


class _Object:
    """A global that is not a number: the math module, a function."""

    __slots__ = ("v",)

    def __init__(self, v):
        self.v = v


def _load(target):
    """``target`` (a name or an item) read, for ``target op= value``."""
    node = ast.Subscript(target.value, target.slice, ast.Load()) if isinstance(target, ast.Subscript) \
        else ast.Name(getattr(target, "id", ""), ast.Load())
    if not isinstance(target, (ast.Name, ast.Subscript)):
        raise NotInlinable("augmented assignment to an attribute")
    return node


def _capped(items):
    if len(items) > MAX_LOOP:
        raise NotInlinable("a loop of more than MAX_LOOP turns")
    return items


def _calls(node):
    return any(isinstance(n, ast.Call) for n in ast.walk(node))


def _returns(node):
    return any(isinstance(n, ast.Return) for n in ast.walk(node))


def _join(inl, a, b, then, orelse):
    """The trees ``a`` (set by the statements ``then``) and ``b`` (``orelse``) as one: a new local
    for each leaf that differs, assigned at the end of both branches."""
    if a is b:
        return a
    if isinstance(a, str) and isinstance(b, str):
        if a == b:
            return a
        name = inl.fresh()
        inl.tick(2)
        then.append(Assign(name, a))
        orelse.append(Assign(name, b))
        if is_float(a, inl.floats) and is_float(b, inl.floats):
            inl.floats.add(name)
        return name
    if isinstance(a, Record) and a is b:
        return a
    if isinstance(a, tuple) and isinstance(b, tuple) and len(a) == len(b):
        return tuple(_join(inl, x, y, then, orelse) for x, y in zip(a, b))
    raise NotInlinable("branches giving values of different shapes")
