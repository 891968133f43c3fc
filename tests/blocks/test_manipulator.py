import numpy as np
import pytest

from hybridsim.blocks.paper.manipulator import Manipulator
from hybridsim.errors import ParameterError


def test_eq5_eq6_without_friction_hand_checked():
    arm = Manipulator(friction=False, q0=(0.3, 0.5))
    x = np.array([0.3, 0.5, 0.0, 0.0])
    d = arm.derivatives(0, x, [np.array([1.0, 2.0]), np.array([3.0, 4.0])])
    # I1(0.5) = 3.98 - 2.625 + 1.6175 = 2.9725; F1 = 1 + 0.5*4 + 0.153*3 = 3.459
    assert d[2] == pytest.approx(3.459 / 2.9725, rel=1e-12)
    # (M2 + M3) = 7.26; F2 = 2 + 3
    assert d[3] == pytest.approx(5.0 / 7.26, rel=1e-12)
    assert list(d[:2]) == [0.0, 0.0]


def test_sliding_friction_opposes_velocity():
    arm = Manipulator(q0=(0.3, 0.5))
    x = np.array([0.3, 0.5, 0.1, -0.1])
    d = arm.derivatives(0, x, [np.zeros(2), np.zeros(2)])
    assert d[2] == pytest.approx(-5.0 / 2.9725)
    assert d[3] == pytest.approx(3.5 / 7.26)


def test_sticking_holds_below_static_limit_and_breaks_above():
    arm = Manipulator(q0=(0.3, 0.5))
    x = np.array([0.3, 0.5, 0.0, 0.0])
    held = arm.derivatives(0, x, [np.array([5.7, 4.5]), np.zeros(2)])
    assert held[2] == 0.0 and held[3] == 0.0
    moving = arm.derivatives(0, x, [np.array([0.0, 6.0]), np.zeros(2)])
    assert moving[3] == pytest.approx((6.0 - 4.6) / 7.26)


def test_stick_band_brings_velocity_to_rest():
    arm = Manipulator(q0=(0.3, 0.5), stick_band=1e-4, stick_time=1e-3)
    x = np.array([0.3, 0.5, 0.0, 5e-5])
    d = arm.derivatives(0, x, [np.zeros(2), np.zeros(2)])
    assert d[3] == pytest.approx(-5e-5 / 1e-3)


def test_endpoint0_uses_inverse_kinematics():
    arm = Manipulator(endpoint0=(0.5, 0.0))
    q = arm.initial_state()[:2]
    assert q[1] == pytest.approx(np.sqrt(0.5**2 - 0.153**2))
    assert q[0] == pytest.approx(np.arctan2(0.153, q[1]))


def test_zero_crossings_mark_stick_slip():
    arm = Manipulator()
    z = arm.zero_crossings(0, np.array([0, 0.5, 2e-4, -5e-5]), None)
    assert z[0] > 0 > z[1]


def _arm_alone(t_end, tau, **arm):
    """The arm with constant torques and no wrist force, from rest at q = (0.3, 0.5)."""
    import hybridsim as hs

    d = hs.Diagram("arm")
    d.add(Manipulator("arm", q0=(0.3, 0.5), **arm))
    d.add(hs.registry.lookup("constant")("tau", value=list(tau)))
    d.add(hs.registry.lookup("constant")("f", value=[0.0, 0.0]))
    d.connect("tau.y", "arm.tau")
    d.connect("f.y", "arm.f_wrist")
    return hs.Simulator(d.build(), hs.RK4(1e-5), log=["arm.q", "arm.qd"], log_period=0.01).run(t_end)


def test_stribeck_sliding_friction_falls_from_static_to_coulomb():
    import math

    arm = Manipulator(q0=(0.3, 0.5), friction_model="stribeck", stribeck_velocity=(1e-3, 2e-3))
    m2 = 6.68 + 0.58
    for v in (2e-3, 5e-3, 0.1):
        acc = arm.derivatives(0, np.array([0.3, 0.5, 0.0, v]), [np.zeros(2), np.zeros(2)])[3]
        g = 3.5 + (4.6 - 3.5) * math.exp(-(v / 2e-3) ** 2)  # g(v) of joint 2
        assert acc == pytest.approx(-g / m2, rel=1e-12)
    # inside the stick band it sticks as Karnopp does: friction cancels a force below tau_s
    acc = arm.derivatives(0, np.array([0.3, 0.5, 0.0, 0.0]), [np.array([0.0, 4.0]), np.zeros(2)])[3]
    assert acc == 0.0


