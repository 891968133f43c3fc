"""Hybrid position/force control in a task frame {C}, in six dimensions, for any arm.

The paper's controller (eqs 12-16) written for an N-joint arm and a compliance
frame {C} with six axes (three translations, three rotations): position errors
go through the inverse of the Jacobian into a joint-space PID, force errors
through its transpose into a joint-space PI with the limiter and the
feed-forward, and the selection matrix S (diagonal in {C}) chooses per axis.
Also here: the force transform with its lever-arm terms, a plane to push on,
and a sequencer of task phases.

Conventions: positions in metres, rotations as rotation vectors (axis times
angle, rad), wrenches as (force N, moment N m). ``F`` is what the robot applies
to its environment (what a wrist sensor reads, as in the paper); a plane's
``wrench`` output is what the environment applies to the tool, the arm's input.
"""
import math

import numpy as np
from scipy.spatial.transform import Rotation

from hybridsim.block import Block
from hybridsim.errors import ParameterError, SimulationError
from hybridsim.registry import register

from . import robot_kernels as rk
from ._util import count, flag, scalar, vector

GROUP = "robot"


def _pinocchio():
    """Pinocchio when installed (its exp3 / log3 take about a microsecond, scipy's Rotation
    a few hundred: the controller converts at every tick), else None."""
    global _PIN
    if _PIN is False:
        try:
            import pinocchio as pin
        except ImportError:  # pragma: no cover - the robots extra brings it
            pin = None
        _PIN = pin
    return _PIN


_PIN = False


def rotation(rotvec):
    """The rotation matrix of a rotation vector (rad): Pinocchio's exp3, else scipy's Rotation."""
    pin = _pinocchio()
    if pin is not None:
        return pin.exp3(np.asarray(rotvec, float))
    return Rotation.from_rotvec(np.asarray(rotvec, float)).as_matrix()


def rotation_vector(R):
    """The rotation vector (rad, angle up to pi) of a rotation matrix: Pinocchio's log3, else
    scipy's Rotation (the two agree to round-off on orthonormal matrices)."""
    R = np.asarray(R, float).reshape(3, 3)
    pin = _pinocchio()
    if pin is not None:
        return pin.log3(R)
    return Rotation.from_matrix(R).as_rotvec()


def inverse(J, v, lam, name, t):
    """J^-1 v for the position loop (eq 14): exact for a square J, else damped least squares
    J^T (J J^T + lam^2 I)^-1 v; a square J with condition number above 1e8 is a SimulationError."""
    if lam > 0.0:
        return J.T @ np.linalg.solve(J @ J.T + lam ** 2 * np.eye(J.shape[0]), v)
    if np.linalg.cond(J) > 1e8:
        raise SimulationError(f"block {name!r}: the task Jacobian is singular at t = {t:.6g} s "
                              "(condition number above 1e8): give dls_damping > 0 or avoid that pose")
    return np.linalg.solve(J, v)


