"""The example diagrams beyond the paper (diagrams/examples/) against closed-form and python-control answers."""
import numpy as np
import pytest

import hybridsim as hs
from conftest import DIAGRAMS

EXAMPLES = DIAGRAMS / "examples"


def test_msd_under_a_discrete_pid_equals_python_controls_sampled_loop():
    import control as ct

    res = hs.simulate(EXAMPLES / "msd_pid.yaml")
    T, Kp, Ki, Kd, N = 0.01, 20.0, 15.0, 4.0, 40.0
    plant = ct.sample_system(ct.tf([1.0], [1.0, 0.4, 4.0]), T, "zoh")
    z = ct.tf([1, 0], [1], T)
    pid = Kp + Ki * T * z / (z - 1) + Kd * N * (z - 1) / ((1 + N * T) * z - 1)
    k = np.arange(301)
    ref = ct.forced_response(ct.feedback(plant * pid, 1), T=k * T, U=np.ones(k.size)).outputs
    assert np.allclose(res.t[:301], k * T, rtol=0, atol=1e-12)
    # measured 1.6e-10 m, the same at steps of 1e-3, 1e-4 and 1e-5 s (python-control's round-off)
    assert np.max(np.abs(res["plant.y[0]"][:301] - ref)) < 1e-9


@pytest.mark.parametrize("name", sorted(p.name for p in EXAMPLES.glob("*.yaml")))
def test_every_example_checks_and_runs(name):
    assert hs.check(EXAMPLES / name) is not None
    res = hs.simulate(EXAMPLES / name, t_end=0.2)
    assert res.t[-1] == pytest.approx(0.2)


@pytest.mark.slow
def test_dc_motor_accelerates_at_the_current_limit_and_settles():
    res = hs.simulate(EXAMPLES / "dc_motor_speed.yaml")
    w, i, t = res["split.y1[0]"], res["split.y2[0]"], res.t
    assert i.max() <= 10.0 + 1e-6  # the speed PI's output limit is the current limit
    # at the limit J w' = Kt i_max - b w: w(1 s) = 500 (1 - exp(-0.1)) = 47.58 rad/s; the current
    # takes about a millisecond to reach 10 A, measured 47.53
    assert w[np.searchsorted(t, 1.0)] == pytest.approx(500 * (1 - np.exp(-0.1)), rel=2e-3)
    assert w[-1] == pytest.approx(100.0, abs=1e-2) and i[-1] == pytest.approx(0.001 * 100 / 0.05, abs=1e-2)
