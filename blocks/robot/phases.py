"""A sequencer of task phases: commands and selection per phase."""

import numpy as np

from hybridsim.engine.block import Block
from hybridsim.errors import ParameterError
from hybridsim.engine.registry import register

from hybridsim.blocks._util import count, scalar, vector

from hybridsim.blocks.robot._frames import rotation
from hybridsim.blocks.robot import task_kernels as tk

GROUP = "robot"


@register("task_phases")
class TaskPhases(Block):
    """A sequencer of task phases: approach in position, press, then trace a circle under force.

    Phases, switched at its ticks:

    0. approach: every axis position-controlled; the command moves from the
       start pose along {C}'s ``normal_axis`` at ``approach_speed`` until the
       measured force along it (input ``F``, the robot on its environment, in
       {C}) exceeds ``contact_force``;
    1. press: that axis force-controlled, its force command ramping from
       contact_force to ``force`` over ``ramp_time``, the others holding the
       pose where contact was found;
    2. trace (after ``ramp_time + settle_time``): one circle of ``radius`` in
       the two other translation axes of {C} in ``circle_period``, starting
       where the tool is and starting and ending at rest (the angle follows
       a half cosine, as eq 17b's position does), under the same force.

    The start pose is the tool's at t = 0 (inputs ``p``, ``R`` in the base
    frame), expressed in {C}. Outputs ``S``, ``X_d``, ``Xd_d``, ``F_d`` (for
    :class:`HybridControl6D`) and ``phase``.

    Parameters
    ----------
    rate : Hz                 tick rate (the controller's)
    frame_origin : [m]        {C}'s origin in the base frame
    frame_rotation : [rad]    {C}'s rotation vector in the base frame
    normal_axis : int         0, 1 or 2: the axis of {C} pointing into the surface
    approach_speed : m/s      speed of the approach
    contact_force : N         force that ends the approach
    force : N                 force to press with
    ramp_time, settle_time : s    force ramp, then wait before tracing
    radius : m                the circle's radius
    circle_period : s         time for the circle
    """

    def __init__(self, name="phases", rate=500, frame_origin=(0.0, 0.0, 0.0), frame_rotation=(0.0, 0.0, 0.0),
                 normal_axis=2, approach_speed=0.05, contact_force=2.0, force=10.0, ramp_time=0.2,
                 settle_time=0.1, radius=0.05, circle_period=2.0):
        super().__init__(name)
        self.declare_rate(rate=rate)
        self.o = vector(frame_origin, "frame_origin", 3)
        self.RC = rotation(vector(frame_rotation, "frame_rotation", 3))
        self.k = count(normal_axis, "normal_axis", minimum=0)
        if self.k > 2:
            raise ParameterError("normal_axis", f"must be 0, 1 or 2, got {normal_axis!r}")
        self.v = scalar(approach_speed, "approach_speed", "positive")
        self.f0 = scalar(contact_force, "contact_force", "positive")
        self.f1 = scalar(force, "force")
        self.t_ramp = scalar(ramp_time, "ramp_time", "nonnegative")
        self.t_settle = scalar(settle_time, "settle_time", "nonnegative")
        self.radius = scalar(radius, "radius", "nonnegative")
        self.T = scalar(circle_period, "circle_period", "positive")
        self.declare_input("p", 3)
        self.declare_input("R", 9)
        self.declare_input("F", 6)
        for port in ("S", "X_d", "Xd_d", "F_d"):
            self.declare_output(port, 6)
        self.declare_output("phase", 1)
        # phase, time it began, the start pose in {C} (6), the pose where contact was found (6)
        self.declare_discrete_state(14, bounded=False, held=True)  # times and the phase, not dynamics
        self.params = tk.PhasesParams(self.o, np.ascontiguousarray(self.RC, dtype=float), self.k, self.v, self.f0,
                                      self.f1, self.t_ramp, self.t_settle, self.radius, self.T)

    def initial_state(self, u=None):
        x = np.zeros(14)
        x[0] = -1.0  # the start pose is read at the first tick
        return x


# every path runs the kernels (blocks.robot.task_kernels): the block's methods are the defaults that call them
TaskPhases.kernels = tk.PHASES
