"""The hybrid controller's two compensators (eqs 15a, 15b), sampled.

Timing (docs/model.md): the first hit is at t = 0; a hit samples its inputs with
no computation delay; integrators use the rectangle rule including the
current sample (z <- z + e T, and the new z is applied at once).
"""
import numpy as np

from hybridsim.engine.block import Block
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.engine.registry import register

from hybridsim.blocks._util import count, matrix, one_rate, vector


GROUP = "paper"  # where `hybridsim blocks` lists this module's blocks

class _Sampled(Block):
    def __init__(self, name, rate, period, n):
        super().__init__(name)
        one_rate(rate, period)
        n = count(n, "width")
        self.declare_rate(period=period, rate=rate)
        self.T = float(self.period)
        self.n = n
        self.declare_discrete_state(n)


@register("position_pid")
class PositionPID(_Sampled):
    """tau_p = Kpp q_e + Kpi int(q_e) dt + Kpd qd_e  (eq 15a).

    In: ``e`` (q_e), ``ed`` (qd_e). Out: ``tau``. Gains: scalar, diagonal
    list or full matrix. Appendix A: Kp = diag(460, 1650), Ki = diag(1.3, 1200),
    Kd = diag(30, 250).
    """

    def __init__(self, name="pid", Kp=(460.0, 1650.0), Ki=(1.3, 1200.0), Kd=(30.0, 250.0),
                 rate=None, period=None, width=2):
        super().__init__(name, rate, period, width)
        width = self.n
        self.params = tuple(matrix(K, k, width) for K, k in ((Kp, "Kp"), (Ki, "Ki"), (Kd, "Kd"))) + (self.T,)
        self.declare_input("e", width)
        self.declare_input("ed", width)
        self.declare_output("tau", width)


@kernel
def pid_output(p, t, z, u, out):
    Kp, Ki, Kd, T = p
    e, ed = u[0], u[1]
    n = Kp.shape[0]
    tau = out[0]
    for i in range(n):  # eq 15a: Kp e + Ki (z + e T) + Kd ed, as loops (compiled: no BLAS call, no array)
        a = b = c = 0.0
        for j in range(n):
            a += Kp[i, j] * e[j]
            b += Ki[i, j] * (z[j] + e[j] * T)
            c += Kd[i, j] * ed[j]
        tau[i] = a + b + c
    return out


@kernel
def pid_update(p, t, z, u, new):
    e = u[0]
    for j in range(len(z)):
        new[j] = z[j] + e[j] * p[3]  # rectangle rule, current sample included
    return new


@register("force_pi")
class ForcePI(_Sampled):
    """tau_f = tau_ff + Kfp tau_e + Kfi int(tau'_e) dt  (eq 15b).

    tau'_e is tau_e clipped element-wise to +-limit (the saturation limiter
    of Fig 6, which lowers the effective integral gain for large errors).
    In: ``e`` (tau_e), ``ff`` (tau_ff = J^T S C_F_d). Out: ``tau``.
    Appendix A: Kp = diag(0.4, 0.3), Ki = diag(240, 220) 1/s,
    limit = (0.004 N m, 0.1 N). ``limit: null`` removes the limiter.
    """

    def __init__(self, name="fpi", Kp=(0.4, 0.3), Ki=(240.0, 220.0), limit=(0.004, 0.1),
                 rate=None, period=None, width=2):
        super().__init__(name, rate, period, width)
        width = self.n
        limit = np.full(width, np.inf) if limit is None else vector(limit, "limit", width, "nonnegative",
                                                                    inf_ok=True)
        self.params = (matrix(Kp, "Kp", width), matrix(Ki, "Ki", width), limit, self.T)
        self.declare_input("e", width)
        self.declare_input("ff", width)
        self.declare_output("tau", width)


@kernel
def limited(e, limit):
    """The saturation limiter: e clipped to +-limit (NaN stays NaN)."""
    return -limit if e < -limit else (limit if e > limit else e)


@kernel
def force_pi_output(p, t, z, u, out):
    Kp, Ki, limit, T = p
    e, ff = u[0], u[1]
    n = Kp.shape[0]
    tau = out[0]
    for i in range(n):  # eq 15b: ff + Kp e + Ki (z + e' T), e' the limited error
        a = b = 0.0
        for j in range(n):
            a += Kp[i, j] * e[j]
            b += Ki[i, j] * (z[j] + limited(e[j], limit[j]) * T)
        tau[i] = ff[i] + a + b
    return out


@kernel
def force_pi_update(p, t, z, u, new):
    Kp, Ki, limit, T = p
    e = u[0]
    for j in range(len(z)):
        new[j] = z[j] + limited(e[j], limit[j]) * T
    return new


PositionPID.kernels = Kernels(output_into=pid_output, update_into=pid_update)
ForcePI.kernels = Kernels(output_into=force_pi_output, update_into=force_pi_update)
