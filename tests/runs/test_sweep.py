"""Sweeps: the same table serially, on local processes and on Dask; resume; failures."""
import json
import os

import numpy as np
import pandas as pd
import pytest

from hybridsim.runs import sweep as sw
from hybridsim.runs.experiment import Experiment
from hybridsim.app.cli import main

from conftest import DIAGRAMS

SMALL = f"""
diagram: {DIAGRAMS / 'fig7_force_steps.yaml'}
set: {{force: 5.0, simulation.t_end: 0.6}}
grid:
  rate: [60, 120]
scale:
  ctrl.fpi.Kp: [1.0, 2.0]
stability: true
"""


def table(path):
    df = pd.read_csv(path).drop(columns=["wall_time_s"])
    return df.sort_values("key").reset_index(drop=True)


@pytest.fixture
def sweep_file(tmp_path):
    p = tmp_path / "s.yaml"
    p.write_text(SMALL)
    return p


@pytest.mark.slow
def test_serial_pool_and_dask_give_the_same_table(sweep_file, tmp_path):
    distributed = pytest.importorskip("distributed")
    sw.run_sweep(sweep_file, tmp_path / "serial", jobs=1, progress=False)
    sw.run_sweep(sweep_file, tmp_path / "pool", jobs=2, progress=False)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        sw.run_sweep(sweep_file, tmp_path / "dask", dask=client, progress=False)
    ref = table(tmp_path / "serial" / "sweep.csv")
    assert len(ref) == 4 and (ref["status"] == "ok").all()
    assert {"rate", "ctrl.fpi.Kp*", "overshoot_pct", "linear_largest_abs_z"} <= set(ref.columns)
    pd.testing.assert_frame_equal(ref, table(tmp_path / "pool" / "sweep.csv"))
    pd.testing.assert_frame_equal(ref, table(tmp_path / "dask" / "sweep.csv"))
    assert len(pd.read_parquet(tmp_path / "serial" / "sweep.parquet")) == 4
    assert (tmp_path / "serial" / "heatmap.png").stat().st_size > 5000


@pytest.mark.slow
def test_resume_runs_only_the_missing_points(sweep_file, tmp_path):
    out = tmp_path / "o"
    sw.run_sweep(sweep_file, out, jobs=1, progress=False)
    lines = (out / "points.jsonl").read_text().splitlines()
    # an interrupted sweep: one point never finished, another's line was cut mid-write
    (out / "points.jsonl").write_text("\n".join(lines[:2]) + "\n" + lines[2][:40])
    sw.run_sweep(sweep_file, out, jobs=1, progress=False)
    whole = [x for x in (out / "points.jsonl").read_text().splitlines() if x.startswith("{") and x.endswith("}")]
    assert len(whole) == 4  # the two kept, and only the two missing ones run again
    assert len({json.loads(x)["key"] for x in whole}) == 4
    assert len(pd.read_csv(out / "sweep.csv")) == 4
    pd.testing.assert_frame_equal(table(out / "sweep.csv"), table(tmp_path / "o" / "sweep.csv"))


@pytest.mark.slow
def test_asking_for_traces_on_a_resumed_sweep_is_a_changed_sweep(sweep_file, tmp_path):
    # 'traces: true' added after a sweep: its points were read back, no run wrote a CSV, exit 0 with
    # an empty traces/ folder
    from hybridsim.errors import InputError

    out = tmp_path / "o"
    sweep_file.write_text(SMALL.replace("stability: true", "stability: false").replace("[60, 120]", "[60]"))
    sw.run_sweep(sweep_file, out, jobs=1, progress=False)
    sweep_file.write_text(sweep_file.read_text() + "traces: true\n")
    with pytest.raises(InputError, match="'traces'"):
        sw.run_sweep(sweep_file, out, jobs=1, progress=False)


@pytest.mark.slow
def test_failing_point_is_recorded_not_fatal(tmp_path, capsys):
    p = tmp_path / "f.yaml"
    p.write_text(f"""
diagram: {DIAGRAMS / 'fig7_force_steps.yaml'}
set: {{force: 5.0, rate: 60, friction: false, ctrl.fpi.limit: null, simulation.t_end: 1.5}}
grid:
  surface.unilateral: [true, false]
""")
    code = main(["sweep", str(p), "-o", str(tmp_path / "o"), "-q", "-j", "2"])
    assert code == 0
    df = pd.read_csv(tmp_path / "o" / "sweep.csv")
    failed = df[df["status"] == "failed"]
    assert len(df) == 2 and len(failed) >= 1
    assert failed["message"].str.contains("diverged").all()
    assert "failed" in capsys.readouterr().out


