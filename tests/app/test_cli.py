"""The command line: every bad input gets its own message and exit code, no traceback."""
import json

import pytest

from hybridsim.app.cli import main

from conftest import DIAGRAMS, ROOT, write
from conftest import GOOD


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


@pytest.mark.parametrize("change, message", [
    (("type: gain", "type: gian"), "unknown block type 'gian'"),
    (("  - g.y -> zoh.u\n", ""), "d.yaml:6: input zoh.u (1 wide) is not connected"),  # at its block's line
    (("src.y -> g.u", "src.y -> g.x"), "has no input 'x'"),
    (("{type: zoh, rate: 100}", "{type: zoh, rate: 100, width: 2}"), "width mismatch"),
    (("rate: 100", "rate: 0"), "bad rate"),
    (("  k: 2.0", "  k: [2.0"), "YAML syntax error"),
])
def test_bad_diagrams_exit_2_with_message(tmp_path, capsys, change, message):
    p = write(tmp_path, GOOD.replace(*change))
    code, _, err = run(capsys, "check", p)
    assert code == 2 and message in err and "d.yaml" in err


@pytest.mark.parametrize("change, message", [
    (("{type: gain, K: $k}", "{type: gain, K: $k, input: src.y}"), "'wires:' section"),
    (("log_period: 1.0e-2", "log_period: 1.0e-2, dt: 1.0e-3"), "unknown simulation setting 'dt'"),
])
def test_a_run_refused_for_bad_input_says_only_why_and_where_signals_are_wired(tmp_path, capsys, change,
                                                                            message):
    p = write(tmp_path, GOOD.replace(*change))
    code, out, err = run(capsys, "run", p, "-o", tmp_path / "out")
    assert code == 2 and message in err and "running" not in err
    assert not (tmp_path / "out").exists()


def test_algebraic_loop_exit_2(tmp_path, capsys):
    text = """\
blocks:
  c: {type: constant, value: 1.0}
  s: {type: sum, signs: "+-"}
  g: {type: gain, K: 0.5}
wires: [c.y -> s.u1, s.y -> g.u, g.y -> s.u2]
"""
    code, _, err = run(capsys, "check", write(tmp_path, text))
    assert code == 2 and "algebraic loop" in err and "insert a delay" in err


def test_incommensurate_rates_exit_2(tmp_path, capsys):
    text = GOOD.replace("zoh:  {type: zoh, rate: 100}", "zoh:  {type: zoh, rate: 100}\n  z2: {type: zoh, rate: 100.003}")
    text = text.replace("  - g.y -> zoh.u\n", "  - g.y -> zoh.u\n  - g.y -> z2.u\n")
    code, _, err = run(capsys, "check", write(tmp_path, text))
    assert code == 2 and "not commensurate" in err


def test_diverging_simulation_exit_3(tmp_path, capsys):
    # printed gains without the limiter: Kfi T > 2 at 60 Hz, unstable (docs/model.md)
    code, _, err = run(capsys, "run", DIAGRAMS / "fig7_force_steps.yaml", "-q", "-o", tmp_path / "o",
                       "--set", "force=5", "--set", "rate=60", "--set", "ctrl.fpi.limit=null",
                       "--set", "arm.friction=false", "--set", "surface.unilateral=false",
                       "--set", "simulation.t_end=1.5")
    assert code == 3 and "diverged" in err
    assert not (tmp_path / "o").exists()  # nothing half-written


def test_missing_file_and_bad_set(tmp_path, capsys):
    code, _, err = run(capsys, "check", tmp_path / "nope.yaml")
    assert code == 2 and "no such file" in err
    code, _, err = run(capsys, "check", DIAGRAMS / "fig9_force_and_position.yaml", "--set", "rat=80")
    assert code == 2 and "did you mean 'rate'" in err


def test_run_writes_csv_plots_metrics(tmp_path, capsys):
    out = tmp_path / "o"
    code, stdout, _ = run(capsys, "run", DIAGRAMS / "eq18_hand_oscillation.yaml", "-q", "-o", out,
                          "--set", "Kr=9.0e5", "--set", "simulation.t_end=0.02")
    assert code == 0, stdout
    names = sorted(p.name for p in out.iterdir())
    assert names == ["eq18_hand_oscillation.csv", "eq18_hand_oscillation.png",
                     "eq18_hand_oscillation.svg", "metrics.json"]
    doc = json.loads((out / "metrics.json").read_text())
    assert doc["set"] == {"Kr": 9.0e5, "simulation.t_end": 0.02}  # what produced it
    m = doc["runs"][0]["metrics"]
    assert m["oscillation_hz"] == pytest.approx(272.5, rel=0.01)
    assert "oscillation 27" in stdout


