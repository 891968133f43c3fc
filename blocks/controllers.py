"""The hybrid controller's two compensators (eqs 15a, 15b), sampled.

Timing (MODEL.md): the first hit is at t = 0; a hit samples its inputs with
no computation delay; integrators use the rectangle rule including the
current sample (z <- z + e T, and the new z is applied at once).
"""
import numpy as np

from hybridsim.block import Block
from hybridsim.registry import register

from ._util import matrix, vector


class _Sampled(Block):
    def __init__(self, name, rate, period, n):
        super().__init__(name)
        if (rate is None) == (period is None):
            raise ValueError("give exactly one of rate (Hz) or period (s)")
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
        self.Kp, self.Ki, self.Kd = (matrix(K, k, width) for K, k in ((Kp, "Kp"), (Ki, "Ki"), (Kd, "Kd")))
        self.declare_input("e", width)
        self.declare_input("ed", width)
        self.declare_output("tau", width)

    def output(self, t, z, u):
        e, ed = u
        return (self.Kp @ e + self.Ki @ (z + e * self.T) + self.Kd @ ed,)

    def update(self, t, z, u):
        return z + u[0] * self.T


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
        self.Kp, self.Ki = matrix(Kp, "Kp", width), matrix(Ki, "Ki", width)
        self.limit = None if limit is None else vector(limit, "limit", width)
        self.declare_input("e", width)
        self.declare_input("ff", width)
        self.declare_output("tau", width)

    def _clipped(self, e):
        return e if self.limit is None else np.clip(e, -self.limit, self.limit)

    def output(self, t, z, u):
        e, ff = u
        return (ff + self.Kp @ e + self.Ki @ (z + self._clipped(e) * self.T),)

    def update(self, t, z, u):
        return z + self._clipped(u[0]) * self.T
