"""The plant FMU in Model Exchange: hybridsim's solvers against fmpy.simulate_fmu (CVode), in one run.

The exported plant (``hybridsim fmu build``), open loop from its balanced start at the 10 N
preload, constant joint torques (8 N m, 20 N) that make the hand slide along the surface
with stick-slip events, 0.5 s simulated, logged every 1 ms. hybridsim runs the FMU block
in a diagram (constants on its inputs) with CVODE; fmpy runs the FMU alone with its own
CVode binding. Both CVODEs get rtol and atol = rtol (fmpy's absolute tolerances are rtol
times the nominals, all 1 here). Each run includes reading the FMU, extracting and
instantiating it. The two alternate, ``--repeat`` rounds; a time is the least CPU time
(``time.process_time``) of its rounds, so a busy machine inflates both alike; the ratio is
hybridsim / fmpy (< 1: hybridsim faster). scipy's BDF runs once per tolerance as a
reference (``--no-bdf`` leaves it out). The largest joint-2 difference to fmpy's
trajectory is reported too.

Run on demand:  python benchmarks/bench_fmu_me.py [--repeat 15] [--no-bdf]
"""
import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import hybridsim as hs  # noqa: E402
from hybridsim.blocks.sources.basic import Constant  # noqa: E402
from hybridsim.fmi.fmu_block import FMUBlock  # noqa: E402
from results import recorded  # noqa: E402

T_END, TAU = 0.5, (8.0, 20.0)
PARAMS = {"balance": 1, "preload": 10.0, "surface_x0": 0.5}


def hybridsim_run(fmu, solver):
    d = hs.Diagram("open_loop")
    d.add(FMUBlock("plant", path=str(fmu), mode="me", parameters=PARAMS))
    for name, value in (("tau", list(TAU)), ("xs", [0.5]), ("vs", [0.0])):
        d.add(Constant(name, value))
    d.connect("tau.y", "plant.tau")
    d.connect("xs.y", "plant.x_surface")
    d.connect("vs.y", "plant.v_surface")
    res = hs.Simulator(d.build(), solver, log=["plant.q"], log_period=0.001).run(T_END)
    return res.t, res["plant.q[1]"]


def fmpy_run(fmu, rtol):
    import fmpy

    r = fmpy.simulate_fmu(str(fmu), fmi_type="ModelExchange", solver="CVode", relative_tolerance=rtol,
                          stop_time=T_END, output_interval=0.001, output=["q[2]"],
                          start_values={**PARAMS, "tau[1]": TAU[0], "tau[2]": TAU[1]})
    return r["time"], r["q[2]"]


def timed(fn):
    """(CPU s, wall s, result) of one call."""
    c0, w0 = time.process_time(), time.perf_counter()
    out = fn()
    return time.process_time() - c0, time.perf_counter() - w0, out


def compare(fmu, rtol, repeat):
    """Alternating rounds of fmpy and hybridsim (CVODE): least CPU and wall times of each."""
    runs = {"fmpy": lambda: fmpy_run(fmu, rtol), "cvode": lambda: hybridsim_run(fmu, hs.CVode(rtol=rtol, atol=rtol))}
    cpu = {k: [] for k in runs}
    wall = {k: [] for k in runs}
    out = {}
    for k in range(repeat):
        for name in (("fmpy", "cvode") if k % 2 == 0 else ("cvode", "fmpy")):
            c, w, out[name] = timed(runs[name])
            cpu[name].append(c)
            wall[name].append(w)
    return {k: min(v) for k, v in cpu.items()}, {k: min(v) for k, v in wall.items()}, out


def diff(got, ref):
    (t, q), (tr, qr) = got, ref
    return float(np.max(np.abs(q - np.interp(t, tr, qr))))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=15, help="alternating rounds (default 15)")
    ap.add_argument("--no-bdf", action="store_true", help="leave out the scipy BDF reference runs")
    args = ap.parse_args()
    from hybridsim.fmus.build import build_plant_fmu

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        fmu = build_plant_fmu(Path(tmp) / "plant.fmu")
        hybridsim_run(fmu, hs.CVode(rtol=1e-6, atol=1e-6))  # imports and first loads out of the timing
        fmpy_run(fmu, 1e-6)
        for rtol in (1e-6, 1e-9):
            cpu, wall, out = compare(fmu, rtol, args.repeat)
            rows.append((rtol, "cvode", cpu["cvode"], wall["cvode"], cpu["fmpy"], wall["fmpy"],
                         diff(out["cvode"], out["fmpy"])))
            if not args.no_bdf:
                c, w, got = timed(lambda: hybridsim_run(fmu, hs.ScipySolver("BDF", rtol=rtol, atol=rtol)))
                rows.append((rtol, "bdf", c, w, cpu["fmpy"], wall["fmpy"], diff(got, out["fmpy"])))
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"{args.repeat} alternating rounds; load average {load:.1f} at the end\n")
    print("| rtol | hybridsim solver | hybridsim CPU ms | fmpy CVode CPU ms | ratio (CPU) | ratio (wall) "
          "| max abs q2 diff to fmpy (rad) |")
    print("|---|---|---|---|---|---|---|")
    for rtol, name, c, w, fc, fw, err in rows:
        print(f"| {rtol:g} | {name} | {c * 1e3:.1f} | {fc * 1e3:.1f} | {c / fc:.2f} | {w / fw:.2f} | {err:.2g} |")
    print("\nratio = hybridsim / fmpy.simulate_fmu (CVode) on the same FMU, same run (< 1: hybridsim faster)")


if __name__ == "__main__":
    with recorded(f"Plant FMU, Model Exchange, open loop {T_END} s (bench_fmu_me.py)"):
        main()