def test_random_design_is_seeded(tmp_path):
    p = tmp_path / "r.yaml"
    p.write_text(f"diagram: {DIAGRAMS / 'fig7_force_steps.yaml'}\nrandom: {{n: 3, seed: 7, ranges: {{Kr: [8.0e5, 1.0e6]}}}}\n")
    a, b = sw.Sweep(p).points(), sw.Sweep(p).points()
    assert [x.label for x in a] == [x.label for x in b] and len(a) == 3
    assert all(8e5 <= x.label["Kr"] <= 1e6 for x in a)


@pytest.mark.slow
def test_compiled_sweep_gives_the_same_table(sweep_file, tmp_path):
    pytest.importorskip("numba")
    sw.run_sweep(sweep_file, tmp_path / "plain", jobs=1, progress=False)
    code = main(["sweep", str(sweep_file), "-o", str(tmp_path / "fast"), "-j", "1", "-q", "--compiled"])
    assert code == 0
    pd.testing.assert_frame_equal(table(tmp_path / "plain" / "sweep.csv"), table(tmp_path / "fast" / "sweep.csv"))


RUNTIME = f"""
diagram: {DIAGRAMS / 'fig7_force_steps.yaml'}
set: {{force: 5.0, rate: 60, simulation.t_end: 0.7}}
scale:
  ctrl.fpi.Kp: [0.5, 1.0, 1.5, 2.0, 2.5]
grid:
  Kr: [8.0e5, 9.0e5]
"""


@pytest.fixture
def runtime_file(tmp_path):
    p = tmp_path / "rt.yaml"
    p.write_text(RUNTIME)
    return p


def counted_rebuilds(monkeypatch):
    """The changes of every experiment built anew from a point's changes (here, in this process)."""
    calls = []
    real = Experiment.rebuilt
    monkeypatch.setattr(Experiment, "rebuilt", lambda self, ch: calls.append(ch) or real(self, ch))
    return calls


@pytest.mark.slow
def test_chunked_sweep_gives_the_point_by_point_table(runtime_file, tmp_path, monkeypatch):
    # every point changes block numbers only (Kp, and Kr through the diagram's params): one built diagram
    calls = counted_rebuilds(monkeypatch)
    sw.run_sweep(runtime_file, tmp_path / "chunks", jobs=1, progress=False)
    assert calls == []  # no point was built on its own
    sw.run_sweep(runtime_file, tmp_path / "points", jobs=1, progress=False, batch=False)
    assert len(calls) == 10
    sw.run_sweep(runtime_file, tmp_path / "pool", jobs=2, progress=False)
    ref = table(tmp_path / "points" / "sweep.csv")
    assert len(ref) == 10 and (ref["status"] == "ok").all()
    metrics = ref.drop(columns=["key", "ctrl.fpi.Kp*", "Kr", "variant", "status", "message"])
    assert len(metrics.drop_duplicates()) >= 5  # the points have numbers of their own
    pd.testing.assert_frame_equal(ref, table(tmp_path / "chunks" / "sweep.csv"))
    pd.testing.assert_frame_equal(ref, table(tmp_path / "pool" / "sweep.csv"))
    assert len((tmp_path / "chunks" / "points.jsonl").read_text().splitlines()) == 10


@pytest.mark.slow
def test_chunks_on_dask_give_the_same_table(runtime_file, tmp_path):
    distributed = pytest.importorskip("distributed")
    sw.run_sweep(runtime_file, tmp_path / "points", jobs=1, progress=False, batch=False)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        sw.run_sweep(runtime_file, tmp_path / "dask", dask=client, progress=False)
    pd.testing.assert_frame_equal(table(tmp_path / "points" / "sweep.csv"), table(tmp_path / "dask" / "sweep.csv"))


