"""Any serial arm from a robot model file (URDF), its dynamics and kinematics by Pinocchio.

The rigid-body dynamics are Pinocchio's (``pip install "hybridsim[robots]"``):
forward dynamics by the articulated-body algorithm, frame Jacobians and
gravity. The blocks here add what the paper's plant adds to a rigid body:
joint friction (the Karnopp law of eq 11, per joint) and viscous damping, and
they expose a tool frame's pose, twist and 6xN Jacobian for the task-space
blocks of :mod:`hybridsim.blocks.robot`. A diagram names a robot by a URDF path, or by
the name of one shipped with ``example-robot-data`` (``ur5``, ``panda``, ...).
"""
import numpy as np

from hybridsim.engine.block import Block
from hybridsim.errors import ParameterError
from hybridsim.engine.registry import register

from hybridsim.blocks.robot import kernels as rk, rigid
from hybridsim.blocks.robot.urdf import (OWN_ROBOTS, ROBOTS, _pinocchio, load_model, model_number,  # noqa: F401
                                         robots_folder, urdf_path)
from hybridsim.blocks._util import choice, flag, scalar, vector

GROUP = "robot"  # where `hybridsim blocks` lists this module's blocks

def _frame_id(model, frame):
    """The id of the tool frame: ``frame`` or, when None, the model's last frame."""
    if frame is None:
        return len(model.frames) - 1
    if not model.existFrame(str(frame)):
        import difflib

        names = [f.name for f in model.frames]
        near = difflib.get_close_matches(str(frame), names, n=1)
        raise ParameterError("frame", f"no frame {frame!r} in the robot model"
                                      + (f" (did you mean {near[0]!r}?)" if near else f"; frames: {', '.join(names)}"))
    return model.getFrameId(str(frame))


class _RobotBlock(Block):
    """Shared set-up: the model, its data, the tool frame, the arrays of the compiled path."""

    def _robot(self, urdf, robot, frame, gravity=None):
        self.path = urdf_path(urdf, robot)
        number = model_number(self.path, gravity)
        self.model = rk.pinocchio_model_of(number)  # shared: never modified
        self.data = self.model.createData()
        self.frame_id = _frame_id(self.model, frame)
        self.n = self.model.nv
        self.tree = rigid.tree(self.model, self.frame_id, number)
        self.tool = (model_number(self.path), self.frame_id)  # the tool frame, whatever the gravity
        return self.n

    def _q(self, value, name, default):
        n = self.n
        q = vector(default if value is None else value, name, n)
        return q


