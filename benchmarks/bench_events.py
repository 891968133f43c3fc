"""Benchmark: 1 s of the one-block limited integrator (and one leaving its limit) on every
solver and path, and the cold / warm start of Fig 9 on the compiled path.

Run on demand (not part of the test suite):

    python benchmarks/bench_events.py [--compile] [--states N]

Prints, per solver and path, the best of three runs' wall and CPU time (``time.process_time``:
on a shared machine the CPU time is the steadier figure) and the events located. With
``--compile`` it also starts Fig 9 compiled in a fresh process three times, the first with an
empty cache folder (cold: numba compiles), then warm (loaded from the cache). With
``--states N`` it runs x_k' = -k x_k + 1 (k = 1..N, one state-space block) on the compiled path
against the generic one and the closed form, timing the compile (the suite runs N = 31 only).
"""
import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
import hybridsim as hs  # noqa: E402
from hybridsim.engine.registry import lookup  # noqa: E402

PATHS = [("rk4", "generic"), ("rk4", "fused"), ("rk4", "compiled"), ("heun", "fused"),
         ("radau", "generic"), ("bdf", "generic"), ("lsoda", "generic"), ("rk45", "generic"),
         ("dop853", "generic")]


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
    return hs.solvers.FIXED_STEP[name](1e-3) if name in hs.solvers.FIXED_STEP else hs.ScipySolver(
        {"bdf": "BDF", "lsoda": "LSODA", "radau": "Radau", "rk45": "RK45", "dop853": "DOP853"}[name])


def time_runs():
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


def time_compile():
    cache = tempfile.mkdtemp(prefix="hybridsim_cache_")
    code = ("import hybridsim as hs; hs.simulate('diagrams/fig9_force_and_position.yaml', compiled=True, "
            "t_end=0.01)")
    env = dict(os.environ, HYBRIDSIM_CACHE=cache, PYTHONPATH=str(ROOT))
    for label in ("cold", "warm", "warm"):
        w0, r0 = time.perf_counter(), resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT, check=True)
        r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime
        print(f"fig9 compiled {label}: process wall {time.perf_counter() - w0:.1f} s, cpu {cpu:.1f} s "
              "(import, build, compile or load, 10 ms run)")


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
    for path in ("generic", "compiled"):
        w0, c0 = time.perf_counter(), time.process_time()
        res = hs.Simulator(system, hs.RK4(1e-3), log=["ss.y"], log_period=0.05,
                           fused=path != "generic", compiled=path == "compiled").run(0.5)
        runs[path] = res["ss.y"]
        print(f"{n} states {path:8s}: first run wall {time.perf_counter() - w0:.1f} s, cpu "
              f"{time.process_time() - c0:.1f} s, y(0.5) - exact = {res['ss.y'][-1, 0] - exact:.2e}")
    print(f"{n} states: compiled - generic = {np.max(np.abs(runs['compiled'] - runs['generic'])):.2e}")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--compile", action="store_true", help="also time Fig 9's cold and warm compiled start")
    ap.add_argument("--states", type=int, metavar="N", help="only: N continuous states on the compiled path")
    args = ap.parse_args()
    if args.states:
        time_states(args.states)
        sys.exit(0)
    time_runs()
    if args.compile:
        time_compile()
