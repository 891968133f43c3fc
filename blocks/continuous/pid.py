"""The continuous PID: parallel form, setpoint weights, a filtered derivative, output limits and anti-windup."""
import math
from typing import NamedTuple

import numpy as np

from hybridsim.engine.block import Block
from hybridsim.errors import ParameterError
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.engine.registry import register

from hybridsim.blocks._util import count, pid_gains, vector

GROUP = "control"  # where `hybridsim blocks` lists this module's blocks

_ANTI_WINDUP = ("none", "clamping", "back_calculation")


@register("pid")
class PID(Block):
    """u = sat(Kp (b r - y) + I + D), a continuous PID in parallel form.

    * I' = Ki e, e = r - y (Ki in 1/s); I(0) = ``initial``;
    * D = Kd N s / (s + N) (c r - y): D = Kd N (e_d - F), F' = N (e_d - F), F(0) = 0
      (Kd in s, N the filter bandwidth in rad/s; from rest, as python-control's
      and Simulink's defaults: a setpoint step kicks the derivative);
    * sat clips to [lower, upper] (units of u);
    * anti-windup ``clamping``: I' = 0 while the output is saturated and Ki e
      pushes it further out (the sign of Ki e: a reverse-acting loop clamps as
      its mirror does); ``back_calculation``: I' = Ki e + Kb (sat(v) - v)
      (Kb in 1/s, default Ki / Kp); ``none``.

    Ports: in ``r`` (setpoint), ``y`` (measurement); out ``u``. The saturation
    limits are zero crossings (v - upper, v - lower, and Ki e), located by the
    solvers that locate switches. Without limits it equals python-control's
    C(s) = Kp + Ki / s + Kd N s / (s + N) (b = c = 1).
    """

    def __init__(self, name="pid", Kp=1.0, Ki=0.0, Kd=0.0, N=100.0, b=1.0, c=1.0, lower=-math.inf,
                 upper=math.inf, anti_windup="clamping", Kb=None, initial=0.0, width=1):
        super().__init__(name)
        n = count(width, "width")
        if anti_windup not in _ANTI_WINDUP:
            raise ParameterError("anti_windup", f"must be one of {', '.join(_ANTI_WINDUP)}; got {anti_windup!r}")
        Kp_, Ki_, Kd_, lo, hi, Kb_ = pid_gains(Kp, Ki, Kd, lower, upper, Kb, n)
        big = 1e300  # an infinite limit kept finite: the event functions stay numbers
        self.params = ContinuousPIDParams(Kp_, Ki_, Kd_, vector(N, "N", n, "positive"), vector(b, "b", n),
                                          vector(c, "c", n), np.clip(lo, -big, big), np.clip(hi, -big, big),
                                          float(_ANTI_WINDUP.index(anti_windup)), Kb_, n)
        self.x0 = np.concatenate((vector(initial, "initial", n), np.zeros(n)))
        self.event_directions = (0,) * (3 * n)
        if anti_windup == "clamping":
            self.sliding_advice = (
                "A PID held at its limit by clamping anti-windup slides along it while the error keeps its "
                "integrator on the edge (clamped, the output leaves the limit; integrating, it returns): "
                "use anti_windup: back_calculation, which has no such edge, or a fixed-step solver (rk4, heun) "
                "without locate_switches")
        self.declare_input("r", n)
        self.declare_input("y", n)
        self.declare_output("u", n)
        self.declare_continuous_state(2 * n)  # I, then the filter state F

    def initial_state(self, u=None):
        return self.x0.copy()


class ContinuousPIDParams(NamedTuple):
    Kp: np.ndarray     # proportional gain
    Ki: np.ndarray     # integral gain, 1/s
    Kd: np.ndarray     # derivative gain, s
    N: np.ndarray      # derivative filter bandwidth, rad/s
    b: np.ndarray      # setpoint weight, proportional
    c: np.ndarray      # setpoint weight, derivative
    lower: np.ndarray  # output limits
    upper: np.ndarray
    mode: float        # anti-windup: 0 none, 1 clamping, 2 back-calculation
    Kb: np.ndarray     # back-calculation gain, 1/s
    n: int             # width


@kernel
def cpid_terms(p, x, u):
    """(unclipped v, clipped u, e, e_d, F) at one instant."""
    xa, r, y = np.asarray(x), np.asarray(u[0]), np.asarray(u[1])
    integ, f = xa[:p.n], xa[p.n:]
    e, ed = r - y, p.c * r - y
    v = p.Kp * (p.b * r - y) + integ + p.Kd * p.N * (ed - f)
    return v, np.minimum(np.maximum(v, p.lower), p.upper), e, ed, f


@kernel
def cpid_output(p, t, x, u):
    v, sat, e, ed, f = cpid_terms(p, x, u)
    return (sat,)


@kernel
def cpid_derivatives(p, t, x, u):
    v, sat, e, ed, f = cpid_terms(p, x, u)
    di = p.Ki * e
    if p.mode == 1.0:
        di = np.where(((v > p.upper) & (di > 0.0)) | ((v < p.lower) & (di < 0.0)), 0.0, di)
    elif p.mode == 2.0:
        di = di + p.Kb * (sat - v)
    return np.concatenate((di, p.N * (ed - f)))


@kernel
def cpid_crossings(p, t, x, u):
    v, sat, e, ed, f = cpid_terms(p, x, u)
    return np.concatenate((v - p.upper, v - p.lower, p.Ki * e))


PID.kernels = Kernels(output=cpid_output, derivatives=cpid_derivatives, zero_crossings=cpid_crossings)
