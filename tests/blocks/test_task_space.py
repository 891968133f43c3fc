"""Six-axis task-space blocks: the force transform, the plane, the 6-D hybrid law, task phases."""
import numpy as np
import pytest

from hybridsim.blocks.paper.controllers import ForcePI, PositionPID
from hybridsim.blocks.paper.kinematics import ForceTransform, endpoint, jacobian_rows
from hybridsim.blocks.robot.sensing import ForceTorqueSensor
from hybridsim.blocks.robot.hybrid6d import HybridControl6D
from hybridsim.blocks.robot.jacobians import TaskJacobianInverse
from hybridsim.blocks.robot.contact import PlaneContact
from hybridsim.blocks.robot.phases import TaskPhases
from hybridsim.blocks.robot.sensing import WrenchTransform
from hybridsim.blocks.robot._frames import rotation
from hybridsim.errors import ParameterError, SimulationError


def test_wrench_transform_adds_the_lever_arm_moment():
    # 10 N along X at a point 0.2 m above (Z) the new reference point: moment r x f = (0, 2, 0) N m
    wt = WrenchTransform(lever=(0.0, 0.0, 0.2))
    (w,) = wt.output(0, None, [np.array([10.0, 0, 0, 0, 0, 0]), np.eye(3).ravel(), np.array([0, 0, 0.2])])
    np.testing.assert_allclose(w, [10, 0, 0, 0, 2.0, 0], atol=1e-15)
    # a quarter turn about Z turns X into Y, the moment too
    R = rotation([0, 0, np.pi / 2]).ravel()
    (w,) = wt.output(0, None, [np.array([1.0, 0, 0, 0.5, 0, 0]), R, np.zeros(3)])
    np.testing.assert_allclose(w, [0, 1, 0, 0, 0.5, 0], atol=1e-15)


def test_in_the_plane_it_equals_the_papers_force_transform():
    ft, wt = ForceTransform(), WrenchTransform()
    rng = np.random.default_rng(4)
    for q, F in zip(rng.uniform([-2, 0.2], [2, 0.8], size=(10, 2)), rng.normal(size=(10, 2)) * 10):
        R = rotation([0, 0, q[0]]).ravel()  # the hand frame turns with q1
        (w,) = wt.output(0, None, [np.concatenate([F, np.zeros(4)]), R, np.zeros(3)])
        np.testing.assert_allclose(w[:2], ft.output(0, None, [q, F])[0], rtol=0, atol=1e-12)


def test_plane_pushes_along_its_normal_and_rubs_against_sliding():
    plane = PlaneContact(point=(0, 0, 0.1), normal=(0, 0, 2.0), stiffness=1e4, damping=100.0, mu=0.5,
                         slip_velocity=1e-3)
    # 1 mm inside, sinking at 1 cm/s, sliding at 0.2 m/s along X: fn = 1e4 * 1e-3 + 100 * 0.01 = 11 N
    w, F, contact, depth = plane.output(0, None, [np.array([0.3, 0.0, 0.099]), np.array([0.2, 0, -0.01, 0, 0, 0])])
    assert depth[0] == pytest.approx(1e-3) and contact[0] == 1.0
    assert w[2] == pytest.approx(11.0)
    assert w[0] == pytest.approx(-0.5 * 11.0 * 0.2 / np.sqrt(0.04 + 1e-6))
    np.testing.assert_allclose(F, -w)
    # outside, or pulling away faster than the spring pushes: no force (unilateral)
    assert not plane.output(0, None, [np.array([0, 0, 0.2]), np.zeros(6)])[0].any()
    assert not plane.output(0, None, [np.array([0, 0, 0.0999]), np.array([0, 0, 1.0, 0, 0, 0])])[0].any()
    assert plane.zero_crossings(0, None, [np.array([0, 0, 0.099]), np.zeros(6)])[0] == pytest.approx(1e-3)


def _tick_inputs(q, F, Xd, Xdd, Fd, S):
    """The 6-D controller's inputs for the Fig 3 arm at joint position q (zero speed)."""
    p = np.concatenate([endpoint(q), [0.0]])
    J = np.zeros((6, 2))
    J[:2] = np.array(jacobian_rows(q, 0.153))
    six = lambda v: np.concatenate([v, np.zeros(4)])  # noqa: E731
    return [p, rotation([0, 0, q[0]]).ravel(), np.zeros(6), J.ravel(), six(F), six(Xd), six(Xdd), six(Fd),
            six(S), np.concatenate([np.zeros(3), np.eye(3).ravel()]), np.zeros(2)]


