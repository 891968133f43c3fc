"""The task Jacobian's transpose and inverse, for the force and position loops (eqs 14-15)."""

import numpy as np

from hybridsim.engine.block import Block
from hybridsim.errors import ParameterError
from hybridsim.engine.registry import register

from hybridsim.blocks._util import count, scalar, zero_one

from hybridsim.blocks.robot._frames import inverse
from hybridsim.blocks.robot import task_kernels as tk

GROUP = "robot"


class _JacobianBlock(Block):
    """Shared: N joints, the controlled axes of the six (rows of J kept)."""

    def _setup(self, joints, axes):
        self.n = count(joints, "joints")
        self.axes = zero_one(axes, "axes", 6, "0 (left out) or 1 (kept)") != 0
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
        self.params = tk.JacobianParams(n, np.flatnonzero(self.axes).astype(np.int64), 0.0)

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
        self.params = tk.JacobianParams(n, np.flatnonzero(self.axes).astype(np.int64), self.lam)

    def output(self, t, x, u):
        return (inverse(self._rows(u), np.asarray(u[1], float)[self.axes], self.lam, self.name, t),)


# the kernels of the fused and compiled paths (blocks.robot.task_kernels); the methods above are the generic path's
TaskJacobianTranspose.kernels = tk.TRANSPOSE
TaskJacobianInverse.kernels = tk.INVERSE
