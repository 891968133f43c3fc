"""run_many: grids of points, the executor, the resume store, run-time and structural changes, measures."""
import hashlib
import json

import numpy as np
import pytest

from hybridsim.errors import InputError, SimulationError
from hybridsim.runs.executor import Executor
from hybridsim.runs.experiment import Experiment
from hybridsim.runs.grid import Grid, point, point_key
from hybridsim.runs.many import Failure, Linearize, Simulate, run_many
from hybridsim.runs.store import Store
from hybridsim.runs.variants import run_experiment

from conftest import write

#: x' = k from x(0) = 0, sampled by a zero-order hold: x(t_end) = k t_end exactly (RK4 integrates a ramp exactly)
RAMP = """\
params: {k: 2.0, rate: 100}
blocks:
  c: {type: constant, value: $k}
  f: {type: integrator}
  z: {type: zoh, rate: $rate}
wires: [c.y -> f.u, f.y -> z.u]
simulation: {t_end: 0.5, log_period: 0.01}
log: [f.y, z.y]
"""


def final(run):
    """A reduce: the integrator's value at t_end (None for a failed run)."""
    return None if run.error is not None else float(run.result["f.y"][-1, 0])


def doubled(experiment, pt):
    """A per-point measure: twice the point's k."""
    return 2 * pt.changes["k"]


@pytest.fixture
def ramp(tmp_path):
    return write(tmp_path, RAMP)


def test_grids_hand_checked():
    g = Grid.values({"a": [1, 2], "b": ["x"]}) * Grid.scaled({"k": [0.5, 2.0]}, {"k": [2.0, 4.0]})
    assert [p.changes for p in g] == [{"a": 1, "b": "x", "k": [1.0, 2.0]}, {"a": 1, "b": "x", "k": [4.0, 8.0]},
                                      {"a": 2, "b": "x", "k": [1.0, 2.0]}, {"a": 2, "b": "x", "k": [4.0, 8.0]}]
    assert [p.label for p in g][:2] == [{"a": 1, "b": "x", "k*": 0.5}, {"a": 1, "b": "x", "k*": 2.0}]
    assert point_key({"a": 1}) == hashlib.sha1(b'{"a": 1}').hexdigest()[:16]
    assert all(p.key == point_key(p.changes) for p in g)
    r = Grid.random({"u": (1.0, 2.0)}, n=5, seed=3)
    assert [p.changes for p in r] == [p.changes for p in Grid.random({"u": (1.0, 2.0)}, n=5, seed=3)]
    draws = np.random.default_rng(3).uniform(1.0, 2.0, 5)
    assert [p.changes["u"] for p in r] == pytest.approx(draws)
    assert len(g + r) == 9 and (g + r)[4].changes == r[0].changes


@pytest.mark.slow
def test_run_time_and_structural_points_give_the_exact_answer_serially_and_on_processes(ramp, monkeypatch):
    exp = Experiment(ramp)
    pts = Grid.values({"rate": [50, 100]}) * Grid.values({"k": [1.0, 3.0]})
    rebuilt = []
    real = Experiment.rebuilt
    monkeypatch.setattr(Experiment, "rebuilt", lambda self, ch: rebuilt.append(ch) or real(self, ch))
    got = run_many(exp, pts, measure=Simulate(final))
    assert got == [[pytest.approx(0.5)], [pytest.approx(1.5)], [pytest.approx(0.5)], [pytest.approx(1.5)]]
    assert rebuilt == [{"rate": 50}]  # k at run time; rate 100 is the file's: only rate 50 is built anew
    with Executor(2) as ex:
        assert run_many(exp, pts, ex, measure=Simulate(final)) == got
        assert run_many(exp, pts, ex, measure=Simulate(final, rebuild=True)) == got  # each point from the file


def test_every_variant_is_a_run_of_each_point(tmp_path):
    exp = Experiment(write(tmp_path, RAMP + "variants: {rate: [50, 100]}\n"))
    got = run_many(exp, [{"k": 1.0}, {"k": 4.0}], measure=Simulate(final))
    assert got == [[pytest.approx(0.5), pytest.approx(0.5)], [pytest.approx(2.0), pytest.approx(2.0)]]
    f, runs, settings = run_experiment(exp.path, jobs=2, k=4.0)
    assert [r["label"] for r in runs] == ["rate=50", "rate=100"] and settings["simulation"]["t_end"] == 0.5
    assert [float(r["result"]["f.y"][-1, 0]) for r in runs] == pytest.approx([2.0, 2.0])