def test_draw_and_blocks_and_help(tmp_path, capsys):
    code, _, _ = run(capsys, "draw", DIAGRAMS / "hybrid_controller.yaml", "-o", tmp_path / "f.png")
    assert code == 0 and (tmp_path / "f.png").stat().st_size > 10000
    code, out, _ = run(capsys, "blocks")
    assert code == 0 and "manipulator" in out and "force_pi" in out
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    assert "--set PATH=VALUE" in capsys.readouterr().out


@pytest.mark.slow
def test_analyze_prints_poles_margins_and_sweeps(tmp_path, capsys):
    code, out, _ = run(capsys, "analyze", DIAGRAMS / "hybrid_controller.yaml", "--set", "rate=120",
                       "-o", tmp_path)
    assert code == 0
    assert "largest |z|" in out and "loop force (ctrl.dF.y[0])" in out and "servo rate (Hz)" in out
    doc = json.loads((tmp_path / "analysis.json").read_text())
    assert doc["period_s"] == pytest.approx(1 / 120) and doc["loops"]["force"]["signal"] == "ctrl.dF.y[0]"
    assert 0.99 < doc["hand_mode_hz"] / 272.48 < 1.0


@pytest.mark.slow
def test_report_writes_html_and_figures(tmp_path, capsys):
    code, out, _ = run(capsys, "report", DIAGRAMS / "fig9_force_and_position.yaml", "-o", tmp_path / "r")
    assert code == 0
    names = {p.name for p in (tmp_path / "r").iterdir()}
    for stem in ("diagram", "bode_force", "bode_position", "poles", "root_locus", "stability_vs_rate",
                 "stability_vs_gain", "step_linear_vs_nonlinear"):
        assert {f"{stem}.png", f"{stem}.svg"} <= names
    page = (tmp_path / "r" / "report.html").read_text()
    assert page.count("data:image/png;base64") >= 8
    assert "as printed</b>, rate=60 … rate=120" in page and "damped</b>" in page
    data = json.loads((tmp_path / "r" / "analysis.json").read_text())
    labels = [c["label"] for c in data["configurations"]]
    assert labels[:3] == ["as printed rate=60", "as printed rate=80", "as printed rate=120"]


@pytest.mark.slow
def test_run_compiled_writes_the_same_csv(tmp_path, capsys):
    smooth = ROOT / "tests" / "data" / "smooth_contact.yaml"
    code, _, _ = run(capsys, "run", smooth, "-q", "-o", tmp_path / "a")
    assert code == 0
    code, _, _ = run(capsys, "run", smooth, "-q", "-o", tmp_path / "b", "--compiled")
    assert code == 0
    assert (tmp_path / "a" / "smooth_contact.csv").read_text() == (tmp_path / "b" / "smooth_contact.csv").read_text()
    code, _, err = run(capsys, "run", smooth, "-q", "-o", tmp_path / "c", "--compiled", "--set", "simulation.solver=radau")
    assert code == 2 and "compiled path integrates with a fixed-step Runge-Kutta" in err


def test_run_without_signal_roles_draws_a_scope(tmp_path, capsys):
    # no 'signals' section (force, position...): one panel per logged signal instead of a crash
    code, _, _ = run(capsys, "run", ROOT / "tests" / "data" / "discrete_only.yaml", "-q", "-o", tmp_path)
    assert code == 0
    assert (tmp_path / "discrete_only.png").stat().st_size > 10000


def test_blocks_verbose_shows_defaults_and_ports(capsys):
    code, out, _ = run(capsys, "blocks", "-v")
    assert code == 0
    assert "parameters: g=9.81, e=0.8, h0=1.0, v0=0.0" in out  # bouncing_ball, its defaults
    assert "inputs: none; outputs: h[1], v[1]; 2 continuous states" in out
    assert "inputs: tau[2], f_wrist[2]; outputs: q[2], qd[2]; 4 continuous states" in out  # the arm


def test_blocks_of_named_types_show_their_parameters_and_a_typo_gets_the_closest(capsys):
    code, out, _ = run(capsys, "blocks", "integrator", "relay")
    assert code == 0 and out.splitlines()[0].split()[0] == "integrator" and "lower=-inf" in out
    assert "switch_on=0.0" in out and "gain " not in out
    code, _, err = run(capsys, "blocks", "integrater")
    assert code == 2 and "did you mean 'integrator'" in err


def test_blocks_lists_the_library_by_group(capsys):
    assert main(["blocks"]) == 0
    out = capsys.readouterr().out
    heads = [line[:-1] for line in out.splitlines() if line and not line.startswith(" ")]
    assert heads[:6] == ["paper", "control", "math", "sources", "sinks", "FMU"]
    section = out.split("\ncontrol:")[1].split("\n\n")[0]
    assert "discrete_pid" in section and "integrator" in section and "manipulator" not in section