def _rot6(R, v):
    """Both halves of a six-vector rotated by R."""
    return np.concatenate([R @ v[:3], R @ v[3:]])


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
        R = globals()["rotation"](vector(rotation, "rotation", 3))
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

    Parameters
    ----------
    mass : kg                 tool mass m
    stiffness : [N/m]         K per sensor axis (3)
    damping : [N s/m]         B per sensor axis (3)
    gravity : [m/s^2]         gravity vector in the base frame
    gravity_compensation : bool    subtract the tool's weight from the reading
    p0 : [m]                  the tool's start position (base frame); default hanging in balance
                              under the flange at t = 0
    """

    def __init__(self, name="ft", mass=0.5, stiffness=(1e5, 1e5, 1e5), damping=(100.0, 100.0, 100.0),
                 gravity=(0.0, 0.0, -9.81), gravity_compensation=False, p0=None):
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
        self.declare_input("tare", 1, default=np.zeros(1), optional=True)
        self.declare_output("wrench", 6, depends_on=("p", "R", "twist"))
        self.declare_output("p", 3, depends_on=())
        self.declare_output("twist", 6, depends_on=("twist",))
        self.declare_output("F", 6, depends_on=("p", "R", "twist"))
        # the tool's position and velocity, and the reading stored at the last tare (constant between tares)
        self.declare_continuous_state(9, atol=[1e-12] * 3 + [1e-10] * 3 + [1e-9] * 3)
        self.init_needs_inputs = True
        self.event_directions = [1]
        self.params = rk.SensorParams(self.m, tuple(self.K.tolist()), tuple(self.B.tolist()),
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

    def zero_crossings(self, t, x, u):
        return np.array([float(u[4][0]) - 0.5])

    def event_action(self, t, x, u, fired):
        x = np.array(x, float)
        x[6:9] = self._reading(x, u)  # a tare: the reading now becomes zero
        return x


class _JacobianBlock(Block):
    """Shared: N joints, the controlled axes of the six (rows of J kept)."""

    def _setup(self, joints, axes):
        self.n = count(joints, "joints")
        self.axes = vector(axes, "axes", 6) != 0
        if not self.axes.any():
            raise ParameterError("axes", "must keep at least one of the six axes")
        return self.n

    def _rows(self, u):
        return np.asarray(u[0], float).reshape(6, self.n)[self.axes]


@register("task_jacobian_transpose")
class TaskJacobianTranspose(_JacobianBlock):
    """tau = J^T F (eq 14b): a wrench (force N, moment N m) to joint torques, for N joints.

    Parameters
    ----------
    joints : int     N
    axes : [1]       six entries: 1 for the rows of J (and entries of F) used
    """

    def __init__(self, name="jt", joints=6, axes=(1, 1, 1, 1, 1, 1)):
        super().__init__(name)
        n = self._setup(joints, axes)
        self.declare_input("J", 6 * n)
        self.declare_input("F", 6)
        self.declare_output("tau", n)

    def output(self, t, x, u):
        return (self._rows(u).T @ np.asarray(u[1], float)[self.axes],)


@register("task_jacobian_inverse")
class TaskJacobianInverse(_JacobianBlock):
    """q_e = J^-1 X_e (eq 14a) for N joints: exact when as many axes as joints are kept, else damped
    least squares J^T (J J^T + lambda^2 I)^-1 (``dls_damping`` lambda must then be positive). A square
    J with condition number above 1e8 (a singular pose) is a run-time error naming the time.

    Parameters
    ----------
    joints : int          N
    axes : [1]            six entries: 1 for the rows of J (and entries of X) used
    dls_damping : m       lambda
    """

    def __init__(self, name="jinv", joints=6, axes=(1, 1, 1, 1, 1, 1), dls_damping=0.0):
        super().__init__(name)
        n = self._setup(joints, axes)
        self.lam = scalar(dls_damping, "dls_damping", "nonnegative")
        if self.axes.sum() != n and self.lam == 0.0:
            raise ParameterError("dls_damping", f"must be positive: {int(self.axes.sum())} axes kept with "
                                                f"{n} joints (J is not square)")
        self.declare_input("J", 6 * n)
        self.declare_input("X", 6)
        self.declare_output("q", n)

    def output(self, t, x, u):
        return (inverse(self._rows(u), np.asarray(u[1], float)[self.axes], self.lam, self.name, t),)


@register("plane_contact")
class PlaneContact(Block):
    """A plane the tool presses on: unilateral spring-damper along its normal, Coulomb friction along it.

    Penetration d = (point - p) . n (positive inside; n points out of the
    plane, toward the free side). Normal force f_n = max(0, K d + B d') when
    d > 0 (``unilateral``; else K d + B d' at any d), friction
    ``f_t = -mu f_n v_t / sqrt(|v_t|^2 + slip_velocity^2)`` (Coulomb, smoothed
    below ``slip_velocity``). First touch and lift-off (d = 0) are located
    events. The surface of the paper's Figs 7-10, in three dimensions.

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
        self.params = rk.PlaneParams(tuple(self.point.tolist()), tuple(self.n.tolist()), self.K, self.B, self.mu,
                                     self.v_s, self.unilateral)

    def depth(self, p):
        """Penetration (m) of point ``p`` into the plane: positive inside."""
        n, c = self.n, self.point
        return float(n[0] * (c[0] - p[0]) + n[1] * (c[1] - p[1]) + n[2] * (c[2] - p[2]))

    def output(self, t, x, u):
        # plain floats: this runs at every right-hand side, where numpy's per-call cost dominates
        n, tw = self.n, u[1]
        d = self.depth(u[0])
        v = (float(tw[0]), float(tw[1]), float(tw[2]))
        vn = v[0] * n[0] + v[1] * n[1] + v[2] * n[2]
        fn = self.K * d - self.B * vn
        inside = d > 0.0 or not self.unilateral
        fn = (max(fn, 0.0) if self.unilateral else fn) if inside else 0.0
        vt = (v[0] - vn * n[0], v[1] - vn * n[1], v[2] - vn * n[2])
        k = -self.mu * abs(fn) / math.sqrt(vt[0] ** 2 + vt[1] ** 2 + vt[2] ** 2 + self.v_s ** 2)
        w = np.array([fn * n[0] + k * vt[0], fn * n[1] + k * vt[1], fn * n[2] + k * vt[2], 0.0, 0.0, 0.0])
        return (w, -w, np.array([1.0 if fn > 0.0 else 0.0]), np.array([d]))

    def zero_crossings(self, t, x, u):
        return np.array([self.depth(u[0])])


@register("hybrid_control_6d")
class HybridControl6D(Block):
    """The hybrid position/force controller of eqs 12-16 for N joints and a six-axis task frame {C}.

    At each tick (``rate``), with {C} given by ``frame_origin`` and
    ``frame_rotation`` (or the input ``C``: origin 3, rotation 9), and A the
    diagonal of the controlled ``axes``:

    * eq 12: ΔX = X_d - X (position in {C}; orientation error log(R_d R^T) as a
      rotation vector), ΔX' = X_d' - twist, ΔF = F_d - F, all in {C} axes;
    * eq 13: X_e = A (I - S) ΔX, X_e' = A (I - S) ΔX', F_e = A S ΔF;
    * eq 14: q_e = J_C^-1 X_e, q_e' = J_C^-1 X_e', tau_e = J_C^T F_e, with J_C
      the Jacobian's controlled rows in {C}; exact when as many axes as joints
      are controlled, else damped least squares J^T (J J^T + lambda^2 I)^-1
      (``dls_damping`` lambda, which must then be positive);
    * eq 15: tau_p = Kpp q_e + Kpi ∫q_e + Kpd q_e';
      tau_f = J_C^T A S F_d + Kfp tau_e + Kfi ∫clip(tau_e, +-tau_max);
    * eq 16: tau = tau_p + tau_f + tau_ff (the input, e.g. gravity), held to the next tick.

    Integrals use the rectangle rule including the current sample, as the
    2-D controller does. When S changes (task phases, input ``S``), the
    force integrator absorbs the step so that tau stays where it was
    (bumpless transfer; a joint whose Kfi is 0 keeps its step); from then on
    each loop integrates its own error. A
    square J_C whose condition number exceeds 1e8 is a run-time error
    (a singular pose), with its time.

    Parameters
    ----------
    rate : Hz                servo rate
    joints : int             N
    S : [1]                  six entries, 1 force-controlled, 0 position-controlled (when S is unwired)
    axes : [1]               six entries, 1 where {C}'s axis is controlled at all (default all)
    frame_origin : [m]       origin of {C} in the base frame (when C is unwired)
    frame_rotation : [rad]   rotation vector of {C} in the base frame (when C is unwired)
    Kpp, Kpi, Kpd : [N m/rad, N m/(rad s), N m s/rad]   joint-space PID gains (or N/m... for prismatic joints)
    Kfp, Kfi : [1, 1/s]      joint-space force gains
    tau_max : [N m or N]     limiter on the force integrand
    dls_damping : m          lambda of the damped least squares
    """

    def __init__(self, name="hybrid", rate=500, joints=6, S=(0, 0, 0, 0, 0, 0), axes=(1, 1, 1, 1, 1, 1),
                 frame_origin=(0.0, 0.0, 0.0), frame_rotation=(0.0, 0.0, 0.0), Kpp=0.0, Kpi=0.0, Kpd=0.0,
                 Kfp=0.0, Kfi=0.0, tau_max=np.inf, dls_damping=0.0):
        super().__init__(name)
        n = self.n = count(joints, "joints")
        self.declare_rate(rate=rate)
        self.axes = vector(axes, "axes", 6) != 0
        self.S0 = vector(S, "S", 6)
        if not set(np.unique(self.S0)) <= {0.0, 1.0}:
            raise ParameterError("S", f"entries must be 0 (position) or 1 (force), got {self.S0.tolist()}")
        self.gains = {k: vector(v, k, n) for k, v in
                      (("Kpp", Kpp), ("Kpi", Kpi), ("Kpd", Kpd), ("Kfp", Kfp), ("Kfi", Kfi))}
        self.tau_max = vector(tau_max, "tau_max", n, "nonnegative", inf_ok=True)
        self.lam = scalar(dls_damping, "dls_damping", "nonnegative")
        if self.axes.sum() != n and self.lam == 0.0:
            raise ParameterError("dls_damping", f"must be positive: {int(self.axes.sum())} axes controlled with "
                                                f"{n} joints (J_C is not square)")
        C = np.concatenate([vector(frame_origin, "frame_origin", 3),
                            rotation(vector(frame_rotation, "frame_rotation", 3)).ravel()])
        for port, width in (("p", 3), ("R", 9), ("twist", 6), ("J", 6 * n), ("F", 6)):
            self.declare_input(port, width)
        self.declare_input("X_d", 6)
        self.declare_input("Xd_d", 6, default=np.zeros(6), optional=True)
        self.declare_input("F_d", 6)
        self.declare_input("S", 6, default=self.S0, optional=True)
        self.declare_input("C", 12, default=C, optional=True)
        self.declare_input("tau_ff", n, default=np.zeros(n), optional=True)
        self.declare_output("tau", n)
        self.declare_output("F_C", 6)
        self.declare_discrete_state(2 * n + 6)  # ∫q_e, ∫tau'_e, the S of the last tick

    def initial_state(self, u=None):
        return np.concatenate([np.zeros(2 * self.n), -np.ones(6)])  # -1: no S before the first tick

    def _law(self, t, x, u, S):
        """(tau, new integrators, F in {C}) of eqs 12-16 with selection ``S``."""
        n, g = self.n, self.gains
        p, R, tw, J, F, Xd, Xdd, Fd, _, C, tff = (np.asarray(v, float) for v in u)
        RC, o = C[3:].reshape(3, 3), C[:3]
        R = R.reshape(3, 3)
        dX = np.concatenate([Xd[:3] - RC.T @ (p - o), rotation_vector(rotation(Xd[3:]) @ (RC.T @ R).T)])  # eq 12
        dXd = Xdd - _rot6(RC.T, tw)
        FC = _rot6(RC.T, F)
        A = self.axes
        Xe, Xed, Fe = (1 - S) * dX, (1 - S) * dXd, S * (Fd - FC)  # eq 13
        JC = np.vstack([RC.T @ J.reshape(6, n)[:3], RC.T @ J.reshape(6, n)[3:]])[A]
        qe, qed = self._inverse(t, JC, np.column_stack([Xe[A], Xed[A]])).T  # eq 14, one factorization
        tau_e = JC.T @ Fe[A]
        zq = x[:n] + qe * self.period_s
        zf = x[n:2 * n] + np.clip(tau_e, -self.tau_max, self.tau_max) * self.period_s
        tau_p = g["Kpp"] * qe + g["Kpi"] * zq + g["Kpd"] * qed  # eq 15a
        tau_f = JC.T @ (S * Fd)[A] + g["Kfp"] * tau_e + g["Kfi"] * zf  # eq 15b
        return tau_p + tau_f + tff, zq, zf, FC  # eq 16

    def _inverse(self, t, JC, v):
        return inverse(JC, v, self.lam, self.name, t)

    @property
    def period_s(self):
        """The sample period, s."""
        return float(self.period)

    def _tick(self, t, x, u):
        key = (t, np.asarray(x, float).tobytes(), b"".join(np.asarray(v, float).tobytes() for v in u))
        if getattr(self, "_last", (None,))[0] == key:  # output and update of one tick: computed once
            return self._last[1]
        self._last = (key, self._compute(t, x, u))
        return self._last[1]

    def _compute(self, t, x, u):
        x = np.asarray(x, float)
        S = (np.asarray(u[8], float) != 0).astype(float)
        tau, zq, zf, FC = self._law(t, x, u, S)
        prev = x[2 * self.n:]
        if (prev >= 0).all() and (prev != S).any():  # bumpless: the force integrator takes the step S would make
            before = self._law(t, x, u, prev)[0]
            ki = self.gains["Kfi"]
            zf = zf + np.divide(before - tau, ki, out=np.zeros(self.n), where=ki != 0)
            tau = np.where(ki != 0, before, tau)
        return tau, np.concatenate([zq, zf, S]), FC

    def output(self, t, x, u):
        tau, _, FC = self._tick(t, x, u)
        return (tau, FC)

    def update(self, t, x, u):
        return self._tick(t, x, u)[1]


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
        self.declare_discrete_state(14)

    def initial_state(self, u=None):
        x = np.zeros(14)
        x[0] = -1.0  # the start pose is read at the first tick
        return x

    def _start(self, u):
        p, R = np.asarray(u[0], float), np.asarray(u[1], float).reshape(3, 3)
        return np.concatenate([self.RC.T @ (p - self.o), rotation_vector(self.RC.T @ R)])

    def _commands(self, t, x, u):
        x = np.asarray(x, float).copy()
        if x[0] < 0:
            x[0], x[1], x[2:8] = 0.0, t, self._start(u)
        k = self.k
        F = np.asarray(u[2], float)
        FC = np.concatenate([self.RC.T @ F[:3], self.RC.T @ F[3:]])
        S, Xd, Xdd, Fd = np.zeros(6), x[2:8].copy(), np.zeros(6), np.zeros(6)
        if x[0] == 0.0:
            if FC[k] >= self.f0:  # contact: hold where it was found, press from here on
                x[8:14] = x[2:8]
                x[8 + k] += self.v * (t - x[1])
                x[0], x[1] = 1.0, t
            else:
                Xd[k] += self.v * (t - x[1])
                Xdd[k] = self.v
        if x[0] >= 1.0:
            S[k] = 1.0
            Xd = x[8:14].copy()
            s = t - x[1]
            ramp = min(1.0, s / self.t_ramp) if self.t_ramp > 0 and x[0] == 1.0 else 1.0
            Fd[k] = self.f0 + (self.f1 - self.f0) * ramp
            if x[0] == 1.0 and s >= self.t_ramp + self.t_settle - 1e-9:  # a tick that lands on it, in floats
                x[0], x[1] = 2.0, t
            if x[0] == 2.0:
                a, b = [i for i in range(3) if i != k]
                s = min(t - x[1], self.T)  # one turn, from rest to rest: th = pi (1 - cos(pi s / T))
                th = np.pi * (1.0 - np.cos(np.pi * s / self.T))
                w = np.pi ** 2 / self.T * np.sin(np.pi * s / self.T)
                Xd[a] += self.radius * (np.cos(th) - 1.0)
                Xd[b] += self.radius * np.sin(th)
                Xdd[a], Xdd[b] = -self.radius * w * np.sin(th), self.radius * w * np.cos(th)
        return (S, Xd, Xdd, Fd, np.array([x[0]])), x

    def output(self, t, x, u):
        return self._commands(t, x, u)[0]

    def update(self, t, x, u):
        return self._commands(t, x, u)[1]


# the fused path's kernels (robot_kernels); the methods above are the generic path's
ForceTorqueSensor.kernels = rk.SENSOR
PlaneContact.kernels = rk.PLANE
