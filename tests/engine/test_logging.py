"""Logging only observes: the log grid never changes the simulated answer.

The solver's step grid depends on the sample hits and the step alone; log
rows between hits come from the method's dense output. Fig 9 (60 Hz, friction
on: chaotic once contact is lost, so any perturbation would grow) is run with
three log periods on every path; final states are equal bit for bit and so
are the values at common log times. Before, 0.5 ms and 0.3 ms logs differed
by 5.8 mN at 0.2 s and by up to 10.6 N later.
"""
import numpy as np
import pytest

import hybridsim as hs
from hybridsim.engine.solvers import Heun, RK4

from conftest import DIAGRAMS

FIG9 = DIAGRAMS / "fig9_force_and_position.yaml"
PERIODS = (0.0005, 0.0003, 1 / 2400)


def common_rows(a, b):
    """Rows of results a and b at the times both logged."""
    ia, ib = [], []
    j = 0
    for i, t in enumerate(a.t):
        while j < len(b.t) and b.t[j] < t - 1e-12:
            j += 1
        if j < len(b.t) and abs(b.t[j] - t) <= 1e-12:
            ia.append(i)
            ib.append(j)
    return a.table()[ia, 1:], b.table()[ib, 1:]


@pytest.mark.slow
@pytest.mark.parametrize("settings", [
    {"fused": False}, {}, {"compiled": True},
    {"solver": "heun", "step": 5e-5, "fused": False}, {"solver": "heun", "step": 5e-5},
    {"solver": "heun", "step": 5e-5, "compiled": True},
    {"solver": "dop853", "rtol": 1e-8, "t_end": 0.3},
], ids=["rk4-generic", "rk4-fused", "rk4-compiled", "heun-generic", "heun-fused", "heun-compiled",
        "dop853"])
def test_the_log_period_does_not_change_the_answer(settings):
    settings = {"rate": 60, "t_end": 1.0, **settings}
    runs = [hs.simulate(FIG9, log_period=p, **settings) for p in PERIODS]
    ref = runs[0]
    for other in runs[1:]:
        assert np.array_equal(ref.context.xc, other.context.xc)
        x, y = common_rows(ref, other)
        assert len(x) >= 100
        assert np.array_equal(x, y)


@pytest.mark.slow
def test_the_added_method_runs_bit_for_bit_on_every_path():
    runs = [hs.simulate(FIG9, rate=120, t_end=0.3, solver="heun", step=5e-5, **kw)
            for kw in ({"fused": False}, {}, {"compiled": True})]
    for r in runs[1:]:
        assert np.array_equal(runs[0].table(), r.table())
        assert np.array_equal(runs[0].context.xc, r.context.xc)
    # and it is a second-order method: halving the step quarters the error on x' = -x
    errs = []
    for h in (0.02, 0.01):
        x, _ = Heun(h).advance(lambda t, x: -x, 0.0, 1.0, np.array([1.0]))
        errs.append(abs(x[0] - np.exp(-1.0)))
    assert errs[0] / errs[1] == pytest.approx(4.0, rel=0.05)


def test_dense_output_is_accurate_between_steps():
    # x' = cos t from 0: x = sin t; RK4's dense output is of order 3, exact at step points
    x, outs = RK4(0.01).advance(lambda t, x: np.array([np.cos(t)]), 0.0, 1.0, np.zeros(1),
                                [0.25, 0.253, 0.5, 0.5071])
    assert [o[0] for o in outs] == pytest.approx(np.sin([0.25, 0.253, 0.5, 0.5071]), abs=1e-9)


@pytest.mark.parametrize("settings", [{"fused": False}, {}, {"solver": "dop853", "rtol": 1e-8}, {"solver": "cvode"}],
                         ids=["rk4-generic", "rk4-fused", "dop853", "cvode"])
def test_a_run_without_log_rows_ends_in_the_same_state(settings):
    # an operating point (analyze --at) ran with the full log: a 30 s run interpolated 60,000 log
    # points it threw away (1.2 s of each of the 24 runs of a gain boundary search)
    _, sim, _ = hs.build(FIG9, rate=60, t_end=0.2, **settings)
    logged, bare = sim.run(0.2), sim.run(0.2, logged=False)
    assert len(logged.t) >= 400 and len(bare.t) == 0
    for a, b in ((logged.context.xc, bare.context.xc), (logged.context.z, bare.context.z)):
        if settings.get("solver") == "cvode":  # CVODE returns at each log time: the same run within its tolerance
            assert np.allclose(a, b, rtol=1e-4, atol=1e-7)
        else:
            assert np.array_equal(a, b)


@pytest.mark.parametrize("solver", ["rk4", "radau"])
def test_the_last_row_is_at_t_end_off_the_log_grid_too(tmp_path, solver):
    # t_end 0.2537 logged every 0.1 s ended at 0.2: the run's final value was not in its log
    p = tmp_path / "d.yaml"
    p.write_text("blocks:\n  c: {type: constant, value: 2.0}\n  i: {type: integrator}\nwires: [c.y -> i.u]\n"
                 f"log: [i.y]\nsimulation: {{t_end: 0.2537, log_period: 0.1, solver: {solver}}}\n")
    res = hs.simulate(p)
    np.testing.assert_allclose(res.t, [0.0, 0.1, 0.2, 0.2537], rtol=0, atol=1e-15)
    np.testing.assert_allclose(res["i.y"][:, 0], 2.0 * res.t, rtol=0, atol=1e-9)
