"""Kernels written in place (hybridsim.engine.inline) give their calls' numbers, bit for bit."""
import math

import numpy as np
import pytest

import hybridsim as hs
from hybridsim.engine import floatcode, inline
from hybridsim.engine.kernels import kernel

from conftest import DIAGRAMS


def inlined(fn, params, n_x, widths, into=None):
    """``fn`` written in place as a function ``g(P, t, x, u)`` of the same arguments (or None);
    ``into``: the widths of the arrays an ``_into`` kernel writes (a list: ports; an int: a state)."""
    hoists = []
    p = floatcode.param_tree(params, "P", "P", hoists)
    xs = tuple(f"x{j}" for j in range(n_x))
    us = tuple(tuple(f"u{k}_{j}" for j in range(w)) for k, w in enumerate(widths))
    env = {"math": math}
    count = iter(range(10 ** 6))
    inl = inline.Inliner(lambda: f"v{next(count)}", env)
    args = [p, "t", xs, us]
    if into is not None:
        args.append(floatcode.Out(into) if isinstance(into, int) else tuple(floatcode.Out(w) for w in into))
    try:
        tree = inl.call(fn, args)
    except floatcode.NotInlinable:
        return None
    lines = ["def g(P, t, x, u, *out):"] + [f"    {n} = {e}" for n, e in hoists]
    lines += [f"    {n} = x[{j}]" for j, n in enumerate(xs)]
    lines += [f"    {n} = u[{k}][{j}]" for k, port in enumerate(us) for j, n in enumerate(port)]
    lines += floatcode.lines(inl.out, "    ") + [f"    return {floatcode.source(tree)}"]
    exec("\n".join(lines), env)  # noqa: S102
    return env["g"]


def flat(r):
    if isinstance(r, (tuple, list)):
        return [v for item in r for v in flat(item)]
    if isinstance(r, np.ndarray):
        return r.ravel().tolist()
    return [r]


def same(f, g, *args):
    try:
        want = f(*args)
    except (ArithmeticError, ValueError) as exc:
        with pytest.raises(type(exc)):
            g(*args)
        return
    got = g(*args)
    assert np.array_equal(np.array(flat(got), float), np.array(flat(want), float), equal_nan=True)


def block_cases():
    """Every registered block that builds with its defaults: ``(type, block)``."""
    out = []
    for name in sorted(hs.registry.types()):
        for kw in ({}, {"rate": 100.0}):  # sampled blocks need a rate
            try:
                b = hs.registry.lookup(name)(name, **kw)
            except Exception:  # noqa: BLE001 - blocks that need other arguments (files, models) are skipped
                continue
            if b.kernels is not None:
                out.append((name, b))
            break
    return out


@pytest.mark.parametrize("name, block", block_cases(), ids=lambda v: v if isinstance(v, str) else "")
def test_every_block_kernel_written_in_place_equals_its_call(name, block):
    rng = np.random.default_rng(7)
    widths = [p.width for p in block.inputs]
    n_x = block.n_continuous or block.n_discrete
    ports = [p.width for p in block.outputs]
    k = block.kernels
    cases = [(k.output, None), (k.output_into, ports), (k.zero_crossings, None), (k.update, None),
             (k.update_into, block.n_discrete)]
    if block.n_continuous:
        cases.append((k.derivatives, None))
    for f, into in cases:
        if f is None:
            continue
        g = inlined(f, block.params, n_x, widths, into)
        if g is None:
            continue

        def call(*args, f=f, into=into):
            if into is None:
                return f(*args)
            arrays = np.empty(into) if isinstance(into, int) else tuple(np.empty(w) for w in into)
            return f(*args, arrays)

        for scale in (1.0, 1e-3, 100.0):
            for _ in range(20):
                x = tuple(float(v) for v in rng.normal(0, scale, n_x))
                u = tuple(tuple(float(v) for v in rng.normal(0, scale, w)) for w in widths)
                same(call, g, block.params, 0.37, x, u)
            same(call, g, block.params, 0.0, (0.0,) * n_x, tuple((0.0,) * w for w in widths))


def test_the_paper_blocks_are_written_in_place():
    system, sim, _ = hs.build(DIAGRAMS / "fig9_force_and_position.yaml")
    stage = sim._fused.stage
    names = {system.blocks[i].name for i in stage.inlined}
    assert {"arm", "wrist", "surface"} <= names and not stage.called


@kernel
def _root(p, t, x, u):
    return ((math.sqrt(x[0]) if x[0] > 0.0 else 0.0, x[0] > 0.0 and math.log(x[0]) > 1.0),)


@kernel
def _early(p, t, x, u):
    a, b = p
    if x[0] < a:
        return ((a,),)
    y = x[0] * b
    if y > 1.0:
        y = y - 1.0
    return ((y,),)


@kernel
def _looped(p, t, x, u):
    s = 0.0
    for v in x:
        s += v
    return ((s,),)


@kernel
def _while(p, t, x, u):
    s = 0.0
    while s < x[0]:
        s += 1.0
    return ((s,),)


def test_conditional_calls_stay_conditional_and_branches_merge():
    g = inlined(_root, (), 1, [])
    assert g((), 0.0, (-4.0,), ()) == ((0.0, False),)  # no sqrt or log of a negative number
    assert g((), 0.0, (9.0,), ()) == _root((), 0.0, (9.0,), ())
    g = inlined(_early, (0.5, 3.0), 1, [])
    for x in (0.1, 0.5, 0.6, 2.0):
        assert g((0.5, 3.0), 0.0, (x,), ()) == _early((0.5, 3.0), 0.0, (x,), ())
    assert inlined(_looped, (), 2, [])((), 0.0, (0.1, 0.2), ()) == ((0.1 + 0.2,),)  # a loop written out
    assert inlined(_while, (), 1, []) is None  # a loop of unknown length: the call is kept


@kernel
def _scaled_cos(p, t, x, u):
    return (math.cos(x[0]) * p.k,)


def test_names_the_params_and_a_cos_shared_by_two_kernels():
    inl = inline.Inliner(iter(f"v{k}" for k in range(100)).__next__, {"math": math})
    from typing import NamedTuple

    class K(NamedTuple):
        k: float

    hoists = []
    p = floatcode.param_tree(K(2.0), "P", "P", hoists)
    assert hoists == [("P_k", "P.k")]
    a = inl.call(_scaled_cos, [p, "t", ("x0",), ()])
    b = inl.call(_scaled_cos, [p, "t", ("x0",), ()])
    assert a == b  # the second call's expressions are the first's locals
    assert [s.expr for s in inl.out] == ["math.cos(x0)", "(v0 * P_k)"]