@pytest.mark.slow
def test_a_point_that_changes_structure_runs_on_its_own(tmp_path, monkeypatch):
    p = tmp_path / "rate.yaml"
    p.write_text(f"diagram: {DIAGRAMS / 'fig7_force_steps.yaml'}\n"
                 "set: {force: 5.0, simulation.t_end: 0.3}\ngrid: {rate: [60, 120]}\n")
    assert not sw.Sweep(p).experiment.runtime("rate", 120, names=True)  # a rate is the diagram's structure
    calls = counted_rebuilds(monkeypatch)
    rows = sw.run_sweep(p, tmp_path / "o", jobs=1, progress=False)
    assert calls == [{"rate": 60}, {"rate": 120}] and all(r["status"] == "ok" for r in rows)


@pytest.mark.slow
def test_a_bad_swept_value_stops_the_sweep_before_any_run(tmp_path):
    from hybridsim.errors import InputError

    p = tmp_path / "bad.yaml"
    p.write_text(f"diagram: {DIAGRAMS / 'fig7_force_steps.yaml'}\n"
                 "grid: {ctrl.fpi.Kp: [[0.4, 0.3], [0.1, 0.2, 0.3]]}\n")
    with pytest.raises(InputError, match=r"bad.yaml:2: swept value ctrl.fpi.Kp = \[0.1, 0.2, 0.3\]"):
        sw.run_sweep(p, tmp_path / "o", jobs=1, progress=False)
    assert not (tmp_path / "o" / "points.jsonl").exists()


def test_a_scaled_subsystem_parameter_of_a_broken_diagram_reports_the_diagram(tmp_path):
    from hybridsim.errors import InputError

    (tmp_path / "sub.yaml").write_text("name: sub\nparams: {k: 1.0}\nblocks:\n  g: {type: gain, K: $k}\n"
                                       "inputs: {u: g.u}\noutputs: {y: g.y}\n")
    (tmp_path / "d.yaml").write_text("blocks:\n  c: {type: constant, value: 1.0}\n"
                                     "  s: {type: subsystem, file: sub.yaml, kk: 2.0}\n"
                                     "wires: [c.y -> s.u]\nsimulation: {t_end: 0.1}\n")
    p = tmp_path / "s.yaml"
    p.write_text("diagram: d.yaml\nscale:\n  s.g.K: [0.5, 1.0]\n")
    with pytest.raises(InputError, match=r"d.yaml:3: subsystem 's' \(sub.yaml\) has no parameter 'kk'"):
        sw.run_sweep(p, tmp_path / "o", jobs=1, progress=False)
    p.write_text("diagram: d.yaml\nscale:\n  nosuch: [0.5, 1.0]\n")
    with pytest.raises(InputError, match=r"s.yaml:3: cannot scale 'nosuch'"):
        sw.Sweep(p).points()


def test_a_parameter_that_is_not_finite_is_not_scaled(tmp_path):
    from hybridsim.errors import InputError

    d = tmp_path / "d.yaml"
    d.write_text("blocks:\n  c: {type: constant, value: 1.0}\n  x: {type: integrator}\nwires: [c.y -> x.u]\n"
                 "simulation: {t_end: 0.1}\n")
    p = tmp_path / "s.yaml"
    p.write_text("diagram: d.yaml\nscale: {x.upper: [0.5, 1.0]}\n")  # inf both times: two rows of one point
    with pytest.raises(InputError, match="cannot scale 'x.upper': its value is inf, not finite"):
        sw.run_sweep(p, tmp_path / "o", jobs=1, progress=False)


@pytest.mark.parametrize("axes", ["grid: {x.K: [2, 2]}", "grid: {x.K: [2, 2.0]}",
                                  "random: {n: 2, ranges: {x.K: [3, 3]}}", "scale: {x.initial: [1, 2]}"])
def test_a_sweep_that_names_one_point_twice_is_refused(tmp_path, axes):
    from hybridsim.errors import InputError

    d = tmp_path / "d.yaml"
    d.write_text("blocks:\n  c: {type: constant, value: 1.0}\n  x: {type: integrator}\nwires: [c.y -> x.u]\n"
                 "simulation: {t_end: 0.1}\n")
    p = tmp_path / "s.yaml"
    p.write_text(f"diagram: d.yaml\n{axes}\n")
    with pytest.raises(InputError, match=r"s.yaml:2: points 1 and 2 are the same run"):
        sw.run_sweep(p, tmp_path / "o", jobs=1, progress=False)


