"""The arm of Fig 3: joint 1 revolute, joint 2 prismatic, with stick-slip friction."""
import math
from typing import NamedTuple

import numpy as np

from hybridsim.engine.block import Block
from hybridsim.errors import ParameterError
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.engine.registry import register

from hybridsim.blocks._util import choice, flag, floats, scalar, vector
from hybridsim.blocks.paper.kinematics import L_OFFSET, inverse_kinematics


GROUP = "paper"  # where `hybridsim blocks` lists this module's blocks
BALANCE_KEYS = ("surface_x", "force", "Kr", "Kw", "y")


def balance_endpoint(balance):
    """Endpoint (m, m) in static balance: the surface and wrist springs in series carry the force.

    ``balance`` is ``{surface_x: m, force: N, Kr: N/m, Kw: N/m, y: m (default 0)}``;
    X = surface_x + force (1/Kr + 1/Kw) (docs/model.md, "Geometry").
    """
    if not isinstance(balance, dict):
        raise ParameterError("balance", f"must be a mapping {{surface_x, force, Kr, Kw[, y]}}, got {balance!r}")
    unknown = sorted(set(balance) - set(BALANCE_KEYS))
    missing = [k for k in BALANCE_KEYS[:4] if k not in balance]
    if unknown or missing:
        raise ParameterError("balance", "needs surface_x, force, Kr and Kw (y optional)"
                             + (f"; unknown {', '.join(map(str, unknown))}" if unknown else "")
                             + (f"; missing {', '.join(missing)}" if missing else ""))
    Kr = scalar(balance["Kr"], "balance.Kr", "positive")
    Kw = scalar(balance["Kw"], "balance.Kw", "positive")
    x = scalar(balance["surface_x"], "balance.surface_x") + scalar(balance["force"], "balance.force") * (1.0 / Kr + 1.0 / Kw)
    return [x, scalar(balance.get("y", 0.0), "balance.y")]


