"""The fixed-step stability check (hybridsim.engine.stiffness): a step beyond the method's
stability region on a mode of the system is refused before the run."""
import numpy as np
import pytest

import hybridsim as hs
from hybridsim.engine.solvers import RK4, Heun
from hybridsim.engine.stiffness import longest_stable_step, stability_function
from hybridsim.errors import SimulationError

STIFF_LAG_INTO_LIMIT = """blocks:
  c: {type: constant, value: 1.0}
  ff: {type: first_order, tau: 1.0e-4, initial: 0.0}
  i: {type: integrator, upper: 0.5}
wires: [c.y -> ff.u, ff.y -> i.u]
simulation: {t_end: 0.2, step: 1.0e-3, log_period: 0.01}
log: [ff.y, i.y]
"""


def test_the_stability_functions_are_the_truncated_exponentials():
    # explicit RK with s = p <= 4 stages: R(z) = sum z^k / k!, k <= p. By hand: RK4 at z = -1 is
    # 1 - 1 + 1/2 - 1/6 + 1/24 = 0.375; Heun at z = -10 is 1 - 10 + 50 = 41
    assert stability_function(RK4.A, RK4.b, -1.0)[0] == pytest.approx(0.375, abs=1e-15)
    assert stability_function(Heun.A, Heun.b, -10.0)[0] == pytest.approx(41.0, abs=1e-12)
    assert abs(stability_function(Heun.A, Heun.b, 1j)[0]) == pytest.approx(np.sqrt(1.25), abs=1e-15)


def test_the_longest_stable_step_on_a_real_mode_is_the_methods_interval():
    # real stability intervals: Heun h |lam| <= 2, RK4 <= 2.785 (Hairer & Wanner IV.2), 5 % growth
    # over the exact step allowed on top, the bisection 2 % close
    lam = -1e4
    assert longest_stable_step(Heun.A, Heun.b, 1e-3, lam) == pytest.approx(2.0e-4, rel=0.03)
    assert longest_stable_step(RK4.A, RK4.b, 1e-3, lam) == pytest.approx(2.785e-4, rel=0.03)


@pytest.mark.parametrize("solver", ["heun", "rk4"])
def test_a_step_too_long_for_a_fast_lag_is_refused_naming_its_block(tmp_path, solver):
    # events at the integrator's limit cut heun's steps short: it used to end with ff.y = -2345
    # at 0.04 s and exit 0 (a lag to 1). Now the run is refused before it starts
    path = tmp_path / "d.yaml"
    path.write_text(STIFF_LAG_INTO_LIMIT)
    with pytest.raises(SimulationError, match=r"lambda = -1e\+04 1/s.*block 'ff'.*step <= 0\.000(2|28)"):
        hs.simulate(path, solver=solver)
    res = hs.simulate(path, solver=solver, step=1e-5, t_end=0.6)  # a stable step: the lag settles at 1
    assert res["ff.y"][-1, 0] == pytest.approx(1.0, abs=1e-9)
    assert res["i.y"][-1, 0] == pytest.approx(0.5, abs=1e-12)
