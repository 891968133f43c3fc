"""The task-space kernels (blocks/robot/task_kernels.py) against the blocks' methods and Pinocchio.

Oracles: Pinocchio's exp3 and log3 for the rotations (the generic path uses them); the blocks'
methods (the generic path's reference) for hybrid_control_6d, task_phases, wrench_transform and
the Jacobian blocks, on random inputs run in plain Python; and those blocks in a small diagram on
the generic, fused and compiled paths (the compiled one is numba's build of these kernels).
"""
import numpy as np
import pytest

from hybridsim.blocks.robot import task_kernels as tk
from hybridsim.blocks.robot.hybrid6d import HybridControl6D
from hybridsim.blocks.robot.jacobians import TaskJacobianInverse, TaskJacobianTranspose
from hybridsim.blocks.robot.phases import TaskPhases
from hybridsim.blocks.robot.sensing import WrenchTransform
from hybridsim.errors import SimulationError

from paths import PATHS, block, check, run

RNG = np.random.default_rng(12)


def rotations():
    """Random rotation vectors, and some near no turn and near a half turn."""
    axes = RNG.normal(size=(40, 3))
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    angles = np.concatenate([RNG.uniform(0, np.pi, 20), [0.0, 1e-9, 1e-5, 1e-3, 2.0, 2.1, 3.0, 3.1, 3.14159,
                                                         np.pi - 1e-7], RNG.uniform(2.5, np.pi, 10)])
    return axes * angles[:, None]


def test_exp3_and_log3_equal_pinocchios():
    pin = pytest.importorskip("pinocchio")
    for w in rotations():
        R = pin.exp3(w)
        np.testing.assert_allclose(tk.exp3(w), R, rtol=0, atol=1e-15)
        np.testing.assert_allclose(tk.log3(R), pin.log3(R), rtol=0, atol=1e-12)


def _hybrid_inputs(n, S):
    from scipy.spatial.transform import Rotation

    R = Rotation.random(random_state=RNG.integers(1 << 30)).as_matrix()
    C = np.concatenate([RNG.normal(size=3) * 0.1, Rotation.random(random_state=RNG.integers(1 << 30)).as_matrix().ravel()])
    return [RNG.normal(size=3) * 0.3, R.ravel(), RNG.normal(size=6), RNG.normal(size=6 * n), RNG.normal(size=6) * 5,
            np.concatenate([RNG.normal(size=3) * 0.3, RNG.normal(size=3)]), RNG.normal(size=6), RNG.normal(size=6) * 5,
            np.asarray(S, float), C, RNG.normal(size=n)]


@pytest.mark.parametrize("n, axes, lam", [(6, [1] * 6, 0.0), (2, [1, 1, 0, 0, 0, 0], 0.0), (7, [1] * 6, 0.05),
                                          (6, [1, 1, 1, 0, 0, 0], 0.01)])