@register("robot_arm")
class RobotArm(_RobotBlock):
    """Joint-space dynamics of a URDF arm: M(q) q'' + C(q, q') q' + g(q) = tau + J^T w - b q' + B.

    Forward dynamics by Pinocchio's articulated-body algorithm, with gravity
    (``gravity``, m/s^2, default Pinocchio's (0, 0, -9.81)). ``w`` is the
    wrench (force N, moment N m; world axes, about the tool frame's origin)
    that the environment applies to the tool frame (input ``wrench``).
    Friction B is the Karnopp law of the paper's eq 11 applied per joint:

    * sliding, ``|q_i'| >= stick_band``: B_i = -sgn(q_i') tau_c,i (``friction_model:
      stribeck``: -sgn(q_i') g(q_i'), g(v) = tau_c + (tau_s - tau_c) exp(-(v / stribeck_velocity)^2),
      as the 2-DOF arm's);
    * sticking: B_i = clip(-F_i - M_ii q_i' / stick_time, +-tau_s,i), with F_i
      the net non-friction generalized force on joint i (tau + J^T w - b q'
      - C q' - g) and M_ii its diagonal inertia; joints are judged one by one
      (the coupling through M's off-diagonal terms is neglected in the stuck
      law only, not in the dynamics).

    Crossing a band edge is a located event. The state is (q, q').

    Parameters
    ----------
    urdf : path           robot model file (only revolute and prismatic joints), or
    robot : str           a shipped robot: fig3_arm (the paper's), ur3, ur5, ur10, panda, kinova, iiwa
    frame : str           the tool frame the wrench acts on (default the model's last frame)
    q0, qd0 : [rad or m]  initial joint positions and speeds (default: the model's neutral pose, rest)
    damping : [N m s/rad or N s/m]   viscous joint damping b (scalar or one per joint)
    friction : bool       joint friction on (default false)
    tau_c, tau_s : [N m or N]   Coulomb and static friction levels per joint
    stick_band : rad/s or m/s   Karnopp capture band
    stick_time : s        time constant bringing a stuck joint to rest
    gravity : [m/s^2]     gravity vector in the robot's base frame
    friction_model : str  karnopp (default), stribeck or lugre (a bristle state per joint: n more
                          states; in steady sliding it equals the Stribeck curve, as the 2-DOF arm's)
    stribeck_velocity : rad/s or m/s   speed scale of the Stribeck decay (scalar or per joint)
    bristle_stiffness : N m/rad or N/m  LuGre sigma0 (default 1e5)
    bristle_damping : N m s/rad or N s/m  LuGre sigma1 (default critical: 2 sqrt(sigma0 M_ii(q0)))
    start_position : [m]  start with the tool frame's origin here (base frame): the joints are
                          solved from q0 by damped Newton steps to 1e-12 m (the nearest solution
                          for a redundant arm); a point out of reach is a ParameterError
    """

    def __init__(self, name="arm", urdf=None, robot=None, frame=None, q0=None, qd0=None, damping=0.0,
                 friction=False, tau_c=0.0, tau_s=0.0, stick_band=1e-4, stick_time=1e-3,
                 gravity=(0.0, 0.0, -9.81), start_position=None, friction_model="karnopp",
                 stribeck_velocity=1e-3, bristle_stiffness=1e5, bristle_damping=None):
        super().__init__(name)
        n = self._robot(urdf, robot, frame, vector(gravity, "gravity", 3))
        pin = _pinocchio()
        self.q0 = self._q(q0, "q0", pin.neutral(self.model))
        if start_position is not None:
            self.q0 = inverse_position(self.model, self.data, self.frame_id, self.q0,
                                       vector(start_position, "start_position", 3))
        self.qd0 = self._q(qd0, "qd0", 0.0)
        self.b = vector(damping, "damping", n, "nonnegative")
        self.friction = flag(friction, "friction")
        self.tau_c = vector(tau_c, "tau_c", n, "nonnegative")
        self.tau_s = vector(tau_s, "tau_s", n, "nonnegative")
        if self.friction and (self.tau_c > self.tau_s).any():
            raise ParameterError("tau_s", "must be at least tau_c (static >= Coulomb) at every joint")
        friction_model = choice(friction_model, "friction_model", ("karnopp", "stribeck", "lugre"))
        self.stribeck = friction_model == "stribeck"
        self.lugre = friction_model == "lugre" and self.friction
        self.v_s = vector(stribeck_velocity, "stribeck_velocity", n, "positive")
        self.sigma0 = vector(bristle_stiffness, "bristle_stiffness", n, "positive")
        if bristle_damping is not None:
            self.sigma1 = vector(bristle_damping, "bristle_damping", n, "nonnegative")
        elif self.lugre:  # critical for each joint's own inertia at the start
            self.sigma1 = 2.0 * np.sqrt(self.sigma0 * np.diag(pin.crba(self.model, self.data, self.q0)))
        self.band = scalar(stick_band, "stick_band", "nonnegative")
        self.t_stick = scalar(stick_time, "stick_time", "positive")
        _check_inertia(self.model, self.data, self.q0, self.path)
        self.declare_input("tau", n)
        self.declare_input("wrench", 6, default=np.zeros(6), optional=True)
        self.declare_output("q", n, depends_on=())
        self.declare_output("qd", n, depends_on=())
        if self.lugre:  # a bristle deflection per joint, at rest at the start
            self.declare_continuous_state(3 * n, atol=[1e-10] * n + [1e-8] * n + [1e-13] * n)
        else:
            self.declare_continuous_state(2 * n, atol=[1e-10] * n + [1e-8] * n)
            if self.friction:
                self.event_directions = [0] * n
        self.kernels = rk.ARM_LUGRE if self.lugre else rk.ARM_FRICTION if self.friction else rk.ARM
        self.params = rk.ArmParams(self.tree, self.tool, n, self.b,
                                   self.friction, self.stribeck, self.lugre, self.tau_c, self.tau_s, self.v_s,
                                   self.sigma0, getattr(self, "sigma1", np.zeros(n)), self.band, self.t_stick)

    def initial_state(self, u=None):
        return np.concatenate([self.q0, self.qd0] + ([np.zeros(self.n)] if self.lugre else []))

    def output(self, t, x, u):
        n = self.n
        return (np.asarray(x[:n], float), np.asarray(x[n:2 * n], float))

    def applied(self, x, u):
        """The generalized force on the joints besides friction: tau + J^T w - b q' (N m or N)."""
        pin = _pinocchio()
        n = self.n
        q = np.asarray(x[:n], float)
        f = np.asarray(u[0], float) - self.b * np.asarray(x[n:2 * n], float)
        w = np.asarray(u[1], float)
        if w.any():
            f = f + rk.frame_jacobian(pin, self.model, self.data, q, self.frame_id).T @ w
        return f

    def sliding_level(self, v):
        """g(v): the sliding friction level per joint, Coulomb's, or Stribeck's falling from static."""
        if not (self.stribeck or self.lugre):
            return self.tau_c
        return self.tau_c + (self.tau_s - self.tau_c) * np.exp(-(v / self.v_s) ** 2)

    def joint_friction(self, x, applied):
        """B of eq 11 per joint (N m or N) at state ``x`` under the non-friction force ``applied``."""
        pin = _pinocchio()
        n = self.n
        q, v = np.asarray(x[:n], float), np.asarray(x[n:2 * n], float)
        bias = pin.rnea(self.model, self.data, q, v, np.zeros(n))  # C(q, q') q' + g(q)
        m = np.diag(pin.crba(self.model, self.data, q))
        stuck = np.clip(-(applied - bias) - m * v / self.t_stick, -self.tau_s, self.tau_s)
        return np.where(np.abs(v) >= self.band, -np.sign(v) * self.sliding_level(v), stuck)

    def bristles(self, x):
        """(B, z') of LuGre per joint: ``z' = v - sigma0 |v| z / g(v)``, ``B = -(sigma0 z + sigma1 z')``."""
        n = self.n
        v, z = np.asarray(x[n:2 * n], float), np.asarray(x[2 * n:], float)
        g = self.sliding_level(v)
        zd = v - np.divide(self.sigma0 * np.abs(v) * z, g, out=np.zeros(n), where=g > 0)
        return -(self.sigma0 * z + self.sigma1 * zd), zd

    def derivatives(self, t, x, u):
        pin = _pinocchio()
        n = self.n
        q, v = np.asarray(x[:n], float), np.asarray(x[n:2 * n], float)
        f = self.applied(x, u)
        if self.lugre:
            B, zd = self.bristles(x)
            return np.concatenate([v, pin.aba(self.model, self.data, q, v, f + B), zd])
        if self.friction:
            f = f + self.joint_friction(x, f)
        return np.concatenate([v, pin.aba(self.model, self.data, q, v, f)])


