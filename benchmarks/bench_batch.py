"""Benchmark: sweep throughput on the compiled path - batch call vs single runs vs a process pool.

Run on demand:  python benchmarks/bench_batch.py [--points 400]

Fig 9 at 120 Hz, 4 s simulated, RK4 h = 0.278 ms (the step whose accuracy
tests/engine/test_solver_agreement.py checks), ``arm.stick_band`` drawn at random per
point, metrics included, all in one process run after one warm-up that
compiles. Two log grids: at the ticks (1/120 s, as benchmarks/bench_fig9.py
logs) and the diagrams' default 0.5 ms. Rows:

* floor - one built simulator, ``sim.run(t_end, params=...)`` and the metrics
  in a Python loop, one thread: the per-run cost with nothing around it;
* sweep, batch - ``hybridsim sweep --compiled`` (``run_sweep``) on 2 processes:
  points as run-time parameters of one built diagram per worker, chunks of
  ``Simulator.run_batch``, points.jsonl, sweep.csv/parquet and the heat map
  included;
* sweep, each point built - the same sweep with ``batch=False``: each point
  builds its diagram from YAML (the reference the batches equal), on the
  same 2 processes.
"""
import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=400)
    args = ap.parse_args()
    import numpy as np

    import hybridsim as hs
    from hybridsim.analysis import metrics
    from hybridsim.runs.sweep import run_sweep

    n = args.points
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        os.environ.setdefault("HYBRIDSIM_CACHE", str(tmp / "cache"))
        print(f"{n} runs of Fig 9 (120 Hz, 4 s, RK4 h = 0.278 ms), metrics included\n")
        print(f"{'log grid':>10} {'executor':>22} {'wall s':>8} {'runs/s':>8} {'x floor':>8}")
        for grid, lp in (("ticks", 1 / 120), ("0.5 ms", 0.0005)):
            spec = tmp / f"s{lp}.yaml"
            spec.write_text(f"diagram: {ROOT / 'diagrams' / 'fig9_force_and_position.yaml'}\n"
                            f"set: {{rate: 120, simulation.t_end: 4.0, simulation.step: 0.000278, "
                            f"simulation.log_period: {lp!r}}}\n"
                            f"random: {{n: {n}, seed: 1, ranges: {{arm.stick_band: [1.0e-4, 5.0e-4]}}}}\n")
            run_sweep(spec, tmp / f"warm{lp}", progress=False, compiled=True, jobs=1)  # compiles
            warm = tmp / f"w{lp}.yaml"  # the per-point path logs more: its own module, compiled here too
            warm.write_text(spec.read_text().replace(f"n: {n},", "n: 1,"))
            run_sweep(warm, tmp / f"warm2{lp}", progress=False, compiled=True, jobs=1, batch=False)
            system, sim, settings = hs.build(ROOT / "diagrams" / "fig9_force_and_position.yaml", rate=120,
                                             t_end=4.0, step=0.000278, log_period=lp, compiled=True,
                                             log=list(hs.load(ROOT / "diagrams" / "fig9_force_and_position.yaml")
                                                      .build()[1]["signals"].values()))
            bands = np.random.default_rng(1).uniform(1e-4, 5e-4, n)
            t0 = time.perf_counter()
            for b in bands:
                r = sim.run(4.0, params={"arm.stick_band": float(b)})
                metrics.compute(r, settings["signals"], settings["metrics"])
            floor = time.perf_counter() - t0
            rows = [("floor (single runs)", floor)]
            for label, kw in (("sweep, batch (2 proc)", {"jobs": 2}),
                              ("sweep, each built (2)", {"jobs": 2, "batch": False})):
                if kw.get("batch") is False and n > 100:
                    m = 100  # the slow path: fewer points, rate scaled
                    spec2 = tmp / f"p{lp}.yaml"
                    spec2.write_text(spec.read_text().replace(f"n: {n},", f"n: {m},"))
                    t0 = time.perf_counter()
                    run_sweep(spec2, tmp / f"{label}{lp}", progress=False, compiled=True, **kw)
                    rows.append((label, (time.perf_counter() - t0) * n / m))
                    continue
                t0 = time.perf_counter()
                run_sweep(spec, tmp / f"{label}{lp}", progress=False, compiled=True, **kw)
                rows.append((label, time.perf_counter() - t0))
            for label, dt in rows:
                print(f"{grid:>10} {label:>22} {dt:8.2f} {n / dt:8.0f} {floor / dt:8.2f}")
    sys.stdout.flush()


if __name__ == "__main__":
    from results import recorded  # benchmarks/results.py: the dated section in RESULTS.md

    with recorded("Sweep throughput: single runs, batched runs, process pool (Fig 9)"):
        main()
