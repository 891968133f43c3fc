"""The generic N-joint, six-axis controller reproduces the paper's 2-D one, tick by tick; a 6-DOF arm presses and traces."""
import numpy as np
import pytest

import hybridsim as hs
from conftest import DIAGRAMS


@pytest.mark.parametrize("fig, base, t_end, rates, tol", [
    ("fig10_generic", "fig10_force_ramp", 1.0, (60,), 1e-6),
    ("fig9_generic", "fig9_force_and_position", 0.25, (60, 80, 120), 1e-4),
])
def test_the_generic_controller_reproduces_the_papers_figures(fig, base, t_end, rates, tol):
    """URDF kinematics + wrench_transform + hybrid_control_6d around the paper's plant: the force and
    position at every tick equal the 2-D controller's (measured 4e-16 N on Fig 10; 1.9e-10 N on Fig 9,
    whose sampled loop is unstable inside the limiter band and grows round-off)."""
    for rate in rates:
        ov = dict(rate=rate, t_end=t_end, log_period=1 / rate)
        paper = hs.simulate(DIAGRAMS / f"{base}.yaml", **ov)
        generic = hs.simulate(DIAGRAMS / f"{fig}.yaml", **ov)
        assert np.max(np.abs(paper["ctrl.ft.CF"][:, 0] - generic["ctrl.planar.y1"][:, 0])) < tol, rate
        assert np.max(np.abs(paper["ctrl.fk.X"][:, 1] - generic["ctrl.Xp.y1"][:, 1])) < tol * 1e-3, rate
        assert np.max(np.abs(paper["ctrl.tau.y"] - generic["ctrl.hybrid.tau"])) < tol, rate
