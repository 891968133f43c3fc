"""URDF arms by Pinocchio: dynamics against a hand derivation, kinematics against finite differences."""
import re

import numpy as np
import pytest

from hybridsim.blocks.robot.arm import GravityTorque, RobotArm, RobotKinematics, urdf_path
from hybridsim.blocks.paper.kinematics import endpoint, jacobian_rows
from hybridsim.blocks.robot._frames import rotation_vector
from hybridsim.errors import ParameterError

# the Fig 3 arm as a rigid body (diagrams/robots/fig3_arm.urdf)
IA, IB, M, C, L = 2.850929, 0.01, 7.26, -0.361570, 0.153


def lagrange_fig3(q, qd, tau, g=9.81):
    """q'' of the URDF's two bodies by Lagrange's equations, written out by hand, gravity along -Y.

    Link 2 (mass M, own inertia IB about Z) has its centre at R(q1) (q2 + C, -L); link 1 only
    rotates (IA). KE = 1/2 (IA + IB) q1'^2 + 1/2 M ((q2' + L q1')^2 + (q2 + C)^2 q1'^2),
    V = M g ((q2 + C) sin q1 - L cos q1).
    """
    q1, q2 = q
    d1, d2 = qd
    mass = np.array([[IA + IB + M * (L ** 2 + (q2 + C) ** 2), M * L], [M * L, M]])
    coriolis = np.array([2 * M * (q2 + C) * d1 * d2, -M * (q2 + C) * d1 ** 2])
    gravity = np.array([M * g * ((q2 + C) * np.cos(q1) + L * np.sin(q1)), M * g * np.sin(q1)])
    return np.linalg.solve(mass, np.asarray(tau) - coriolis - gravity)


def test_forward_dynamics_equal_a_lagrangian_written_by_hand():
    arm = RobotArm(robot="fig3_arm", frame="tool", gravity=(0.0, -9.81, 0.0))
    rng = np.random.default_rng(1)
    for _ in range(20):
        q, qd, tau = rng.uniform([-2, 0.2], [2, 0.8]), rng.normal(size=2), rng.normal(size=2) * 20
        d = arm.derivatives(0.0, np.concatenate([q, qd]), [tau, np.zeros(6)])
        np.testing.assert_allclose(d[:2], qd, rtol=0, atol=0)
        np.testing.assert_allclose(d[2:], lagrange_fig3(q, qd, tau), rtol=0, atol=1e-9)


def test_the_fig3_urdf_has_the_papers_geometry_and_inertia_coefficients():
    kin = RobotKinematics(robot="fig3_arm", frame="tool")
    arm = RobotArm(robot="fig3_arm")
    rng = np.random.default_rng(2)
    for q in rng.uniform([-2, 0.2], [2, 0.8], size=(10, 2)):
        p, R, _, J = kin.output(0.0, None, [q, np.zeros(2)])
        np.testing.assert_allclose(p[:2], endpoint(q), atol=1e-12)  # eq 3a
        np.testing.assert_allclose(J.reshape(6, 2)[:2], np.array(jacobian_rows(q, L)), atol=1e-12)
        import pinocchio as pin

        M11 = pin.crba(arm.model, arm.data, q)[0, 0]
        assert M11 == pytest.approx(3.98 - 5.25 * q[1] + 7.26 * q[1] ** 2, abs=1e-5)  # eq 5, q2^2: 7.26 not 6.47


def test_ur5_jacobian_equals_finite_differences_of_the_pose():
    kin = RobotKinematics(robot="ur5", frame="tool0")
    rng = np.random.default_rng(3)
    h = 1e-6
    for q in rng.uniform(-2.5, 2.5, size=(5, 6)):
        p, R, _, J = kin.output(0.0, None, [q, np.zeros(6)])
        J = J.reshape(6, 6)
        for i in range(6):
            dq = np.zeros(6)
            dq[i] = h
            p1, R1, _, _ = kin.output(0.0, None, [q + dq, np.zeros(6)])
            p0, R0, _, _ = kin.output(0.0, None, [q - dq, np.zeros(6)])
            np.testing.assert_allclose((p1 - p0) / (2 * h), J[:3, i], atol=1e-8)
            w = rotation_vector(R1.reshape(3, 3) @ R0.reshape(3, 3).T) / (2 * h)
            np.testing.assert_allclose(w, J[3:, i], atol=1e-8)