def test_finished_points_are_read_back_not_run(ramp, tmp_path):
    (tmp_path / "o").mkdir()
    store = Store(tmp_path / "o", "id1", "points.jsonl", "m.json", "sweep", "it changed")
    pts = Grid.values({"k": [1.0, 2.0, 3.0]})
    first = run_many(Experiment(ramp), pts, measure=Simulate(final), store=store)
    lines = (tmp_path / "o" / "points.jsonl").read_text().splitlines()
    assert len(lines) == 3 and json.loads(lines[0])["value"] == first[0]
    (tmp_path / "o" / "points.jsonl").write_text("\n".join(lines[:2]) + "\n" + lines[2][:20])  # cut by a crash
    again = Store(tmp_path / "o", "id1", "points.jsonl", "m.json", "sweep", "it changed")
    assert len(again.done) == 2
    assert run_many(Experiment(ramp), pts, measure=Simulate(final), store=again) == first
    whole = [x for x in (tmp_path / "o" / "points.jsonl").read_text().splitlines() if x.endswith("}")]
    assert len(whole) == 3  # only the point whose line was cut ran again
    with pytest.raises(InputError, match="different sweep .it changed.*--force"):
        Store(tmp_path / "o", "id2", "points.jsonl", "m.json", "sweep", "it changed")
    Store(tmp_path / "o", "id2", "points.jsonl", "m.json", "sweep", "it changed", restart=True)
    assert (tmp_path / "o" / "points.jsonl.old").exists() and not (tmp_path / "o" / "points.jsonl").exists()


@pytest.mark.parametrize("linked", ["points.jsonl", "m.json", "points.jsonl.old"])
def test_a_store_never_writes_through_a_link_nor_renames_before_it_knows(tmp_path, linked):
    # a points.jsonl linked to a user's file was appended to; a linked manifest was refused only after
    # --force had renamed the points ("nothing was written")
    from hybridsim.errors import OutputError

    out = tmp_path / "o"
    out.mkdir()
    store = Store(out, "id1", "points.jsonl", "m.json", "sweep", "it changed")
    store.add({"a": 1.0})
    (out / "points.jsonl.old").write_text("")  # hybridsim's, as far as this test goes: replaced below
    mine = tmp_path / "mine.txt"
    mine.write_text("user data\n")
    (out / linked).unlink()
    (out / linked).symlink_to(mine)
    before = sorted(p.name for p in out.iterdir())
    if linked == "points.jsonl.old":  # never written: the points set aside go to the next free name
        Store(out, "id2", "points.jsonl", "m.json", "sweep", "it changed", restart=True)
        assert (out / linked).is_symlink() and (out / "points.jsonl.old.1").read_text().count("\n") == 1
        assert mine.read_text() == "user data\n"
        return
    for restart in (False, True):
        with pytest.raises(OutputError, match="is a symbolic link; hybridsim does not write through it"):
            Store(out, "id2" if restart else "id1", "points.jsonl", "m.json", "sweep", "it changed", restart=restart)
    assert mine.read_text() == "user data\n" and sorted(p.name for p in out.iterdir()) == before


def test_a_run_that_diverges_is_a_failure_in_its_place(tmp_path):
    text = RAMP.replace("simulation: {", "simulation: {max_state: 1.0, ")
    exp = Experiment(write(tmp_path, text))
    ok, bad = run_many(exp, [{"k": 1.0}, {"k": 10.0}])  # x reaches 5 > max_state 1 at k = 10
    assert ok[0]["metrics"] is not None and isinstance(bad[0], Failure)
    assert isinstance(bad[0].error, SimulationError)
    with Executor(2) as ex:  # from a worker: rebuilt from its class and message
        (_,), (far,) = run_many(exp, [{"k": 1.0}, {"k": 10.0}], ex)
    assert type(far.error) is SimulationError and str(far.error) == str(bad[0].error)
    with pytest.raises(SimulationError):
        run_experiment(exp.path, k=10.0)


