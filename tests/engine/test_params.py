"""Parameters at run time: sim.run(params=...), the batch call, and batched sweeps."""
import numpy as np
import pytest

import hybridsim as hs
from hybridsim.errors import InputError, ParameterError, SimulationError

from conftest import DIAGRAMS, ROOT

FIG10 = DIAGRAMS / "fig10_force_ramp.yaml"
SMOOTH = ROOT / "tests" / "data" / "smooth_contact.yaml"


@pytest.mark.slow
@pytest.mark.parametrize("path", [{"fused": False}, {}, {"compiled": True}], ids=["generic", "fused", "compiled"])
def test_run_time_params_equal_a_rebuilt_diagram(path):
    change = {"arm.stick_band": 3e-4, "ctrl.fpi.Ki": [200.0, 180.0]}
    _, sim, _ = hs.build(FIG10, t_end=0.5, **path)
    a = sim.run(0.5, params=change)
    b = hs.simulate(FIG10, t_end=0.5, **path, **change)
    assert np.array_equal(a.table(), b.table())
    # and the built simulator is unchanged for the next run
    assert np.array_equal(sim.run(0.5).table(), hs.simulate(FIG10, t_end=0.5, **path).table())


def test_a_change_of_structure_is_refused_with_the_parameter_named():
    _, sim, _ = hs.build(FIG10)
    with pytest.raises(ParameterError, match="'rate' would change the structure of block 'ctrl.pid'"):
        sim.run(0.1, params={"ctrl.pid.rate": 120})
    with pytest.raises(ParameterError, match="'width'"):
        sim.run(0.1, params={"ctrl.dF.width": 3})
    with pytest.raises(InputError, match="did you mean 'arm'"):
        sim.run(0.1, params={"amr.M2": 3.0})
    with pytest.raises(ParameterError, match="'M3' must be positive"):
        sim.run(0.1, params={"arm.M3": 0.0})


@pytest.mark.slow
def test_batch_equals_single_runs_and_reports_divergence_in_place():
    _, sim, _ = hs.build(SMOOTH, t_end=0.3, compiled=True)
    sets = [{"arm.damping": [d, 10 * d]} for d in (50.0, 100.0, 200.0)] + [{"ctrl.fpi.Ki": [1e9, 1e9]}]
    out = sim.run_batch(0.3, sets, workers=2)
    for params, r in zip(sets[:3], out[:3]):
        assert np.array_equal(r.table(), sim.run(0.3, params=params).table())
    assert isinstance(out[3], SimulationError) and "diverged" in str(out[3])


def test_runtime_params_of_a_file_follow_dollar_references():
    f = hs.load(DIAGRAMS / "fig7_force_steps.yaml", force=5.0, rate=60)
    # Kr also moves the arm's balanced start (X = surface_x + force0 (1/Kr + 1/Kw))
    assert f.runtime_params({"Kr": 1e6, "ctrl.fpi.Kp": [1, 2]}) == {
        "surface.Kr": 1e6, "ctrl.fpi.Kp": [1, 2],
        "arm.balance": {"surface_x": 0.5, "force": 0.0, "Kr": 1e6, "Kw": 8e5}}
    with pytest.raises(InputError, match="a setting of .simulation."):
        f.runtime_params({"simulation.t_end": 1})


@pytest.mark.slow
def test_an_unrelated_kernel_does_not_change_the_compiled_module():
    from hybridsim.engine.kernels import kernel

    _, sim, _ = hs.build(SMOOTH, compiled=True)
    before = sim._compiled.source

    @kernel
    def unrelated_kernel(p, t, x, u):  # defined anywhere: Fig 6 does not reach it
        return (x,)

    _, sim, _ = hs.build(SMOOTH, compiled=True)
    assert sim._compiled.source == before


LOOKUP = """\
blocks:
  clk: {type: clock}
  lut: {type: lookup_1d, x: [0.0, 0.5, 1.0], y: [0.0, 1.0, 0.0]}
  int: {type: integrator}
wires: [clk.y -> lut.u, lut.y -> int.u]
simulation: {t_end: 1.0, solver: rk4, step: 1.0e-3, log_period: 0.01}
log: [lut.y, int.y]
"""


@pytest.mark.slow
def test_a_longer_table_at_run_time_runs_compiled_as_on_the_python_path(tmp_path):
    # the compiled path refused it ("its params changed their layout"), and the whole batch with it
    path = tmp_path / "lut.yaml"
    path.write_text(LOOKUP)
    longer = {"lut.x": [0.0, 0.2, 0.4, 0.6, 0.8, 1.0], "lut.y": [0.0, 1.0, -1.0, 2.0, -2.0, 3.0]}
    _, sim, _ = hs.build(path, compiled=True)
    _, generic, _ = hs.build(path, fused=False)
    out = sim.run_batch(1.0, [{}, longer, {}], workers=2)
    assert np.array_equal(out[1].table(), generic.run(1.0, params=longer).table())
    assert np.array_equal(out[0].table(), out[2].table())
    assert np.array_equal(out[0].table(), generic.run(1.0).table())
    assert out[1]["lut.y"][-1, 0] == 3.0  # the longer table's end