def test_a_wrench_balanced_by_jacobian_transpose_holds_the_arm_still():
    arm = RobotArm(robot="ur5", frame="tool0", gravity=(0, 0, 0))
    kin = RobotKinematics(robot="ur5", frame="tool0")
    q = np.array([0.3, -1.2, 1.5, -1.0, -1.6, 0.2])
    J = kin.output(0.0, None, [q, np.zeros(6)])[3].reshape(6, 6)
    w = np.array([10.0, -5.0, 20.0, 0.5, -0.3, 1.0])
    d = arm.derivatives(0.0, np.concatenate([q, np.zeros(6)]), [-J.T @ w, w])  # tau = -J^T F: static
    np.testing.assert_allclose(d, 0.0, atol=1e-10)


def test_gravity_torque_holds_the_arm_against_gravity():
    arm, grav = RobotArm(robot="ur5"), GravityTorque(robot="ur5")
    q = np.array([0.3, -1.2, 1.5, -1.0, -1.6, 0.2])
    d = arm.derivatives(0.0, np.concatenate([q, np.zeros(6)]), [grav.output(0, None, [q])[0], np.zeros(6)])
    np.testing.assert_allclose(d, 0.0, atol=1e-10)
    assert np.abs(grav.output(0, None, [q])[0]).max() > 1.0  # the shoulder carries the arm


def test_friction_holds_a_joint_below_the_static_level_and_lets_it_slide_above():
    common = dict(robot="fig3_arm", gravity=(0, 0, 0), friction=True, tau_c=[5.0, 3.5], tau_s=[5.75, 4.6])
    arm = RobotArm(**common)
    x = np.array([0.3, 0.5, 0.0, 0.0])
    held = arm.derivatives(0.0, x, [np.array([0.0, 4.5]), np.zeros(6)])
    assert abs(held[3]) < 1e-9  # 4.5 N < 4.6 N static: stuck
    slides = arm.derivatives(0.0, x, [np.array([0.0, 4.7]), np.zeros(6)])
    assert slides[3] > 0.0
    sliding = arm.derivatives(0.0, np.array([0.3, 0.5, 0.0, 0.1]), [np.zeros(2), np.zeros(6)])
    ref = RobotArm(robot="fig3_arm", gravity=(0, 0, 0)).derivatives(
        0.0, np.array([0.3, 0.5, 0.0, 0.1]), [np.array([0.0, -3.5]), np.zeros(6)])
    np.testing.assert_allclose(sliding, ref, atol=1e-12)  # sliding: -sgn(v) tau_c
    assert list(arm.zero_crossings(0, np.array([0.3, 0.5, 0.0, 0.1]), None)) == pytest.approx([-1e-4, 0.1 - 1e-4])


@pytest.mark.parametrize("kwargs, text", [
    ({}, "give a URDF file"),
    ({"robot": "r2d2"}, "unknown robot"),
    ({"urdf": "no/such.urdf"}, "file not found"),
    ({"robot": "ur5", "frame": "tool1"}, "did you mean 'tool0'"),
    ({"robot": "ur5", "q0": [0.0, 1.0]}, "'q0' must have 6 elements"),
    ({"robot": "ur5", "friction": True, "tau_c": 2.0, "tau_s": 1.0}, "static >= Coulomb"),
])
def test_bad_robot_parameters_are_parameter_errors(kwargs, text):
    with pytest.raises(ParameterError, match=text):
        RobotArm(**kwargs)


