"""The hand on the wrist force sensor (eqs 7, 8) and what the sensor reads."""
import math
from typing import NamedTuple

import numpy as np

from hybridsim.engine.block import Block
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.engine.registry import register

from hybridsim.blocks._util import scalar, vector
from hybridsim.blocks.paper.kinematics import L_OFFSET


GROUP = "paper"  # where `hybridsim blocks` lists this module's blocks

@register("wrist")
class Wrist(Block):
    """Hand mass M3 held by the wrist spring Kw, pushed by the surface.

    State w, w' : hand displacement relative to the arm endpoint, in {H}.

    Eqs 7, 8 (with optional wrist damping bw, 0 as printed):
        M3 w1'' = -Kw w1 - bw w1' - fx cos q1
        M3 w2'' = -Kw w2 - bw w2' + fx sin q1

    Outputs
    -------
    F : H_F = -Kw w, the force the hand exerts, as the sensor reads it (N, {H})
    f_arm : Kw w + bw w', the wrist force acting on the arm (N, {H})
    x : hand position Lambda(q) + R(q1) w in {C} (m)
    v : hand velocity (m/s)

    ``preload`` (N) starts the hand in static balance against a contact force
    of that size along C-X (w = preload (-cos q1, sin q1) / Kw, computed from
    the arm's q at t = 0); ``dw0`` adds an initial deflection, ``wd0`` a
    velocity (to excite the eq 18 oscillation).
    """

    init_needs_inputs = True

    def __init__(self, name="wrist", Kw=8.0e5, bw=0.0, M3=0.58, l=L_OFFSET,
                 preload=0.0, dw0=(0.0, 0.0), wd0=(0.0, 0.0)):
        super().__init__(name)
        self.params = WristParams(Kw=scalar(Kw, "Kw", "positive"), bw=scalar(bw, "bw", "nonnegative"),
                                  M3=scalar(M3, "M3", "positive"), l=scalar(l, "l"))
        self.preload = scalar(preload, "preload")
        self.dw0, self.wd0 = vector(dw0, "dw0", 2), vector(wd0, "wd0", 2)
        self.declare_input("q", 2)
        self.declare_input("qd", 2)
        self.declare_input("fx", 1)
        self.declare_output("F", 2, depends_on=())
        self.declare_output("f_arm", 2, depends_on=())
        self.declare_output("x", 2, depends_on=("q",))
        self.declare_output("v", 2, depends_on=("q", "qd"))
        self.declare_continuous_state(4, atol=(1e-12, 1e-12, 1e-9, 1e-9))

    def initial_state(self, u=None):
        q1 = u[0][0] if u is not None else 0.0
        w = self.preload * np.array([-math.cos(q1), math.sin(q1)]) / self.params.Kw + self.dw0
        return np.concatenate([w, self.wd0])


class WristParams(NamedTuple):
    Kw: float   # wrist stiffness, N/m
    bw: float   # wrist damping, N s/m
    M3: float   # hand mass, kg
    l: float    # link offset, m


@kernel
def wrist_output(p, t, x, u):
    q1, q2 = u[0][0], u[0][1]
    qd1, qd2 = u[1][0], u[1][1]
    w1, w2, wd1, wd2 = x[0], x[1], x[2], x[3]
    k, b, _, l = p
    c, s = math.cos(q1), math.sin(q1)
    rw1, rw2 = w1 * c - w2 * s, w1 * s + w2 * c          # R(q1) w
    hand = (q2 * c + l * s + rw1, q2 * s - l * c + rw2)    # Lambda(q) + R w
    # d/dt [Lambda(q) + R w] = J q' + R w' + q1' dR/dq1 w
    vel = ((-q2 * s + l * c) * qd1 + c * qd2 + wd1 * c - wd2 * s - qd1 * rw2,
           (q2 * c + l * s) * qd1 + s * qd2 + wd1 * s + wd2 * c + qd1 * rw1)
    return ((-k * w1, -k * w2), (k * w1 + b * wd1, k * w2 + b * wd2), hand, vel)


@kernel
def wrist_derivatives(p, t, x, u):
    w1, w2, wd1, wd2 = x[0], x[1], x[2], x[3]
    q1, fx = u[0][0], u[2][0]
    k, b, m, _ = p
    return (wd1, wd2,
            (-k * w1 - b * wd1 - fx * math.cos(q1)) / m,   # eq 7
            (-k * w2 - b * wd2 + fx * math.sin(q1)) / m)   # eq 8


Wrist.kernels = Kernels(output=wrist_output, derivatives=wrist_derivatives)
