"""Benchmark scripts append their figures to benchmarks/RESULTS.md as dated sections."""
import datetime
import os
import subprocess
import sys

from conftest import ROOT

sys.path.insert(0, str(ROOT / "benchmarks"))
import pytest  # noqa: E402
import results  # noqa: E402


def test_a_section_is_appended_with_date_command_and_output(tmp_path):
    out = tmp_path / "RESULTS.md"
    out.write_text("# Benchmark results\n\n## 2026-11-22: earlier\n\nkept\n")
    results.append_section("a title", "row 1\nrow 2\n", command="python bench.py --n 3", date="2026-12-02", path=out)
    text = out.read_text()
    assert text.startswith("# Benchmark results\n\n## 2026-11-22: earlier\n\nkept\n")  # nothing earlier changed
    assert "\n## 2026-12-02: a title\n\n`python bench.py --n 3` (" in text and "```text\nrow 1\nrow 2\n```\n" in text


def test_recorded_copies_what_the_benchmark_prints_and_skips_a_failed_run(tmp_path, capsys):
    out = tmp_path / "RESULTS.md"
    with results.recorded("demo", path=out):
        print("42 runs/s")
    assert "42 runs/s" in capsys.readouterr().out  # still printed
    today = datetime.datetime.now(datetime.timezone.utc).date().isoformat()
    assert f"## {today}: demo" in out.read_text() and "42 runs/s" in out.read_text()
    before = out.read_text()
    try:
        with results.recorded("broken", path=out):
            print("half a table")
            raise RuntimeError("benchmark failed")
    except RuntimeError:
        pass
    assert out.read_text() == before


@pytest.mark.slow
def test_a_benchmark_script_records_its_run(tmp_path):
    out = tmp_path / "RESULTS.md"
    env = {**os.environ, "HYBRIDSIM_BENCH_RESULTS": str(out), "PYTHONPATH": str(ROOT)}
    r = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "fuzz_entry_points.py"), "--examples", "2"],
                       capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    text = out.read_text()
    assert ": Fuzzing the entry points" in text and "fuzz_entry_points.py --examples 2" in text
    assert "cases in" in text