def test_other_measures(tmp_path):
    from hybridsim.analysis.stability import linearization

    fig = write(tmp_path, RAMP.replace("wires: [c.y -> f.u, f.y -> z.u]",
                                       "  g: {type: gain, K: -1.0}\nwires: [f.y -> z.u, z.y -> g.u, g.y -> f.u]")
                .replace("  c: {type: constant, value: $k}\n", ""))
    exp = Experiment(fig)
    loops = run_many(exp, Grid.values({"g.K": [-1.0, -300.0]}), measure=Linearize())
    # x' = K x held over T = 0.01 s: z = 1 + K T
    assert [cl.growth for cl in loops] == pytest.approx([0.99, 2.0])
    assert loops[0].growth == pytest.approx(linearization(fig).closed_loop().growth)
    with Executor(2) as ex:
        assert run_many(exp, [point({"k": 1.5}), point({"k": 4.0})], ex, measure=doubled) == [3.0, 8.0]


def test_jobs_must_be_a_whole_number():
    for bad in (0, -1, True, 1.5):
        with pytest.raises(InputError, match="jobs must be a whole number"):
            Executor(bad)
    with Executor(2) as ex:
        assert ex.map(abs, [-3, 2, -1]) == [3, 2, 1] and ex.width == 2


@pytest.mark.parametrize("make, says", [
    (lambda: Grid.values([1, 2]), "Grid.values: axes must be a mapping"),  # said IndexError
    (lambda: Grid.values({"k": 3}), "Grid.values: axes - 'k': must be a list"),
    (lambda: Grid.scaled({"k": ["x"]}, {"k": 1.0}), "must be a number, got 'x'"),
    (lambda: Grid.random({"k": (1, 2)}, n=-1), "Grid.random: n must be a whole number from 1"),  # was 0 points
    (lambda: Grid.random({"k": (2, 1)}, n=3), "range of 'k' must be [low, high] with finite low <= high"),
    (lambda: Grid.random({"k": (1, 2)}, n=3, seed=-2), "Grid.random: seed must be"),
])
def test_a_grid_from_python_is_checked_as_a_sweep_file_is(make, says):
    from hybridsim.errors import InputError

    with pytest.raises(InputError) as err:
        make()
    assert says in str(err.value)
    assert len(Grid.random({"k": (1, 2)}, n=3)) == 3 and len(Grid.values({"k": (1, 2)})) == 2


def test_a_grid_takes_numpy_arrays_ranges_and_checks_its_base():
    # Grid.values({'a': np.arange(3)}) was refused ("must be a list"); Grid.scaled with no base value for
    # a name raised KeyError
    from hybridsim.errors import InputError

    assert len(Grid.values({"a": np.arange(3)})) == 3 and len(Grid.values({"a": range(2)})) == 2
    assert len(Grid.random({"a": np.array([0.0, 1.0])}, np.int64(3))) == 3
    assert Grid.scaled({"a": np.array([1.0, 2.0])}, {"a": np.array([1.0, 3.0])})[1].changes == {"a": [2.0, 6.0]}
    for base in ({}, None, {"a": "x"}, {"a": []}):
        with pytest.raises(InputError, match="Grid.scaled: base"):
            Grid.scaled({"a": [1.0]}, base)


def _nap(seconds):
    import time

    time.sleep(seconds)
    return seconds


@pytest.mark.slow
def test_an_interrupt_stops_the_pools_workers_instead_of_waiting_for_them():
    # Ctrl-C during a sweep on 2 processes: the pool's shutdown waited for its workers, once for ever
    # (workers the interrupt reached, blocked on the pool's queue); they are stopped now
    import time

    ex = Executor(jobs=2)
    done = ex.as_completed(_nap, [0.0, 60.0, 60.0])
    assert next(done) == (0, 0.0)  # both workers are now in a 60 s call
    workers = list(ex._pool._processes.values())
    t0 = time.perf_counter()
    ex.__exit__(KeyboardInterrupt, KeyboardInterrupt(), None)
    # (the pool's own thread may reap a worker first: its exit code reaches this process a moment later)
    while any(w.is_alive() for w in workers) and time.perf_counter() - t0 < 10:
        time.sleep(0.05)
    assert time.perf_counter() - t0 < 10 and not any(w.is_alive() for w in workers)
