"""Every entry point is safe: no user file lost, no silent wrong answer, no traceback.

One test per case of the hardening issue (each failed on the code before it):
output folders, file names from diagrams, temporaries after signals, sweeps
that resume only what is identical, parameters validated where declared,
references and sizes checked before any run, and exit codes as documented.
"""
import json
import os
import stat
import subprocess
import sys
import time
import zipfile

import pytest

from hybridsim import api
from hybridsim.app.cli import main
from hybridsim.runs import variants
from hybridsim.errors import (DiagramError, FMUError, InputError, LoaderError, OutputError,
                              ParameterError, SimulationError)

from conftest import DIAGRAMS, write
from conftest import GOOD

HC = DIAGRAMS / "hybrid_controller.yaml"


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def tree(folder):
    """{relative path: (bytes or None for folders, mode)} of everything under ``folder``."""
    out = {}
    for root, dirs, files in os.walk(folder):
        for n in dirs + files:
            p = os.path.join(root, n)
            st = os.lstat(p)
            data = None if stat.S_ISDIR(st.st_mode) else open(p, "rb").read()
            out[os.path.relpath(p, folder)] = (data, stat.S_IMODE(st.st_mode))
    return out


# -- output folders are ours only ------------------------------------------------------

def test_a_users_file_with_an_outputs_name_is_never_replaced_even_with_o(tmp_path, capsys):
    # -o DIR replaced DIR/d.csv of the user's (exit 0): only a file hybridsim wrote is replaced
    out = tmp_path / "mine"
    out.mkdir()
    (out / "d.csv").write_text("an old result of mine")
    code, _, err = run(capsys, "run", write(tmp_path, GOOD), "-q", "-o", out)
    assert code == 2 and "d.csv' exists and hybridsim did not write it" in err
    assert (out / "d.csv").read_text() == "an old result of mine" and sorted(p.name for p in out.iterdir()) == ["d.csv"]
    (out / "d.csv").unlink()
    assert run(capsys, "run", write(tmp_path, GOOD), "-q", "-o", out)[0] == 0
    assert run(capsys, "run", write(tmp_path, GOOD), "-q", "-o", out)[0] == 0  # its own files: replaced


def test_run_into_a_user_folder_keeps_every_file_subfolder_and_mode(tmp_path, capsys):
    out = tmp_path / "mine"
    (out / "sub" / "deep").mkdir(parents=True)
    (out / "notes.txt").write_text("my notes")
    (out / "sub" / "deep" / "data.bin").write_bytes(b"\x00\x01")
    os.chmod(out, 0o751)
    os.chmod(out / "notes.txt", 0o640)
    before = tree(out)
    code, _, _ = run(capsys, "run", write(tmp_path, GOOD), "-q", "-o", out)
    assert code == 0
    after = tree(out)
    for rel, (data, mode) in before.items():
        assert after[rel] == (data, mode), rel
    assert stat.S_IMODE(out.stat().st_mode) == 0o751
    assert {"d.csv", "d.png", "d.svg", "metrics.json"} <= set(after)
    assert after["d.csv"][0].startswith(b"time,")
    assert not [n for n in after if n.endswith(".tmp")]


def test_output_files_follow_the_umask(tmp_path, capsys):
    old = os.umask(0o027)
    try:
        code, _, _ = run(capsys, "run", write(tmp_path, GOOD), "-q", "-o", tmp_path / "o")
    finally:
        os.umask(old)
    assert code == 0
    for name in ("d.csv", "d.png", "metrics.json"):
        assert stat.S_IMODE((tmp_path / "o" / name).stat().st_mode) == 0o640, name


def test_output_path_that_is_a_file_is_refused_and_untouched(tmp_path, capsys):
    f = tmp_path / "results"
    f.write_text("precious")
    code, _, err = run(capsys, "run", write(tmp_path, GOOD), "-q", "-o", f)
    assert code == 2 and "exists and is not a folder" in err
    assert f.read_text() == "precious"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.yaml", "results"]


def test_output_under_a_file_is_refused_before_the_simulation(tmp_path, capsys, monkeypatch):
    (tmp_path / "afile").write_text("x")
    monkeypatch.setattr(variants, "run_experiment", lambda *a, **k: pytest.fail("simulated before checking -o"))
    code, _, err = run(capsys, "run", write(tmp_path, GOOD), "-q", "-o", tmp_path / "afile" / "o")
    assert code == 2 and "is not a folder" in err


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write anywhere")
def test_output_under_an_unwritable_folder_is_refused_before_the_simulation(tmp_path, capsys, monkeypatch):
    ro = tmp_path / "ro"
    ro.mkdir(mode=0o555)
    monkeypatch.setattr(variants, "run_experiment", lambda *a, **k: pytest.fail("simulated before checking -o"))
    code, _, err = run(capsys, "run", write(tmp_path, GOOD), "-q", "-o", ro / "o")
    assert code == 5 and "Permission denied" in err and "no permission: choose another -o" in err