def test_a_points_file_that_is_not_text_is_refused_then_set_aside_with_force(tmp_path):
    from hybridsim.errors import InputError
    from hybridsim.runs.store import Store

    Store(tmp_path, "id", "points.jsonl", "m.json", "sweep", "?")  # the manifest of this sweep
    (tmp_path / "points.jsonl").write_bytes(b"\xff\xfe\x00")  # was UnicodeDecodeError, exit 70
    with pytest.raises(InputError, match="not a file of points hybridsim wrote"):
        Store(tmp_path, "id", "points.jsonl", "m.json", "sweep", "?")
    assert len(Store(tmp_path, "id", "points.jsonl", "m.json", "sweep", "?", restart=True).done) == 0
    assert (tmp_path / "points.jsonl.old").read_bytes() == b"\xff\xfe\x00"
    # a second --force replaced the first's .old (the points of two runs ago were lost); a user's .old
    # was refused: each generation goes to the first free name now, and nothing is replaced
    (tmp_path / "points.jsonl").write_bytes(b"\xff")
    (tmp_path / "points.jsonl.old").write_text("my notes")
    with pytest.raises(InputError, match=r"kept as points.jsonl.old.1\)"):
        Store(tmp_path, "id", "points.jsonl", "m.json", "sweep", "?")
    Store(tmp_path, "id", "points.jsonl", "m.json", "sweep", "?", restart=True)
    (tmp_path / "points.jsonl").write_bytes(b"\xfe")
    Store(tmp_path, "id", "points.jsonl", "m.json", "sweep", "?", restart=True)
    assert (tmp_path / "points.jsonl.old").read_text() == "my notes"
    assert (tmp_path / "points.jsonl.old.1").read_bytes() == b"\xff"
    assert (tmp_path / "points.jsonl.old.2").read_bytes() == b"\xfe"


def test_a_missing_diagram_is_named_at_its_line_of_the_sweep_file(tmp_path):
    from hybridsim.errors import LoaderError

    p = tmp_path / "bad.yaml"
    p.write_text("scale: {g.K: [1, 2]}\ndiagram: nowhere.yaml\n")
    with pytest.raises(LoaderError, match="'diagram' 'nowhere.yaml': no such file") as err:
        sw.run_sweep(p, tmp_path / "o", jobs=1, progress=False)
    assert str(err.value).startswith(f"{p}:2:")
    assert not (tmp_path / "o").exists()


def test_a_diagram_that_is_a_folder_or_a_fifo_is_named_as_such(tmp_path):
    # both said "no such file"
    from hybridsim.errors import LoaderError
    from hybridsim.tune.spec import TuneSpec

    (tmp_path / "d.yaml").mkdir()
    os.mkfifo(tmp_path / "f.yaml")
    for name, says in (("d.yaml", "a folder"), ("f.yaml", "not a regular file")):
        p = tmp_path / "s.yaml"
        p.write_text(f"diagram: {name}\nscale: {{g.K: [1, 2]}}\n")
        with pytest.raises(LoaderError, match=f"'diagram' '{name}': {says}"):
            sw.Sweep(p)
        p.write_text(f"diagram: {name}\nparameters: {{g.K: {{low: 1, high: 2}}}}\nobjectives: []\n")
        with pytest.raises(LoaderError, match=f"'diagram' '{name}': {says}"):
            TuneSpec(p)


@pytest.mark.slow
def test_compiled_chunks_give_the_point_by_point_table(runtime_file, tmp_path):
    pytest.importorskip("numba")
    sw.run_sweep(runtime_file, tmp_path / "points", jobs=1, progress=False, batch=False)
    sw.run_sweep(runtime_file, tmp_path / "fast", jobs=2, progress=False, compiled=True)
    pd.testing.assert_frame_equal(table(tmp_path / "points" / "sweep.csv"), table(tmp_path / "fast" / "sweep.csv"))


