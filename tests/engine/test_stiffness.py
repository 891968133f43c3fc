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


@pytest.mark.slow
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


def test_the_mode_is_named_by_the_state_that_takes_part_in_it_not_the_one_it_moves():
    # a transfer function's lag (state scaled by 1e4 into its output) feeding an integrator: the
    # eigenvector of -1e4 is larger on the integrator's state, which was named; the participation
    # factor |left * right| of the integrator is 0 (the helper's diagram, heun at 1 ms)
    d = hs.Diagram("d")
    from hybridsim.blocks.continuous.basic import Integrator, TransferFunction
    from hybridsim.blocks.sources.basic import Constant

    d.add(Constant("one", 1.0))
    d.add(TransferFunction("ff", num=[1.0], den=[1e-4, 1.0]))
    d.add(Integrator("int", upper=1.0, lower=-1.0))
    d.connect("one.y", "ff.u")
    d.connect("ff.y", "int.u")
    with pytest.raises(SimulationError, match=r"lambda = -1e\+04 1/s.*mostly state 0 of block 'ff'"):
        hs.Simulator(d.build(), Heun(1e-3)).run(0.04)


KINK_AT_START = """blocks:
  f: {type: lookup_1d, x: [-2.0, 1.0, 3.0], y: [-2000.0, 1000.0, 1001.0], extrapolation: linear}
  g: {type: gain, K: -1.0}
  x: {type: integrator, initial: 1.0}
wires: [x.y -> f.u, f.y -> g.u, g.y -> x.u]
simulation: {t_end: 0.2, step: 1.0e-2, log_period: 0.01, solver: rk4}
log: [x.y]
"""


def test_both_sides_of_a_kink_at_the_initial_state_are_judged(tmp_path):
    # x' = -f(x), f of slope 1000 below x = 1 and 0.5 above, x(0) = 1 on the kink: x = exp(-1000 t).
    # Central differences read the mean slope (-500) and advised h <= 5.5 ms, which diverged (exit 0,
    # x between -0.71 and 5.03); the side the motion takes has -1000: rk4 needs h <= 2.8 ms
    path = tmp_path / "d.yaml"
    path.write_text(KINK_AT_START)
    for h in (1e-2, 5.5e-3):
        with pytest.raises(SimulationError, match=r"lambda = -1000 1/s.*step <= 0\.002[78]"):
            hs.simulate(path, step=h)
    res = hs.simulate(path, step=2e-3)
    assert abs(res["x.y"][-1, 0]) < 1e-12 and np.all(np.diff(res["x.y"][:, 0]) <= 0)


def test_a_contact_about_to_open_counts_with_its_spring():
    # eq 18's hand pressed on a stiff surface (Kr = 1e6 N/m, 3 N: 3 um deep): the longer difference
    # step left the contact and the spring was dropped as a kink; rk4 at 2 ms was accepted and the
    # hand bounced off (40 N, contact lost; 3-7 N and contact kept at 10 us)
    from conftest import DIAGRAMS

    with pytest.raises(SimulationError, match=r"too long for rk4.*block 'wrist'"):
        hs.simulate(DIAGRAMS / "eq18_hand_oscillation.yaml", step=2e-3, Kr=1e6)
