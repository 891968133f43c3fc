"""The robot blocks' fused-path kernels (blocks/robot/kernels.py) against their methods, and the
UR5 press-and-trace on the fused path against the generic path.

Oracles: the blocks' methods (numpy and Pinocchio, the generic path's reference) on random states
and inputs; Pinocchio's own frame Jacobian for the reused one; the generic path's run.
"""
import numpy as np
import pytest

pytest.importorskip("pinocchio")

import hybridsim as hs  # noqa: E402
from hybridsim.blocks.robot import kernels as rk  # noqa: E402
from hybridsim.blocks.robot.arm import RobotArm, RobotKinematics  # noqa: E402
from hybridsim.blocks.robot.sensing import ForceTorqueSensor
from hybridsim.blocks.robot.contact import PlaneContact
from hybridsim.errors import CompiledPathError  # noqa: E402

from conftest import DIAGRAMS  # noqa: E402

RNG = np.random.default_rng(25)


def close(a, b, tol=1e-12):
    a, b = np.concatenate([np.ravel(v) for v in a]), np.concatenate([np.ravel(v) for v in b])
    return np.max(np.abs(a - b) / np.maximum(1.0, np.abs(b))) < tol


@pytest.mark.parametrize("robot", ["ur5", "panda", "fig3_arm"])
@pytest.mark.parametrize("friction", [None, "karnopp", "stribeck", "lugre"])
def test_arm_kernels_equal_the_methods(robot, friction):
    kw = dict(friction=True, tau_c=0.5, tau_s=0.8, friction_model=friction) if friction else {}
    arm = RobotArm("arm", robot=robot, damping=0.3, **kw)
    for _ in range(5):
        x = RNG.normal(size=arm.n_continuous)
        x[arm.n:2 * arm.n] *= 1e-4 if RNG.random() < 0.5 else 1.0  # stuck and sliding joints
        u = [RNG.normal(size=arm.n), RNG.normal(size=6) * 5.0]
        rk._JACOBIANS.clear()
        assert close(arm.kernels.derivatives(arm.params, 0.0, tuple(x), tuple(map(tuple, u))),
                     arm.derivatives(0.0, x, u))
        assert close(arm.kernels.output(arm.params, 0.0, tuple(x), ()), arm.output(0.0, x, u))


def test_kinematics_kernel_equals_the_method_and_the_arm_reuses_its_jacobian():
    import pinocchio as pin

    kin = RobotKinematics("kin", robot="ur5", frame="tool0")
    arm = RobotArm("arm", robot="ur5", frame="tool0")
    rk._JACOBIANS.clear()
    for _ in range(5):
        q, qd = RNG.normal(size=6), RNG.normal(size=6)
        got = kin.kernels.output(kin.params, 0.0, (), (tuple(q), tuple(qd)))
        assert close(got, kin.output(0.0, None, [q, qd]))
        # the arm at other joint positions: its own Jacobian, not the one kin left behind
        q2, w = RNG.normal(size=6), RNG.normal(size=6)
        x = np.concatenate([q2, np.zeros(6)])
        J = pin.computeFrameJacobian(arm.model, arm.model.createData(), q2, arm.frame_id, pin.LOCAL_WORLD_ALIGNED)
        want = pin.aba(arm.model, arm.model.createData(), q2, np.zeros(6), J.T @ w)
        assert close([arm.kernels.derivatives(arm.params, 0.0, tuple(x), ((0.0,) * 6, tuple(w)))[6:]], [want])
        # and at kin's: the same numbers through the reused Jacobian
        kin.kernels.output(kin.params, 0.0, (), (tuple(q2), tuple(qd)))
        assert close([arm.kernels.derivatives(arm.params, 0.0, tuple(x), ((0.0,) * 6, tuple(w)))[6:]], [want])


@pytest.mark.parametrize("compensate", [False, True])
def test_sensor_and_plane_kernels_equal_the_methods(compensate):
    from scipy.spatial.transform import Rotation

    ft = ForceTorqueSensor("ft", mass=0.5, stiffness=[1e5, 2e5, 3e5], damping=[100, 200, 300],
                           gravity_compensation=compensate)
    plane = PlaneContact("table", point=[0.1, 0.0, 0.2], normal=[0.2, 0.1, 1.0], stiffness=5e4, damping=300.0,
                         mu=0.3)
    for _ in range(10):
        x = RNG.normal(size=9)
        u = [RNG.normal(size=3), Rotation.random(random_state=RNG.integers(1 << 30)).as_matrix().ravel(),
             RNG.normal(size=6), RNG.normal(size=6), np.array([RNG.random()])]
        tu = tuple(tuple(v) for v in u)
        assert close(ft.kernels.output(ft.params, 0.0, tuple(x), tu), ft.output(0.0, x, u))
        assert close(ft.kernels.derivatives(ft.params, 0.0, tuple(x), tu), ft.derivatives(0.0, x, u))
        assert close(ft.kernels.zero_crossings(ft.params, 0.0, tuple(x), tu), ft.zero_crossings(0.0, x, u))
        assert close(ft.kernels.event_action(ft.params, 0.0, tuple(x), tu, (True,)),
                     ft.event_action(0.0, x, u, (True,)))
        up = [u[0] * 0.1 + [0.1, 0.0, 0.2], u[2]]
        assert close(plane.kernels.output(plane.params, 0.0, (), tuple(tuple(v) for v in up)),
                     plane.output(0.0, None, up))


def test_ur5_press_and_trace_fused_equals_generic():
    # 0.7 s: the approach, first touch (~0.25 s), the press with its force ramp
    runs = {f: hs.simulate(DIAGRAMS / "ur5_press_and_trace.yaml", t_end=0.7, fused=f) for f in (False, True)}
    generic, fused = runs[False], runs[True]
    assert generic.meta["solver"] == fused.meta["solver"]
    assert fused["phases.phase"].max() >= 1  # it reached the press
    for ref in ("hybrid.F_C", "ft.F", "hybrid.tau"):
        assert np.max(np.abs(fused[ref] - generic[ref])) < 1e-9, ref  # N (N m for tau)
    assert np.max(np.abs(fused["kin.p"] - generic["kin.p"])) < 1e-12


def test_the_fused_path_is_taken_and_the_compiled_path_refuses_pinocchio():
    _, sim, _ = hs.build(DIAGRAMS / "ur5_press_and_trace.yaml")
    assert sim._fused is not None
    with pytest.raises(CompiledPathError, match="Pinocchio"):
        hs.check(DIAGRAMS / "ur5_press_and_trace.yaml", compiled=True)
