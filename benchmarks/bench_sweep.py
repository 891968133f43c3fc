"""Benchmark: compiled sweep throughput, where each point's time goes, local pool vs Dask.

Run on demand:  python benchmarks/bench_sweep.py [--small 40] [--large 440] [--jobs 2] [--rounds 3] [--no-dask]

The sweep: Fig 9 (diagrams/fig9_force_and_position.yaml) at 120 Hz, 4 s simulated,
``scale:`` over ``ctrl.fpi.Kp``, ``simulation.compiled: true``. In one process run:

1. the baseline: one compiled run of the same diagram logging what the sweep logs (the
   signals its metrics read), CPU time, median of 20 after the warm-up that compiles or
   reads the cached loop; ``jobs / t_run`` is what ``jobs`` cores could do if the sweep
   machinery cost nothing;
2. where a point's time goes: ``--small`` points through ``run_many`` here (no pool), the
   CPU time of each part measured by wrapping it (contexts, the compiled loop, the
   engine around it, metrics, the row, the store), and the pickled size and time of a
   chunk's task and rows (what crosses to a worker and back);
3. the local process pool (``--jobs``): a sweep of ``--small`` and one of ``--large``
   points, each into an empty folder; the marginal rate is
   ``(large - small) / (t_large - t_small)`` (start-up, imports and the table cancel), in
   wall time and in CPU time of this process and its workers;
4. the same two sweeps on a local Dask cluster of ``--jobs`` worker processes (one
   thread each), warmed by a 4-point sweep so that both sizes find built workers;
5. ``--rounds`` rounds of 3 and 4, their order alternating; the median marginal rate of
   each executor is reported (one round's rate scatters by 15 % on a shared machine).

On a machine other jobs share, wall times are inflated; the CPU figures and the ratios
measured in the same run are the ones to compare. The output goes to the terminal and a
dated section of benchmarks/RESULTS.md.
"""
import argparse
import os
import pickle
import statistics
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

DIAGRAM = ROOT / "diagrams" / "fig9_force_and_position.yaml"


def sweep_file(path, n):
    scales = [round(0.5 + k / max(1, n - 1), 9) for k in range(n)]
    path.write_text(f"diagram: {DIAGRAM}\n"
                    "set: {rate: 120, simulation.t_end: 4.0, simulation.compiled: true}\n"
                    f"scale: {{ctrl.fpi.Kp: {scales}}}\n")
    return path


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--small", type=int, default=40)
    ap.add_argument("--large", type=int, default=440)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--no-dask", action="store_true")
    ap.add_argument("--rounds", type=int, default=3, help="rounds of the pool's and Dask's sweeps, alternating")
    args = ap.parse_args()
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")
    from hybridsim.runs.experiment import Experiment
    from hybridsim.runs.sweep import run_sweep

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        small, large = sweep_file(tmp / "small.yaml", args.small), sweep_file(tmp / "large.yaml", args.large)
        exp = Experiment(DIAGRAM, rate=120, t_end=4.0, compiled=True).recording("metrics")
        exp.run()  # compiles, or reads the cached loop
        single = statistics.median(_cpu(exp.run) for _ in range(20))
        parts = breakdown(small, args.small)

        def timed_sweep(spec, label, client=None):
            """(wall s, CPU s of this process and its workers) of one sweep."""
            before = _cpu_now(client)
            wall = _timed(lambda: run_sweep(spec, tmp / label, progress=False, jobs=args.jobs, dask=client))
            return wall, _cpu_now(client) - before

        timed_sweep(sweep_file(tmp / "warm.yaml", 4), "warm")
        pool, dask = [], []  # per round: ((wall, CPU) small, (wall, CPU) large)

        def round_of(k, client):
            """One round: the pool's two sweeps and Dask's, in turn (the order alternates)."""
            runs = [("pool", None, pool)] + ([("dask", client, dask)] if client is not None else [])
            for label, cl, into in (runs if k % 2 == 0 else runs[::-1]):
                into.append((timed_sweep(small, f"{label}-small-{k}", cl),
                             timed_sweep(large, f"{label}-large-{k}", cl)))

        if args.no_dask:
            for k in range(args.rounds):
                round_of(k, None)
        else:
            from distributed import Client, LocalCluster

            with LocalCluster(n_workers=args.jobs, threads_per_worker=1, processes=True,
                              dashboard_address=None) as cl, Client(cl) as client:
                timed_sweep(tmp / "warm.yaml", "dask-warm", client)
                for k in range(args.rounds):
                    round_of(k, client)
    report(args, single, parts, pool, dask)


