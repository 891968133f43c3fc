"""The compiled path's rigid-body algorithms (blocks/robot/rigid.py) against Pinocchio's, on every robot
example-robot-data ships that the robot blocks accept.

Oracle: Pinocchio's ABA, RNEA, CRBA and frame Jacobian (LOCAL_WORLD_ALIGNED) and frame placement on
the same model at random states, each to 1e-12 of max(1, Pinocchio's largest entry). Once in plain
Python, once compiled by numba (the code the compiled path runs). The robots refused are refused
with a reason: continuous joints, a floating base, no moving joint, a file that is no URDF.
"""
import numpy as np
import pytest

pin = pytest.importorskip("pinocchio")

from hybridsim.blocks.robot import rigid  # noqa: E402
from hybridsim.blocks.robot.arm import RobotArm, load_model, robots_folder  # noqa: E402
from hybridsim.errors import ParameterError  # noqa: E402

FOLDER = robots_folder()
URDFS = sorted(str(p.relative_to(FOLDER)) for p in FOLDER.rglob("*.urdf")) if FOLDER else []
#: why a robot may be refused, as the messages say it
REASONS = ("continuous: an unbounded revolute joint", "a floating base", "planar", "spherical",
           "has no moving joint", "is not a robot model Pinocchio can read")
TOL = 1e-12


def model_or_reason(rel):
    try:
        return load_model(FOLDER / rel), None
    except ParameterError as exc:
        return None, str(exc)


def close(got, want):
    return np.max(np.abs(got - want)) <= TOL * max(1.0, np.max(np.abs(want)))


def check(model, algorithms, states=3, seed=0):
    """Compare ``algorithms`` (aba, rnea, crba, tool: rigid's or their numba builds) with Pinocchio's
    at random states, with the tool frame the model's last; returns whether ABA was defined."""
    aba, rnea, crba, tool = algorithms
    data = model.createData()
    fid = len(model.frames) - 1
    tree = rigid.tree(model, fid)
    rng = np.random.default_rng(seed)
    defined = True
    for _ in range(states):
        q, v, a, tau = rng.uniform(-np.pi, np.pi, model.nq), rng.normal(size=model.nv), \
            rng.normal(size=model.nv), rng.normal(size=model.nv)
        assert close(rnea(tree, q, v, a), pin.rnea(model, data, q, v, a)), "rnea"
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T  # Pinocchio fills the upper triangle
        assert close(crba(tree, q), M), "crba"
        R, p, J = tool(tree, q)
        assert close(J, pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)), "jacobian"
        pose = pin.updateFramePlacement(model, data, fid)
        assert close(R, pose.rotation) and close(p, pose.translation), "placement"
        want = pin.aba(model, data, q, v, tau)
        if np.all(np.isfinite(want)):
            assert close(aba(tree, q, v, tau), want), "aba"
        else:  # a joint that moves no mass: no forward dynamics, and robot_arm says so
            defined = False
    return defined


PLAIN = (rigid.aba, rigid.rnea, rigid.crba, rigid.tool)


@pytest.mark.skipif(not URDFS, reason="example-robot-data is not installed")
def test_every_shipped_robot_is_taken_or_refused_with_its_reason():
    taken, refused = [], []
    for rel in URDFS:
        model, why = model_or_reason(rel)
        if model is None:
            assert any(r in why for r in REASONS), why
            refused.append(rel)
        else:
            taken.append(rel)
    assert len(taken) >= 50 and "ur_description/urdf/ur5_robot.urdf" in taken
    assert "kinova_description/robots/kinova.urdf" in refused  # continuous joints


@pytest.mark.parametrize("rel", [r for r in URDFS if model_or_reason(r)[0] is not None and
                                 load_model(FOLDER / r).nv <= 12])
def test_rigid_algorithms_equal_pinocchios_in_python(rel):
    """Plain Python on the smaller trees (up to 12 joints); numba runs them all, below."""
    check(load_model(FOLDER / rel), PLAIN, states=2)


def test_an_arm_with_a_massless_joint_is_refused_with_the_joint_named():
    rel = "romeo_description/urdf/romeo.urdf"
    if rel not in URDFS:
        pytest.skip("no romeo in this example-robot-data")
    assert not check(load_model(FOLDER / rel), PLAIN, states=1)
    with pytest.raises(ParameterError, match="move no mass"):
        RobotArm(urdf=str(FOLDER / rel))


def test_a_tree_of_prismatic_and_unaligned_joints_with_armature():
    """panda: its fingers are prismatic (one unaligned); armature set on every joint (the rotor
    inertia Pinocchio adds to M's diagonal and ABA's D)."""
    model = load_model(FOLDER / "panda_description/urdf/panda.urdf").copy()
    model.armature[:] = np.linspace(0.1, 0.5, model.nv)
    assert check(model, PLAIN, states=3, seed=4)


@pytest.fixture(scope="module")
def compiled_algorithms():
    numba = pytest.importorskip("numba")
    from hybridsim.engine.kernels import make_jitable

    make_jitable()  # the algorithms and the spatial helpers they call
    return (numba.njit(lambda tr, q, v, tau: rigid.aba(tr, q, v, tau)),
            numba.njit(lambda tr, q, v, a: rigid.rnea(tr, q, v, a)),
            numba.njit(lambda tr, q: rigid.crba(tr, q)), numba.njit(lambda tr, q: rigid.tool(tr, q)))


@pytest.mark.slow
@pytest.mark.skipif(not URDFS, reason="example-robot-data is not installed")
def test_rigid_algorithms_compiled_by_numba_equal_pinocchios_on_every_shipped_robot(compiled_algorithms):
    checked, no_dynamics = [], []
    for k, rel in enumerate(URDFS):
        model, _ = model_or_reason(rel)
        if model is not None:
            (checked if check(model, compiled_algorithms, states=5, seed=k) else no_dynamics).append(rel)
    assert len(checked) + len(no_dynamics) >= 50