def test_output_into_the_current_folder(tmp_path, capsys, monkeypatch):
    p = write(tmp_path, GOOD)
    (tmp_path / "keep.txt").write_text("k")
    monkeypatch.chdir(tmp_path)
    code, _, _ = run(capsys, "run", p, "-q", "-o", ".")
    assert code == 0
    assert (tmp_path / "keep.txt").read_text() == "k" and (tmp_path / "d.csv").exists()
    assert (tmp_path / "d.yaml").read_text() == GOOD


def test_output_folder_missing_parents_are_created(tmp_path, capsys):
    code, _, _ = run(capsys, "run", write(tmp_path, GOOD), "-q", "-o", tmp_path / "a" / "b" / "c")
    assert code == 0 and (tmp_path / "a" / "b" / "c" / "d.csv").exists()


@pytest.mark.parametrize("name, stem", [("../../x", "x"), ("..", "diagram"), ("sub/dir", "sub-dir"),
                                        ("/etc/passwd", "etc-passwd"), ("a b:c", "a-b-c")])
def test_diagram_names_become_safe_file_names(tmp_path, capsys, name, stem):
    work = tmp_path / "w" / "v"
    work.mkdir(parents=True)
    p = write(work, f"name: {json.dumps(name)}\n" + GOOD)
    out = work / "o"
    code, _, _ = run(capsys, "run", p, "-q", "-o", out)
    assert code == 0
    assert sorted(x.name for x in out.iterdir()) == sorted([f"{stem}.csv", f"{stem}.png", f"{stem}.svg",
                                                           "metrics.json"])
    assert sorted(x.name for x in work.iterdir()) == ["d.yaml", "o"]
    assert sorted(x.name for x in (tmp_path / "w").iterdir()) == ["v"]


def test_sigterm_while_writing_leaves_no_temporaries(tmp_path, capsys, monkeypatch):
    from hybridsim.engine.result import Result

    real = Result.to_csv

    def slow(self, path):
        real(self, path)
        os.kill(os.getpid(), 15)  # SIGTERM mid-write

    monkeypatch.setattr(Result, "to_csv", slow)
    out = tmp_path / "o"
    out.mkdir()
    (out / "old.csv").write_text("earlier")
    code, _, err = run(capsys, "run", write(tmp_path, GOOD), "-q", "-o", out)
    assert code == 143 and "terminated" in err
    assert sorted(p.name for p in out.iterdir()) == ["old.csv"]


def test_stale_temporaries_of_a_killed_run_are_removed_and_nothing_else(tmp_path, capsys):
    """Temporaries live in hybridsim's own subfolder: a user's names that look like them are never touched."""
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    out = tmp_path / "o"
    own = out / ".hybridsim"
    (own / f"tmp-{dead.pid}-ab12").mkdir(parents=True)
    (own / f"tmp-{dead.pid}-ab12" / "partial.csv").write_text("time\n0")
    (own / f"tmp-{dead.pid}-x9").write_text("half")
    (own / f"tmp-{os.getppid()}-zz").write_text("a live process's")
    (out / ".mine.tmp").write_text("not ours")
    (out / f".d.csv.hybridsim-{dead.pid}-x9.tmp").write_text("a user's file named like an old temporary")
    code, _, _ = run(capsys, "run", write(tmp_path, GOOD), "-q", "-o", out)
    assert code == 0
    names = {p.name for p in out.iterdir()}
    assert names == {"d.csv", "d.png", "d.svg", "metrics.json", ".mine.tmp", ".hybridsim",
                     f".d.csv.hybridsim-{dead.pid}-x9.tmp"}
    assert {p.name for p in own.iterdir()} == {f"tmp-{os.getppid()}-zz"}


