"""A ball bouncing on the floor: the state event with a reset, in its simplest form."""
from typing import NamedTuple

from hybridsim.engine.block import Block
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.engine.registry import register

from hybridsim.blocks._util import scalar


GROUP = "examples"  # where `hybridsim blocks` lists this module's blocks

@register("bouncing_ball")
class BouncingBall(Block):
    """A ball under gravity with restitution at the floor h = 0.

    State h (m), v (m/s): h' = v, v' = -g. Event: h falls through 0; action:
    h+ = 0, v+ = -e v- (e the coefficient of restitution). Outputs ``h`` and
    ``v``. Dropped from rest at h0 it lands at t1 = sqrt(2 h0 / g) and then
    after flights of 2 e^k v1 / g (v1 = g t1); the bounces accumulate at
    t1 (1 + e) / (1 - e) (Zeno), which a run stops with a clear error.
    """

    event_directions = (-1,)

    def __init__(self, name="ball", g=9.81, e=0.8, h0=1.0, v0=0.0):
        super().__init__(name)
        self.params = BallParams(g=scalar(g, "g", "positive"), e=scalar(e, "e", "nonnegative"))
        if self.params.e > 1:
            raise ValueError("restitution e must be at most 1")
        self.x0 = (scalar(h0, "h0", "nonnegative"), scalar(v0, "v0"))
        self.declare_output("h", 1, depends_on=())
        self.declare_output("v", 1, depends_on=())
        self.declare_continuous_state(2, atol=(1e-12, 1e-12))

    def initial_state(self, u=None):
        return list(self.x0)


class BallParams(NamedTuple):
    g: float  # gravity, m/s^2
    e: float  # coefficient of restitution


@kernel
def ball_output(p, t, x, u):
    return (x[0],), (x[1],)


@kernel
def ball_derivatives(p, t, x, u):
    return (x[1], -p.g)


@kernel
def ball_floor(p, t, x, u):
    return (x[0],)


@kernel
def ball_bounce(p, t, x, u, fired):
    return (0.0, -p.e * x[1])


BouncingBall.kernels = Kernels(output=ball_output, derivatives=ball_derivatives,
                               zero_crossings=ball_floor, event_action=ball_bounce)
