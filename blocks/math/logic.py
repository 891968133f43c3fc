"""Comparisons and logic: relational and logical operators, MinMax, hit crossing.

Signals are element-wise; true is 1.0 and false 0.0, and an input counts as
true when it is not zero (Simulink's convention). The switching points of a
comparison are zero crossings, so solvers that locate switches stop on them.
"""
from typing import NamedTuple

import numpy as np

from hybridsim.engine.block import Block
from hybridsim.errors import ParameterError
from hybridsim.engine.kernels import Kernels, kernel, unroll
from hybridsim.engine.registry import register

from hybridsim.blocks._sides import side_function
from hybridsim.blocks._util import choice, count, vector

GROUP = "math"  # where `hybridsim blocks` lists this module's blocks

_RELATIONS = ("<", "<=", ">", ">=", "==", "!=")
_LOGIC = ("and", "or", "nand", "nor", "xor", "not")


@register("relational")
class Relational(Block):
    """y = 1 where ``u1 op u2`` holds, else 0; ``op`` one of < <= > >= == !=.

    Ports: in ``u1``, ``u2`` (width each); out ``y``. The zero crossings are
    u1 - u2. Example: op '>', u1 = sin(t), u2 = 0 gives y = 1 on (0, pi).
    """

    def __init__(self, name="relational", op="<", width=1):
        super().__init__(name)
        if op not in _RELATIONS:
            raise ParameterError("op", f"must be one of {' '.join(_RELATIONS)}; got {op!r}")
        n = count(width, "width")
        self.params = (float(_RELATIONS.index(op)), n)
        self.event_directions = (0,) * n
        self.declare_input("u1", n)
        self.declare_input("u2", n)
        self.declare_output("y", n)


@kernel
def relational_output(p, t, x, u):
    a, b = np.asarray(u[0]), np.asarray(u[1])
    op = p[0]
    if op == 0.0:
        r = a < b
    elif op == 1.0:
        r = a <= b
    elif op == 2.0:
        r = a > b
    elif op == 3.0:
        r = a >= b
    elif op == 4.0:
        r = a == b
    else:
        r = a != b
    return (np.where(r, 1.0, 0.0),)


@kernel
def difference_crossings(p, t, x, u):
    """u1 - u2, never zero where equality is one of the sides: there it is past zero on the side whose
    output equality gives (<, >=: that of u1 > u2; <=, >: that of u1 < u2), as the output a stage sees."""
    d = np.asarray(u[0]) - np.asarray(u[1])
    op = p[0]
    if op == 0.0 or op == 3.0:
        return np.where(d == 0.0, 1e-300, d)
    if op == 1.0 or op == 2.0:
        return np.where(d == 0.0, -1e-300, d)
    return d  # == and !=: equality is a value of its own


@register("logical")
class Logical(Block):
    """y = the logical ``op`` (and, or, nand, nor, xor, not) of the inputs u1 .. u_inputs, element-wise.

    An input is true when it is not 0; y is 1.0 or 0.0. ``xor`` is true when an
    odd number of inputs is; ``not`` takes one input.
    """

    def __init__(self, name="logical", op="and", inputs=2, width=1):
        super().__init__(name)
        if op not in _LOGIC:
            raise ParameterError("op", f"must be one of {', '.join(_LOGIC)}; got {op!r}")
        m = 1 if op == "not" else count(inputs, "inputs")
        n = count(width, "width")
        self.params = (float(_LOGIC.index(op)), n)
        for k in range(m):
            self.declare_input(f"u{k + 1}", n)
        self.declare_output("y", n)


@kernel
def logical_output(p, t, x, u):
    op, n = p
    trues = np.zeros(n)
    m = 0
    for v in unroll(u):
        trues = trues + np.where(np.asarray(v) != 0.0, 1.0, 0.0)
        m += 1
    if op == 0.0 or op == 2.0:
        r = trues == m
    elif op == 1.0 or op == 3.0:
        r = trues > 0.0
    elif op == 4.0:
        r = np.mod(trues, 2.0) == 1.0
    else:
        r = trues == 0.0
    if op == 2.0 or op == 3.0:
        r = ~r
    return (np.where(r, 1.0, 0.0),)


