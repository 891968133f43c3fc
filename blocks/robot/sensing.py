"""Wrenches between frames and the wrist force/torque sensor.

Conventions: positions in metres, rotations as rotation vectors (axis times
angle, rad), wrenches as (force N, moment N m). ``F`` is what the robot applies
to its environment (what a wrist sensor reads, as in the paper); a plane's
``wrench`` output is what the environment applies to the tool, the arm's input.
"""

from typing import NamedTuple

import numpy as np

from hybridsim.engine.block import Block
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.engine.registry import register

from hybridsim.blocks.robot import task_kernels as tk
from hybridsim.blocks.robot._frames import rotation as rotation_matrix
from hybridsim.blocks._util import flag, scalar, vector


GROUP = "robot"


@register("wrench_transform")
class WrenchTransform(Block):
    """The force transform with its lever-arm terms: a wrench moved to another frame and point.

    f_out = R f_in, m_out = R m_in + r x (R f_in): ``R`` (9, row by row) turns
    the input's axes into the output's, ``r`` (3, output axes) runs from the
    new reference point to the old one. With R = I, r = 0 it passes the wrench.
    Unwired, ``R`` is the parameter ``rotation`` (a rotation vector) and ``r``
    the parameter ``lever``.

    Parameters
    ----------
    rotation : [rad]    rotation vector of the input axes in the output axes (when R is unwired)
    lever : [m]         r, from the new reference point to the old (when r is unwired)
    """

    def __init__(self, name="wrench_transform", rotation=(0.0, 0.0, 0.0), lever=(0.0, 0.0, 0.0)):
        super().__init__(name)
        R = rotation_matrix(vector(rotation, "rotation", 3))
        self.declare_input("wrench", 6)
        self.declare_input("R", 9, default=R.ravel(), optional=True)
        self.declare_input("r", 3, default=vector(lever, "lever", 3), optional=True)
        self.declare_output("wrench", 6)

    def output(self, t, x, u):
        w, R, r = (np.asarray(v, float) for v in u)
        f = R.reshape(3, 3) @ w[:3]
        return (np.concatenate([f, R.reshape(3, 3) @ w[3:] + np.cross(r, f)]),)


