"""Budgets checked before work starts, each with a message and a documented way to raise it."""
import time

import pytest

from hybridsim import limits
from hybridsim.app.cli import main

from conftest import DIAGRAMS, write
from conftest import GOOD

HC = DIAGRAMS / "hybrid_controller.yaml"


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, err


def _doubling(tmp_path, levels):
    """``levels`` files, each using the next twice: 2**levels blocks once expanded."""
    leaf = "inputs: {u: g.u}\noutputs: {y: g.y}\nblocks:\n  g: {type: gain, K: 1.0}\n"
    (tmp_path / f"l{levels}.yaml").write_text(leaf)
    for k in range(levels - 1, 0, -1):
        (tmp_path / f"l{k}.yaml").write_text(
            "inputs: {u: a.u}\noutputs: {y: b.y}\nblocks:\n"
            f"  a: {{type: subsystem, file: l{k + 1}.yaml}}\n  b: {{type: subsystem, file: l{k + 1}.yaml}}\n"
            "wires: [a.y -> b.u]\n")
    return write(tmp_path, "blocks:\n  c: {type: constant, value: 1.0}\n  a: {type: subsystem, file: l1.yaml}\n"
                           "  b: {type: subsystem, file: l1.yaml}\nwires: [c.y -> a.u, a.y -> b.u]\n"
                           "simulation: {t_end: 0.01}\n")


def test_subsystems_that_double_at_every_level_are_refused_before_expanding(tmp_path, capsys):
    p = _doubling(tmp_path, 24)
    t0 = time.perf_counter()
    code, err = run(capsys, "check", p)
    assert code == 2 and "expands to more than 20000 blocks" in err and "HYBRIDSIM_MAX_BLOCKS" in err
    assert time.perf_counter() - t0 < 10  # each file read once: not 2**24 expansions


def test_a_small_doubling_tree_builds_and_the_limit_can_be_raised(tmp_path, capsys, monkeypatch):
    p = _doubling(tmp_path, 5)
    code, err = run(capsys, "check", p)
    assert code == 0, err
    monkeypatch.setenv("HYBRIDSIM_MAX_BLOCKS", "10")
    code, err = run(capsys, "check", p)
    assert code == 2 and "more than 10 blocks" in err


def test_too_many_steps_is_refused_with_how_to_raise_the_limit(tmp_path, capsys, monkeypatch):
    p = write(tmp_path, GOOD.replace("log_period: 1.0e-2", "log_period: 1.0e-2, step: 1.0e-9"))
    code, err = run(capsys, "check", p)
    assert code == 2 and "2e+08 steps" in err and "HYBRIDSIM_MAX_STEPS=N" in err
    monkeypatch.setenv("HYBRIDSIM_MAX_STEPS", "1e9")
    assert run(capsys, "check", p)[0] == 0
    monkeypatch.setenv("HYBRIDSIM_MAX_STEPS", "lots")
    code, err = run(capsys, "check", p)
    assert code == 2 and "HYBRIDSIM_MAX_STEPS='lots'" in err


def test_the_issue_example_step_1e_9_to_t_end_1_is_refused(capsys):
    code, err = run(capsys, "check", DIAGRAMS / "fig7_force_steps.yaml", "--set", "simulation.step=1e-9",
                    "--set", "simulation.t_end=1")
    assert code == 2 and "steps" in err
    # the message named the diagram's simulation line only, not the --set that gave the values
    assert "(from --set simulation.step, --set simulation.t_end)" in err or \
        "(from --set simulation.t_end, --set simulation.step)" in err, err


def test_a_negative_element_index_says_indexes_count_from_0(capsys):
    code, err = run(capsys, "check", DIAGRAMS / "fig7_force_steps.yaml", "--set", "ctrl.fpi.Kp[-1]=1")
    assert code == 2 and "an element index counts from 0 at the first element (no negative" in err, err


@pytest.mark.slow
def test_a_linearisation_horizon_too_long_is_exit_2_not_memory_error(tmp_path, capsys):
    t0 = time.perf_counter()
    code, err = run(capsys, "analyze", HC, "--at", "1e7")
    assert code == 2 and "linearize at 1e+07 s" in err
    p = write(tmp_path, f"extends: {HC}\nanalysis:\n  at: 1.0e8\n")
    code, err = run(capsys, "check", p)
    assert code == 2 and "d.yaml:3" in err and "analysis at 1e+08 s" in err
    assert time.perf_counter() - t0 < 30


@pytest.mark.parametrize("value, message", [
    ("[&a [1,1,1,1,1,1,1,1,1,1], &b [*a,*a,*a,*a,*a,*a,*a,*a,*a,*a], &c [*b,*b,*b,*b,*b,*b,*b,*b,*b,*b], "
     "&d [*c,*c,*c,*c,*c,*c,*c,*c,*c,*c], &e [*d,*d,*d,*d,*d,*d,*d,*d,*d,*d], [*e,*e,*e,*e,*e,*e,*e,*e,*e,*e]]",
     "expands to"),
    ("&a [*a]", "recursive"),
    ("[" * 100 + "]" * 100, "nested deeper than 64"),
    ("x" * 20_000, "longer than 10000 characters"),
    ("{a: 1, a: 2}", "duplicate key"),
    ("[1, 2", "YAML syntax error"),
])
def test_set_values_get_the_limits_of_files(capsys, value, message):
    t0 = time.perf_counter()
    code, err = run(capsys, "check", DIAGRAMS / "fig7_force_steps.yaml", "--set", f"force={value}")
    assert code == 2 and "--set force" in err and message in err, err
    assert time.perf_counter() - t0 < 10


def test_a_sweep_with_too_many_points_is_refused_before_any_run(tmp_path, capsys):
    d = write(tmp_path, GOOD)
    values = list(range(400))
    s = write(tmp_path, f"diagram: {d}\ngrid: {{k: {values}, params.rate: {values}}}\n", "s.yaml")
    code, err = run(capsys, "sweep", s, "-q", "-o", tmp_path / "o")
    assert code == 2  # the same parameter twice, or too many points: refused before anything runs
    s.write_text(f"diagram: {d}\ngrid: {{k: {values}, zoh.rate: {values}}}\n")
    code, err = run(capsys, "sweep", s, "-q", "-o", tmp_path / "o")
    assert code == 2 and "160000 points" in err
    assert not (tmp_path / "o").exists()


def test_a_very_wide_log_is_plotted_thinned_in_bounded_time(tmp_path, capsys):
    width = 10_000
    text = (f"blocks:\n  c: {{type: constant, value: {[0.5] * width}}}\n"
            "simulation: {t_end: 0.005, log_period: 1.0e-3}\nlog: [c.y]\n")
    t0 = time.perf_counter()
    code, err = run(capsys, "run", write(tmp_path, text), "-q", "-o", tmp_path / "o")
    assert code == 0, err
    assert time.perf_counter() - t0 < 60
    svg = (tmp_path / "o" / "d.svg").read_text()
    assert f"elements 0..{limits.get('MAX_PLOT_LINES') - 1} of {width} drawn" in svg


def test_every_limit_is_documented_with_its_variable():
    page = (DIAGRAMS.parent / "docs" / "settings.md").read_text()
    for name in limits.LIMITS:
        assert limits.env_name(name) in page