def test_one_tick_equals_the_papers_2d_controller():
    gains = dict(Kpp=[460.0, 1650.0], Kpi=[1.3, 1200.0], Kpd=[30.0, 250.0], Kfp=[0.4, 0.3], Kfi=[240.0, 220.0],
                 tau_max=[0.004, 0.1])
    hyb = HybridControl6D(rate=60, joints=2, S=[1, 0, 0, 0, 0, 0], axes=[1, 1, 0, 0, 0, 0], **gains)
    pid, fpi = PositionPID(rate=60), ForcePI(rate=60)
    rng = np.random.default_rng(5)
    for _ in range(10):
        q = rng.uniform([0.2, 0.4], [0.5, 0.6])
        F, Fd, Xd = rng.normal(size=2) * 5 + [10, 0], np.array([12.0, 0.0]), endpoint(q) + rng.normal(size=2) * 1e-3
        z = rng.normal(size=4) * 1e-3
        tau, _ = hyb.output(0.0, np.concatenate([z, [1, 0, 0, 0, 0, 0]]), _tick_inputs(q, F, Xd, np.zeros(2), Fd, [1, 0]))
        # eqs 12-16 with the 2-D blocks: only Y position, only X force
        J = np.array(jacobian_rows(q, 0.153))
        qe = np.linalg.solve(J, np.array([0.0, (Xd - endpoint(q))[1]]))
        tau_e = J.T @ np.array([Fd[0] - F[0], 0.0])
        ref = pid.output(0.0, z[:2], [qe, np.zeros(2)])[0] + fpi.output(0.0, z[2:], [tau_e, J.T @ [Fd[0], 0.0]])[0]
        np.testing.assert_allclose(tau, ref, rtol=0, atol=1e-12)


def test_switching_S_is_bumpless():
    """At the tick S changes, tau is what the old law gives at that tick; the next tick moves by
    no more than the force loop's own step (its proportional part and one integrator increment)."""
    Kfp, Kfi, T = np.array([0.4, 0.3]), np.array([200.0, 200.0]), 0.01
    hyb = HybridControl6D(rate=1 / T, joints=2, S=[0, 0, 0, 0, 0, 0], axes=[1, 1, 0, 0, 0, 0], Kpp=[400, 1500],
                          Kpi=[5, 500], Kpd=[20, 100], Kfp=Kfp, Kfi=Kfi)
    q = np.array([0.31, 0.476])
    Xd = endpoint(q) + [0.002, -0.001]
    pos = _tick_inputs(q, [3.0, 0.0], Xd, [0, 0], [10.0, 0.0], [0, 0])
    force = _tick_inputs(q, [3.0, 0.0], Xd, [0, 0], [10.0, 0.0], [1, 0])
    x = hyb.initial_state()
    for k in range(3):
        x = hyb.update(k * T, x, pos)
    old_law = hyb.output(3 * T, x, pos)[0]
    switched = hyb.output(3 * T, x, force)[0]
    np.testing.assert_allclose(switched, old_law, rtol=0, atol=1e-12)
    x = hyb.update(3 * T, x, force)
    after = hyb.output(4 * T, x, force)[0]
    J = np.array(jacobian_rows(q, 0.153))
    tau_e = J.T @ np.array([10.0 - 3.0, 0.0])
    qe = np.linalg.solve(J, [0.0, (Xd - endpoint(q))[1]])  # Y stays position-controlled
    one_step = Kfi * tau_e * T + np.array([5, 500]) * qe * T  # one increment of each integrator
    np.testing.assert_allclose(after - switched, one_step, rtol=0, atol=1e-9)


def test_a_singular_pose_is_a_runtime_error_and_uneven_axes_need_damping():
    hyb = HybridControl6D(rate=100, joints=2, axes=[1, 1, 0, 0, 0, 0], Kpp=1.0)
    inputs = _tick_inputs(np.array([0.3, 0.0]), [0, 0], [0.1, 0.1], [0, 0], [0, 0], [0, 0])
    inputs[3] = np.zeros(12)  # a Jacobian with no rank
    with pytest.raises(SimulationError, match="singular at t = 0.5 s"):
        hyb.output(0.5, hyb.initial_state(), inputs)
    with pytest.raises(ParameterError, match="dls_damping"):
        HybridControl6D(joints=6, axes=[1, 1, 1, 0, 0, 0])
    with pytest.raises(ParameterError, match="0 \\(position\\) or 1"):
        HybridControl6D(S=[0.5, 0, 0, 0, 0, 0])
    # axes of 0.5 ran as 1 (any non-zero was an axis): a selection is 0 or 1 in every block
    with pytest.raises(ParameterError, match="axes.*0 \\(left out\\) or 1"):
        HybridControl6D(axes=[1, 1, 1, 1, 1, 0.5])
    with pytest.raises(ParameterError, match="axes.*0 \\(left out\\) or 1"):
        TaskJacobianInverse(joints=2, axes=[1, 2, 0, 0, 0, 0], dls_damping=0.1)