def test_a_file_that_is_not_a_robot_is_a_parameter_error(tmp_path):
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot name='x'><link name='a'/></robot>")
    with pytest.raises(ParameterError, match="no moving joint|not a robot model"):
        RobotArm(urdf=str(bad))
    # the reason was only on urdfdom's stderr (and its XML line was always 1)
    bad.write_text(SLIDER.replace('\n    <limit lower="-1" upper="1" effort="100" velocity="5"/>', "")
                   .replace("prismatic", "revolute"))
    with pytest.raises(ParameterError, match=r"not a robot model .*\(Joint \[z\] is of type REVOLUTE but it does "
                                             r"not specify limits"):
        RobotArm(urdf=str(bad))
    bad.write_text(SLIDER[:-len("</robot>")])
    with pytest.raises(ParameterError, match=r"bad.urdf:7: not well-formed XML \(column 1\): no element found"):
        RobotArm(urdf=str(bad))
    # Pinocchio takes these: a zero axis gave a rotation of cos(q) I and a NaN warning, a negative mass
    # a gravity torque of 8e32 N m
    for text, why in ((SLIDER.replace('axis xyz="0 0 1"', 'axis xyz="0 0 0"'), "joint 'z' has a zero axis"),
                      (SLIDER.replace('mass value="1.0"', 'mass value="-2.0"'), "link 'puck' has a negative mass")):
        bad.write_text(text)
        with pytest.raises(ParameterError, match=why):
            RobotKinematics(urdf=str(bad), frame="puck")
    # urdfdom read a mass of '2.O' as 0 kg and went on (its complaint on stderr only): a gravity torque
    # of a lighter arm, exit 0
    for old, new, says in (('mass value="1.0"', 'mass value="1.O"', "<mass> value='1.O' is not a number"),
                           ('axis xyz="0 0 1"', 'axis xyz="0 1"', "<axis> xyz='0 1' is not 3 numbers"),
                           # Python's float takes these, urdfdom reads 0 (or prints its complaint only)
                           ('mass value="1.0"', 'mass value="1_0"', "<mass> value='1_0' is not a number"),
                           ('mass value="1.0"', 'mass value=" 1.0 "', "<mass> value=' 1.0 ' is not a number"),
                           ('mass value="1.0"', 'mass value="１.0"', "<mass> value='１.0' is not a number"),
                           ('mass value="1.0"', "mass", "<mass> has no value (Pinocchio would read 0)"),
                           ('ixx="0.01"', 'ixx="-1.0"', "<inertia> ixx='-1.0' is not a moment of inertia >= 0")):
        bad.write_text(SLIDER.replace(old, new))
        at = SLIDER[:SLIDER.index(old)].count("\n") + 1
        with pytest.raises(ParameterError, match=f"bad.urdf:{at}: {re.escape(says)}"):
            RobotKinematics(urdf=str(bad), frame="puck")
    assert urdf_path(robot="ur5").name == "ur5_robot.urdf"


def test_start_position_solves_the_joints_for_a_tool_position():
    from hybridsim.blocks.paper.manipulator import Manipulator

    arm = RobotArm(robot="fig3_arm", frame="tool", q0=[0.3, 0.5], start_position=[0.5, 0.0, 0.0])
    np.testing.assert_allclose(arm.q0, Manipulator(endpoint0=(0.5, 0.0)).x0[:2], rtol=0, atol=1e-12)
    ur5 = RobotArm(robot="ur5", q0=[0.0, -1.2, 1.6, -1.9708, -1.5708, 0.0], start_position=[0.55, 0.1, 0.3])
    p = RobotKinematics(robot="ur5").output(0.0, None, [ur5.q0, np.zeros(6)])[0]
    np.testing.assert_allclose(p, [0.55, 0.1, 0.3], rtol=0, atol=1e-12)
    with pytest.raises(ParameterError, match="out of the robot's reach"):
        RobotArm(robot="ur5", start_position=[3.0, 0.0, 0.0])


SLIDER = """<?xml version="1.0"?>
<robot name="slider"><link name="base"/>
  <link name="puck"><inertial><origin xyz="0 0 0"/><mass value="1.0"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
  <joint name="z" type="prismatic"><parent link="base"/><child link="puck"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="100" velocity="5"/></joint>
</robot>"""


def test_a_one_joint_robot_has_a_6x1_jacobian(tmp_path):
    # Pinocchio gives a one-joint robot's frame Jacobian as a vector of 6: robot_kinematics stopped
    # with a numpy error (exit 70), a wrench on robot_arm and start_position too
    urdf = tmp_path / "slider.urdf"
    urdf.write_text(SLIDER)
    kin = RobotKinematics(urdf=str(urdf), frame="puck")
    p, _, twist, J = kin.output(0.0, None, [np.array([0.3]), np.array([2.0])])
    assert p[2] == pytest.approx(0.3) and np.allclose(twist, [0, 0, 2.0, 0, 0, 0]) and np.allclose(J, [0, 0, 1, 0, 0, 0])
    arm = RobotArm(urdf=str(urdf), frame="puck", start_position=[0.0, 0.0, 0.08])
    assert arm.q0 == pytest.approx([0.08], abs=1e-12)
    assert arm.applied(np.zeros(2), [np.zeros(1), np.array([0, 0, 5.0, 0, 0, 0])]) == pytest.approx([5.0])


