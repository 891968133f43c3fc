"""The paper's hybrid position/force controller (eqs 12-16) for an N-joint arm in a six-axis task frame {C}.

Conventions: positions in metres, rotations as rotation vectors (axis times
angle, rad), wrenches as (force N, moment N m). ``F`` is what the robot applies
to its environment (what a wrist sensor reads, as in the paper); a plane's
``wrench`` output is what the environment applies to the tool, the arm's input.
"""

import numpy as np

from hybridsim.engine.block import Block
from hybridsim.errors import ParameterError
from hybridsim.engine.registry import register

from hybridsim.blocks._util import count, scalar, vector, zero_one

from hybridsim.blocks.robot._frames import rotation, rotation_vector, inverse, _rot6
from hybridsim.blocks.robot import task_kernels as tk

GROUP = "robot"


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
    S : [1]                  six entries, 1 force-controlled, 0 position-controlled (when S is unwired;
                             a wired S reads any non-zero entry as 1)
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
        self.axes = zero_one(axes, "axes", 6, "0 (left out) or 1 (controlled)") != 0
        self.S0 = zero_one(S, "S", 6, "0 (position) or 1 (force)")
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
        # ∫q_e, ∫tau'_e, the S of the last tick
        self.declare_discrete_state(2 * n + 6, held=[False] * (2 * n) + [True] * 6)
        g = self.gains
        self.params = tk.HybridParams(n, self.period_s, np.flatnonzero(self.axes).astype(np.int64), g["Kpp"],
                                      g["Kpi"], g["Kpd"], g["Kfp"], g["Kfi"], self.tau_max, self.lam)

    def initial_state(self, u=None):
        return np.concatenate([np.zeros(2 * self.n), -np.ones(6)])  # -1: no S before the first tick

    def _law(self, t, x, u, S):
        """(tau, new integrators, F in {C}) of eqs 12-16 with selection ``S``."""
        n, g = self.n, self.gains
        p, R, tw, J, F, Xd, Xdd, Fd, _, C, tff = (np.asarray(v, float) for v in u)
        RC, o = C[3:].reshape(3, 3), C[:3]
        tk.check_rotation(RC, t)
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


# the kernels of the fused and compiled paths (blocks.robot.task_kernels); the methods above are the generic path's
HybridControl6D.kernels = tk.HYBRID