def test_diverging_run_leaves_no_folder(tmp_path, capsys):
    text = GOOD.replace("  g:    {type: gain, K: $k}", "  g:    {type: gain, K: $k}\n  x: {type: state_space, A: [[1.0e3]], B: [[0.0]], C: [[1.0]], x0: [1.0]}\n  xr: {type: recorder}")
    text = text.replace("  - g.y -> zoh.u\n", "  - g.y -> zoh.u\n  - g.y -> x.u\n  - x.y -> xr.u\n")
    code, _, err = run(capsys, "run", write(tmp_path, text), "-q", "-o", tmp_path / "o")
    assert code == 3 and "diverged" in err
    assert not (tmp_path / "o").exists()


def test_fmu_build_into_an_existing_folder_is_refused(tmp_path, capsys):
    d = tmp_path / "existing"
    d.mkdir()
    (d / "keep").write_text("k")
    code, _, err = run(capsys, "fmu", "build", "-o", d)
    assert code == 2 and "exists and is not a file" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["existing"]
    assert [p.name for p in d.iterdir()] == ["keep"]


def _hybridsim_temps():
    import tempfile

    return {p for p in os.listdir(tempfile.gettempdir()) if p.startswith("hybridsim-fmu-") or p.startswith("tmp")}


def test_fmu_with_an_absolute_member_is_refused_and_leaves_nothing(tmp_path, capsys):
    bad = tmp_path / "evil.fmu"
    with zipfile.ZipFile(bad, "w") as z:
        z.writestr("modelDescription.xml", "<fmiModelDescription/>")
        z.writestr("/tmp/evil.txt", "x")
    before = _hybridsim_temps()
    text = GOOD.replace("  zoh:  {type: zoh, rate: 100}", f"  zoh:  {{type: zoh, rate: 100}}\n  f: {{type: fmu, path: {bad}, rate: 10}}")
    code, _, err = run(capsys, "check", write(tmp_path, text))
    assert code == 4 and "unsafe member '/tmp/evil.txt'" in err
    assert _hybridsim_temps() <= before


# -- wrong answers with exit 0 ---------------------------------------------------------

def test_vector_parameter_of_the_wrong_width_is_an_error_at_its_line(tmp_path, capsys):
    p = write(tmp_path, f"extends: {HC}\nblocks:\n  arm:\n    balance: null\n    endpoint0: [0.5]\n")
    code, _, err = run(capsys, "check", p)
    assert code == 2 and "d.yaml:5" in err and "'endpoint0' must have 2 elements, got 1" in err


def test_sweep_grid_with_an_unknown_parameter_is_exit_2(tmp_path, capsys):
    d = write(tmp_path, GOOD)
    s = write(tmp_path, f"diagram: {d}\ngrid: {{kk: [1, 2]}}\n", "s.yaml")
    code, _, err = run(capsys, "sweep", s, "-q", "-o", tmp_path / "o")
    assert code == 2 and "no parameter 'kk'" in err and "did you mean 'k'" in err
    assert not (tmp_path / "o").exists()


def test_duplicate_keys_are_an_error_naming_both_lines(tmp_path, capsys):
    text = GOOD.replace("  zoh:  {type: zoh, rate: 100}", "  zoh:  {type: zoh, rate: 100}\n  g:    {type: gain, K: 3.0}")
    code, _, err = run(capsys, "check", write(tmp_path, text))
    assert code == 2 and "d.yaml:7: duplicate key 'g' (first given on line 5)" in err
    code, _, err = run(capsys, "check", write(tmp_path, GOOD.replace("rate: 100}", "rate: 100, rate: 50}")))
    assert code == 2 and "duplicate key 'rate'" in err


def test_yaml_merge_keys_may_still_override(tmp_path, capsys):
    text = GOOD.replace("  k: 2.0", "  k: 2.0\n  base: &b {type: zoh, rate: 100}").replace(
        "zoh:  {type: zoh, rate: 100}", "zoh:  {<<: *b, rate: 50}")
    code, out, _ = run(capsys, "check", write(tmp_path, text))
    assert code == 0 and "50 Hz" in out


@pytest.mark.parametrize("ref, message", [
    ("zoh.y[7]", "index 7 is out of range; zoh.y has 1 element(s), 0..0"),
    ("zoh.y[a]", "is not of the form block.port or block.port[i]"),
    ("zoh.y[-1]", "is not of the form block.port or block.port[i]"),
    ("zoh.q", "has no output 'q'"),
    ("zz.y", "no block 'zz'"),
])
def test_log_and_signal_references_are_checked(tmp_path, capsys, ref, message):
    code, _, err = run(capsys, "check", write(tmp_path, GOOD.replace("log: [zoh.y]", f"log: ['{ref}']")))
    assert code == 2 and message in err and "d.yaml:11" in err
    code, _, err = run(capsys, "check", write(tmp_path, GOOD + f"signals: {{force: '{ref}'}}\n"))
    assert code == 2 and message in err and "signal 'force'" in err


