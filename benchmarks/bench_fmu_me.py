"""The plant FMU in Model Exchange: hybridsim's solvers against fmpy.simulate_fmu (CVode), in one run.

The exported plant (``hybridsim fmu build``), open loop from its balanced start at the 10 N
preload, constant joint torques (8 N m, 20 N) that make the hand slide along the surface
with stick-slip events, 0.5 s simulated, logged every 1 ms. hybridsim runs the FMU block
in a diagram (constants on its inputs) with CVODE and with scipy's BDF; fmpy runs the FMU
alone with its own CVode binding. Both CVODEs get rtol and atol = rtol (fmpy's absolute
tolerances are rtol times the nominals, all 1 here). Times are the best of --repeat runs,
each including the FMU's instantiation; the ratio is hybridsim / fmpy (< 1: faster).
The largest joint-2 difference to fmpy's trajectory is reported too.

Run on demand:  python benchmarks/bench_fmu_me.py [--repeat 5]
"""
import argparse
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


def best(fn, repeat):
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    from hybridsim.fmus.build import build_plant_fmu

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        fmu = build_plant_fmu(Path(tmp) / "plant.fmu")
        hybridsim_run(fmu, hs.CVode(rtol=1e-6, atol=1e-6))  # imports and first loads out of the timing
        fmpy_run(fmu, 1e-6)
        for rtol in (1e-6, 1e-9):
            ref_wall, (tr, qr) = best(lambda: fmpy_run(fmu, rtol), args.repeat)
            for name, make in (("cvode", lambda: hs.CVode(rtol=rtol, atol=rtol)),
                               ("bdf", lambda: hs.ScipySolver("BDF", rtol=rtol, atol=rtol))):
                wall, (t, q) = best(lambda: hybridsim_run(fmu, make()), 1 if name == "bdf" else args.repeat)
                err = float(np.max(np.abs(q - np.interp(t, tr, qr))))
                rows.append((rtol, name, wall, ref_wall, err))
    lines = ["| rtol | hybridsim solver | hybridsim s | fmpy CVode s | ratio | max abs q2 diff to fmpy (m) |",
             "|---|---|---|---|---|---|"]
    for rtol, name, wall, ref, err in rows:
        lines.append(f"| {rtol:g} | {name} | {wall:.3f} | {ref:.3f} | {wall / ref:.2f} | {err:.2g} |")
    text = "\n".join(lines)
    print(text)
    write_section(f"Plant FMU, Model Exchange, open loop {T_END} s (bench_fmu_me.py, best of {args.repeat})",
                  text + "\n\nratio = hybridsim / fmpy.simulate_fmu (CVode) on the same FMU, same run.")


def write_section(title, body):
    """Append a dated section to benchmarks/RESULTS.md (as bench_sweep.py does)."""
    from bench_sweep import _write_section

    return _write_section(title, body)


if __name__ == "__main__":
    main()
