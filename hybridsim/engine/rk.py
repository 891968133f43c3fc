"""Fixed-step explicit Runge-Kutta steps on arrays: the stepper (:class:`~.stepping.Ops`) of the core.

A method is its Butcher tableau (:class:`~hybridsim.engine.solvers.ExplicitRK`);
:func:`hybridsim.engine.rk_code.array_source` writes its steps out on the
core's arrays (each coefficient times h once, terms summed left to right, the
weights factored when they are whole multiples of the smallest: the order the
fused path's tuples use too), so the paths agree bit for bit. The generic
path runs them in Python (:func:`ops`); the compiled core compiles the same
source. :class:`RKState` holds where a run is on its step grid.
"""
import functools
from typing import NamedTuple

import numpy as np

from hybridsim.engine import stepping


# the numbers of RKState.num
STEP, H, N, K, T0, T1, KSAVE = 0, 1, 2, 3, 4, 5, 7


class RKState(NamedTuple):
    """Where a run is on its Runge-Kutta step grid."""

    c: np.ndarray    # float64[s]: the method's nodes (s: its number of stages)
    num: np.ndarray  # float64[8]: step, h, n (steps in the grid), k (taken), t0, t1, -, k at the last `steps`
    tmp: np.ndarray  # float64[8]: a grid of one step, as num (the compiled glue's restep)


def rk_state(method):
    """A fresh :class:`RKState` of an :class:`~hybridsim.engine.solvers.ExplicitRK` method."""
    num = np.zeros(8)
    num[STEP] = method.step
    return RKState(np.array(method.c, float), num, np.zeros(8))


@functools.lru_cache(maxsize=None)
def ops(method_class):
    """The :class:`~.stepping.Ops` of a method's steps as plain Python functions (the generic path)."""
    from hybridsim.engine import rk_code

    env = {}
    exec(compile(rk_code.array_source(method_class), f"<{method_class.name} steps>", "exec"), env)  # noqa: S102
    return stepping.Ops(*(env[f"rk_{k}"] for k in stepping.Ops._fields))