@pytest.mark.slow
def test_chunked_traces_equal_the_point_by_point_traces(tmp_path):
    p = tmp_path / "tr.yaml"
    p.write_text(RUNTIME.replace("[0.5, 1.0, 1.5, 2.0, 2.5]", "[0.5, 2.0]").replace("[8.0e5, 9.0e5]", "[9.0e5]")
                 + "traces: true\n")
    sw.run_sweep(p, tmp_path / "chunks", jobs=1, progress=False)
    sw.run_sweep(p, tmp_path / "points", jobs=1, progress=False, batch=False)
    a = sorted((tmp_path / "chunks" / "traces").glob("*.csv"))
    b = sorted((tmp_path / "points" / "traces").glob("*.csv"))
    assert [x.name for x in a] == [x.name for x in b] and len(a) == 2
    for x, y in zip(a, b):
        pd.testing.assert_frame_equal(pd.read_csv(x), pd.read_csv(y))


def test_a_column_of_numbers_and_lists_writes_to_parquet(tmp_path):
    # a grid over g.K: [2.0, [1, 2, 3]] ran every point, then pyarrow refused the column (exit 70)
    import pandas as pd

    from hybridsim.runs.table import write_table

    write_table([{"g.K": 2.0, "m": 1.0}, {"g.K": [1.0, 2.0, 3.0], "m": 2.0}], tmp_path)
    back = pd.read_parquet(tmp_path / "sweep.parquet")
    assert back["g.K"].tolist() == ["2.0", "[1.0, 2.0, 3.0]"] and back["m"].tolist() == [1.0, 2.0]


def test_a_bad_set_value_names_the_sweep_file_and_its_line(tmp_path, capsys):
    # it named the diagram and blamed "--set kpp", which the user never gave
    p = tmp_path / "s.yaml"
    p.write_text(SMALL.replace("force: 5.0", "forse: 5.0"))
    assert main(["check", str(p)]) == 2
    err = capsys.readouterr().err
    assert "s.yaml:3: in 'set': " in err and "set forse: no parameter 'forse' in 'params' (did you mean 'force'?)" in err


def test_a_sweep_of_a_parameter_and_of_the_only_value_using_it_is_refused(tmp_path, capsys):
    # four points in which the k column changed nothing (g.K: $k is swept too)
    from conftest import GOOD

    (tmp_path / "d.yaml").write_text(GOOD)
    p = tmp_path / "s.yaml"
    p.write_text("diagram: d.yaml\ngrid: {k: [1, 2], g.K: [3, 4]}\n")
    assert main(["check", str(p)]) == 2
    assert "the sweep's k: changes nothing: every value that uses $k is set too (g.K)" in capsys.readouterr().err


def test_a_bad_block_value_in_set_and_a_sweep_as_the_diagram_name_the_sweep_file(tmp_path, capsys):
    p = tmp_path / "s.yaml"
    p.write_text(SMALL.replace("force: 5.0", "force: 5.0, ctrl.fpi.Ki: abc"))
    assert main(["check", str(p)]) == 2
    err = capsys.readouterr().err
    assert "s.yaml:3: in 'set': " in err and "set ctrl.fpi.Ki: " in err, err
    (tmp_path / "t.yaml").write_text(f"diagram: {p}\ngrid: {{force: [1, 2]}}\n")
    assert main(["check", str(tmp_path / "t.yaml")]) == 2
    assert "t.yaml:1: 'diagram': " in capsys.readouterr().err


def test_a_heat_map_over_an_axis_of_lists_and_numbers_labels_them(tmp_path):
    # a grid axis mixing a number and a list ended the sweep in "unhashable type" (exit 70) after
    # every point had run
    from hybridsim.analysis.metrics import headline
    from hybridsim.runs.table import heatmaps

    metric = headline()[0]
    rows = [{"ctrl.fpi.Kp": kp, "Kr": kr, "status": "ok", metric: float(k)}
            for k, (kp, kr) in enumerate([(0.4, 9e5), ([0.2, 0.3], 9e5), (0.4, 5e5), ([0.2, 0.3], 5e5)])]
    heatmaps(rows, ["ctrl.fpi.Kp", "Kr"], tmp_path)
    assert (tmp_path / "heatmap.png").stat().st_size > 5000


@pytest.mark.parametrize("body, line", [("grid:\n  a.K: [1.0]\n  b.K: 5\n", 4),
                                        ("random:\n  n: 2\n  ranges:\n    a.K: [1.0, 2.0]\n    b.K: [1.0, 2.0, 3.0]\n", 6),
                                        # a misspelled key of 'random' was named at 'random:' (line 2)
                                        ("random:\n  n: 2\n  b.K:\n    a.K: [1.0, 2.0]\n", 4),
                                        # an unknown key whose value is a block below it: the key's line
                                        ("b.K:\n  a.K: [1.0, 2.0]\n", 2)])
