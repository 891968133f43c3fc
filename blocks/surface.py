"""The reaction surface (eq 9), unilateral: it can push, never pull."""
import numpy as np

from hybridsim.block import Block
from hybridsim.registry import register


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

    tuple_kernels = True

    def __init__(self, name="surface", Kr=9.0e5, br=0.0, position=0.5,
                 moving=False, unilateral=True):
        super().__init__(name)
        self.Kr, self.br, self.xs = float(Kr), float(br), float(position)
        self.unilateral = bool(unilateral)
        self.moving = bool(moving)
        self.declare_input("x", 2)
        self.declare_input("v", 2)
        if self.moving:
            self.declare_input("xs", 1)
            self.declare_input("vs", 1)
        self.declare_output("fx", 1)
        self.declare_output("contact", 1)

    def _penetration(self, u):
        if self.moving:
            return u[0][0] - u[2][0], u[1][0] - u[3][0]
        return u[0][0] - self.xs, u[1][0]

    def output(self, t, x, u):
        p, pd = self._penetration(u)
        if self.unilateral:
            if p <= 0.0:
                return (0.0,), (0.0,)
            return (max(0.0, self.Kr * p + self.br * pd),), (1.0,)
        return (self.Kr * p + self.br * pd,), (float(p > 0.0),)

    def zero_crossings(self, t, x, u):
        return np.array([self._penetration(u)[0]])  # contact make / break
