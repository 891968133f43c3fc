"""Every command's work is one public function of the Python API, callable with a path or a parsed file."""
import json

import pytest

from conftest import DIAGRAMS, GOOD, write
import hybridsim as hs
from hybridsim.format import DiagramFile


def test_run_writes_what_the_command_writes(tmp_path):
    done = hs.run(write(tmp_path, GOOD), tmp_path / "o", t_end=0.2)
    assert sorted(p.name for p in done["outdir"].iterdir()) == ["d.csv", "d.png", "d.svg", "metrics.json"]
    assert done["runs"][0]["result"].t[-1] == pytest.approx(0.2)
    f = DiagramFile(write(tmp_path, GOOD, "e.yaml"), {"k": 3.0})  # a parsed file brings its overrides along
    done = hs.run(f, tmp_path / "p", t_end=0.2)
    assert done["runs"][0]["result"]["zoh.y"][-1, 0] == pytest.approx(3.0)  # k = 3 after the step


def test_write_analysis_returns_the_results_and_writes_them(tmp_path):
    from hybridsim.report.stability import write_analysis

    res = write_analysis(DIAGRAMS / "eq18_hand_oscillation.yaml", tmp_path)
    assert res["domain"] == "continuous" and "_objects" in res
    doc = json.loads((tmp_path / "analysis.json").read_text())
    assert doc["hand_mode_hz"] == pytest.approx(272.5, abs=0.1) and "_objects" not in doc


def test_write_picture_never_replaces_a_users_file(tmp_path, monkeypatch):
    from hybridsim.report.picture import write_picture

    monkeypatch.chdir(tmp_path)
    (tmp_path / "d.png").write_text("mine")
    out, note = write_picture(write(tmp_path, GOOD))
    assert out.name == "d-2.png" and "did not write" in note and (tmp_path / "d.png").read_text() == "mine"
    out, note = write_picture(write(tmp_path, GOOD), tmp_path / "x.svg", expand=True)
    assert note is None and out.read_text().startswith("<?xml")


def test_write_schema_and_the_catalog(tmp_path):
    from hybridsim.format.catalog import block_info, catalog
    from hybridsim.format.schema import write_schema

    out = write_schema(tmp_path / "s.json")
    assert json.loads(out.read_text())["title"] == "hybridsim diagram"
    gain = block_info("gain")
    assert gain.inputs == [("u", 1)] and gain.outputs == [("y", 1)] and gain.states == 0
    groups = catalog()
    assert list(groups)[0] == "paper" and "gain" in [b.type_name for b in groups["math"]]
    pid = block_info("discrete_pid")  # needs a rate to be built; its ports do not
    assert pid.inputs == [("r", 1), ("y", 1)] and pid.outputs == [("u", 1)] and pid.rate_hz is None
    integ = block_info("integrator")  # x and its mode, which only events change
    assert integ.states == 2 and integ.held == 1


def test_find_diagram_names_a_shipped_one(tmp_path, monkeypatch):
    from hybridsim.shipped import find_diagram

    monkeypatch.chdir(tmp_path)
    path, note = find_diagram("diagrams/fig10_force_ramp.yaml")
    assert path.is_file() and "using the shipped" in note
    here = write(tmp_path, GOOD)
    assert find_diagram(here) == (here, None)


def test_the_html_helper():
    from hybridsim.report import html

    assert html.fmt(None) == "–" and html.fmt(True) == "yes" and html.fmt(2 / 3) == "0.6667"
    table = html.table([{"a": 1.23456, "b": "<x>"}], ["a", "b"], head=["A", "B"])
    assert table == "<table><tr><th>A</th><th>B</th></tr><tr><td>1.235</td><td>&lt;x&gt;</td></tr></table>"
    page = html.page("T & U", "<p>body</p>", width=900)
    assert "<title>T &amp; U</title>" in page and "max-width:900px" in page and page.endswith("</html>\n")
    assert html.figure("QUJD", "a < b") == ("<figure><img src='data:image/png;base64,QUJD'/>"
                                           "<figcaption>a &lt; b</figcaption></figure>")


