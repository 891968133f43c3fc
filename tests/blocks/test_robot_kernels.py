"""The plant kernels of the robot blocks (blocks/robot/kernels.py) against the blocks' methods, and the
UR5 press-and-trace on the fused and compiled paths against the generic path.

Oracles: the blocks' methods (numpy and Pinocchio, the generic path's reference) on random states
and inputs, for both bodies of each rigid-body kernel: the fused path's (Pinocchio) and its twin
(blocks/robot/rigid.py, what numba compiles), run here in plain Python; Pinocchio's own frame
Jacobian for the reused one; the generic path's run of the diagram.
"""
import numpy as np
import pytest

pytest.importorskip("pinocchio")

import hybridsim as hs  # noqa: E402
from hybridsim.blocks.robot import kernels as rk  # noqa: E402
from hybridsim.blocks.robot.arm import GravityTorque, RobotArm, RobotKinematics  # noqa: E402
from hybridsim.blocks.robot.sensing import ForceTorqueSensor  # noqa: E402
from hybridsim.blocks.robot.contact import PlaneContact  # noqa: E402

from conftest import DIAGRAMS  # noqa: E402

RNG = np.random.default_rng(25)
UR5 = DIAGRAMS / "ur5_press_and_trace.yaml"


def close(a, b, tol=1e-12):
    a, b = np.concatenate([np.ravel(v) for v in a]), np.concatenate([np.ravel(v) for v in b])
    return np.max(np.abs(a - b) / np.maximum(1.0, np.abs(b))) < tol


def twin_params(block):
    """``block.params`` as another process would hold them: no Pinocchio model under its number
    (the kernels then run their twins, the code numba compiles)."""
    p = block.params
    return p._replace(tree=p.tree._replace(model=-1))


@pytest.mark.parametrize("robot", ["ur5", "panda", "fig3_arm"])
@pytest.mark.parametrize("friction", [None, "karnopp", "stribeck", "lugre"])
def test_arm_kernels_equal_the_methods(robot, friction):
    kw = dict(friction=True, tau_c=0.5, tau_s=0.8, friction_model=friction) if friction else {}
    arm = RobotArm("arm", robot=robot, damping=0.3, **kw)
    for _ in range(5):
        x = RNG.normal(size=arm.n_continuous)
        x[arm.n:2 * arm.n] *= 1e-4 if RNG.random() < 0.5 else 1.0  # stuck and sliding joints
        u = [RNG.normal(size=arm.n), RNG.normal(size=6) * 5.0]
        rk._TOOLS.clear()
        for p in (arm.params, twin_params(arm)):
            assert close(arm.kernels.derivatives(p, 0.0, tuple(x), tuple(map(tuple, u))),
                         arm.derivatives(0.0, x, u))
            assert close(arm.kernels.output(p, 0.0, tuple(x), ()), arm.output(0.0, x, u))


def test_kinematics_kernel_equals_the_method_and_the_arm_reuses_its_jacobian():
    import pinocchio as pin

    kin = RobotKinematics("kin", robot="ur5", frame="tool0")
    arm = RobotArm("arm", robot="ur5", frame="tool0")
    assert kin.params.tool == arm.params.tool  # one tool frame, whatever the arm's gravity
    rk._TOOLS.clear()
    for _ in range(5):
        q, qd = RNG.normal(size=6), RNG.normal(size=6)
        for p in (kin.params, twin_params(kin)):
            got = kin.kernels.output(p, 0.0, (), (tuple(q), tuple(qd)))
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


@pytest.mark.parametrize("robot", ["ur5", "panda"])
def test_gravity_kernel_equals_the_method(robot):
    g = GravityTorque("g", robot=robot, gravity=(0.5, -1.0, -9.0))
    for _ in range(5):
        q = RNG.uniform(-3, 3, g.n)
        for p in (g.params, twin_params(g)):
            assert close(g.kernels.output(p, 0.0, (), (tuple(q),)), g.output(0.0, None, [q]))


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
        tup = tuple(tuple(v) for v in up)
        assert close(plane.kernels.output(plane.params, 0.0, (), tup), plane.output(0.0, None, up))
        assert close(plane.kernels.zero_crossings(plane.params, 0.0, (), tup), plane.zero_crossings(0.0, None, up))


def _numbers_only(value, where):
    """Assert ``value`` is what numba takes in params: floats, ints, bools, C-contiguous numeric
    arrays, and tuples (named or not) of them."""
    if isinstance(value, tuple):
        for k, v in enumerate(value):
            _numbers_only(v, f"{where}[{getattr(value, '_fields', range(len(value)))[k]}]")
    elif isinstance(value, np.ndarray):
        assert value.flags.c_contiguous and value.dtype.kind in "fib", where
    else:
        assert isinstance(value, (bool, int, float)), (where, value)


def test_every_robot_blocks_params_are_numbers_and_arrays():
    system, _, _ = hs.build(UR5)
    for b in system.blocks:
        _numbers_only(b.params, b.name)
    _numbers_only(RobotArm(robot="panda", friction=True, friction_model="lugre").params, "lugre arm")