# -- limits checked before work starts -------------------------------------------------

@pytest.mark.parametrize("change, message", [
    (("rate: 100", "rate: 1.0e12"), "sample hits and log points"),
    (("t_end: 0.2", "t_end: 1.0e9"), "sample hits and log points"),
    (("t_end: 0.2", "t_end: .inf"), "'t_end' must be a positive, finite number"),
    (("t_end: 0.2", "t_end: 0.2, step: 1.0e-15"), "steps; at most"),
    (("t_end: 0.2", "t_end: 0.2, atol: -1.0e-9"), "'atol' must be a positive"),
    (("t_end: 0.2", "t_end: 0.2, rtol: -1"), "'rtol' must be a positive"),
    (("log_period: 1.0e-2", "log_period: 1.0e-9"), "needs about"),
])
def test_runs_too_large_or_ill_posed_are_refused_by_check(tmp_path, capsys, change, message):
    t0 = time.perf_counter()
    code, _, err = run(capsys, "check", write(tmp_path, GOOD.replace(*change)))
    assert code == 2 and message in err, err
    assert time.perf_counter() - t0 < 5


@pytest.mark.parametrize("sets, message, line", [
    (["arm.M3=0"], "'M3' must be positive", "arm"),
    (["wrist.M3=0"], "'M3' must be positive", "wrist"),
    (["arm.I1=[0, 0, 0]"], "the inertia must be positive", "arm"),
    (["arm.stick_time=0"], "'stick_time' must be positive", "arm"),
    (["ctrl.fpi.Kp=[.nan, 1]"], "(NaN)", "fpi"),
    (["ctrl.pid.Kp=.inf"], "'Kp' must be finite", "pid"),
    (["surface.Kr=0"], "'Kr' must be positive", "surface"),
    (["arm.damping=[-1, 0]"], "'damping' must not be negative", "arm"),
    (["arm.friction=yes please"], "'friction' must be true or false", "arm"),
    (["ctrl.fpi.width=2.5"], "whole number", "fpi"),
])
def test_bad_block_parameters_are_named_with_their_block(tmp_path, capsys, sets, message, line):
    code, _, err = run(capsys, "check", HC, *[x for s in sets for x in ("--set", s)])
    assert code == 2 and message in err and f"block {line!r}" in err, err


def test_bad_parameter_in_a_file_names_its_own_line(tmp_path, capsys):
    p = write(tmp_path, f"extends: {HC}\nblocks:\n  surface:\n    br: 0\n    Kr: -5\n")
    code, _, err = run(capsys, "check", p)
    assert code == 2 and "d.yaml:5" in err and "'Kr' must be positive" in err


def test_nul_byte_and_deep_nesting_are_clear_errors(tmp_path, capsys):
    code, _, err = run(capsys, "check", write(tmp_path, GOOD.replace("k: 2.0", "k: 2.0\x00")))
    assert code == 2 and "d.yaml:2" in err and "not allowed" in err
    deep = GOOD.replace("k: 2.0", "k: " + "[" * 5000 + "]" * 5000)
    code, _, err = run(capsys, "check", write(tmp_path, deep))
    assert code == 2 and "nested deeper than" in err


@pytest.mark.slow
def test_extends_dev_zero_a_huge_file_and_a_fifo(tmp_path, capsys):
    code, _, err = run(capsys, "check", write(tmp_path, "extends: /dev/zero\nblocks: {}\n"))
    assert code == 2 and "is not a YAML file" in err
    big = tmp_path / "big.yaml"
    with open(big, "w") as fh:
        fh.write("blocks: {}\n" + "#" * 100 + "\n")
        fh.truncate(50 * 2**20)
    t0 = time.perf_counter()
    code, _, err = run(capsys, "check", write(tmp_path, "extends: big.yaml\nblocks: {}\n"))
    assert code == 2 and "MiB" in err and time.perf_counter() - t0 < 2
    code, _, err = run(capsys, "check", write(tmp_path, f"extends: {HC}\n"))  # absolute, YAML: allowed
    assert code == 0
    fifo = tmp_path / "f.yaml"
    os.mkfifo(fifo)
    code, _, err = run(capsys, "check", fifo)
    assert code == 2 and "not a regular file" in err
    code, _, err = run(capsys, "check", tmp_path)
    assert code == 2 and "is a folder" in err