@register("minmax")
class MinMax(Block):
    """y = the element-wise min or max (``function``) of the inputs u1 .. u_inputs.

    With ``inputs: 1``, y (width 1) is the min or max over the elements of u.
    """

    def __init__(self, name="minmax", function="min", inputs=2, width=1):
        super().__init__(name)
        function = choice(function, "function", ("min", "max"))
        m, n = count(inputs, "inputs"), count(width, "width")
        self.params = (1.0 if function == "max" else -1.0, m)
        for k in range(m):
            self.declare_input(f"u{k + 1}", n)
        self.declare_output("y", 1 if m == 1 else n)


@kernel
def minmax_output(p, t, x, u):
    s, m = p
    if m == 1:
        a = np.asarray(u[0])
        return (np.array([np.max(a) if s > 0 else np.min(a)]),)
    y = s * np.asarray(u[0])
    for v in unroll(u):
        y = np.maximum(y, s * np.asarray(v))
    return (s * y,)


@register("hit_crossing")
class HitCrossing(Block):
    """Locates each time u crosses ``offset`` in ``direction`` (rising, falling or either) as a state event.

    Outputs: ``count``, the crossings so far, and ``time``, the time (s) of the
    last one (-1 before the first). Every solver stops exactly at the crossing
    (it is an event with a reset of the block's own counters), as Simulink's
    Hit Crossing forces the solver to step on it. A crossing goes from one side
    of ``offset`` to the other: u starting on it and leaving is not one.
    Example: u = sin(2 pi t), rising through 0: count 1, 2 at t = 1, 2 s.
    """

    init_needs_inputs = True

    def __init__(self, name="hit", offset=0.0, direction="either", width=1):
        super().__init__(name)
        dirs = {"rising": 1, "falling": -1, "either": 0}
        direction = choice(direction, "direction", tuple(dirs))
        n = count(width, "width")
        self.params = HitParams(vector(offset, "offset", n), n, float(dirs[direction]))
        self.event_directions = (-1,) * n  # side * (u - offset) falls at a crossing (blocks/_sides.py)
        self.declare_input("u", n)
        self.declare_output("count", n, depends_on=())
        self.declare_output("time", n, depends_on=())
        # count, time of the last crossing, the side of offset u is on (-1, 0 at the start on it, +1)
        self.declare_continuous_state(3 * n, bounded=[False] * (2 * n) + [True] * n, held=True)  # counts, times grow

    def initial_state(self, u=None):
        p = self.params
        side = np.sign(np.asarray(u[0], float) - p.offset) if u is not None else np.zeros(p.n)
        return np.concatenate((np.zeros(p.n), -np.ones(p.n), side))


class HitParams(NamedTuple):
    offset: np.ndarray  # the level crossed, units of u
    n: int              # width
    direction: float    # +1 rising, -1 falling, 0 either


@kernel
def hit_output(p, t, x, u):
    xa = np.asarray(x)
    return xa[:p.n], xa[p.n:2 * p.n]


@kernel
def hit_derivatives(p, t, x, u):
    return np.zeros(3 * p.n)


@kernel
def hit_crossings(p, t, x, u):
    """side * (u - offset), falling through 0 at a crossing (:mod:`hybridsim.blocks._sides`)."""
    xa, ua = np.asarray(x), np.asarray(u[0])
    g = np.empty(p.n)
    for i in range(p.n):
        g[i] = side_function(xa[2 * p.n + i], ua[i] - p.offset[i])
    return g


@kernel
def hit_event(p, t, x, u, fired):
    out = np.asarray(x).copy()
    ua = np.asarray(u[0])
    for i in range(p.n):
        if fired[i]:
            # the side u is on now; a crossing is a change from one side to the other (u leaving the
            # level to the side it came from, or from the start on it, is none)
            side, new = out[2 * p.n + i], float(np.sign(ua[i] - p.offset[i]))
            if side != 0.0 and new != 0.0 and new != side and (p.direction == 0.0 or p.direction == new):
                out[i] += 1.0
                out[p.n + i] = t
            if new != 0.0:
                out[2 * p.n + i] = new
    return out


Relational.kernels = Kernels(output=relational_output, zero_crossings=difference_crossings)
Logical.kernels = Kernels(output=logical_output)
MinMax.kernels = Kernels(output=minmax_output)
HitCrossing.kernels = Kernels(output=hit_output, derivatives=hit_derivatives, zero_crossings=hit_crossings,
                              event_action=hit_event)