def breakdown(spec, n):
    """CPU seconds per point of each part of a sweep's point, run here (see the module doc)."""
    from hybridsim.analysis import metrics
    from hybridsim.engine import simulator
    from hybridsim.runs import many, store, sweep

    spent = defaultdict(float)
    patched = []

    def wrap(owner, name, part):
        real = getattr(owner, name)

        def timed(*a, **k):
            t0 = time.process_time()
            try:
                return real(*a, **k)
            finally:
                spent[part] += time.process_time() - t0

        setattr(owner, name, timed)
        patched.append((owner, name, real))

    def wrap_session(self, *a, **k):  # the numba core itself, which Session.walk calls
        real_init(self, *a, **k)
        fn = self._run

        def timed(*a2, **k2):
            t0 = time.process_time()
            try:
                return fn(*a2, **k2)
            finally:
                spent["compiled loop (numba)"] += time.process_time() - t0
        self._run = timed

    real_init = simulator.Session.__init__
    simulator.Session.__init__ = wrap_session
    patched.append((simulator.Session, "__init__", real_init))
    wrap(simulator.Session, "walk", "engine: compiled run, all")
    wrap(simulator.Simulator, "_context", "engine: contexts (with_params, initial outputs)")
    wrap(simulator.Simulator, "_run", "engine: one run, all")
    wrap(metrics, "compute", "metrics")
    wrap(sweep.Row, "__call__", "row, all")
    wrap(many.Simulate, "__call__", "chunk, all")
    wrap(store.Store, "add", "store (points.jsonl)")
    try:
        sw = sweep.Sweep(spec)
        pts = sw.points()
        measure = many.Simulate(sweep.Row(), records="metrics")
        with tempfile.TemporaryDirectory() as out:
            st = store.Store(out, "x", "points.jsonl", "m.json", "sweep", "")
            many.run_many(sw.experiment, list(pts)[:2], 1, measure=measure)  # built once, as a worker does
            spent.clear()
            t0 = time.process_time()
            many.run_many(sw.experiment, pts, 1, measure=measure, store=st)
            total = time.process_time() - t0
        tasks, _ = many._tasks(sw.experiment, list(pts), 2, measure)
        task = tasks[0]
        rows = many._work(task)
    finally:
        for owner, name, real in reversed(patched):
            setattr(owner, name, real)
    pickle.loads(pickle.dumps(task))  # a worker's first task builds its experiment; later ones find it kept
    t0 = time.process_time()
    sent, back = pickle.dumps(task), pickle.dumps(rows)
    pickle.loads(sent)
    pickle.loads(back)
    ipc = (time.process_time() - t0) / len(task[4])
    run_all = spent["engine: one run, all"]
    loop_all = spent["engine: compiled run, all"]
    numba = spent["compiled loop (numba)"]
    out = {
        "compiled loop (numba)": numba,
        "engine around the loop (arrays, copy back)": loop_all - numba,
        "engine: contexts (with_params, initial outputs)": spent["engine: contexts (with_params, initial outputs)"],
        "engine: rest of a run (snapshot, final outputs, result)": run_all - loop_all,
        "metrics": spent["metrics"],
        "the row (metrics to a table row)": spent["row, all"] - spent["metrics"],
        "store (points.jsonl, one write per chunk)": spent["store (points.jsonl)"],
    }
    accounted = sum(out.values())
    out["the rest (points, chunks, run_many)"] = total - accounted
    per_point = {k: v / n for k, v in out.items()}
    per_point["_ipc"] = ipc
    per_point["_sent"] = len(sent) / len(task[4])
    per_point["_back"] = len(back) / len(task[4])
    per_point["_total"] = total / n
    return per_point


def report(args, single, parts, pool, dask):
    n = args.large - args.small
    ideal = args.jobs / single
    lines = [f"one compiled run as the sweep runs it (baseline): {single * 1e3:.2f} ms CPU; "
             f"{args.jobs} cores at that speed: {ideal:.0f} runs/s", "",
             f"where a point's CPU time goes ({args.small} points run here, no pool):", "",
             "| part | ms per point | share |", "|---|---|---|"]
    for part, v in parts.items():
        if not part.startswith("_"):
            lines.append(f"| {part} | {v * 1e3:.3f} | {v / parts['_total']:.1%} |")
    lines += [f"| all | {parts['_total'] * 1e3:.3f} | 100% |", "",
              f"to and from a worker per point: {parts['_sent']:.0f} bytes sent, {parts['_back']:.0f} bytes back, "
              f"{parts['_ipc'] * 1e3:.3f} ms CPU to pickle and unpickle both", "",
              "| executor | small sweep s | large sweep s | marginal runs/s (wall; median and each round) "
              "| of the baseline's "
              "| CPU ms per point (marginal) | runs/s on idle cores (jobs / CPU per point) |",
              "|---|---|---|---|---|---|---|"]
    rates, cpu_rates = {}, {}
    for label, rounds in (("process pool", pool), ("Dask", dask)):
        if not rounds:
            continue
        marginal = [n / (w1 - w0) for (w0, _), (w1, _) in rounds]
        cpus = [(c1 - c0) / n for (_, c0), (_, c1) in rounds]
        k = marginal.index(statistics.median(marginal)) if len(rounds) % 2 else 0
        (w0, _), (w1, _) = rounds[k]
        rates[label] = statistics.median(marginal)
        cpu = statistics.median(cpus)
        cpu_rates[label] = args.jobs / cpu
        lines.append(f"| {label} ({args.jobs}) | {w0:.2f} | {w1:.2f} | {rates[label]:.0f} "
                     f"({', '.join(f'{r:.0f}' for r in marginal)}) | "
                     f"{rates[label] / ideal:.0%} | {cpu * 1e3:.2f} | {cpu_rates[label]:.0f} |")
    if "Dask" in rates:
        lines += ["", f"Dask / process pool, median marginal rate of {len(pool)} rounds: "
                      f"{rates['Dask'] / rates['process pool']:.2f} (wall), "
                      f"{cpu_rates['Dask'] / cpu_rates['process pool']:.2f} (CPU)"]
    lines += ["", f"machine load average at the end: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"]
    print("\n".join(lines))


def _cpu(fn):
    t0 = time.process_time()
    fn()
    return time.process_time() - t0


def _cpu_now(client=None):
    """CPU seconds so far of this process, its finished children and the Dask workers."""
    import resource

    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)  # pool processes once joined
    total = own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime
    if client is not None:
        def cpu():
            import psutil

            t = psutil.Process().cpu_times()
            return t.user + t.system

        total += sum(client.run(cpu).values())
    return total


def _timed(fn):
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


if __name__ == "__main__":
    from results import recorded  # benchmarks/results.py: the dated section in RESULTS.md

    with recorded("Compiled Fig 9 sweep: where a point's time goes; local pool vs Dask (bench_sweep.py)"):
        main()
