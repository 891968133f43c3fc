"""Rotations and the damped inverse shared by the task-space blocks (rotation vectors in rad)."""

import numpy as np
from scipy.spatial.transform import Rotation

from hybridsim.errors import SimulationError




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
