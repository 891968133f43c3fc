"""Friction and play: Coulomb and viscous friction, backlash.

Their switching points are zero crossings (a velocity through 0, a gear
taking up its play) that the solvers locate.
"""
from typing import NamedTuple

import numpy as np

from hybridsim.engine.block import Block
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.engine.registry import register

from hybridsim.blocks._util import count, vector

GROUP = "control"  # where `hybridsim blocks` lists this module's blocks


@register("coulomb_viscous")
class CoulombViscous(Block):
    """y = sgn(u) (coulomb + viscous abs(u)) = coulomb sgn(u) + viscous u, sgn(0) = 0.

    Parameters
    ----------
    coulomb : float or list   Coulomb friction level Fc (N or N m)
    viscous : float or list   viscous coefficient b (N s/m or N m s/rad)
    width : int

    Ports: in ``u`` (a velocity, m/s or rad/s), out ``y`` (the friction force
    or torque, opposing u when subtracted). u = 0 is a zero crossing (direction
    either), as in Simulink's Coulomb & Viscous Friction. Example: Fc = 2,
    b = 0.5, u = -3 gives y = -3.5.
    """

    def __init__(self, name="friction", coulomb=1.0, viscous=0.0, width=1):
        super().__init__(name)
        n = count(width, "width")
        self.params = (vector(coulomb, "coulomb", n, "nonnegative"), vector(viscous, "viscous", n))
        self.event_directions = (0,) * n
        self.declare_input("u", n)
        self.declare_output("y", n)


@kernel
def coulomb_viscous_output(p, t, x, u):
    ua = np.asarray(u[0])
    return (p[0] * np.sign(ua) + p[1] * ua,)


@kernel
def input_crossings(p, t, x, u):
    return np.asarray(u[0]) * 1.0


@register("backlash")
class Backlash(Block):
    """Backlash (play) of total ``deadband`` between a driving position u and a driven position y.

    y stays where it is while u moves within the play, and follows u at a
    distance of half the play once u pushes it: y = u - w/2 (engaged pushing
    up), y = u + w/2 (pushing down), y constant in between - the play operator
    y(t) = clip(y(t-), u - w/2, u + w/2).

    Parameters
    ----------
    deadband : float or list   the total play w (units of u)
    initial : float or list    y(0); it must lie within u(0) +- w/2 (default u(0))
    width : int

    Ports: in ``u`` and ``du``, u's time derivative (units of u per s: the
    driving shaft's speed, which a plant gives beside its angle); out ``y``.
    Taking up the play (u - w/2 - y rising through 0, or u + w/2 - y falling)
    and leaving contact (du turning back) are located events, so y is exact on
    every solver. Example: w = 0.2, u = sin t from y(0) = 0: y = sin t - 0.1
    from t = asin(0.1) until the peak at t = pi/2, then held at 0.9.
    """

    init_needs_inputs = True

    def __init__(self, name="backlash", deadband=0.1, initial=None, width=1):
        super().__init__(name)
        n = count(width, "width")
        self.params = BacklashParams(vector(deadband, "deadband", n, "nonnegative") / 2.0, n)
        self.y0 = None if initial is None else vector(initial, "initial", n)
        # take up the play upward, downward; leave contact from above, from below
        self.event_directions = (1,) * n + (-1,) * n + (-1,) * n + (1,) * n
        self.declare_input("u", n)
        self.declare_input("du", n)
        self.declare_output("y", n, depends_on=("u",))
        # y while in the play, and the mode (+1, 0, -1)
        self.declare_continuous_state(2 * n, held=[False] * n + [True] * n)

    def initial_state(self, u=None):
        h, n = self.params
        u0 = np.asarray(u[0], float) if u is not None else np.zeros(n)
        y0 = u0 if self.y0 is None else self.y0
        if np.any(np.abs(y0 - u0) > h + 1e-12):
            from hybridsim.errors import ParameterError

            raise ParameterError("initial", f"y(0) = {y0.tolist()} must lie within u(0) +- deadband / 2")
        return np.concatenate((y0, np.zeros(n)))


class BacklashParams(NamedTuple):
    h: np.ndarray  # half the play, units of u
    n: int         # width


@kernel
def backlash_output(p, t, x, u):
    xa, ua = np.asarray(x), np.asarray(u[0])
    m = xa[p.n:]
    return (np.where(m > 0.5, ua - p.h, np.where(m < -0.5, ua + p.h, xa[:p.n])),)


@kernel
def backlash_derivatives(p, t, x, u):
    return np.zeros(2 * p.n)  # y is set at the events; in contact it is u -+ w/2 itself


@kernel
def backlash_crossings(p, t, x, u):
    xa, ua, du = np.asarray(x), np.asarray(u[0]), np.asarray(u[1])
    y, m = xa[:p.n], xa[p.n:]
    free = np.abs(m) < 0.5
    up = np.where(free, ua - p.h - y, -1.0)       # rises through 0: contact from below
    down = np.where(free, ua + p.h - y, 1.0)      # falls through 0: contact from above
    leave_up = np.where(m > 0.5, du, 1.0)         # falls through 0: the driver turns back
    leave_down = np.where(m < -0.5, du, -1.0)     # rises through 0
    return np.concatenate((up, down, leave_up, leave_down))


@kernel
def backlash_event(p, t, x, u, fired):
    n = p.n
    out = np.asarray(x).copy()
    ua = np.asarray(u[0])
    for i in range(n):
        if fired[i]:
            out[i], out[n + i] = ua[i] - p.h[i], 1.0
        elif fired[n + i]:
            out[i], out[n + i] = ua[i] + p.h[i], -1.0
        elif fired[2 * n + i]:
            out[i], out[n + i] = ua[i] - p.h[i], 0.0
        elif fired[3 * n + i]:
            out[i], out[n + i] = ua[i] + p.h[i], 0.0
    return out


CoulombViscous.kernels = Kernels(output=coulomb_viscous_output, zero_crossings=input_crossings)
Backlash.kernels = Kernels(output=backlash_output, derivatives=backlash_derivatives,
                           zero_crossings=backlash_crossings, event_action=backlash_event)
