"""An Experiment parses and builds a diagram once; a block-parameter change is made at run time."""
import warnings

import numpy as np
import pytest

from conftest import DIAGRAMS
from hybridsim.analysis import stability as an
from hybridsim.errors import InputError
from hybridsim.runs.experiment import Experiment

FIG9 = DIAGRAMS / "fig9_force_and_position.yaml"
KFP = np.array([0.4, 0.3])  # Appendix A


@pytest.fixture(scope="module")
def exp():
    return Experiment(FIG9, friction=False)


def test_changes_split_into_run_time_and_structural(exp):
    params, structural = exp.split({"ctrl.fpi.Kp": [1, 1], "arm.stick_band": 2e-4, "rate": 80, "delay_ticks": 1})
    assert params == {"ctrl.fpi.Kp": [1, 1], "arm.stick_band": 2e-4}
    assert structural == {"rate": 80, "delay_ticks": 1}  # a rate and a delay line change the structure
    # for runs, a name only block numbers use is made at run time in every block that uses it; a width is not
    assert exp.split({"Kr": 8e5})[1] == {"Kr": 8e5}
    params, structural = exp.split({"Kr": 8e5, "ctrl.fpi.Kp": [1, 2, 3]}, names=True)
    assert params["surface.Kr"] == 8e5 and params["arm.balance"]["Kr"] == 8e5
    assert structural == {"ctrl.fpi.Kp": [1, 2, 3]}
    same, p = exp.changed({"ctrl.fpi.Kp": [1, 1]})
    assert same is exp and p == {"ctrl.fpi.Kp": [1, 1]}
    same, p = exp.changed({"rate": exp.file.params["rate"]})  # the value it has: no rebuild
    assert same is exp and p == {}
    other, p = exp.changed({"rate": 80, "ctrl.fpi.Kp": [1, 1]})
    assert other is not exp and other.overrides == {"friction": False, "rate": 80} and p == {"ctrl.fpi.Kp": [1, 1]}


@pytest.mark.parametrize("scale, at", [(0.5, None), pytest.param(4.0, None, marks=pytest.mark.slow),
                                       pytest.param(2.0, 0.1, marks=pytest.mark.slow)])
def test_a_run_time_gain_change_is_the_rebuilt_diagrams_loop(exp, scale, at):
    """The same closed loop as re-parsing the file with the gain set (the reference), about the
    initial state and about the state reached at 0.1 s."""
    change = {"ctrl.fpi.Kp": (KFP * scale).tolist()}
    ours = exp.closed_loop(change, at=at)
    ref = an.linearization(FIG9, at=at, friction=False, **change).closed_loop()
    assert np.sort_complex(ours.poles) == pytest.approx(np.sort_complex(ref.poles), abs=1e-9)
    assert exp.closed_loop(at=at).growth != pytest.approx(ours.growth)  # the change did reach the loop


def test_a_change_of_width_is_refused_as_a_rebuild_would(exp):
    with pytest.raises(InputError, match="Kp"):
        exp.closed_loop({"ctrl.fpi.Kp": [1.0, 2.0, 3.0]})


@pytest.mark.slow
def test_analyze_takes_an_experiment():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a = an.analyze(FIG9, sweeps=False)
        b = an.analyze(Experiment(FIG9), sweeps=False)
    assert b["growth"] == a["growth"] and b["branch"] == a["branch"] == {"friction": False}
    assert b["cases"] == a["cases"]


def test_a_worker_that_kept_an_experiment_builds_an_edited_subsystem_anew(tmp_path):
    # a long-lived worker (Dask) keeps what it built; an edited subsystem file is another experiment
    import pickle

    sub = tmp_path / "sub.yaml"
    top = tmp_path / "top.yaml"
    sub.write_text("name: sub\nblocks:\n  k: {type: constant, value: 1.0}\noutputs: {y: k.y}\n")
    top.write_text("name: top\nblocks:\n  s: {type: subsystem, file: sub.yaml}\n  i: {type: integrator}\n"
                   "wires: [s.y -> i.u]\nlog: [i.y]\nsimulation: {t_end: 1.0, solver: rk4, step: 0.01}\n")
    first = pickle.loads(pickle.dumps(Experiment(top)))  # as a worker gets it
    assert first.run().table()[-1, 1] == pytest.approx(1.0)
    sub.write_text("name: sub\nblocks:\n  k: {type: constant, value: 3.0}\noutputs: {y: k.y}\n")
    again = pickle.loads(pickle.dumps(Experiment(top)))
    assert again is not first
    assert again.run().table()[-1, 1] == pytest.approx(3.0)
    assert pickle.loads(pickle.dumps(Experiment(top))) is again  # unchanged files: the kept one
