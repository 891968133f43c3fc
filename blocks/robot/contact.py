"""A plane to push on: a unilateral spring-damper with friction.

Conventions: positions in metres, rotations as rotation vectors (axis times
angle, rad), wrenches as (force N, moment N m). ``F`` is what the robot applies
to its environment (what a wrist sensor reads, as in the paper); a plane's
``wrench`` output is what the environment applies to the tool, the arm's input.
"""
import math
from typing import NamedTuple

import numpy as np

from hybridsim.engine.block import Block
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.errors import ParameterError
from hybridsim.engine.registry import register

from hybridsim.blocks._util import flag, scalar, vector


GROUP = "robot"


@register("plane_contact")
class PlaneContact(Block):
    """A plane the tool presses on: unilateral spring-damper along its normal, Coulomb friction along it.

    Penetration d = (point - p) . n (positive inside; n points out of the
    plane, toward the free side). Normal force f_n = max(0, K d + B d') when
    d > 0 (``unilateral``; else K d + B d' at any d), friction
    ``f_t = -mu f_n v_t / sqrt(|v_t|^2 + slip_velocity^2)`` (Coulomb, smoothed
    below ``slip_velocity``). Where the plane starts and stops pushing is
    an event function, located as switches are (every variable-step solver;
    rk4 and heun with ``locate_switches``): min(d, K d + B d'), positive
    exactly while it pushes, so lift-off is where K d + B d' reaches 0 (with
    damping, before d does), not where d does. The surface of the paper's
    Figs 7-10, in three dimensions.

    Parameters
    ----------
    point : [m]          a point of the plane
    normal : [1]         its outward normal (normalised here)
    stiffness : N/m      K
    damping : N s/m      B
    mu : 1               friction coefficient
    slip_velocity : m/s  speed below which friction is smoothed
    unilateral : bool    the plane only pushes
    """

    def __init__(self, name="plane", point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), stiffness=1.0e5,
                 damping=0.0, mu=0.0, slip_velocity=1e-3, unilateral=True):
        super().__init__(name)
        self.point = vector(point, "point", 3)
        n = vector(normal, "normal", 3)
        if np.linalg.norm(n) == 0:
            raise ParameterError("normal", "must not be the zero vector")
        self.n = n / np.linalg.norm(n)
        self.K = scalar(stiffness, "stiffness", "nonnegative")
        self.B = scalar(damping, "damping", "nonnegative")
        self.mu = scalar(mu, "mu", "nonnegative")
        self.v_s = scalar(slip_velocity, "slip_velocity", "positive")
        self.unilateral = flag(unilateral, "unilateral")
        self.declare_input("p", 3)
        self.declare_input("twist", 6)
        self.declare_output("wrench", 6)
        self.declare_output("F", 6)
        self.declare_output("contact", 1, depends_on=("p",))
        self.declare_output("depth", 1, depends_on=("p",))
        self.event_directions = [0]
        self.params = PlaneParams(tuple(self.point.tolist()), tuple(self.n.tolist()), self.K, self.B, self.mu,
                                     self.v_s, self.unilateral)

    def output(self, t, x, u):  # the kernel's law, as arrays
        return tuple(np.array(v) for v in plane_output(self.params, t, x, u))

    def zero_crossings(self, t, x, u):
        return np.array(plane_zero_crossings(self.params, t, x, u))


# -- the plane's kernels (every path): its law in floats
class PlaneParams(NamedTuple):
    point: tuple
    n: tuple
    K: float
    B: float
    mu: float
    v_s: float
    unilateral: bool


@kernel
def plane_depth(p, pt):
    """Penetration (m) of the point ``pt`` into the plane: positive inside."""
    n, c = p.n, p.point
    return n[0] * (c[0] - pt[0]) + n[1] * (c[1] - pt[1]) + n[2] * (c[2] - pt[2])


@kernel
def plane_output(p, t, x, u):
    """wrench on the tool, F on the plane, contact, depth (the method's law in floats)."""
    n, pt, tw = p.n, u[0], u[1]
    d = plane_depth(p, pt)
    vn = tw[0] * n[0] + tw[1] * n[1] + tw[2] * n[2]
    fn = p.K * d - p.B * vn
    inside = d > 0.0 or not p.unilateral
    fn = (max(fn, 0.0) if p.unilateral else fn) if inside else 0.0
    vt = (tw[0] - vn * n[0], tw[1] - vn * n[1], tw[2] - vn * n[2])
    k = -p.mu * abs(fn) / math.sqrt(vt[0] ** 2 + vt[1] ** 2 + vt[2] ** 2 + p.v_s ** 2)
    w = (fn * n[0] + k * vt[0], fn * n[1] + k * vt[1], fn * n[2] + k * vt[2])
    return ((w[0], w[1], w[2], 0.0, 0.0, 0.0), (-w[0], -w[1], -w[2], 0.0, 0.0, 0.0),
            (1.0 if fn > 0.0 else 0.0,), (d,))


@kernel
def plane_zero_crossings(p, t, x, u):
    """Touch and lift-off: positive exactly while a unilateral plane pushes, min(d, K d + B d')
    (m and N: only the sign is read); the depth d for a plane that pushes and pulls."""
    n, tw = p.n, u[1]
    d = plane_depth(p, u[0])
    if not p.unilateral:
        return (d,)
    return (min(d, p.K * d - p.B * (tw[0] * n[0] + tw[1] * n[1] + tw[2] * n[2])),)


PLANE = Kernels(output=plane_output, zero_crossings=plane_zero_crossings)


PlaneContact.kernels = PLANE