@register("manipulator")
class Manipulator(Block):
    """Arm dynamics, eqs 5, 6 and 11 (docs/model.md's corrected form).

    Eq 5:  I1(q2) q1'' = tau1 + B1 + q2 f2 + l f1 - b1 q1'
    Eq 6:  (M2 + M3) q2'' = tau2 + B2 + f1 - b2 q2'

    where f = Kw w (+ bw w') is the wrist spring force on the arm in {H}
    (input ``f_wrist``), so that ``q2 f2 + l f1, f1`` is J^T R f.

    Friction (eq 11), Karnopp model with a capture band ``stick_band``:

    * sliding, ``|q_i'| >= stick_band``: B_i = -sgn(q_i') tau_c,i
    * sticking, ``|q_i'| < stick_band``: friction cancels the net non-friction force
      F_i and brings the velocity to rest with time constant ``stick_time``,
      up to the static limit: B_i = clip(-F_i - m_i q_i'/stick_time, +-tau_s,i).

    A joint inside the band drifts at most ``stick_band * stick_time``
    (1e-7 m or rad with the defaults), and no switch chatters.

    ``friction_model`` chooses the law (docs/model.md, "Friction"):

    * ``karnopp`` (default): the above, sliding friction tau_c at every speed;
    * ``stribeck``: the same stick band, but sliding friction falls from the
      static level to the Coulomb level as the speed grows,
      g(v) = tau_c + (tau_s - tau_c) exp(-(v / stribeck_velocity)^2);
    * ``lugre``: a bristle deflection z_i per joint (two more states),
      ``z' = v - sigma0 |v| z / g(v)``, friction -(sigma0 z + sigma1 z'); in steady
      sliding it equals the Stribeck curve -sgn(v) g(v), and below the break-away
      force a joint deflects elastically by F / sigma0 (presliding). It is stiff:
      z relaxes at the rate ``sigma0 |v| / g``, which a fixed step h must keep below
      about 2.7 / h (RK4; h = 1e-4 s holds speeds up to ~0.9 m/s with the defaults).

    Parameters
    ----------
    I1 : [a0, a1, a2]   I1(q2) = a0 + a1 q2 + a2 q2^2, kg m^2
    M2, M3 : kg          link 2 and hand masses
    tau_c, tau_s : [N m, N]   Coulomb and static friction levels
    friction : bool      False removes B entirely
    damping : [N m s/rad, N s/m]   viscous joint damping b1, b2 (0 as printed)
    q0 : [rad, m]        initial joint position, or
    endpoint0 : [m, m]   initial endpoint Lambda(q) in {C} (inverse kinematics)
    balance : {surface_x: m, force: N, Kr: N/m, Kw: N/m, y: m}   or start in static
                         balance pressing ``force`` along C-X on a surface at X = surface_x
                         through the surface and wrist springs in series:
                         endpoint0 = (surface_x + force (1/Kr + 1/Kw), y); y defaults to 0
    l : m                link offset
    friction_model : 'karnopp', 'stribeck' or 'lugre'
    stribeck_velocity : [rad/s, m/s]   speed scale of the static-to-Coulomb decay
    bristle_stiffness : [N m/rad, N/m]  LuGre sigma0 (default 1e5)
    bristle_damping : [N m s/rad, N s/m]  LuGre sigma1 (default 2 sqrt(sigma0 m): critical)
    """

    kernels = None  # set below, after the kernel functions

    def __init__(self, name="arm", I1=(3.98, -5.25, 6.47), M2=6.68, M3=0.58,
                 tau_c=(5.0, 3.5), tau_s=(5.75, 4.6), friction=True,
                 damping=(0.0, 0.0), q0=None, endpoint0=None, balance=None, qd0=(0.0, 0.0),
                 l=L_OFFSET, stick_band=1e-4, stick_time=1e-3, friction_model="karnopp",
                 stribeck_velocity=(1e-3, 1e-3), bristle_stiffness=(1e5, 1e5), bristle_damping=None):
        super().__init__(name)
        friction_model = choice(friction_model, "friction_model", FRICTION_MODELS)
        zero = (0.0, 0.0)
        friction = flag(friction, "friction")
        m2 = scalar(M2, "M2", "nonnegative") + scalar(M3, "M3", "positive")
        self.params = ArmParams(
            I1=floats(I1, "I1", 3), m2=m2,
            tau_c=floats(tau_c, "tau_c", 2, "nonnegative") if friction else zero,
            tau_s=floats(tau_s, "tau_s", 2, "nonnegative") if friction else zero,
            friction=friction, b=floats(damping, "damping", 2, "nonnegative"), l=scalar(l, "l"),
            eps=scalar(stick_band, "stick_band", "nonnegative"),
            t_stick=scalar(stick_time, "stick_time", "positive"),
            v_s=floats(stribeck_velocity, "stribeck_velocity", 2, "positive"),
            sigma0=floats(bristle_stiffness, "bristle_stiffness", 2, "positive"),
            sigma1=(0.0, 0.0))
        if friction and any(c > s for c, s in zip(self.params.tau_c, self.params.tau_s)):
            raise ParameterError("tau_s", f"must be at least tau_c (static >= Coulomb), got {tau_s!r}")
        given = [k for k, v in (("q0", q0), ("endpoint0", endpoint0), ("balance", balance)) if v is not None]
        if len(given) > 1:
            raise ParameterError(given[1], f"and {given[0]} both given: give one of them")
        if balance is not None:
            endpoint0 = balance_endpoint(balance)
        if endpoint0 is not None:
            e = vector(endpoint0, "endpoint0", 2)
            try:
                q0 = inverse_kinematics(e[0], e[1], self.params.l)
            except ValueError as exc:
                raise ParameterError("endpoint0", f"is out of reach: {exc}") from None
        q0 = vector(q0 if q0 is not None else (0, 0.5), "q0", 2)
        if not inertia(self.params.I1, q0[1]) > 0:
            raise ParameterError("I1", f"gives I1(q2) = {inertia(self.params.I1, q0[1]):g} kg m^2 at the "
                                       f"initial q2 = {q0[1]:g} m; the inertia must be positive (it divides)")
        self.x0 = np.concatenate([q0, vector(qd0, "qd0", 2)])
        self.declare_input("tau", 2)
        self.declare_input("f_wrist", 2)
        self.declare_output("q", 2, depends_on=())
        self.declare_output("qd", 2, depends_on=())
        if friction_model == "lugre" and friction:
            masses = (inertia(self.params.I1, q0[1]), m2)
            s1 = floats(bristle_damping, "bristle_damping", 2, "nonnegative") if bristle_damping is not None \
                else tuple(2.0 * math.sqrt(k * m) for k, m in zip(self.params.sigma0, masses))
            self.params = self.params._replace(sigma1=s1)
            self.x0 = np.concatenate([self.x0, np.zeros(2)])  # bristles at rest
            self.kernels = Kernels(output=arm_output, derivatives=arm_lugre_derivatives)
            self.declare_continuous_state(6, atol=(1e-11, 1e-11, 1e-9, 1e-9, 1e-13, 1e-13))
        else:
            if friction_model == "stribeck" and friction:
                self.kernels = Kernels(output=arm_output, derivatives=arm_stribeck_derivatives,
                                       zero_crossings=arm_switches)
            self.declare_continuous_state(4, atol=(1e-11, 1e-11, 1e-9, 1e-9))

    def initial_state(self, u=None):
        return self.x0.copy()

    def inertia(self, q2):
        """I1(q2), kg m^2."""
        return inertia(self.params.I1, q2)


class ArmParams(NamedTuple):
    I1: tuple        # a0, a1, a2 of I1(q2), kg m^2
    m2: float        # M2 + M3, kg
    tau_c: tuple     # Coulomb friction, N m and N
    tau_s: tuple     # static friction, N m and N
    friction: bool
    b: tuple         # viscous joint damping b1, b2
    l: float         # link offset, m
    eps: float       # stick band, rad/s and m/s
    t_stick: float   # time constant that brings a sticking joint to rest, s
    v_s: tuple       # Stribeck velocity, rad/s and m/s
    sigma0: tuple    # LuGre bristle stiffness, N m/rad and N/m
    sigma1: tuple    # LuGre bristle damping, N m s/rad and N s/m