BOMB = """\
params:
  a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]
  b: &b [*a, *a, *a, *a, *a, *a, *a, *a, *a, *a]
  c: &c [*b, *b, *b, *b, *b, *b, *b, *b, *b, *b]
  d: &d [*c, *c, *c, *c, *c, *c, *c, *c, *c, *c]
  e: &e [*d, *d, *d, *d, *d, *d, *d, *d, *d, *d]
  f: &f [*e, *e, *e, *e, *e, *e, *e, *e, *e, *e]
  g: &g [*f, *f, *f, *f, *f, *f, *f, *f, *f, *f]
  h: &h [*g, *g, *g, *g, *g, *g, *g, *g, *g, *g]
"""


@pytest.mark.parametrize("tail", ["blocks: {x: {type: constant, value: $h}}\n", "blocks: {}\nlog: *h\n"])
def test_alias_bombs_are_refused_quickly_and_small(tmp_path, capsys, tail):
    import tracemalloc

    tracemalloc.start()
    t0 = time.perf_counter()
    code, _, err = run(capsys, "check", write(tmp_path, BOMB + tail))
    wall = time.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert code == 2 and "aliases repeat values" in err
    assert wall < 2 and peak < 50 * 2**20


def test_recursive_alias_is_refused(tmp_path, capsys):
    code, _, err = run(capsys, "check", write(tmp_path, "params:\n  a: &a [1, *a]\nblocks: {}\n"))
    assert code == 2 and "contains it" in err


def test_draw_to_an_unknown_format_is_refused_before_drawing(tmp_path, capsys):
    code, _, err = run(capsys, "draw", write(tmp_path, GOOD), "-o", tmp_path / "fig.xyz")
    assert code == 2 and "unsupported file type '.xyz'" in err and ".svg" in err
    assert not (tmp_path / "fig.xyz").exists()


def test_report_on_a_diagram_without_state(tmp_path, capsys):
    text = "blocks:\n  c: {type: constant, value: 1.0}\n  z: {type: zoh, rate: 10}\n  s: {type: recorder}\n" \
           "wires: [c.y -> z.u, z.y -> s.u]\nsimulation: {t_end: 0.1}\n"
    code, _, err = run(capsys, "report", write(tmp_path, text), "-o", tmp_path / "r")
    assert code == 0, err
    assert (tmp_path / "r" / "report.html").exists()


def test_bad_fmu_parameter_value_is_exit_2(tmp_path, capsys):
    from hybridsim.fmi.fmu_block import find_compiler
    from hybridsim.fmus.build import build_plant_fmu

    try:
        find_compiler()
    except FMUError:
        pytest.skip("no C compiler")
    fmu = build_plant_fmu(tmp_path / "plant.fmu")
    code, _, err = run(capsys, "check", DIAGRAMS / "fig9_fmu_cs.yaml", "--set", f"fmu={fmu}",
                       "--set", "plant.parameters={Kw: [1, [2]]}")
    assert code == 2 and "must be a finite number" in err
    code, _, err = run(capsys, "check", DIAGRAMS / "fig9_fmu_cs.yaml", "--set", f"fmu={fmu}",
                       "--set", "plant.parameters=7")
    assert code == 2 and "'parameters' must be a mapping {variable name" in err


# -- exit codes ------------------------------------------------------------------------

@pytest.mark.parametrize("argv, message", [
    (["check", "{d}", "--set", "nonsense"], "--set expects PATH=VALUE"),
    (["check", "{d}", "--set", "=3"], "no PATH"),
    (["check", "{d}", "--set", "k=[1"], "cannot read value"),
    (["analyze", "{d}", "--at", "-1"], "finite time >= 0"),
    (["analyze", "{d}", "--at", "nan"], "finite time >= 0"),
    (["sweep", "{s}", "-j", "0"], "at least 1"),
    (["sweep", "{s}", "-j", "-3"], "at least 1"),
    (["reproduce", "-j", "0"], "at least 1"),
])
def test_bad_options_exit_2(tmp_path, capsys, argv, message):
    d = write(tmp_path, GOOD)
    s = write(tmp_path, f"diagram: {d}\ngrid: {{k: [1, 2]}}\n", "s.yaml")
    argv = [a.format(d=d, s=s) for a in argv]
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's own errors
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2 and message in err and "Traceback" not in err


