"""Figures: a grid of variants gets one small panel per case, as the paper draws Fig 7."""
import matplotlib.pyplot as plt
import pytest

import hybridsim as hs
from hybridsim.report.figures import experiment_figure
from conftest import DIAGRAMS


@pytest.mark.slow
def test_a_two_parameter_grid_of_variants_gets_small_multiples():
    f, runs, settings = hs.run_experiment(DIAGRAMS / "fig7_force_steps.yaml", t_end=0.05)
    fig = experiment_figure(f, runs, settings)
    assert len(fig.axes) == 9  # force 1, 5, 10 N x rate 60, 80, 120 Hz
    titles = [ax.get_title() for ax in fig.axes[:3]]
    assert titles == ["rate = 60", "rate = 80", "rate = 120"]
    assert fig.axes[0].get_ylabel().startswith("force = 1.0")


def test_one_swept_parameter_stays_one_overlaid_figure():
    f, runs, settings = hs.run_experiment(DIAGRAMS / "fig9_force_and_position.yaml", t_end=0.05)
    fig = experiment_figure(f, runs, settings)
    assert len(fig.axes) == 3  # position, force, contact; the three rates overlaid as in Fig 9


@pytest.mark.parametrize("graphviz", [True, False], ids=["dot", "layers"])
def test_the_diagram_picture_keeps_every_box_and_wire_on_the_canvas(graphviz, monkeypatch):
    import shutil

    from matplotlib.patches import FancyArrowPatch

    from hybridsim.report.picture import draw_diagram

    if graphviz and shutil.which("dot") is None:
        pytest.skip("Graphviz's dot is not installed (the layered layout is tested)")
    if not graphviz:
        monkeypatch.setattr(shutil, "which", lambda name: None)
    file = hs.load(DIAGRAMS / "fig9_force_and_position.yaml")
    system = file.build()[0].build()
    fig = draw_diagram(system, expand=True)
    fig.canvas.draw()
    ax = fig.axes[0]
    frame = ax.get_window_extent()
    drawn = list(ax.patches) + [t.arrow_patch for t in ax.texts if getattr(t, "arrow_patch", None)]
    for p in drawn:
        e = p.get_window_extent()
        assert frame.x0 - 1 <= e.x0 and e.x1 <= frame.x1 + 1 and frame.y0 - 1 <= e.y0 and e.y1 <= frame.y1 + 1, p
    if graphviz:  # every wire is one of dot's splines; the feedback ones red
        arrows = [p for p in ax.patches if isinstance(p, FancyArrowPatch)]
        assert len(arrows) >= 20 and any(a.get_edgecolor()[0] > 0.7 for a in arrows)
    plt.close(fig)


def test_values_matplotlib_cannot_scale_lose_the_figure_not_the_run(tmp_path, caplog):
    # exp(709.5) is finite (1.4e308) but matplotlib's ticks overflow on it: the run ended in an
    # internal error after simulating, writing nothing
    from hybridsim.app.cli import main

    p = tmp_path / "huge.yaml"
    p.write_text("name: huge\nblocks:\n  c: {type: constant, value: [709.5, 709.7]}\n"
                 "  e: {type: math_function, function: exp, width: 2}\nwires: [c.y -> e.u]\n"
                 "simulation: {t_end: 0.01, log_period: 0.005}\nlog: [e.y]\n")
    assert main(["run", str(p), "-o", str(tmp_path / "out")]) == 0
    assert (tmp_path / "out" / "huge.csv").exists() and not (tmp_path / "out" / "huge.png").exists()
    assert "no figure drawn" in caplog.text


def test_a_users_figure_among_the_reports_files_is_refused_before_the_analysis(tmp_path, monkeypatch):
    """A user's poles.svg was refused after the analysis (38 s on Fig 9)."""
    from hybridsim.errors import OutputError
    from hybridsim.report import stability

    monkeypatch.setattr(stability, "_analyse", lambda *a: (_ for _ in ()).throw(AssertionError("analysed")))
    (tmp_path / "poles.svg").write_text("mine")
    with pytest.raises(OutputError, match="poles.svg' exists and hybridsim did not write it"):
        stability.write_report(DIAGRAMS / "examples" / "msd_pid.yaml", tmp_path)


def test_a_sampled_signal_is_drawn_as_stairs():
    """A discrete block's output is held between its hits (Simulink draws it as stairs); the plant's
    continuous output is a line."""
    from hybridsim.format.build import load
    from hybridsim.report.figures import scope_figure

    path = DIAGRAMS / "examples" / "msd_pid.yaml"
    res = hs.simulate(path, t_end=0.1)
    assert res.meta["sampled"] == [r for r in res.signals if r.startswith("pid.")]
    fig = scope_figure(load(path), [{"result": res, "label": ""}])
    styles = {ax.get_ylabel(): ax.lines[0].get_drawstyle() for ax in fig.axes}
    assert styles["pid.u"] == "steps-post" and styles["plant.y"] == "default"
    plt.close(fig)


@pytest.mark.slow
def test_a_subsystem_file_is_drawn_with_its_inputs_as_sources(tmp_path):
    """`hybridsim draw` of a subsystem file (one with `inputs:`) listed its 14 unwired inputs and exited 2:
    it draws its blocks, fed by the sources its FMU export would read."""
    from hybridsim.format import DiagramFile
    from hybridsim.report.picture import write_picture

    sub = DIAGRAMS / "subsystems" / "fig6_controller.yaml"
    out, _ = write_picture(sub, tmp_path / "sub.png")
    assert out.stat().st_size > 10_000
    out, _ = write_picture(DiagramFile(sub), tmp_path / "sub.svg")  # as the command gives it
    svg = out.read_text()
    assert "in_q" in svg and "sub.fpi" in svg
