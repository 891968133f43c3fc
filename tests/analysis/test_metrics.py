"""The metrics layer (hybridsim.analysis.metrics): settings the run does not reach."""
import numpy as np
import pytest

import hybridsim.forcecontrol  # noqa: F401 - registers the force-control metrics and their settings
from hybridsim.analysis import metrics
from hybridsim.engine.result import Result


def _run(t_end):
    t = np.linspace(0.0, t_end, 101)
    f = np.where(t >= 0.1, 1.0, 0.0)
    return Result(t, {"f.y": f[:, None], "fd.y": f[:, None]}, {"wall_time_s": 0.0})


def test_times_the_run_does_not_reach_are_left_out_with_a_note():
    # a 0.25 s run: a step at 0.3 s and an error window up to 0.5 s were computed over whatever
    # part of the run there was (a window past the end: the whole run), without a word
    cfg, notes = metrics.within_run({"step_time": 0.3, "ss_window": 2.0, "error_window": [0.1, 0.5],
                                     "filter_cutoff": 12.0}, 0.25)
    assert cfg == {"ss_window": 0.25, "filter_cutoff": 12.0}
    assert notes == ["metrics step_time: 0.3 s is not before the end of the run (t_end 0.25 s); the metrics "
                     "that need it are left out",
                     "metrics ss_window: 2 s is longer than the run (t_end 0.25 s); the whole run is taken",
                     "metrics error_window: [0.1, 0.5] s does not lie within the run (t_end 0.25 s); the "
                     "metrics that need it are left out"]
    res = _run(0.25)
    m = metrics.compute(res, {"force": "f.y", "force_desired": "fd.y"},
                        {"step_time": 0.3, "error_window": [0.1, 0.5]})
    assert "rise_time_s" not in m and "force_error_max_raw_N" not in m
    assert len(res.meta["metric_notes"]) == 2


def test_settings_inside_the_run_are_used_as_given():
    cfg, notes = metrics.within_run({"step_time": 0.1, "ss_window": 0.25, "error_window": [0.0, 0.25]}, 0.25)
    assert notes == [] and cfg == {"step_time": 0.1, "ss_window": 0.25, "error_window": [0.0, 0.25]}
    m = metrics.compute(_run(0.25), {"force": "f.y", "force_desired": "fd.y"}, {"step_time": 0.1})
    assert m["ss_force_error_raw_N"] == pytest.approx(0.0)


def test_no_note_without_metrics_or_for_a_default():
    # a diagram with no signal roles got a note on the default ss_window (0.5 s) of a 0.25 s run
    res = _run(0.25)
    metrics.compute(res, {}, {"ss_window": 0.5, "filter_cutoff": 12.0})
    assert res.meta.get("metric_notes", []) == []
    cfg, notes = metrics.within_run({"ss_window": 0.5}, 0.25)  # the table's default: the whole run, unsaid
    assert notes == [] and cfg == {"ss_window": 0.5}


def test_a_filter_far_slower_than_the_run_holds_its_first_value_with_a_note():
    # filter_cutoff 1e-9 Hz at 100 Hz logging: scipy's design of the filter is singular, and the run
    # ended with exit 3, "the linearized model has no finite solution"
    t = np.arange(21) * 0.01
    y = 1.0 + np.sin(10 * t)
    assert np.array_equal(metrics.lowpass(t, y, 1e-9), np.ones(21))
    slow, fast = metrics.lowpass(t, y, 1e-3), metrics.lowpass(t, y, 5.0)
    assert np.all(np.isfinite(slow)) and abs(slow[-1] - 1.0) < 1e-6 and abs(fast[-1] - 1.0) > 0.01
    _, notes = metrics.within_run({"filter_cutoff": 1e-9}, 0.2)
    assert notes and "filter_cutoff" in notes[0]


def test_a_window_between_two_log_points_is_left_out_with_a_note():
    # error_window [0.1001, 0.1002] at a 0.01 s log: force_error_max None and no note
    t = np.arange(21) * 0.01
    cfg, notes = metrics.within_run({"error_window": [0.1001, 0.1002]}, 0.2, t)
    assert "error_window" not in cfg and "holds no logged time" in notes[0]
    cfg, notes = metrics.within_run({"error_window": [0.1, 0.1]}, 0.2, t)
    assert cfg == {"error_window": [0.1, 0.1]} and notes == []


def test_a_filter_cutoff_above_the_logs_nyquist_frequency_is_noted():
    # 1e6 Hz at a 0.01 s log ran as 49.5 Hz, silently (the same numbers as 60 Hz)
    _, notes = metrics.within_run({"filter_cutoff": 1e6}, 1.0, np.arange(101) * 0.01)
    assert "above 0.99 of the log's Nyquist frequency (50 Hz)" in notes[0]
    assert metrics.within_run({"filter_cutoff": 12.0}, 1.0, np.arange(101) * 0.01)[1] == []


def test_a_step_at_the_first_sample_is_measured_from_where_the_force_starts():
    # the command is 1 from t = 0 on, the force rises as 1 - exp(-t / 0.1): rise 0.1 ln 9 = 0.2197 s;
    # with no command sample before the step, the step was taken as 1 -> 1 and every figure was None
    t = np.linspace(0.0, 2.0, 20001)
    f = 1.0 - np.exp(-t / 0.1)
    res = Result(t, {"f.y": f[:, None], "fd.y": np.ones((t.size, 1))}, {"wall_time_s": 0.0})
    m = metrics.compute(res, {"force": "f.y", "force_desired": "fd.y"}, {"step_time": 0.0})
    assert m["rise_time_raw_s"] == pytest.approx(0.1 * np.log(9.0), abs=2e-4)
    assert m["overshoot_raw_pct"] == pytest.approx(0.0)
