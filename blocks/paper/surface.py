"""The reaction surface (eq 9), unilateral: it can push, never pull."""
from typing import NamedTuple

from hybridsim.engine.block import Block
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.engine.registry import register

from hybridsim.blocks._util import flag, scalar


GROUP = "paper"  # where `hybridsim blocks` lists this module's blocks

@register("surface")
class Surface(Block):
    """Spring surface normal to C-X at X_s (a parameter or the input ``xs``).

    Eq 9 made unilateral, with optional contact damping br (0 as printed):
        p  = X_hand - X_s                      (penetration, m)
        fx = max(0, Kr p + br p')  if p > 0, else 0

    Set ``unilateral: false`` for the printed bilateral spring fx = Kr p + br p'.
    Outputs ``fx`` (N, pushing the hand towards -X) and ``contact`` (1 in
    contact, else 0). With ``moving: true`` the surface position and velocity
    come from inputs ``xs`` and ``vs`` (Fig 8's receding table).
    """

    def __init__(self, name="surface", Kr=9.0e5, br=0.0, position=0.5,
                 moving=False, unilateral=True):
        super().__init__(name)
        self.params = SurfaceParams(Kr=scalar(Kr, "Kr", "positive"), br=scalar(br, "br", "nonnegative"),
                                    xs=scalar(position, "position"),
                                    unilateral=flag(unilateral, "unilateral"))
        self.moving = flag(moving, "moving")
        self.declare_input("x", 2)
        self.declare_input("v", 2)
        if self.moving:
            self.declare_input("xs", 1)
            self.declare_input("vs", 1)
            self.kernels = Kernels(output=moving_surface_output, zero_crossings=moving_surface_contact)
        self.declare_output("fx", 1)
        self.declare_output("contact", 1)


class SurfaceParams(NamedTuple):
    Kr: float         # surface stiffness, N/m
    br: float         # contact damping, N s/m
    xs: float         # surface position along C-X when fixed, m
    unilateral: bool


@kernel
def contact_force(p, pen, pen_d):
    """Eq 9 for penetration ``pen`` (m) and its rate: (fx N, contact 0/1)."""
    Kr, br, _, unilateral = p
    if unilateral:
        if pen <= 0.0:
            return (0.0,), (0.0,)
        return (max(0.0, Kr * pen + br * pen_d),), (1.0,)
    return (Kr * pen + br * pen_d,), (1.0 if pen > 0.0 else 0.0,)


@kernel
def surface_output(p, t, x, u):
    return contact_force(p, u[0][0] - p[2], u[1][0])


@kernel
def moving_surface_output(p, t, x, u):
    """Eq 9 against a surface at the input position ``xs`` moving at ``vs``."""
    return contact_force(p, u[0][0] - u[2][0], u[1][0] - u[3][0])


@kernel
def surface_contact(p, t, x, u):
    """Contact make / break: the penetration X_hand - X_s (m)."""
    return (u[0][0] - p[2],)


@kernel
def moving_surface_contact(p, t, x, u):
    """Contact make / break for a moving surface: X_hand - xs (m)."""
    return (u[0][0] - u[2][0],)


Surface.kernels = Kernels(output=surface_output, zero_crossings=surface_contact)
