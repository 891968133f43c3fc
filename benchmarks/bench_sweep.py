"""Benchmark: sweep throughput, runs per second, serial vs local pool vs Dask.

Run on demand:  python benchmarks/bench_sweep.py [--points 8]

One small sweep (Fig 7, 5 N, 0.6 s simulated per run) executed serially, on a
local process pool of 2, and on a local Dask cluster with 1 and 2 worker
processes, each from an empty output folder, in one process run; then the
same sweep on the compiled path (``simulation.compiled: true``), serially and
on the pool, after one warm-up run has put the compiled module in the cache.
"""
import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from hybridsim.sweep import run_sweep  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=8)
    args = ap.parse_args()
    scales = [0.5 + 0.25 * k for k in range(args.points)]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        spec, fast = tmp / "s.yaml", tmp / "fast.yaml"
        for path, extra in ((spec, ""), (fast, ", simulation.compiled: true")):
            path.write_text(f"diagram: {ROOT / 'diagrams' / 'fig7_force_steps.yaml'}\n"
                            f"set: {{force: 5.0, rate: 60, simulation.t_end: 0.6{extra}}}\n"
                            f"scale: {{ctrl.fpi.Kp: {scales}}}\n")

        def timed(label, sweep=spec, **kw):
            t0 = time.perf_counter()
            run_sweep(sweep, tmp / label, progress=False, **kw)
            dt = time.perf_counter() - t0
            return dt

        rows = [("serial", timed("serial", jobs=1)), ("local pool (2)", timed("pool", jobs=2))]
        try:
            from distributed import Client, LocalCluster

            for n in (1, 2):
                with LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cl, Client(cl) as client:
                    client.run(lambda: __import__("hybridsim.api"))  # warm the workers' imports
                    rows.append((f"dask, {n} worker(s)", timed(f"dask{n}", dask=client)))
        except ImportError:
            print("(distributed not installed: no Dask rows)")
        try:
            import numba  # noqa: F401

            os.environ["HYBRIDSIM_CACHE"] = str(tmp / "cache")
            t0 = time.perf_counter()
            timed("warm", sweep=fast, jobs=1)
            print(f"compiled path warm-up (compiles once, {args.points} runs): {time.perf_counter() - t0:.1f} s")
            rows += [("compiled, serial", timed("fast1", sweep=fast, jobs=1)),
                     ("compiled, pool (2)", timed("fast2", sweep=fast, jobs=2))]
        except ImportError:
            print("(numba not installed: no compiled rows)")
    base = rows[0][1]
    print(f"{args.points} runs of Fig 7 (0.6 s simulated each)\n")
    print(f"{'executor':>20} {'wall s':>8} {'runs/s':>7} {'speed-up':>9}")
    for label, dt in rows:
        print(f"{label:>20} {dt:8.2f} {args.points / dt:7.2f} {base / dt:9.2f}")


if __name__ == "__main__":
    from results import recorded  # benchmarks/results.py: the dated section in RESULTS.md

    with recorded("Sweep executors (serial, local pool, Dask)"):
        main()