def inverse_position(model, data, frame_id, q, target, tol=1e-12, iterations=200, damping=1e-6):
    """Joint positions near ``q`` that put frame ``frame_id``'s origin at ``target`` (m), by damped Newton steps."""
    pin = _pinocchio()
    q = np.array(q, float)
    for _ in range(iterations):
        pin.framesForwardKinematics(model, data, q)
        err = target - data.oMf[frame_id].translation
        if np.linalg.norm(err) < tol:
            return q
        J = rk.frame_jacobian(pin, model, data, q, frame_id)[:3]
        q = q + J.T @ np.linalg.solve(J @ J.T + damping ** 2 * np.eye(3), err)
    raise ParameterError("start_position", f"{target.tolist()} is out of the robot's reach from q0 "
                                           f"(still {np.linalg.norm(err):.3g} m away after {iterations} steps)")


@register("robot_kinematics")
class RobotKinematics(_RobotBlock):
    """Pose, twist and geometric Jacobian of a robot's tool frame from its joints.

    Outputs, all in the robot's base (world) axes: ``p`` the frame's origin
    (m), ``R`` its rotation matrix (9, row by row), ``twist`` its linear (m/s)
    and angular (rad/s) velocity (6), and ``J`` the 6xN Jacobian (row by row)
    with twist = J q'. The paper's eq 3a (X = Lambda(q)) and eq 12b
    (X' = J q') for any serial arm.

    Parameters
    ----------
    urdf : path         robot model file, or
    robot : str         a shipped robot (ur5, panda, ...)
    frame : str         the frame (default the model's last frame)
    """

    def __init__(self, name="kinematics", urdf=None, robot=None, frame=None):
        super().__init__(name)
        n = self._robot(urdf, robot, frame)
        self.declare_input("q", n)
        self.declare_input("qd", n)
        self.declare_output("p", 3, depends_on=("q",))
        self.declare_output("R", 9, depends_on=("q",))
        self.declare_output("twist", 6)
        self.declare_output("J", 6 * n, depends_on=("q",))
        self.params = rk.KinematicsParams(self.tree, self.tool)

    def output(self, t, x, u):
        pin = _pinocchio()
        q = np.asarray(u[0], float)
        J = rk.frame_jacobian(pin, self.model, self.data, q, self.frame_id)
        pose = pin.updateFramePlacement(self.model, self.data, self.frame_id)  # the joints' placements are fresh
        return (pose.translation.copy(), pose.rotation.ravel().copy(), J @ np.asarray(u[1], float), J.ravel())


