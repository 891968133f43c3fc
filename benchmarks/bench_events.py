"""Benchmark: the stepping core on events, many states, and the compiled path's start.

Run on demand (not part of the test suite):

    python benchmarks/bench_events.py [--compile] [--states N]

* 1 s of the one-block limited integrator (``integrator, K: 2, upper: 1.5`` on a constant: it
  reaches its limit at 0.75 s; and K = 10, upper = 0.5 on cos(2 pi t): it reaches it and leaves
  it inside a 1 ms step at 0.25 s) on every solver and path: the best of three runs' wall and
  CPU time (``time.process_time``, the steadier figure on a shared machine) and the events.
* ``--compile``: Fig 9 compiled in fresh processes. First with an empty cache folder (the
  stepping core compiles, once per machine, and Fig 9's glue and kernels), then a cache that
  holds only the core (a new diagram: its glue and kernels compile), then warm (loaded), then
  with only Fig 9's glue removed (the core and the kernels cached: what a new diagram built
  from blocks already used on the machine compiles). The
  in-process figure is ``hs.build`` to the first run's end, without Python's and numba's imports.
* ``--states N``: x_k' = -k x_k + 1 (k = 1..N, one state-space block) on every path against the
  closed form; the first run's time includes the compile.
"""
import argparse
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(Path(__file__).resolve().parent)]
import hybridsim as hs  # noqa: E402
from hybridsim.engine.registry import lookup  # noqa: E402

PATHS = [("rk4", "generic"), ("rk4", "fused"), ("rk4", "compiled"), ("heun", "generic"), ("heun", "fused"),
         ("heun", "compiled"), ("radau", "generic"), ("bdf", "generic"), ("lsoda", "generic"),
         ("rk45", "generic"), ("dop853", "generic"), ("cvode", "generic")]


def limited(source):
    """``integrator, K: 2, upper: 1.5`` on a constant 1 (reach at 0.75 s), or K = 10,
    upper = 0.5 on cos(2 pi t) (reach, then leave at 0.25 s inside a 1 ms step)."""
    d = hs.Diagram("limited")
    if source == "constant":
        d.add(lookup("constant")("u", value=1.0))
        d.add(lookup("integrator")("i", K=2.0, upper=1.5))
    else:
        d.add(lookup("cosine")("u", amplitude=1.0, frequency=1.0))
        d.add(lookup("integrator")("i", K=10.0, upper=0.5))
    d.connect("u.y", "i.u")
    return d.build()


def solver(name):
    if name in hs.engine.solvers.FIXED_STEP:
        return hs.engine.solvers.FIXED_STEP[name](1e-3)
    if name == "cvode":
        return hs.CVode()
    return hs.ScipySolver({"bdf": "BDF", "lsoda": "LSODA", "radau": "Radau", "rk45": "RK45",
                           "dop853": "DOP853"}[name])


def time_runs():
    print("the limited integrator, 1 s simulated (RK steps 1 ms; scipy/CVODE defaults), best of 3")
    for source in ("constant", "cosine"):
        system = limited(source)
        for name, path in PATHS:
            sim = hs.Simulator(system, solver(name), log=["i.y"], fused=path != "generic",
                               compiled=path == "compiled")
            sim.run(1.0)  # first run: compiles / warms up
            best_wall = best_cpu = float("inf")
            for _ in range(3):
                w0, c0 = time.perf_counter(), time.process_time()
                res = sim.run(1.0)
                best_wall = min(best_wall, time.perf_counter() - w0)
                best_cpu = min(best_cpu, time.process_time() - c0)
            events = [round(t, 9) for t, _ in res.meta["events"]]
            print(f"{source:8s} {name:7s} {path:8s} wall {best_wall * 1e3:6.1f} ms  cpu {best_cpu * 1e3:6.1f} ms  "
                  f"events {events}")


START = """
import time
t0 = time.perf_counter()
import hybridsim as hs
t1 = time.perf_counter()
_, sim, _ = hs.build({diagram!r}, compiled=True, t_end=0.01)
sim.run(0.01)
print(f"{{time.perf_counter() - t1:.2f}} {{t1 - t0:.2f}}")
"""