#: the friction laws of eq 11 the arm offers (``friction_model``)
FRICTION_MODELS = ("karnopp", "stribeck", "lugre")


@kernel
def inertia(a, q2):
    """I1(q2) = a0 + a1 q2 + a2 q2^2, kg m^2."""
    return a[0] + a[1] * q2 + a[2] * q2 * q2


@kernel
def stribeck_level(v, tau_c, tau_s, v_s):
    """g(v) = tau_c + (tau_s - tau_c) exp(-(v/v_s)^2): the sliding friction level at speed v."""
    r = v / v_s
    return tau_c + (tau_s - tau_c) * math.exp(-r * r)


@kernel
def friction_force(v, F, m, tau_c, tau_s, eps, t_stick):
    """B_i of eq 11 (Karnopp, see the Manipulator docstring) for one joint."""
    if abs(v) >= eps:
        return -math.copysign(tau_c, v)
    return min(tau_s, max(-tau_s, -F - m * v / t_stick))


@kernel
def stribeck_friction(v, F, m, tau_c, tau_s, v_s, eps, t_stick):
    """B_i with Stribeck sliding friction: -sgn(v) g(v) outside the band, Karnopp's sticking inside."""
    if abs(v) >= eps:
        return -math.copysign(stribeck_level(v, tau_c, tau_s, v_s), v)
    return friction_force(v, F, m, tau_c, tau_s, eps, t_stick)


@kernel
def arm_output(p, t, x, u):
    return x[0:2], x[2:4]


@kernel
def joint_forces(p, x, u):
    """(v1, v2, I1, F1, F2): joint rates, I1(q2) and the forces of eqs 5 and 6 without friction."""
    q2, v1, v2 = x[1], x[2], x[3]
    tau, f = u[0], u[1]
    F1 = tau[0] + q2 * f[1] + p.l * f[0] - p.b[0] * v1  # eq 5 without B1
    F2 = tau[1] + f[0] - p.b[1] * v2                    # eq 6 without B2
    return v1, v2, inertia(p.I1, q2), F1, F2


@kernel
def arm_derivatives(p, t, x, u):
    v1, v2, I1, F1, F2 = joint_forces(p, x, u)
    if p.friction:
        F1 = F1 + friction_force(v1, F1, I1, p.tau_c[0], p.tau_s[0], p.eps, p.t_stick)
        F2 = F2 + friction_force(v2, F2, p.m2, p.tau_c[1], p.tau_s[1], p.eps, p.t_stick)
    return (v1, v2, F1 / I1, F2 / p.m2)


@kernel
def arm_stribeck_derivatives(p, t, x, u):
    """Eqs 5 and 6 with Stribeck friction (its own kernel: a branch in the Karnopp one slowed the
    compiled loop 5x)."""
    v1, v2, I1, F1, F2 = joint_forces(p, x, u)
    F1 = F1 + stribeck_friction(v1, F1, I1, p.tau_c[0], p.tau_s[0], p.v_s[0], p.eps, p.t_stick)
    F2 = F2 + stribeck_friction(v2, F2, p.m2, p.tau_c[1], p.tau_s[1], p.v_s[1], p.eps, p.t_stick)
    return (v1, v2, F1 / I1, F2 / p.m2)


@kernel
def lugre(p, i, v, z):
    """(friction B_i, z') of LuGre for joint ``i``: ``z' = v - sigma0 |v| z / g(v)``, ``B = -(sigma0 z + sigma1 z')``."""
    g = stribeck_level(v, p.tau_c[i], p.tau_s[i], p.v_s[i])
    zd = v - p.sigma0[i] * abs(v) * z / g
    return -(p.sigma0[i] * z + p.sigma1[i] * zd), zd


@kernel
def arm_lugre_derivatives(p, t, x, u):
    """Eqs 5 and 6 with LuGre friction: (q1', q2', q1'', q2'', z1', z2')."""
    q2, v1, v2, z1, z2 = x[1], x[2], x[3], x[4], x[5]
    tau, f = u[0], u[1]
    I1 = inertia(p.I1, q2)
    B1, zd1 = lugre(p, 0, v1, z1)
    B2, zd2 = lugre(p, 1, v2, z2)
    F1 = tau[0] + q2 * f[1] + p.l * f[0] - p.b[0] * v1 + B1  # eq 5
    F2 = tau[1] + f[0] - p.b[1] * v2 + B2                    # eq 6
    return (v1, v2, F1 / I1, F2 / p.m2, zd1, zd2)


@kernel
def arm_switches(p, t, x, u):
    """Slide <-> stick of each joint: |q_i'| - stick_band (constant 1 without friction)."""
    if not p.friction:
        return (1.0, 1.0)
    return (abs(x[2]) - p.eps, abs(x[3]) - p.eps)


Manipulator.kernels = Kernels(output=arm_output, derivatives=arm_derivatives, zero_crossings=arm_switches)