def test_a_bad_entry_of_a_sweep_section_is_named_at_its_own_line(tmp_path, body, line):
    from hybridsim.errors import InputError

    p = tmp_path / "s.yaml"
    p.write_text(f"diagram: {DIAGRAMS / 'fig7_force_steps.yaml'}\n" + body)
    with pytest.raises(InputError, match=rf"s.yaml:{line}: .*'b.K'"):
        sw.Sweep(p)


def test_a_random_range_over_a_sample_rate_is_refused_by_the_check(tmp_path):
    # a rate drawn anywhere in [40, 60] Hz is incommensurate with the 100 Hz log: the ends passed, every
    # drawn point failed and the sweep exited 0 with an empty table (check of the diagram, too, passed
    # a rate its run refused)
    from hybridsim.errors import InputError

    import hybridsim as hs

    msd = DIAGRAMS / "examples" / "msd_pid.yaml"
    with pytest.raises(InputError, match=r"log_period': sample rates are not commensurate \(pid 48.0005 Hz"):
        hs.check(msd, rate=48.0005)
    p = tmp_path / "s.yaml"
    p.write_text(f"diagram: {msd}\nrandom: {{n: 2, seed: 1, ranges: {{rate: [40, 60]}}}}\n")
    with pytest.raises(InputError, match=r"s.yaml:2: swept value rate = 47.639.*not commensurate"):
        sw.Sweep(p).validate()


def test_too_many_points_are_named_at_the_line_of_the_section_that_makes_them(tmp_path):
    from hybridsim.errors import InputError

    p = tmp_path / "s.yaml"
    p.write_text(f"diagram: {DIAGRAMS / 'examples' / 'msd_pid.yaml'}\ngrid: {{pid.Kp: [1, 2]}}\n"
                 "random: {n: 100000, seed: 1, ranges: {pid.Ki: [1, 2]}}\n")
    with pytest.raises(InputError, match=r"s\.yaml:3: the sweep has 100002 points; at most 100000"):
        sw.Sweep(p).points()


def test_a_users_table_in_the_output_folder_is_refused_before_any_point_runs(sweep_file, tmp_path):
    from hybridsim.errors import OutputError

    out = tmp_path / "o"
    out.mkdir()
    (out / "heatmap.png").write_text("mine")  # was refused after every point had run
    with pytest.raises(OutputError, match="heatmap.png' exists and hybridsim did not write it"):
        sw.run_sweep(sweep_file, out, jobs=1, progress=False)
    assert sorted(p.name for p in out.iterdir()) == ["heatmap.png"]


def test_stability_of_a_continuous_diagram_is_its_largest_real_part_and_a_stable_column(tmp_path):
    """1/(s - 1) under a gain K: the closed-loop pole is 1 - K (a negative "|z|" before, no verdict)."""
    (tmp_path / "d.yaml").write_text(
        "name: d\nparams: {K: 1.0}\nblocks:\n  r: {type: constant, value: 0.0}\n  e: {type: sum, signs: '+-'}\n"
        "  k: {type: gain, K: $K}\n  p: {type: transfer_function, num: [1.0], den: [1.0, -1.0]}\n"
        "wires: [r.y -> e.u1, p.y -> e.u2, e.y -> k.u, k.y -> p.u]\nsimulation: {t_end: 0.1}\nlog: [p.y]\n")
    p = tmp_path / "s.yaml"
    p.write_text("diagram: d.yaml\ngrid:\n  K: [0.5, 2.0]\nstability: true\n")
    rows = {r["K"]: r for r in sw.run_sweep(p, tmp_path / "o", jobs=1, progress=False)}
    assert rows[0.5]["linear_largest_abs_z"] == pytest.approx(0.5, abs=1e-6) and rows[0.5]["linear_stable"] is False
    assert rows[2.0]["linear_largest_abs_z"] == pytest.approx(-1.0, abs=1e-6) and rows[2.0]["linear_stable"] is True