def test_lugre_steady_sliding_equals_the_stribeck_curve():
    import math

    from hybridsim.blocks.paper.manipulator import lugre, stribeck_level

    arm = Manipulator(q0=(0.3, 0.5), friction_model="lugre", stribeck_velocity=(1e-3, 2e-3))
    p = arm.params
    for v in (-0.05, -1e-3, 5e-4, 2e-3, 0.2):
        g = stribeck_level(v, p.tau_c[1], p.tau_s[1], p.v_s[1])
        z_ss = math.copysign(g, v) / p.sigma0[1]  # z' = 0
        B, zd = lugre(p, 1, v, z_ss)
        assert zd == pytest.approx(0.0, abs=1e-15) and B == pytest.approx(-math.copysign(g, v), rel=1e-12)
    # and the bristle state gets there: held at 0.01 m/s from z = 0, z' -> 0 and B -> the curve
    z = 0.0
    for _ in range(100000):  # 0.1 s: the bristle's time constant g / (sigma0 v) is 3.5 ms here
        z += 1e-6 * lugre(p, 1, 0.01, z)[1]
    g = stribeck_level(0.01, p.tau_c[1], p.tau_s[1], p.v_s[1])
    assert lugre(p, 1, 0.01, z)[0] == pytest.approx(-g, rel=1e-6)


@pytest.mark.parametrize("force", [0.05, 2.0])
def test_lugre_presliding_deflection_follows_the_bristle_stiffness(force):
    res = _arm_alone(0.3, (0.0, force), friction_model="lugre", bristle_stiffness=(1e5, 1e5))
    x = res["arm.q[1]"][-1] - 0.5
    z = res.context.xc[5]  # joint 2's bristle deflection (the arm is the only continuous block)
    assert abs(res["arm.qd[1]"][-1]) < 1e-8  # it stopped: below break-away (4.6 N) it does not slide
    assert z == pytest.approx(force / 1e5, rel=1e-6)  # at rest the bristles carry the force: sigma0 z = F
    if force < 0.1:  # a small force: the linear bristle stiffness, x = F / sigma0
        assert x == pytest.approx(force / 1e5, rel=0.01)
    else:  # nearer break-away the bristles also slip a little (x > z); measured 2.73e-5 m for 2 N
        assert force / 1e5 < x < 1.5 * force / 1e5


def test_bad_friction_models_are_parameter_errors():
    with pytest.raises(ParameterError, match="friction_model"):
        Manipulator(friction_model="coulomb")
    with pytest.raises(ParameterError, match="tau_s"):
        Manipulator(tau_c=(5.0, 3.5), tau_s=(4.0, 4.6))


def test_balance_start_is_where_the_two_springs_carry_the_force():
    # 10 N through Kr = 9e5 and Kw = 8e5 in series: 10 (1/9e5 + 1/8e5) = 2.36111e-5 m past the surface
    arm = Manipulator(balance={"surface_x": 0.5, "force": 10.0, "Kr": 9e5, "Kw": 8e5})
    given = Manipulator(endpoint0=(0.5 + 10.0 / 9e5 + 10.0 / 8e5, 0.0))
    np.testing.assert_allclose(arm.x0, given.x0, rtol=0, atol=1e-15)
    q1, q2 = arm.x0[:2]
    assert np.cos(q1) * q2 + 0.153 * np.sin(q1) == pytest.approx(0.5000236111111, abs=1e-13)  # eq 1: X
    assert Manipulator(balance={"surface_x": 0.6, "force": 0.0, "Kr": 1, "Kw": 1, "y": 0.1}).x0[0] == \
        pytest.approx(Manipulator(endpoint0=(0.6, 0.1)).x0[0], abs=1e-15)


@pytest.mark.parametrize("kwargs, text", [
    ({"balance": {"surface_x": 0.5, "force": 1.0, "Kr": 9e5}}, "missing Kw"),
    ({"balance": {"surface_x": 0.5, "force": 1.0, "Kr": 9e5, "Kw": 8e5, "z": 1}}, "unknown z"),
    ({"balance": {"surface_x": 0.5, "force": 1.0, "Kr": 0.0, "Kw": 8e5}}, "balance.Kr"),
    ({"balance": [0.5, 1.0]}, "must be a mapping"),
    ({"balance": {"surface_x": 0.5, "force": 1.0, "Kr": 9e5, "Kw": 8e5}, "endpoint0": [0.5, 0]}, "both given"),
])
def test_bad_balance_is_a_parameter_error(kwargs, text):
    with pytest.raises(ParameterError, match=text):
        Manipulator(**kwargs)
