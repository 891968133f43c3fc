"""Benchmark: compiled sweep throughput, runs per second per point, local pool vs Dask.

Run on demand:  python benchmarks/bench_sweep.py [--small 40] [--large 440] [--jobs 2]

The sweep: Fig 9 (diagrams/fig9_force_and_position.yaml) at 120 Hz, 4 s simulated,
``scale:`` over ``ctrl.fpi.Kp``, ``simulation.compiled: true``. In one process run:

1. the baseline: one compiled run of the same diagram (median of 20, after the warm-up
   that compiles or reads the cached loop) - ``jobs / t_run`` is what ``jobs`` cores
   could do if the sweep machinery cost nothing;
2. the local process pool (``--jobs``): a sweep of ``--small`` and one of ``--large``
   points, each into an empty folder; the marginal rate is
   ``(large - small) / (t_large - t_small)`` (start-up, imports and the table cancel);
3. the same two sweeps on a local Dask cluster of ``--jobs`` worker processes (one
   thread each), warmed by a 4-point sweep so that both sizes find built workers.

The ratios are against the baseline of the same run, so a loaded machine shows in
both. The numbers go to the terminal and a dated section of benchmarks/RESULTS.md.
"""
import argparse
import os
import statistics
import sys
import tempfile
import time
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
    args = ap.parse_args()
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")
    import hybridsim as hs
    from hybridsim.runs.sweep import run_sweep

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        small, large = sweep_file(tmp / "small.yaml", args.small), sweep_file(tmp / "large.yaml", args.large)
        _, sim, settings = hs.build(DIAGRAM, rate=120, t_end=4.0, compiled=True)
        sim.run(4.0)  # compiles, or reads the cached loop
        single = statistics.median(_timed(lambda: sim.run(4.0)) for _ in range(20))

        single_cpu = statistics.median(_cpu(lambda: sim.run(4.0)) for _ in range(10))

        def timed_sweep(spec, label, client=None, **kw):
            """(wall s, CPU s of this process and its workers) of one sweep."""
            before = _cpu_now(client)
            wall = _timed(lambda: run_sweep(spec, tmp / label, progress=False, jobs=args.jobs, dask=client, **kw))
            return wall, _cpu_now(client) - before

        timed_sweep(sweep_file(tmp / "warm.yaml", 4), "warm")
        pool = (timed_sweep(small, "pool-small"), timed_sweep(large, "pool-large"))
        dask = None
        if not args.no_dask:
            from distributed import Client, LocalCluster

            with LocalCluster(n_workers=args.jobs, threads_per_worker=1, processes=True,
                              dashboard_address=None) as cl, Client(cl) as client:
                timed_sweep(tmp / "warm.yaml", "dask-warm", client)
                dask = (timed_sweep(small, "dask-small", client), timed_sweep(large, "dask-large", client))
    n = args.large - args.small
    ideal = args.jobs / single
    lines = [f"one compiled run (baseline): {single * 1e3:.2f} ms wall, {single_cpu * 1e3:.2f} ms CPU; "
             f"{args.jobs} cores at that speed: {ideal:.0f} runs/s", "",
             "| executor | small sweep s | large sweep s | marginal runs/s (wall) | of the baseline's "
             "| CPU ms per point (marginal) | runs/s on idle cores (jobs / CPU per point) |",
             "|---|---|---|---|---|---|---|"]
    rates = {}
    for label, t in (("process pool", pool), ("Dask", dask)):
        if t is None:
            continue
        (w0, c0), (w1, c1) = t
        rates[label] = n / (w1 - w0)
        cpu = (c1 - c0) / n
        lines.append(f"| {label} ({args.jobs}) | {w0:.2f} | {w1:.2f} | {rates[label]:.0f} | "
                     f"{rates[label] / ideal:.0%} | {cpu * 1e3:.2f} | {args.jobs / cpu:.0f} |")
    if "Dask" in rates:
        lines += ["", f"Dask / process pool, marginal rate (wall): {rates['Dask'] / rates['process pool']:.2f}"]
    lines += ["", f"machine load average at the end: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"]
    text = "\n".join(lines)
    print(text)
    _write_section(f"Compiled Fig 9 sweep, 120 Hz, 4 s, scale ctrl.fpi.Kp: {args.small} and {args.large} "
                   f"points, {args.jobs} jobs (bench_sweep.py)", text)


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


def _write_section(title, body):
    """Append a dated section (``## date — title (issue 25)``) to benchmarks/RESULTS.md: the
    shared writer when there is one, else a plain append (the file merges by union)."""
    try:
        from results import write_section  # benchmarks/results.py
    except ImportError:
        write_section = None
    if write_section is not None:
        try:
            return write_section(title, body)
        except TypeError:  # another signature: write plainly
            pass
    path = ROOT / "benchmarks" / "RESULTS.md"
    machine = f"Machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} when it finished."
    with open(path, "a") as fh:
        fh.write(f"\n## {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())} — {title} (issue 25)\n\n"
                 f"{machine}\n\n{body}\n")


if __name__ == "__main__":
    from results import recorded  # benchmarks/results.py: the dated section in RESULTS.md

    with recorded("Sweep executors (serial, local pool, Dask)"):
        main()
