"""The compiled glue's functions that every diagram without them shares.

The compiled path takes no time events and no step hooks (:func:`~hybridsim.engine.compiled.problems`
refuses them), and a diagram without located events has no event functions: these stand in for
those functions, compiled once per machine (numba's cache) rather than once per diagram. Their
arguments are :data:`~hybridsim.engine.native.types` ``["glue"]``'s.
"""
import math


def next_time(t, x_p, y_p, z_p, pf_p, pi_p):
    """No time event ahead."""
    return math.inf


def timed(t, x_p, xn_p, y_p, z_p, pf_p, pi_p):
    """No time event at ``t``: go on (stepping.GO)."""
    return 0


def stepped(t, x_p, y_p, z_p, pf_p, pi_p):
    """No block told of the step: go on (stepping.GO)."""
    return 0


def zc(t, x_p, g_p, y_p, z_p, pf_p, pi_p):
    """No located event functions: nothing to write."""
    return


#: the glue's fields these stand for, where the generated module does not define them
FIELDS = ("next_time", "timed", "stepped", "zc")