@register("ft_sensor")
class ForceTorqueSensor(Block):
    """A wrist force/torque sensor: a tool of mass ``mass`` on a stiff spring-damper under the flange.

    The tool is a point mass at the flange's origin (when unloaded) that
    translates against the sensor's spring K and damper B (per axis of the
    sensor frame, which turns with the flange: ``R`` input) and follows the
    flange's rotation rigidly. Its state is its position and velocity in the
    base frame:

        m p_t'' = -K_w (p_t - p_f) - B_w (v_t - v_f) + m g + f_env,

    with K_w = R K R^T (B_w alike). Outputs: ``wrench`` (the spring-damper's
    pull on the flange, base axes, for the arm's ``wrench`` input), ``p`` and
    ``twist`` of the tool (for the environment), and ``F``, what the robot
    applies to its environment through the tool as the sensor gives it (base
    axes, the paper's convention): the flange's push on the tool (spring and
    damper), plus the tool's weight m g when ``gravity_compensation``, minus the
    reading at the last ``tare`` (a rising edge through 0.5 stores the reading
    then). Held still in free air it reads -m g (the flange carrying the
    tool's weight) without compensation, and zero with it or after taring; in
    steady contact, compensated, it reads the force on the environment
    exactly. The moments are zero (the tool's centre is the sensor's origin).
    With ``tare: false`` the block has no ``tare`` input and no event to locate
    (the stored reading stays zero).

    Parameters
    ----------
    mass : kg                 tool mass m
    stiffness : [N/m]         K per sensor axis (3)
    damping : [N s/m]         B per sensor axis (3)
    gravity : [m/s^2]         gravity vector in the base frame
    gravity_compensation : bool    subtract the tool's weight from the reading
    p0 : [m]                  the tool's start position (base frame); default hanging in balance
                              under the flange at t = 0
    tare : bool               a ``tare`` input (default true)
    """

    def __init__(self, name="ft", mass=0.5, stiffness=(1e5, 1e5, 1e5), damping=(100.0, 100.0, 100.0),
                 gravity=(0.0, 0.0, -9.81), gravity_compensation=False, p0=None, tare=True):
        super().__init__(name)
        self.m = scalar(mass, "mass", "positive")
        self.K = vector(stiffness, "stiffness", 3, "positive")
        self.B = vector(damping, "damping", 3, "nonnegative")
        self.g = vector(gravity, "gravity", 3)
        self.compensate = flag(gravity_compensation, "gravity_compensation")
        self.p0 = None if p0 is None else vector(p0, "p0", 3)
        self.declare_input("p", 3)          # the flange
        self.declare_input("R", 9)
        self.declare_input("twist", 6)
        self.declare_input("f_env", 6, default=np.zeros(6), optional=True)
        self.tare = flag(tare, "tare")
        if self.tare:
            self.declare_input("tare", 1, default=np.zeros(1), optional=True)
            self.event_directions = [1]
        self.kernels = SENSOR if self.tare else SENSOR_UNTARED
        self.declare_output("wrench", 6, depends_on=("p", "R", "twist"))
        self.declare_output("p", 3, depends_on=())
        self.declare_output("twist", 6, depends_on=("twist",))
        self.declare_output("F", 6, depends_on=("p", "R", "twist"))
        # the tool's position and velocity, and the reading stored at the last tare (constant between tares)
        self.declare_continuous_state(9, atol=[1e-12] * 3 + [1e-10] * 3 + [1e-9] * 3, held=[False] * 6 + [True] * 3)
        self.init_needs_inputs = True
        self.params = SensorParams(self.m, tuple(self.K.tolist()), tuple(self.B.tolist()),
                                      tuple(self.g.tolist()), self.compensate)

    def initial_state(self, u=None):
        if self.p0 is not None:
            p = self.p0
        else:  # hanging in balance under the flange: sagged by R K^-1 R^T m g
            R = np.asarray(u[1], float).reshape(3, 3)
            p = np.asarray(u[0], float) + R @ ((R.T @ (self.m * self.g)) / self.K)
        return np.concatenate([p, np.zeros(6)])

    def _spring(self, x, u):
        """The force (N, base axes) the spring-damper puts on the tool."""
        R = np.asarray(u[1], float).reshape(3, 3)
        x = np.asarray(x, float)
        d = x[:6] - np.concatenate([np.asarray(u[0], float), np.asarray(u[2], float)[:3]])
        return -(R @ (self.K * (R.T @ d[:3]) + self.B * (R.T @ d[3:])))

    def _reading(self, x, u, f=None):
        """The reading before taring (base axes, N): the flange's push on the tool, plus m g when compensated."""
        f = self._spring(x, u) if f is None else f
        return f + (self.m * self.g if self.compensate else 0.0)

    def output(self, t, x, u):
        f = self._spring(x, u)
        omega = np.asarray(u[2], float)[3:]
        return (np.concatenate([-f, np.zeros(3)]), np.asarray(x[:3], float).copy(),
                np.concatenate([np.asarray(x[3:6], float), omega]),
                np.concatenate([self._reading(x, u, f) - np.asarray(x[6:9], float), np.zeros(3)]))

    def derivatives(self, t, x, u):
        acc = (self._spring(x, u) + self.m * self.g + np.asarray(u[3], float)[:3]) / self.m
        return np.concatenate([np.asarray(x[3:6], float), acc, np.zeros(3)])

    @property
    def has_zero_crossings(self):
        """True with a tare input (its rising edge is the sensor's one event)."""
        return self.tare

    @property
    def has_event_action(self):
        """True with a tare input."""
        return self.tare

    def zero_crossings(self, t, x, u):
        return np.array([float(u[4][0]) - 0.5]) if self.tare else None

    def event_action(self, t, x, u, fired):
        x = np.array(x, float)
        x[6:9] = self._reading(x, u)  # a tare: the reading now becomes zero
        return x


