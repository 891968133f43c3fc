"""Continuous linear blocks: state space, the second-order low-pass."""
import math

import numpy as np

from hybridsim.engine.block import Block
from hybridsim.errors import ParameterError
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.engine.registry import register

from hybridsim.blocks._util import count, finite_matrix, scalar, vector


GROUP = "math"  # where `hybridsim blocks` lists this module's blocks

@register("lowpass")
class LowPass(Block):
    """Second-order Butterworth low-pass, continuous: the paper's 12 Hz display filter.

    y'' + sqrt(2) wc y' + wc^2 y = wc^2 u, wc = 2 pi cutoff; unity DC gain,
    starts at rest at ``initial``.
    """

    group = "control"

    def __init__(self, name="filter", cutoff=12.0, width=1, initial=0.0):
        super().__init__(name)
        wc = 2 * math.pi * scalar(cutoff, "cutoff", "positive")
        self.n = count(width, "width")
        self.params = (wc, self.n)
        self.y0 = vector(initial, "initial", self.n)
        self.declare_input("u", self.n)
        self.declare_output("y", self.n, depends_on=())
        self.declare_continuous_state(2 * self.n, atol=1e-9)

    def initial_state(self, u=None):
        return np.concatenate([self.y0, np.zeros(self.n)])


@kernel
def lowpass_output(p, t, x, u):
    return (np.asarray(x)[: p[1]],)


@kernel
def lowpass_derivatives(p, t, x, u):
    wc, n = p
    xa = np.asarray(x)
    y, yd = xa[:n], xa[n:]
    return np.concatenate((yd, wc * wc * (np.asarray(u[0]) - y) - math.sqrt(2) * wc * yd))


@register("state_space")
class StateSpace(Block):
    """Continuous LTI system x' = A x + B u, y = C x + D u (any plant or filter).

    ``D`` defaults to zero (then y has no direct feedthrough); ``x0`` the initial state.
    """

    group = "control"

    def __init__(self, name="ss", A=((0.0,),), B=((1.0,),), C=((1.0,),), D=None, x0=None):
        super().__init__(name)
        A, B, C = (finite_matrix(M, k) for M, k in ((A, "A"), (B, "B"), (C, "C")))
        n, m, p = A.shape[0], B.shape[1], C.shape[0]
        if A.shape != (n, n) or B.shape[0] != n or C.shape[1] != n:
            raise ParameterError("A", f"B and C have inconsistent shapes: A {A.shape}, B {B.shape}, C {C.shape}")
        D = np.zeros((p, m)) if D is None else finite_matrix(D, "D")
        if D.shape != (p, m):
            raise ParameterError("D", f"must be {p}x{m}, got {D.shape}")
        self.params = tuple(np.ascontiguousarray(M) for M in (A, B, C, D))
        self.x0 = np.zeros(n) if x0 is None else vector(x0, "x0", n)
        self.declare_input("u", m)
        self.declare_output("y", p, depends_on=None if np.any(D) else ())
        self.declare_continuous_state(n)

    def initial_state(self, u=None):
        return self.x0.copy()


@kernel
def abcd_output(p, t, x, u):
    """y = C x + D u of a state-space model ``p = (A, B, C, D)``."""
    A, B, C, D = p
    return (np.dot(C, np.asarray(x)) + np.dot(D, np.asarray(u[0])),)


@kernel
def abcd_step(p, t, x, u):
    """A x + B u: a continuous model's derivatives, a discrete one's next state."""
    A, B, C, D = p
    return np.dot(A, np.asarray(x)) + np.dot(B, np.asarray(u[0]))


LowPass.kernels = Kernels(output=lowpass_output, derivatives=lowpass_derivatives)
StateSpace.kernels = Kernels(output=abcd_output, derivatives=abcd_step)