def test_ur5_dynamics_agree_with_drakes_multibody_plant():
    """A second rigid-body library on the same URDF: Drake's MultibodyPlant (continuous) at random
    states (measured 5.7e-14 rad/s^2 apart)."""
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant

    plant = MultibodyPlant(0.0)
    Parser(plant).AddModels(str(urdf_path(robot="ur5")))  # the URDF welds base_link to the world
    plant.Finalize()
    ctx = plant.CreateDefaultContext()
    arm = RobotArm(robot="ur5", frame="tool0")
    rng = np.random.default_rng(6)
    for _ in range(10):
        q, v, tau = rng.uniform(-2.5, 2.5, 6), rng.normal(size=6), rng.normal(size=6) * 10
        plant.SetPositions(ctx, q)
        plant.SetVelocities(ctx, v)
        plant.get_actuation_input_port().FixValue(ctx, tau)
        deriv = plant.AllocateTimeDerivatives()
        plant.CalcTimeDerivatives(ctx, deriv)
        drake = deriv.get_vector().CopyToVector()[6:]
        np.testing.assert_allclose(arm.derivatives(0.0, np.concatenate([q, v]), [tau, np.zeros(6)])[6:], drake,
                                   rtol=0, atol=1e-9)


def test_stribeck_sliding_friction_matches_the_2dof_arms():
    """The same Stribeck law as the paper arm's friction_model: stribeck, at a few speeds."""
    common = dict(robot="fig3_arm", gravity=(0, 0, 0), friction=True, tau_c=[5.0, 3.5], tau_s=[5.75, 4.6],
                  friction_model="stribeck", stribeck_velocity=[2e-3, 2e-3])
    arm, free = RobotArm(**common), RobotArm(robot="fig3_arm", gravity=(0, 0, 0))
    for v in (5e-4, 2e-3, 1e-2):
        x = np.array([0.3, 0.5, 0.0, v])
        g = 3.5 + (4.6 - 3.5) * np.exp(-(v / 2e-3) ** 2)
        np.testing.assert_allclose(arm.derivatives(0, x, [np.zeros(2), np.zeros(6)]),
                                   free.derivatives(0, x, [np.array([0.0, -g]), np.zeros(6)]), atol=1e-12)
    with pytest.raises(ParameterError, match="karnopp, stribeck or lugre"):
        RobotArm(robot="fig3_arm", friction_model="coulomb")


def test_lugre_steady_sliding_is_the_stribeck_curve_and_at_rest_the_bristles_carry_the_force():
    common = dict(robot="fig3_arm", gravity=(0, 0, 0), friction=True, tau_c=[5.0, 3.5], tau_s=[5.75, 4.6],
                  stribeck_velocity=[2e-3, 2e-3])
    lugre, stribeck = RobotArm(friction_model="lugre", **common), RobotArm(friction_model="stribeck", **common)
    assert lugre.n_continuous == 6 and lugre.initial_state()[4:].tolist() == [0.0, 0.0]
    for v in (5e-4, 3e-3, 2e-2):
        g = 3.5 + (4.6 - 3.5) * np.exp(-(v / 2e-3) ** 2)
        z = g / 1e5  # z' = 0: steady sliding
        d = lugre.derivatives(0, np.array([0.3, 0.5, 0.0, v, 0.0, z]), [np.zeros(2), np.zeros(6)])
        assert d[5] == pytest.approx(0.0, abs=1e-15)
        ref = stribeck.derivatives(0, np.array([0.3, 0.5, 0.0, v]), [np.zeros(2), np.zeros(6)])
        np.testing.assert_allclose(d[:4], ref, atol=1e-12)
    # at rest under 2 N (below the 4.6 N static level) the bristles deflect F / sigma0 and hold it
    d = lugre.derivatives(0, np.array([0.3, 0.5, 0.0, 0.0, 0.0, 2.0 / 1e5]), [np.array([0.0, 2.0]), np.zeros(6)])
    np.testing.assert_allclose(d, 0.0, atol=1e-12)
    assert lugre.zero_crossings(0, np.zeros(6), None) is None  # smooth: no switches to locate