@register("gravity_torque")
class GravityTorque(_RobotBlock):
    """g(q): the joint torques (N m or N) that hold a robot still against gravity, a feed-forward.

    Parameters
    ----------
    urdf : path         robot model file, or
    robot : str         a shipped robot
    gravity : [m/s^2]   gravity vector in the base frame (as the arm's)
    """

    def __init__(self, name="gravity", urdf=None, robot=None, gravity=(0.0, 0.0, -9.81)):
        super().__init__(name)
        n = self._robot(urdf, robot, None, vector(gravity, "gravity", 3))
        self.declare_input("q", n)
        self.declare_output("tau", n)
        self.params = rk.GravityParams(self.tree)

    def output(self, t, x, u):
        pin = _pinocchio()
        return (pin.computeGeneralizedGravity(self.model, self.data, np.asarray(u[0], float)).copy(),)


# the kernels of the fused and compiled paths (blocks.robot.kernels); the methods above are the generic path's
RobotArm.kernels = rk.ARM  # without joint friction (an arm with it takes its own, set in __init__)
RobotKinematics.kernels = rk.KINEMATICS
GravityTorque.kernels = rk.GRAVITY


def _check_inertia(model, data, q, path):
    """A ParameterError when a joint moves no mass at ``q`` (a singular mass matrix: no forward dynamics)."""
    M = _pinocchio().crba(model, data, q)
    light = [model.names[j + 1] for j in range(model.nv) if not M[j, j] > 0.0]
    if light:
        raise ParameterError("urdf", f"{str(path)!r}: joint(s) {', '.join(map(repr, light[:4]))} move no mass "
                                     "(a singular mass matrix, no forward dynamics): robot_arm needs a "
                                     "mass on every joint (robot_kinematics takes any model)")