def test_stability_is_computed_for_each_variant(tmp_path):
    """The diagram's variants set the rate: the sampled loop z = e^T - K (e^T - 1) of 1/(s - 1) under a
    gain K is the row's own (every variant's row showed the first variant's)."""
    (tmp_path / "d.yaml").write_text(
        "name: d\nparams: {K: 1.0, rate: 10}\nvariants: {rate: [10, 20]}\nblocks:\n  r: {type: constant, value: 0.0}\n"
        "  e: {type: sum, signs: '+-'}\n  k: {type: discrete_transfer_function, num: [$K], den: [1.0], rate: $rate}\n"
        "  p: {type: transfer_function, num: [1.0], den: [1.0, -1.0]}\n"
        "wires: [r.y -> e.u1, p.y -> e.u2, e.y -> k.u, k.y -> p.u]\nsimulation: {t_end: 0.1}\nlog: [p.y]\n")
    p = tmp_path / "s.yaml"
    p.write_text("diagram: d.yaml\ngrid:\n  K: [1.5]\nstability: true\n")
    rows = sw.run_sweep(p, tmp_path / "o", jobs=1, progress=False)
    got = {r["variant"]: r["linear_largest_abs_z"] for r in rows}
    for rate in (10, 20):
        z = np.exp(1 / rate) - 1.5 * (np.exp(1 / rate) - 1)
        assert got[f"rate={rate}"] == pytest.approx(z, abs=1e-7)


def test_scaling_one_element_scales_that_element(tmp_path):
    """scale: g.K[1] multiplied the whole list and wrote it into element 1 (a 'must be a number' error)."""
    (tmp_path / "d.yaml").write_text("name: d\nblocks:\n  c: {type: constant, value: [1.0, 1.0]}\n"
                                     "  g: {type: gain, K: [1.0, 4.0]}\nwires: [c.y -> g.u]\n"
                                     "simulation: {t_end: 0.01}\nlog: [g.y]\n")
    p = tmp_path / "s.yaml"
    p.write_text("diagram: d.yaml\nscale:\n  g.K[1]: [0.5, 2.0]\n")
    assert [pt.changes for pt in sw.Sweep(p).points()] == [{"g.K[1]": 2.0}, {"g.K[1]": 8.0}]
    p.write_text("diagram: d.yaml\nscale:\n  g.K[2]: [0.5, 2.0]\n")
    with pytest.raises(Exception, match=r"index 2 is past the 2 element\(s\) of 'g.K'"):
        sw.Sweep(p).points()


def test_a_users_file_where_a_trace_goes_is_refused_before_any_point_runs(tmp_path):
    """It was refused after some points had written theirs, saying nothing was written."""
    from hybridsim.errors import OutputError

    (tmp_path / "d.yaml").write_text("name: d\nparams: {K: 1.0}\nvariants: {K: [1.0, 2.0]}\nblocks:\n"
                                     "  c: {type: constant, value: $K}\nlog: [c.y]\nsimulation: {t_end: 0.01}\n")
    p = tmp_path / "s.yaml"
    p.write_text("diagram: d.yaml\ngrid:\n  c.value: [3.0, 4.0]\ntraces: true\n")
    key = sw.Sweep(p).points()[1].key
    (tmp_path / "o" / "traces").mkdir(parents=True)
    mine = tmp_path / "o" / "traces" / sw.trace_name(key, "K=2.0", ["K=1.0", "K=2.0"])
    mine.write_text("mine")
    with pytest.raises(OutputError, match="hybridsim did not write it"):
        sw.run_sweep(p, tmp_path / "o", jobs=1, progress=False)
    assert [x.name for x in (tmp_path / "o").rglob("*")] == ["traces", mine.name] and mine.read_text() == "mine"


def test_a_mistake_in_set_is_named_before_a_sweep_without_points(tmp_path):
    # "the sweep has no points" hid 'simulation.t_edn' in 'set'
    from hybridsim.errors import InputError

    p = tmp_path / "s.yaml"
    p.write_text(f"diagram: {DIAGRAMS / 'examples' / 'msd_pid.yaml'}\nset: {{simulation.t_edn: 1}}\n")
    with pytest.raises(InputError, match="unknown simulation setting 't_edn'"):
        sw.Sweep(p).points()
    p.write_text(f"diagram: {DIAGRAMS / 'examples' / 'msd_pid.yaml'}\nset: {{simulation.t_end: 1}}\n")
    with pytest.raises(InputError, match="the sweep has no points"):
        sw.Sweep(p).points()