def test_task_phases_approach_press_then_trace():
    ph = TaskPhases(rate=100, normal_axis=2, approach_speed=0.1, contact_force=2.0, force=10.0, ramp_time=0.1,
                    settle_time=0.0, radius=0.05, circle_period=1.0)
    p, R = np.array([0.4, 0.1, 0.3]), np.eye(3).ravel()
    x = ph.initial_state()
    free, touch = np.zeros(6), np.array([0, 0, 3.0, 0, 0, 0])
    S, Xd, Xdd, Fd, phase = ph.output(0.0, x, [p, R, free])
    assert phase[0] == 0 and not S.any() and Xdd[2] == pytest.approx(0.1)
    x = ph.update(0.0, x, [p, R, free])
    S, Xd, _, Fd, phase = ph.output(0.2, x, [p, R, free])
    assert Xd[2] == pytest.approx(0.3 + 0.02)  # moving along C-Z at 0.1 m/s
    x = ph.update(0.2, x, [p, R, touch])
    assert x[0] == 1.0 and x[8 + 2] == pytest.approx(0.32)  # contact found 2 cm down
    S, Xd, _, Fd, phase = ph.output(0.25, x, [p, R, touch])
    assert list(S) == [0, 0, 1, 0, 0, 0] and Fd[2] == pytest.approx(2.0 + 8.0 * 0.5)
    x = ph.update(0.3, x, [p, R, touch])  # ramp done: trace
    S, Xd, Xdd, Fd, phase = ph.output(0.3, x, [p, R, touch])
    assert phase[0] == 2 and Fd[2] == 10.0 and not Xdd.any()  # the circle starts at rest
    # half the time: half the turn (th = pi (1 - cos(pi s / T)) = pi at s = T / 2), at full speed
    S, Xd, Xdd, Fd, phase = ph.output(0.3 + 0.5, x, [p, R, touch])
    assert Xd[0] == pytest.approx(0.4 - 0.1) and Xd[1] == pytest.approx(0.1, abs=1e-12)
    assert np.hypot(Xdd[0], Xdd[1]) == pytest.approx(0.05 * np.pi ** 2 / 1.0)


def test_the_ft_sensor_at_rest_reads_the_tool_weight_and_zero_after_taring():
    import hybridsim as hs
    from hybridsim.blocks.sources.basic import Constant, Step

    d = hs.Diagram("ft")
    d.add(Constant("flange", value=[0.4, 0.1, 0.3]))
    d.add(Constant("R", value=list(np.eye(3).ravel())))
    d.add(Constant("still", value=[0.0] * 6))
    d.add(Step("tare", initial=0.0, final=1.0, time=0.5))
    d.add(ForceTorqueSensor("ft", mass=0.8, stiffness=[2e4] * 3, damping=[400.0] * 3))
    for a, b in [("flange.y", "ft.p"), ("R.y", "ft.R"), ("still.y", "ft.twist"), ("tare.y", "ft.tare")]:
        d.connect(a, b)
    res = hs.Simulator(d.build(), hs.RK4(1e-4), log=["ft.F", "ft.p"]).run(1.0)
    F = res["ft.F"]
    before, after = F[np.searchsorted(res.t, 0.45)], F[-1]
    # held still, the flange carries the tool's weight: F = -m g = (0, 0, 7.848) N
    np.testing.assert_allclose(before[:3], [0.0, 0.0, 0.8 * 9.81], atol=1e-6)
    assert res["ft.p"][-1][2] == pytest.approx(0.3 - 0.8 * 9.81 / 2e4, abs=1e-9)  # sagged by m g / K
    np.testing.assert_allclose(after, 0.0, atol=1e-9)  # tared at 0.5 s
    comp = ForceTorqueSensor(mass=0.8, gravity_compensation=True)
    x = np.concatenate([[0.4, 0.1, 0.3 - 0.8 * 9.81 / 1e5], np.zeros(6)])
    u = [np.array([0.4, 0.1, 0.3]), np.eye(3).ravel(), np.zeros(6), np.zeros(6), np.zeros(1)]
    np.testing.assert_allclose(comp.output(0, x, u)[3], 0.0, atol=1e-9)  # compensated: reads zero at rest
    # pressed on a table with 10 N (the table pushes the tool up), compensated: reads the 10 N push down
    x[2] = 0.3 - (0.8 * 9.81 + 10.0) / 1e5
    x[:3] = [0.4, 0.1, 0.3 + (10.0 - 0.8 * 9.81) / 1e5]
    np.testing.assert_allclose(comp.output(0, x, u)[3][:3], [0.0, 0.0, -10.0], atol=1e-9)


