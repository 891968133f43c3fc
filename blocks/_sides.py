"""The event function of a block that follows which side of a level its input is on.

A block that counts or acts on crossings of a level (``hit_crossing``, the trigger of
``memory``) keeps the side its input is on (-1, +1; 0 while it starts on the level) and
declares its function falling (direction -1): ``side * (u - level)`` goes below 0 only when u
reaches the other side. u touching the level and turning back, or sitting on it, brings the
function to 0 and back: no event on any solver. Before the first side is known the function
is ``-|u - level|``: leaving the level is an event that only sets the side.
"""
from hybridsim.engine.kernels import kernel


@kernel
def side_function(side, d):
    """side * d, or -|d| when the side is not yet known (0); d = u - level."""
    return side * d if side != 0.0 else -abs(d)
