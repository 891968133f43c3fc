"""Benchmark: ``hybridsim analyze`` on a 7-point gain sweep, this checkout against a baseline checkout.

Run on demand:  python benchmarks/bench_analyze.py --baseline /path/to/other/checkout [--repeats 3]

The diagram is the Fig 6 controller (``diagrams/hybrid_controller.yaml`` of each
checkout) at 120 Hz with one gain in its ``analysis`` section, ``ctrl.fpi.Kp``,
scaled by the 7 default factors (0.125 .. 8), one servo rate and its cases; the
command also bisects that gain's stability boundary. Each checkout's command runs
in its own process (``python -m hybridsim.app.cli analyze``, the checkout's folder
first on the path), the two alternating, ``--repeats`` times each; wall time and
the process's CPU time (user + system, from the children's resource usage) are
reported as medians with their ratio, measured in this one run.
"""
import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def diagram(checkout, folder):
    """A diagram extending ``checkout``'s Fig 6 controller with a 7-point sweep of one gain."""
    p = Path(folder) / f"gain_sweep_{abs(hash(str(checkout))) % 10_000}.yaml"
    p.write_text(f"extends: {Path(checkout) / 'diagrams' / 'hybrid_controller.yaml'}\n"
                 "name: gain_sweep\n"
                 "analysis:\n"
                 "  gains: {Kfp: ctrl.fpi.Kp}\n"
                 "  scales: [0.125, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0]\n"
                 "  rates: [120]\n")
    return p


def once(checkout, path):
    """(wall s, CPU s) of one ``analyze`` by ``checkout``'s code."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    env = {**os.environ, "PYTHONPATH": str(checkout), "NUMBA_NUM_THREADS": "1"}
    done = subprocess.run([sys.executable, "-m", "hybridsim.app.cli", "analyze", str(path), "--set", "rate=120"],
                          cwd=checkout, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise SystemExit(f"{checkout}: exit {done.returncode}\n{done.stderr}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", required=True, help="the other checkout (its root folder)")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    trees = {"baseline": Path(args.baseline).resolve(), "this checkout": ROOT}
    times = {k: [] for k in trees}
    with tempfile.TemporaryDirectory() as tmp:
        files = {k: diagram(v, tmp) for k, v in trees.items()}
        for _ in range(args.repeats):
            for k, tree in trees.items():
                times[k].append(once(tree, files[k]))
    print(f"hybridsim analyze, Fig 6 controller at 120 Hz, 1 gain x 7 scales + its boundary, "
          f"{args.repeats} runs each, alternating (median wall / median CPU):")
    med = {}
    for k, rows in times.items():
        med[k] = (statistics.median(w for w, _ in rows), statistics.median(c for _, c in rows))
        print(f"  {k:14s} ({trees[k]}): wall {med[k][0]:.2f} s, CPU {med[k][1]:.2f} s   "
              f"(runs: {', '.join(f'{w:.2f}/{c:.2f}' for w, c in rows)})")
    b, a = med["baseline"], med["this checkout"]
    print(f"  this checkout / baseline: wall {a[0] / b[0]:.2f}, CPU {a[1] / b[1]:.2f}")


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from results import recorded

    with recorded("hybridsim analyze on a 7-point gain sweep, against a baseline checkout"):
        main()