@pytest.mark.slow
def test_examples_copies_the_shipped_diagrams_and_keeps_a_users_files(tmp_path, capsys):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "fig7_force_steps.yaml").write_text("my own\n")
    assert main(["examples", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert (out / "fig7_force_steps.yaml").read_text() == "my own\n"  # never replaced
    assert "kept" in text and (out / "subsystems" / "fig6_controller.yaml").is_file()
    assert "diagram file(s) and 1 file(s) they read (robot models)" in text  # the .urdf was a diagram
    assert main(["check", str(out / "fig9_force_and_position.yaml")]) == 0  # the copy finds its subsystem
    # a link pointing nowhere was replaced by a copy; a file where a subfolder goes: exit 5, half written
    other = tmp_path / "other"
    other.mkdir()
    (other / "bouncing_ball.yaml").symlink_to(tmp_path / "nowhere.yaml")
    (other / "subsystems").write_text("mine")
    assert main(["examples", "-o", str(other)]) == 2
    assert "is a file of yours where the examples put a folder" in capsys.readouterr().err
    assert sorted(p.name for p in other.iterdir()) == ["bouncing_ball.yaml", "subsystems"]
    (other / "subsystems").unlink()
    assert main(["examples", "-o", str(other)]) == 0
    assert (other / "bouncing_ball.yaml").is_symlink() and (other / "subsystems").is_dir()


@pytest.mark.slow
def test_a_shipped_diagram_runs_from_any_folder(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["check", "diagrams/fig10_force_ramp.yaml"]) == 0
    assert "using the shipped" in capsys.readouterr().err
    assert main(["check", "diagrams/not_there.yaml"]) == 2


def test_check_takes_sweep_and_tune_files(tmp_path, capsys):
    d = write(tmp_path, GOOD)
    sweep = write(tmp_path, f"diagram: {d.name}\ngrid: {{k: [1.0, 2.0, 3.0]}}\n", "s.yaml")
    code, out, _ = run(capsys, "check", sweep)
    assert code == 0 and "a sweep of" in out and "3 point(s)" in out
    tune = write(tmp_path, f"diagram: {d.name}\nparameters: {{g.K: {{low: 0.5, high: 4.0}}}}\n"
                           "objectives: [{metric: overshoot_pct, of: zoh.y, goal: min}]\n", "t.yaml")
    code, out, err = run(capsys, "check", tune)
    assert code == 0 and "a tune file for" in out and "1 parameter(s)" in out, err
    # a swept parameter the diagram lacks: named with the sweep file, exit 2 (not "unknown section")
    bad = write(tmp_path, f"diagram: {d.name}\ngrid: {{g.gain: [1.0]}}\n", "b.yaml")
    code, _, err = run(capsys, "check", bad)
    assert code == 2 and "b.yaml" in err and "gain" in err and "unknown section" not in err
    code, _, err = run(capsys, "check", sweep, "--set", "k=2")
    assert code == 2 and "--set applies to a diagram" in err


@pytest.mark.parametrize("argv, name", [
    (["draw", str(DIAGRAMS / "fig9_force_and_position.yaml"), "-o"], "pic.png"),
    (["schema", "-o"], "schema.json"),
    (["fmu", "export", str(DIAGRAMS / "fig9_force_and_position.yaml"), "-o"], "plant.fmu"),
])
def test_an_output_file_the_user_wrote_is_never_replaced(tmp_path, capsys, argv, name):
    mine = tmp_path / name
    mine.write_text("precious")
    assert main(argv + [str(mine)]) == 2
    assert mine.read_text() == "precious" and "hybridsim did not write it" in capsys.readouterr().err
    if name != "plant.fmu":  # what hybridsim wrote there it replaces
        mine.unlink()
        assert main(argv + [str(mine)]) == 0 and main(argv + [str(mine)]) == 0


def test_an_empty_or_nameless_output_is_refused(tmp_path, capsys, monkeypatch):
    # -o "" (an unset shell variable) wrote to the default folder or file, exit 0; -o .png said the
    # file type was '(none)'
    from conftest import DIAGRAMS

    monkeypatch.chdir(tmp_path)
    msd = str(DIAGRAMS / "examples" / "msd_pid.yaml")
    for cmd in (["run", msd, "-q"], ["draw", msd], ["analyze", msd], ["sweep", str(tmp_path / "s.yaml")]):
        assert main(cmd + ["-o", ""]) == 2, cmd
        assert "is empty (-o '')" in capsys.readouterr().err
    assert main(["draw", msd, "-o", ".png"]) == 2
    assert "'.png' has no name before its suffix" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