def test_a_users_file_among_the_outputs_is_refused_before_anything_runs(tmp_path, monkeypatch):
    from hybridsim.errors import OutputError
    from hybridsim.runs import variants

    def ran(*a, **k):
        raise AssertionError("the runs started")

    monkeypatch.setattr(variants, "run_experiment", ran)
    (tmp_path / "o").mkdir()
    (tmp_path / "o" / "metrics.json").write_text("mine")  # was refused after the runs
    with pytest.raises(OutputError, match="metrics.json' exists and hybridsim did not write it"):
        hs.run(write(tmp_path, GOOD), tmp_path / "o", t_end=0.2)
    (tmp_path / "o" / "metrics.json").unlink()
    (tmp_path / "o" / "d.svg").mkdir()
    with pytest.raises(OutputError, match="d.svg' exists and is not a file \\(it is a folder\\)"):
        hs.run(write(tmp_path, GOOD), tmp_path / "o", t_end=0.2)
    assert (tmp_path / "o" / "d.svg").is_dir()


def test_analyze_is_part_of_the_top_level_api():
    import hybridsim as hs

    res = hs.analyze(DIAGRAMS / "examples" / "msd_pid.yaml", sweeps=False)
    assert res["stable"] and res["growth"] == pytest.approx(0.993018, abs=1e-6)  # python-control's, tested there


def test_check_file_takes_every_file_the_check_command_takes(capsys):
    # getting-started named hybridsim.api.check as check's function: it refuses a subsystem file
    # (its inputs unwired) and a sweep file, which the command checks
    from hybridsim.app.cli import main

    for path in (DIAGRAMS / "subsystems" / "fig6_controller.yaml", DIAGRAMS / "sweeps" / "fig7_force_gains.yaml"):
        got = hs.check_file(path)
        assert main(["check", str(path)]) == 0
        assert got["kind"] in capsys.readouterr().out
    assert hs.check_file(DIAGRAMS / "fig7_force_steps.yaml")["kind"] == "diagram"


def test_the_api_says_what_a_wrong_argument_should_be(tmp_path):
    # each raised a bare Python error naming nothing ("expected str, bytes or os.PathLike object, not
    # NoneType"), or took a string for True
    from hybridsim.errors import InputError
    from hybridsim.runs.sweep import run_sweep
    from hybridsim.tune import load_tune

    msd = str(DIAGRAMS / "examples" / "msd_pid.yaml")
    for call, says in ((lambda: hs.check_file(None), "a file is a path"),
                       (lambda: load_tune(None), "a tune file is a path"),
                       (lambda: run_sweep(3, tmp_path / "o"), "a sweep file is a path"),
                       (lambda: hs.run(msd, 5), "an output folder is a path")):
        with pytest.raises(TypeError, match=says):
            call()
    with pytest.raises(InputError, match="sweeps is True or False"):
        hs.analyze(msd, sweeps="no")
    sweep = tmp_path / "s.yaml"
    sweep.write_text(f"diagram: {msd}\nset: {{simulation.t_end: 0.1}}\ngrid: {{pid.Kp: [1.0, 2.0]}}\n")
    with pytest.raises(TypeError, match="an output folder is a path"):
        run_sweep(sweep, None)
    for kw, says in ((dict(dask=5), "dask is a scheduler address"), (dict(compiled="no"), "compiled is True or False")):
        with pytest.raises(InputError, match=says):  # dask=5: 'int' object has no attribute 'nthreads'
            run_sweep(sweep, tmp_path / "o", **kw)
    for call, says in ((lambda: hs.simulate(msd, progress="no"), "progress is True or False"),
                       (lambda: hs.run(msd, tmp_path / "o", progress="no"), "progress is True or False"),
                       (lambda: hs.run(msd, tmp_path / "o", jobs="2"), "jobs must be a whole number")):
        with pytest.raises(InputError, match=says):
            call()
    assert not (tmp_path / "o").exists()
    import numpy as np

    assert hs.analyze(msd, sweeps=np.False_)["stable"]  # numpy's booleans and whole numbers are taken
    assert len(run_sweep(sweep, tmp_path / "o", jobs=np.int64(1), progress=False)) == 2


def test_the_python_api_finds_a_shipped_diagram_from_any_folder_as_the_cli_does(tmp_path, monkeypatch, caplog):
    # hs.simulate("diagrams/fig7_force_steps.yaml") outside a checkout: "no such file", while the CLI
    # used the shipped one
    import logging

    monkeypatch.chdir(tmp_path)
    with caplog.at_level(logging.INFO, logger="hybridsim"):
        res = hs.simulate("diagrams/fig7_force_steps.yaml", t_end=0.01)
    assert res.t[-1] == pytest.approx(0.01) and "using the shipped" in caplog.text
    with pytest.raises(hs.LoaderError, match="no such file"):
        hs.simulate("diagrams/no_such_diagram.yaml")