def test_hybrid_control_6d_kernels_equal_the_methods(n, axes, lam):
    hyb = HybridControl6D(rate=500, joints=n, axes=axes, Kpp=RNG.uniform(1, 100, n), Kpi=RNG.uniform(1, 100, n),
                          Kpd=RNG.uniform(1, 10, n), Kfp=RNG.uniform(0, 1, n), Kfi=[100.0, 0.0] + [50.0] * (n - 2),
                          tau_max=[0.5] * n, dls_damping=lam)
    for k in range(8):
        S = RNG.integers(0, 2, 6)
        u = _hybrid_inputs(n, S)
        x = np.concatenate([RNG.normal(size=2 * n), RNG.integers(0, 2, 6) if k % 2 else -np.ones(6)])
        tu = tuple(tuple(v) for v in u)
        want = hyb.output(0.1, x, u), hyb.update(0.1, x, u)  # odd k: S may switch (bumpless)
        got = tk.hybrid_output(hyb.params, 0.1, tuple(x), tu), tk.hybrid_update(hyb.params, 0.1, tuple(x), tu)
        for g, w in zip(got[0], want[0]):
            np.testing.assert_allclose(g, w, rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(got[1], want[1], rtol=1e-12, atol=1e-12)


def test_a_singular_task_jacobian_raises_with_its_time():
    hyb = HybridControl6D(rate=100, joints=2, axes=[1, 1, 0, 0, 0, 0], Kpp=1.0)
    u = _hybrid_inputs(2, [0] * 6)
    u[3] = np.zeros(12)
    with pytest.raises(SimulationError, match="singular at t = 0.5 s"):
        tk.hybrid_output(hyb.params, 0.5, tuple(hyb.initial_state()), tuple(tuple(v) for v in u))


def test_task_phases_kernels_equal_the_method_through_every_phase():
    ph = TaskPhases(rate=100, frame_origin=[0.1, 0.0, 0.2], frame_rotation=[np.pi, 0.0, 0.0], normal_axis=2,
                    approach_speed=0.1, contact_force=2.0, force=10.0, ramp_time=0.1, settle_time=0.05,
                    radius=0.05, circle_period=0.5)
    from scipy.spatial.transform import Rotation

    p, R = np.array([0.4, 0.1, 0.3]), Rotation.from_rotvec([3.0, 0.1, -0.2]).as_matrix().ravel()
    x = ph.initial_state()
    phases = set()
    for k in range(120):
        t = k * 0.01
        F = np.array([0.3, -0.2, -3.0 if t >= 0.2 else -0.5, 0, 0, 0])  # {C}'s Z is base -Z: pressing
        u = [p, R, F]
        tu = tuple(tuple(v) for v in u)
        for g, w in zip(tk.phases_output(ph.params, t, tuple(x), tu), ph.output(t, x, u)):
            np.testing.assert_allclose(g, w, rtol=0, atol=1e-12)
        nxt = ph.update(t, x, u)
        np.testing.assert_allclose(tk.phases_update(ph.params, t, tuple(x), tu), nxt, rtol=0, atol=1e-12)
        x = nxt
        phases.add(x[0])
    assert phases == {0.0, 1.0, 2.0}


def test_wrench_and_jacobian_kernels_equal_the_methods():
    from scipy.spatial.transform import Rotation

    wt = WrenchTransform()
    jt, ji = TaskJacobianTranspose(joints=7, axes=[1, 1, 1, 0, 1, 1]), TaskJacobianInverse(joints=5, axes=[1, 1, 1, 0, 1, 1])
    dls = TaskJacobianInverse(joints=7, axes=[1, 1, 1, 1, 1, 1], dls_damping=0.02)
    for _ in range(10):
        u = [RNG.normal(size=6), Rotation.random(random_state=RNG.integers(1 << 30)).as_matrix().ravel(), RNG.normal(size=3)]
        np.testing.assert_allclose(tk.wrench_output((), 0.0, (), tuple(tuple(v) for v in u))[0], wt.output(0.0, None, u)[0],
                                   rtol=0, atol=1e-14)
        for b in (jt, ji, dls):
            v = [RNG.normal(size=6 * b.n), RNG.normal(size=6)]
            np.testing.assert_allclose(b.kernels.output(b.params, 0.0, (), tuple(tuple(a) for a in v))[0],
                                       b.output(0.0, None, v)[0], rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("path", PATHS)
def test_wrench_and_jacobian_blocks_on_every_path(path):
    """A wrench moved to another frame and point, then J^T of it and J^-1 of it (damped), from
    constant sources, against the methods' numbers."""
    J = RNG.normal(size=(6, 7))
    w, lever, rot = RNG.normal(size=6), [0.1, -0.2, 0.05], [0.3, -0.4, 1.0]
    blocks = [block("constant", "w", value=w.tolist()), block("constant", "J", value=J.ravel().tolist()),
              block("wrench_transform", "wt", rotation=rot, lever=lever),
              block("task_jacobian_transpose", "jt", joints=7), block("task_jacobian_inverse", "ji", joints=7,
                                                                          dls_damping=0.05)]
    wires = [("w.y", "wt.wrench"), ("J.y", "jt.J"), ("wt.wrench", "jt.F"), ("J.y", "ji.J"), ("wt.wrench", "ji.X")]
    res = run(path, blocks, wires, 0.02, ["wt.wrench", "jt.tau", "ji.q"])
    moved = blocks[2].output(0.0, None, [w, blocks[2].inputs[1].default, blocks[2].inputs[2].default])[0]
    check("wrench_transform", path, res["wt.wrench"][-1], moved, 1e-14)
    check("task_jacobian_transpose", path, res["jt.tau"][-1], J.T @ moved, 1e-12)
    check("task_jacobian_inverse", path, res["ji.q"][-1], blocks[4].output(0.0, None, [J.ravel(), moved])[0], 1e-12)