def start(diagram, cache):
    """(in-process build-to-first-run s, import s, process wall s, process CPU s) of a fresh process."""
    env = dict(os.environ, HYBRIDSIM_CACHE=cache, PYTHONPATH=str(ROOT))
    w0, r0 = time.perf_counter(), resource.getrusage(resource.RUSAGE_CHILDREN)
    out = subprocess.run([sys.executable, "-W", "ignore", "-c", START.format(diagram=diagram)], env=env,
                         cwd=ROOT, check=True, capture_output=True, text=True).stdout.split()
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime
    return float(out[-2]), float(out[-1]), time.perf_counter() - w0, cpu


def time_compile():
    fig9 = str(ROOT / "diagrams" / "fig9_force_and_position.yaml")
    other = str(ROOT / "diagrams" / "examples" / "msd_pid.yaml")
    print("\nFig 9 on the compiled path, each in a fresh process (build = hs.build to the end of a 10 ms run)")
    with tempfile.TemporaryDirectory() as tmp:
        empty, core_only = str(Path(tmp) / "empty"), str(Path(tmp) / "core")
        rows = [("empty cache: the core and Fig 9", start(fig9, empty))]
        start(other, core_only)  # another diagram first: the cache then holds the core (and its blocks)
        rows.append(("the core cached: Fig 9's glue and kernels", start(fig9, core_only)))
        rows += [("warm", start(fig9, core_only)), ("warm", start(fig9, core_only))]
        for f in Path(core_only).glob("compiled/**/glue_*"):  # Fig 9's glue forgotten, its kernels kept
            f.unlink()
        rows.append(("the core and kernels cached: Fig 9's glue", start(fig9, core_only)))
        shutil.rmtree(empty, ignore_errors=True)
    for label, (build, imports, wall, cpu) in rows:
        print(f"  {label:45s} build {build:6.2f} s   (imports {imports:.2f} s; process wall {wall:.1f} s, "
              f"cpu {cpu:.1f} s)")


def time_states(n):
    import math

    import numpy as np

    d = hs.Diagram("many")
    d.add(lookup("constant")("c", value=1.0))
    d.add(lookup("state_space")("ss", A=(-np.eye(n) * np.arange(1, n + 1)).tolist(), B=np.ones((n, 1)).tolist(),
                                C=np.ones((1, n)).tolist(), D=[[0.0]]))
    d.connect("c.y", "ss.u")
    system = d.build()
    exact = sum((1 - math.exp(-k * 0.5)) / k for k in range(1, n + 1))
    runs = {}
    print(f"\n{n} continuous states (one state_space block), RK4 1 ms, 0.5 s")
    for path in ("generic", "fused", "compiled"):
        w0, c0 = time.perf_counter(), time.process_time()
        sim = hs.Simulator(system, hs.RK4(1e-3), log=["ss.y"], log_period=0.05,
                           fused=path != "generic", compiled=path == "compiled")
        res = sim.run(0.5)
        first = time.perf_counter() - w0
        w1 = time.perf_counter()
        sim.run(0.5)
        runs[path] = res["ss.y"]
        print(f"  {path:8s}: first run (with building and compiling) {first:.1f} s, then {time.perf_counter() - w1:.3f} s;"
              f" y(0.5) - exact = {res['ss.y'][-1, 0] - exact:.2e}")
    print(f"  fused - generic = {np.max(np.abs(runs['fused'] - runs['generic'])):.1e}, "
          f"compiled - generic = {np.max(np.abs(runs['compiled'] - runs['generic'])):.1e}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--compile", action="store_true", help="also time Fig 9's start on the compiled path")
    ap.add_argument("--states", type=int, metavar="N", help="also: N continuous states on every path")
    args = ap.parse_args()
    time_runs()
    if args.compile:
        time_compile()
    if args.states:
        time_states(args.states)


if __name__ == "__main__":
    from results import recorded  # benchmarks/results.py: the dated section in RESULTS.md

    with recorded("the stepping core: events on every solver and path, the compiled start, many states"):
        main()