# -- the sensor's kernels (the fused and compiled paths): the law of the methods above, in floats
class SensorParams(NamedTuple):
    m: float
    K: tuple
    B: tuple
    g: tuple
    compensate: bool


@kernel
def spring_force(p, x, u):
    """The spring-damper's force on the tool (base axes): -R (K R^T d + B R^T d')."""
    fp, R, tw = u[0], u[1], u[2]
    K, B = p.K, p.B
    d0, d1, d2 = x[0] - fp[0], x[1] - fp[1], x[2] - fp[2]
    e0, e1, e2 = x[3] - tw[0], x[4] - tw[1], x[5] - tw[2]
    a0 = K[0] * (R[0] * d0 + R[3] * d1 + R[6] * d2) + B[0] * (R[0] * e0 + R[3] * e1 + R[6] * e2)
    a1 = K[1] * (R[1] * d0 + R[4] * d1 + R[7] * d2) + B[1] * (R[1] * e0 + R[4] * e1 + R[7] * e2)
    a2 = K[2] * (R[2] * d0 + R[5] * d1 + R[8] * d2) + B[2] * (R[2] * e0 + R[5] * e1 + R[8] * e2)
    return (-(R[0] * a0 + R[1] * a1 + R[2] * a2), -(R[3] * a0 + R[4] * a1 + R[5] * a2),
            -(R[6] * a0 + R[7] * a1 + R[8] * a2))


@kernel
def sensor_output(p, t, x, u):
    """wrench on the flange, the tool's p and twist, the reading F (tare subtracted)."""
    f = spring_force(p, x, u)
    tw, g = u[2], p.g
    c = p.m if p.compensate else 0.0
    return ((-f[0], -f[1], -f[2], 0.0, 0.0, 0.0), (x[0], x[1], x[2]), (x[3], x[4], x[5], tw[3], tw[4], tw[5]),
            (f[0] + c * g[0] - x[6], f[1] + c * g[1] - x[7], f[2] + c * g[2] - x[8], 0.0, 0.0, 0.0))


@kernel
def sensor_derivatives(p, t, x, u):
    """The tool's p' and p'' (m p'' = spring + m g + f_env); the tare is constant."""
    f, fe = spring_force(p, x, u), u[3]
    return (x[3], x[4], x[5], (f[0] + p.m * p.g[0] + fe[0]) / p.m, (f[1] + p.m * p.g[1] + fe[1]) / p.m,
            (f[2] + p.m * p.g[2] + fe[2]) / p.m, 0.0, 0.0, 0.0)


@kernel
def sensor_zero_crossings(p, t, x, u):
    """The tare input's crossing of 0.5 (a rising edge tares)."""
    return (u[4][0] - 0.5,)


@kernel
def sensor_event_action(p, t, x, u, fired):
    """A tare: the reading now (before taring) is stored, so the reading becomes zero."""
    f = spring_force(p, x, u)
    c = p.m if p.compensate else 0.0
    return (x[0], x[1], x[2], x[3], x[4], x[5], f[0] + c * p.g[0], f[1] + c * p.g[1], f[2] + c * p.g[2])


#: the sensor's kernels with a tare input (its event) and without
SENSOR = Kernels(output=sensor_output, derivatives=sensor_derivatives, zero_crossings=sensor_zero_crossings,
                 event_action=sensor_event_action)
SENSOR_UNTARED = Kernels(output=sensor_output, derivatives=sensor_derivatives)


# the kernels of the fused and compiled paths (the wrench's in blocks.robot.task_kernels); the methods are the generic path's
ForceTorqueSensor.kernels = SENSOR  # with a tare input (one without takes SENSOR_UNTARED, set in __init__)
WrenchTransform.kernels = tk.WRENCH