@pytest.mark.slow
def test_ur5_press_and_trace_fused_equals_generic():
    # 0.7 s: the approach, first touch (~0.19 s), the press with its force ramp, the trace's start
    runs = {f: hs.simulate(UR5, t_end=0.7, fused=f) for f in (False, True)}
    generic, fused = runs[False], runs[True]
    assert generic.meta["solver"] == fused.meta["solver"]
    assert fused["phases.phase"].max() >= 1  # it reached the press
    for ref in ("hybrid.F_C", "ft.F", "hybrid.tau"):
        assert np.max(np.abs(fused[ref] - generic[ref])) < 1e-9, ref  # N (N m for tau)
    assert np.max(np.abs(fused["kin.p"] - generic["kin.p"])) < 1e-12


def test_the_fused_path_is_taken_and_the_compiled_path_takes_the_ur5():
    from hybridsim.engine.compiled import problems
    from hybridsim.engine.simulator import located_events

    system, sim, _ = hs.build(UR5)
    assert sim._fused is not None
    assert problems(system, sim.solver, located_events(system, sim.solver)) == []


def test_an_arm_has_event_functions_only_with_karnopp_friction_and_as_a_kernel():
    # its zero_crossings method (None without friction) made every arm a block with events given as
    # methods: the compiled path refused the UR5 with a table naming 'arm', and any friction arm
    from hybridsim.engine.compiled import problems
    from hybridsim.engine.simulator import located_events

    assert not RobotArm("arm", robot="ur5").has_zero_crossings
    arm = RobotArm("arm", robot="ur5", friction=True, tau_c=0.5, tau_s=0.8)
    x = RNG.normal(size=arm.n_continuous)
    assert np.array_equal(arm.zero_crossings(0.0, x, None), np.abs(x[6:12]) - arm.band)
    system, sim, _ = hs.build(UR5, **{"arm.friction": True, "arm.tau_c": 0.5, "arm.tau_s": 0.8,
                                      "simulation.locate_switches": True})
    assert problems(system, sim.solver, located_events(system, sim.solver, True)) == []


@pytest.mark.slow
def test_the_rigid_body_kernels_compiled_by_numba_equal_the_methods():
    """The numba builds of the arm's (every friction model), the kinematics' and gravity's kernels
    (what a call of them compiles to: their twins) against the methods, panda (a prismatic finger)."""
    numba = pytest.importorskip("numba")
    from hybridsim.engine import native
    from hybridsim.engine.kernels import make_jitable

    native.use_cache_dir()
    make_jitable()  # as the compiled path registers them (the rigid-body algorithms cached on disk)

    def jit(kernel):
        return numba.njit(lambda p, x, u: kernel(p, 0.0, x, u))

    kin = RobotKinematics("kin", robot="panda", frame="panda_hand")
    grav = GravityTorque("g", robot="panda")
    arms = [RobotArm("arm", robot="panda", frame="panda_hand", damping=0.3, **kw) for kw in
            ({}, dict(friction=True, tau_c=0.5, tau_s=0.8), dict(friction=True, tau_c=0.5, tau_s=0.8,
                                                                 friction_model="stribeck"),
             dict(friction=True, tau_c=0.5, tau_s=0.8, friction_model="lugre"))]
    output, gravity = jit(rk.kinematics_output), jit(rk.gravity_output)
    derivatives = {arm.kernels.derivatives: jit(arm.kernels.derivatives) for arm in arms}
    for _ in range(3):
        q, qd = RNG.uniform(-1, 1, 9), RNG.normal(size=9)
        assert close(output(kin.params, (), (q, qd)), kin.output(0.0, None, [q, qd]))
        assert close(gravity(grav.params, (), (q,)), grav.output(0.0, None, [q]))
        for arm in arms:
            x = RNG.normal(size=arm.n_continuous)
            x[9:18] *= 1e-4 if RNG.random() < 0.5 else 1.0
            u = (RNG.normal(size=9), RNG.normal(size=6) * 5.0)
            got = derivatives[arm.kernels.derivatives](arm.params, tuple(x), u)
            assert close([got], [arm.derivatives(0.0, x, u)])


@pytest.mark.slow
def test_ur5_press_and_trace_compiled_equals_generic():
    # 0.7 s: the approach, first touch, the press and the trace's start (every phase)
    generic = hs.simulate(UR5, t_end=0.7, fused=False)
    compiled = hs.simulate(UR5, t_end=0.7, compiled=True)  # or CompiledPathError
    assert compiled["phases.phase"].max() == 2 and generic["phases.phase"].max() == 2
    for ref in ("hybrid.F_C", "ft.F", "phases.F_d"):
        assert np.max(np.abs(compiled[ref] - generic[ref])) < 1e-9, ref  # N
    assert np.max(np.abs(compiled["hybrid.tau"] - generic["hybrid.tau"])) < 1e-9  # N m
    assert np.max(np.abs(compiled["kin.p"] - generic["kin.p"])) < 1e-12  # m