def test_jacobian_transpose_and_inverse_blocks_equal_the_papers_in_the_plane():
    from hybridsim.blocks.paper.kinematics import InverseJacobian, JacobianTranspose
    from hybridsim.blocks.robot.jacobians import TaskJacobianInverse, TaskJacobianTranspose

    jt, ji = TaskJacobianTranspose(joints=2, axes=[1, 1, 0, 0, 0, 0]), TaskJacobianInverse(joints=2, axes=[1, 1, 0, 0, 0, 0])
    rng = np.random.default_rng(7)
    for q in rng.uniform([0.2, 0.4], [0.5, 0.6], size=(5, 2)):
        J = np.zeros((6, 2))
        J[:2] = np.array(jacobian_rows(q, 0.153))
        F, X = rng.normal(size=2), rng.normal(size=2) * 1e-3
        six = lambda v: np.concatenate([v, np.zeros(4)])  # noqa: E731
        np.testing.assert_allclose(jt.output(0, None, [J.ravel(), six(F)])[0],
                                   JacobianTranspose().output(0, None, [q, F])[0], rtol=0, atol=1e-12)
        np.testing.assert_allclose(ji.output(0, None, [J.ravel(), six(X)])[0],
                                   InverseJacobian().output(0, None, [q, X])[0], rtol=0, atol=1e-12)
    # damped least squares for a redundant arm: 6 joints, 3 axes; near a singular pose it stays finite
    dls = TaskJacobianInverse(joints=6, axes=[1, 1, 1, 0, 0, 0], dls_damping=0.01)
    J = np.zeros((6, 6))
    J[0, 0] = J[1, 1] = 1.0  # the Z row is lost: singular
    q = dls.output(0, None, [J.ravel(), np.array([0.1, 0.2, 0.3, 0, 0, 0])])[0]
    np.testing.assert_allclose(q[:2], [0.1 / (1 + 1e-4), 0.2 / (1 + 1e-4)], rtol=1e-12)
    assert np.all(np.isfinite(q))


def test_a_moving_task_frame_given_as_an_input_equals_the_same_frame_fixed():
    """{C} from the input C (origin, rotation: e.g. a crank's frame from a source block) is used as the
    parameter's would be; turning {C} a quarter turn moves the force axis from base X to base Y."""
    gains = dict(rate=100, joints=2, S=[1, 0, 0, 0, 0, 0], axes=[1, 1, 0, 0, 0, 0], Kpp=[400, 1500],
                 Kfp=[0.4, 0.3], Kfi=[200, 200])
    fixed = HybridControl6D(frame_rotation=[0, 0, np.pi / 2], frame_origin=[0.1, 0.0, 0.0], **gains)
    moving = HybridControl6D(**gains)
    q = np.array([0.31, 0.476])
    u = _tick_inputs(q, [3.0, 1.0], [0.01, -0.4], [0, 0], [10.0, 0.0], [1, 0])
    C = np.concatenate([[0.1, 0.0, 0.0], rotation([0, 0, np.pi / 2]).ravel()])
    a = fixed.output(0.0, fixed.initial_state(), u[:9] + [np.array(fixed.inputs[9].default)] + u[10:])  # unwired
    b = moving.output(0.0, moving.initial_state(), u[:9] + [C] + u[10:])
    turned = moving.output(0.0, moving.initial_state(), u)[0]  # {C} = base axes
    assert np.abs(turned - b[0]).max() > 1.0  # the frame matters
    np.testing.assert_allclose(a[0], b[0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(b[1][:2], [1.0, -3.0], atol=1e-12)  # F in {C}: base (3, 1) turned by -90 deg


def test_a_task_frame_input_that_is_not_a_rotation_is_a_runtime_error_on_every_path():
    # C with twice a rotation (or a mirror) ran, exit 0: forces of +-6000 N where 10 N were asked
    from hybridsim.blocks.robot import task_kernels as tk

    hyb = HybridControl6D(rate=100, joints=2, axes=[1, 1, 0, 0, 0, 0], Kpp=1.0)
    u = _tick_inputs(np.array([0.3, 0.4]), [0, 0], [0.1, 0.1], [0, 0], [0, 0], [0, 0])
    R = rotation([0, 0, 0.3])
    for bad in (2.0 * R, R @ np.diag([1.0, 1.0, -1.0])):
        v = u[:9] + [np.concatenate([np.zeros(3), bad.ravel()])] + u[10:]
        with pytest.raises(SimulationError, match=r"input C at t = 0.25 s: its rotation .* is not a rotation matrix"):
            hyb.output(0.25, hyb.initial_state(), v)
        with pytest.raises(SimulationError, match="is not a rotation matrix"):
            tk.hybrid_output(hyb.params, 0.25, hyb.initial_state(), tuple(v))
    good = u[:9] + [np.concatenate([np.zeros(3), R.ravel()])] + u[10:]
    np.testing.assert_allclose(hyb.output(0.25, hyb.initial_state(), good)[0],
                               tk.hybrid_output(hyb.params, 0.25, hyb.initial_state(), tuple(good))[0], atol=1e-12)