def test_sweep_with_no_points_exits_2(tmp_path, capsys):
    d = write(tmp_path, GOOD)
    code, _, err = run(capsys, "sweep", write(tmp_path, f"diagram: {d}\n", "s.yaml"), "-o", tmp_path / "o")
    assert code == 2 and "no points" in err


@pytest.mark.slow
def test_sweep_dask_address_that_does_not_answer_exits_2(tmp_path, capsys, monkeypatch):
    from hybridsim.runs import executor

    monkeypatch.setattr(executor, "DASK_TIMEOUT_S", 1)
    d = write(tmp_path, GOOD)
    s = write(tmp_path, f"diagram: {d}\ngrid: {{k: [1, 2]}}\n", "s.yaml")
    t0 = time.perf_counter()
    code, _, err = run(capsys, "sweep", s, "-q", "--dask", "tcp://127.0.0.1:9", "-o", tmp_path / "o")
    assert code == 2 and "cannot reach a Dask scheduler" in err and time.perf_counter() - t0 < 8
    code, _, err = run(capsys, "sweep", s, "-q", "--dask", "not an address", "-o", tmp_path / "o")
    assert code == 2 and "cannot reach a Dask scheduler" in err


def test_step_longer_than_t_end_is_said(tmp_path, capsys):
    code, _, err = run(capsys, "check", write(tmp_path, GOOD.replace("t_end: 0.2", "t_end: 0.2, step: 0.5")))
    assert code == 0 and "longer than t_end" in err


def test_every_exception_family_has_its_documented_code():
    assert InputError.exit_code == 2
    for cls in (DiagramError, LoaderError, ParameterError, OutputError):
        assert issubclass(cls, InputError)
    assert SimulationError.exit_code == 3 and FMUError.exit_code == 4
    with pytest.raises(InputError):
        api.simulate(DIAGRAMS / "fig9_force_and_position.yaml", t_end=float("inf"))


# -- sweeps resume only what is identical ----------------------------------------------

def test_a_changed_sweep_does_not_reuse_old_points(tmp_path, capsys):
    d = write(tmp_path, GOOD)
    s = write(tmp_path, f"diagram: {d}\nset: {{simulation.t_end: 0.1}}\ngrid: {{k: [1, 2]}}\n", "s.yaml")
    out = tmp_path / "o"
    assert run(capsys, "sweep", s, "-q", "-o", out)[0] == 0
    assert run(capsys, "sweep", s, "-q", "-o", out)[0] == 0  # identical: resumes (nothing to run)
    s.write_text(s.read_text().replace("t_end: 0.1", "t_end: 0.15"))
    code, _, err = run(capsys, "sweep", s, "-q", "-o", out)
    assert code == 2 and "different sweep" in err and "--force" in err
    d.write_text(GOOD.replace("rate: 100", "rate: 50"))  # the diagram changed too
    s.write_text(s.read_text().replace("t_end: 0.15", "t_end: 0.1"))
    code, _, err = run(capsys, "sweep", s, "-q", "-o", out)
    assert code == 2 and "different sweep" in err
    code, _, _ = run(capsys, "sweep", s, "-q", "-o", out, "--force")
    assert code == 0 and (out / "points.jsonl.old").exists()
    assert len((out / "points.jsonl").read_text().splitlines()) == 2


def test_an_analysis_time_past_t_end_is_said_once(tmp_path, capsys):
    # analyze ran 300 s in silence on a 0.3 s diagram linearized at 100 s
    code, _, err = run(capsys, "check", write(tmp_path, GOOD + "analysis: {at: 100}\n"))
    assert code == 0 and err.count("analysis at 100 s is past t_end 0.2 s") == 1


@pytest.mark.slow
def test_a_reader_that_leaves_early_does_not_stop_the_command(tmp_path):
    """``hybridsim analyze ... | head -1``: the pipe closes after the first line; the command finishes
    its files and exits 0, without 'Broken pipe' (it said so and exited 5, the environment's code)."""
    code = "import sys; from hybridsim.app.cli import main; sys.exit(main(sys.argv[1:]))"
    diagram = DIAGRAMS / "examples" / "msd_pid.yaml"
    p = subprocess.Popen([sys.executable, "-c", code, "analyze", str(diagram), "-o", str(tmp_path / "a")],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=tmp_path)
    first = p.stdout.readline()
    p.stdout.close()
    err = p.stderr.read().decode()
    assert p.wait(timeout=120) == 0, err
    assert first.startswith(b"msd_pid: closed loop") and "Broken pipe" not in err
    assert (tmp_path / "a" / "analysis.json").is_file()