@pytest.mark.slow
def test_a_one_axis_sweep_into_a_two_axis_sweeps_folder_leaves_no_stale_heat_map(tmp_path, capsys):
    # the 2-D sweep's heatmap.png stayed, listed as written by the 1-D one; the manifest named the first
    fig7 = DIAGRAMS / "fig7_force_steps.yaml"
    two, one = tmp_path / "two.yaml", tmp_path / "one.yaml"
    head = f"diagram: {fig7}\nset: {{force: 5.0, rate: 60, simulation.t_end: 0.6}}\n"
    two.write_text(head + "scale: {ctrl.fpi.Kp: [1.0, 2.0], ctrl.fpi.Ki: [1.0, 2.0]}\n")
    one.write_text(head + "scale: {ctrl.fpi.Kp: [1.0, 3.0]}\n")
    out = tmp_path / "o"
    assert main(["sweep", str(two), "-o", str(out), "-j", "1", "-q"]) == 0
    assert (out / "heatmap.png").exists()
    capsys.readouterr()
    assert main(["sweep", str(one), "-o", str(out), "-j", "1", "-q"]) == 0
    assert not (out / "heatmap.png").exists() and "heatmap" not in capsys.readouterr().out
    assert json.loads((out / "sweep-manifest.json").read_text())["sweep"] == str(one)


def test_a_rerun_says_how_many_points_it_found_done(tmp_path, caplog):
    # a finished sweep run again printed the summary of a fresh one, nothing about the store
    import logging

    msd = DIAGRAMS / "examples" / "msd_pid.yaml"
    p = tmp_path / "s.yaml"
    p.write_text(f"diagram: {msd}\nset: {{simulation.t_end: 0.05}}\ngrid: {{pid.Kp: [1.0, 2.0, 3.0]}}\n")
    sw.run_sweep(p, tmp_path / "o", jobs=1, progress=False)
    p.write_text(f"diagram: {msd}\nset: {{simulation.t_end: 0.05}}\ngrid: {{pid.Kp: [1.0, 2.0, 3.0, 4.0]}}\n")
    with caplog.at_level(logging.INFO, logger="hybridsim"):
        assert len(sw.run_sweep(p, tmp_path / "o", jobs=1, progress=True)) == 4
    assert "3 of 4 points found in points.jsonl from an earlier run; 1 to run" in caplog.text


def test_force_sets_the_earlier_sweeps_traces_aside_with_its_points(tmp_path):
    # --force kept the points as .old but replaced the traces of the same keys with the new run's
    msd = DIAGRAMS / "examples" / "msd_pid.yaml"
    p = tmp_path / "s.yaml"
    p.write_text(f"diagram: {msd}\nset: {{simulation.t_end: 0.06}}\ngrid: {{pid.Kp: [1.0, 2.0]}}\ntraces: true\n")
    out = tmp_path / "o"
    sw.run_sweep(p, out, jobs=1, progress=False)
    first = {f.name: f.read_text() for f in (out / "traces").iterdir()}
    p.write_text(p.read_text().replace("t_end: 0.06", "t_end: 0.04"))
    sw.run_sweep(p, out, jobs=1, progress=False, restart=True)
    assert {f.name: f.read_text() for f in (out / "traces.old").iterdir()} == first
    assert sorted(f.name for f in (out / "traces").iterdir()) == sorted(first)  # the same keys, new runs
    assert all(pd.read_csv(f)["time"].iloc[-1] == pytest.approx(0.04) for f in (out / "traces").iterdir())


def test_a_sweeps_set_that_makes_the_analysis_set_idle_still_gives_its_stability(tmp_path):
    # set: {arm.friction: true} with stability: true exited 2 ("--set friction: changes nothing"), a
    # --set nobody gave: the analysis section's set and the sweep's were applied as one
    p = tmp_path / "s.yaml"
    p.write_text(f"diagram: {DIAGRAMS / 'fig10_force_ramp.yaml'}\n"
                 "set: {simulation.t_end: 0.05, arm.friction: true}\nstability: true\ngrid: {rate: [60, 120]}\n")
    rows = sw.run_sweep(p, tmp_path / "o", jobs=1, progress=False)
    assert [r["status"] for r in rows] == ["ok", "ok"]
    assert all(0.0 < r["linear_largest_abs_z"] < 10.0 for r in rows)
