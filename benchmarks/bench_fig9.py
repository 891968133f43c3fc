"""Benchmark: the Fig 9 run through the engine vs. plain loops of the same equations.

Run on demand (not part of the test suite):

    python benchmarks/bench_fig9.py [--repeat 5] [--t-end 4]

The "plain" side is written here from docs/model.md independently of the engine and
the block library: a C99 loop (fig9_loop.c, compiled by this script with the
system C compiler), a bare Python RK4 loop over floats, and one hand-fused
numpy right-hand side and controller integrated between ticks by a numpy RK4
loop or scipy's solve_ivp (DOP853). Each engine path (compiled, fused,
generic, FMU plant) is timed against its plain counterpart in the same process
run and reported as a ratio; force trajectories are compared over 0-0.25 s
(before the undamped model loses contact and the motion turns chaotic) as a
cross-check.
"""
import argparse
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
import hybridsim as hs  # noqa: E402

L, KW, KR, M3, M2 = 0.153, 8e5, 9e5, 0.58, 6.68
TC, TS, EPS, TSTICK = (5.0, 3.5), (5.75, 4.6), 1e-4, 1e-3
KPP, KPI, KPD = np.array([460, 1650.0]), np.array([1.3, 1200.0]), np.array([30, 250.0])
KFP, KFI, TMAX = np.array([0.4, 0.3]), np.array([240, 220.0]), np.array([0.004, 0.1])
XS, F0 = 0.5, 10.0


def _fric(v, F, m, i):
    if abs(v) >= EPS:
        return -math.copysign(TC[i], v)
    return min(TS[i], max(-TS[i], -F - m * v / TSTICK))


def bare_rhs(t, x, tau):
    """docs/model.md's plant (eqs 5-11, Karnopp friction) on floats: a tuple of derivatives."""
    q1, q2, v1, v2, w1, w2, wd1, wd2 = x
    c, s = math.cos(q1), math.sin(q1)
    pen = q2 * c + L * s + w1 * c - w2 * s - XS
    fx = KR * pen if pen > 0 else 0.0
    f1, f2 = KW * w1, KW * w2
    i1 = 3.98 - 5.25 * q2 + 6.47 * q2 * q2
    F1 = tau[0] + q2 * f2 + L * f1
    F2 = tau[1] + f1
    m = M2 + M3
    return (v1, v2, (F1 + _fric(v1, F1, i1, 0)) / i1, (F2 + _fric(v2, F2, m, 1)) / m,
            wd1, wd2, (-KW * w1 - fx * c) / M3, (-KW * w2 + fx * s) / M3)


def bare_run(rate, t_end, step):
    """A bare Python RK4 loop over floats, the controller once per tick."""
    T = 1.0 / rate
    x, z = tuple(plain_x0()), np.zeros(4)
    forces = []
    m = math.ceil(T / step - 1e-9)
    h = T / m
    for k in range(int(round(t_end * rate))):
        tau, z, cfx = plain_controller(k * T, np.array(x), z, T)
        forces.append(cfx)
        tau = (float(tau[0]), float(tau[1]))
        for j in range(m):
            t = k * T + j * h
            k1 = bare_rhs(t, x, tau)
            k2 = bare_rhs(t + h / 2, tuple(a + h / 2 * b for a, b in zip(x, k1)), tau)
            k3 = bare_rhs(t + h / 2, tuple(a + h / 2 * b for a, b in zip(x, k2)), tau)
            k4 = bare_rhs(t + h, tuple(a + h * b for a, b in zip(x, k3)), tau)
            x = tuple(a + h / 6 * (b + 2 * (c + d) + e) for a, b, c, d, e in zip(x, k1, k2, k3, k4))
    return np.array(forces)


def lean_rhs(q1, q2, v1, v2, w1, w2, wd1, wd2, tau1, tau2, cos=math.cos, sin=math.sin):
    """bare_rhs written as lean as plain Python goes: scalars in, a tuple out, no containers."""
    c, s = cos(q1), sin(q1)
    pen = q2 * c + L * s + w1 * c - w2 * s - XS
    fx = KR * pen if pen > 0 else 0.0
    f1 = KW * w1
    i1 = 3.98 - 5.25 * q2 + 6.47 * q2 * q2
    F1 = tau1 + q2 * KW * w2 + L * f1
    F2 = tau2 + f1
    if v1 >= EPS or v1 <= -EPS:
        fr1 = -TC[0] if v1 > 0 else TC[0]
    else:
        fr1 = min(TS[0], max(-TS[0], -F1 - i1 * v1 / TSTICK))
    if v2 >= EPS or v2 <= -EPS:
        fr2 = -TC[1] if v2 > 0 else TC[1]
    else:
        fr2 = min(TS[1], max(-TS[1], -F2 - (M2 + M3) * v2 / TSTICK))
    return (v1, v2, (F1 + fr1) / i1, (F2 + fr2) / (M2 + M3), wd1, wd2,
            (-KW * w1 - fx * c) / M3, (-KW * w2 + fx * s) / M3)


def lean_controller(t, q1, q2, v1, v2, w1, w2, z, T):
    """The controller of fig9_loop.c on floats (S = diag(1, 0)); updates ``z``, returns (tau1, tau2, C-X force)."""
    c, s = math.cos(q1), math.sin(q1)
    j11, j12, j21, j22 = -q2 * s + L * c, c, q2 * c + L * s, s
    det = j11 * j22 - j12 * j21
    wt = 0.75 * math.pi
    ey = 0.30 - 0.30 * math.cos(wt * t) - (q2 * s - L * c)
    eyd = 0.30 * wt * math.sin(wt * t) - (j21 * v1 + j22 * v2)
    qe1, qe2, qde1, qde2 = -j12 * ey / det, j11 * ey / det, -j12 * eyd / det, j11 * eyd / det
    cfx = c * (-KW * w1) - s * (-KW * w2)
    fd = F0 + (F0 if t >= 1.0 else 0.0)
    df = fd - cfx
    te1, te2 = j11 * df, j12 * df
    z[0] += qe1 * T
    z[1] += qe2 * T
    z[2] += min(TMAX[0], max(-TMAX[0], te1)) * T
    z[3] += min(TMAX[1], max(-TMAX[1], te2)) * T
    tau1 = KPP[0] * qe1 + KPI[0] * z[0] + KPD[0] * qde1 + j11 * fd + KFP[0] * te1 + KFI[0] * z[2]
    tau2 = KPP[1] * qe2 + KPI[1] * z[1] + KPD[1] * qde2 + j12 * fd + KFP[1] * te2 + KFI[1] * z[3]
    return float(tau1), float(tau2), cfx


def lean_run(rate, t_end, step):
    """The leanest plain-Python loop of the same equations: RK4 on eight scalar locals, the stages
    written out, the controller once per tick (the engine's fused path is judged against this)."""
    T = 1.0 / rate
    q1, q2, v1, v2, w1, w2, a1, a2 = (float(v) for v in plain_x0())
    z = [0.0, 0.0, 0.0, 0.0]
    forces = []
    m = math.ceil(T / step - 1e-9)
    h = T / m
    h2, h6 = h / 2, h / 6
    f = lean_rhs
    for k in range(int(round(t_end * rate))):
        u1, u2, cfx = lean_controller(k * T, q1, q2, v1, v2, w1, w2, z, T)
        forces.append(cfx)
        for _ in range(m):
            b1, b2, b3, b4, b5, b6, b7, b8 = f(q1, q2, v1, v2, w1, w2, a1, a2, u1, u2)
            c1, c2, c3, c4, c5, c6, c7, c8 = f(q1 + h2 * b1, q2 + h2 * b2, v1 + h2 * b3, v2 + h2 * b4,
                                               w1 + h2 * b5, w2 + h2 * b6, a1 + h2 * b7, a2 + h2 * b8, u1, u2)
            d1, d2, d3, d4, d5, d6, d7, d8 = f(q1 + h2 * c1, q2 + h2 * c2, v1 + h2 * c3, v2 + h2 * c4,
                                               w1 + h2 * c5, w2 + h2 * c6, a1 + h2 * c7, a2 + h2 * c8, u1, u2)
            e1, e2, e3, e4, e5, e6, e7, e8 = f(q1 + h * d1, q2 + h * d2, v1 + h * d3, v2 + h * d4,
                                               w1 + h * d5, w2 + h * d6, a1 + h * d7, a2 + h * d8, u1, u2)
            q1 += h6 * (b1 + 2 * (c1 + d1) + e1)
            q2 += h6 * (b2 + 2 * (c2 + d2) + e2)
            v1 += h6 * (b3 + 2 * (c3 + d3) + e3)
            v2 += h6 * (b4 + 2 * (c4 + d4) + e4)
            w1 += h6 * (b5 + 2 * (c5 + d5) + e5)
            w2 += h6 * (b6 + 2 * (c6 + d6) + e6)
            a1 += h6 * (b7 + 2 * (c7 + d7) + e7)
            a2 += h6 * (b8 + 2 * (c8 + d8) + e8)
    return np.array(forces)


def plain_rhs(t, x, tau):
    """The same right-hand side as a numpy array (for the numpy and scipy loops)."""
    return np.array(bare_rhs(t, x, tau))


def plain_controller(t, x, z, T):
    q1, q2, v1, v2, w1, w2 = x[:6]
    c, s = math.cos(q1), math.sin(q1)
    J = np.array([[-q2 * s + L * c, c], [q2 * c + L * s, s]])
    X = np.array([q2 * c + L * s, q2 * s - L * c])
    Xd = J @ x[2:4]
    wt = 0.75 * math.pi
    yd, vyd = 0.30 - 0.30 * math.cos(wt * t), 0.30 * wt * math.sin(wt * t)
    fd = F0 + (F0 if t >= 1.0 else 0.0)
    qe = np.linalg.solve(J, np.array([0.0, yd - X[1]]))
    qde = np.linalg.solve(J, np.array([0.0, vyd - Xd[1]]))
    hf = np.array([-KW * w1, -KW * w2])
    cfx = c * hf[0] - s * hf[1]
    tau_e = J.T @ np.array([fd - cfx, 0.0])
    tau_ff = J.T @ np.array([fd, 0.0])
    zp = z[:2] + qe * T
    clip = np.clip(tau_e, -TMAX, TMAX)
    zf = z[2:] + clip * T
    tau = KPP * qe + KPI * zp + KPD * qde + tau_ff + KFP * tau_e + KFI * zf
    return tau, np.concatenate([zp, zf]), cfx


def plain_x0():
    ex = XS + F0 * (1 / KR + 1 / KW)
    q2 = math.sqrt(ex * ex - L * L)
    q1 = math.atan2(0.0, ex) + math.atan2(L, q2)
    return np.array([q1, q2, 0, 0, -F0 * math.cos(q1) / KW, F0 * math.sin(q1) / KW, 0, 0])


def plain_run(rate, t_end, method, step=1e-4, rtol=1e-8):
    T = 1.0 / rate
    x, z = plain_x0(), np.zeros(4)
    n = int(round(t_end * rate))
    forces = []
    atol = np.array([1e-11, 1e-11, 1e-9, 1e-9, 1e-12, 1e-12, 1e-9, 1e-9])
    for k in range(n):
        t = k * T
        tau, z, cfx = plain_controller(t, x, z, T)
        forces.append(cfx)
        if method == "rk4":
            m = math.ceil(T / step - 1e-9)
            h = T / m
            f = lambda tt, xx: plain_rhs(tt, xx, tau)  # noqa: E731
            for j in range(m):
                tt = t + j * h
                k1 = f(tt, x)
                k2 = f(tt + h / 2, x + h / 2 * k1)
                k3 = f(tt + h / 2, x + h / 2 * k2)
                k4 = f(tt + h, x + h * k3)
                x = x + h / 6 * (k1 + 2 * (k2 + k3) + k4)
        else:
            x = solve_ivp(plain_rhs, (t, t + T), x, method="DOP853", rtol=rtol, atol=atol,
                          args=(tau,)).y[:, -1]
    return np.array(forces)


def engine(rate, t_end, method, step=1e-4, rtol=1e-8, fused=True, compiled=False):
    """A built simulator of Fig 9 (building - YAML, checks, code generation - is timed apart)."""
    extra = dict(step=step) if method == "rk4" else dict(rtol=rtol, atol=1e-10)
    _, sim, settings = hs.build(ROOT / "diagrams" / "fig9_force_and_position.yaml", log_period=1 / rate,
                                rate=rate, solver=method, t_end=t_end, fused=fused, compiled=compiled,
                                **extra)
    return sim


def c_loop(folder):
    """Compile fig9_loop.c; returns run(rate, t_end, step, repeat) -> (median s, forces), or None."""
    import shutil
    import subprocess

    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        return None
    exe = Path(folder) / "fig9_loop"
    subprocess.run([cc, "-O2", "-std=c99", "-o", str(exe), str(ROOT / "benchmarks" / "fig9_loop.c"), "-lm"],
                   check=True)

    def run(rate, t_end, step, repeat):
        out = subprocess.run([str(exe), str(rate), str(t_end), repr(step), str(repeat)],
                             capture_output=True, text=True, check=True).stdout.split()
        return float(out[1]), np.array(out[2:], float)

    return run


def fmu_sim(rate, t_end, fmu):
    return hs.build(ROOT / "diagrams" / "fig9_fmu_cs.yaml", rate=rate, t_end=t_end, fmu=str(fmu),
                    log_period=1 / rate)[1]


def timed(fn, repeat):
    """(median CPU time s, the last result) of ``repeat`` calls (CPU time: steadier on a shared machine)."""
    times, out = [], None
    for _ in range(repeat):
        t0 = time.process_time()
        out = fn()
        times.append(time.process_time() - t0)
    return statistics.median(times), out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--t-end", type=float, default=4.0)
    args = ap.parse_args()
    print(f"Fig 9, {args.t_end} s simulated, friction on, logged at the ticks, median of {args.repeat}\n")
    h = 2.78e-4  # accurate enough for the targets (docs/semantics.md, "Accuracy")
    import os
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        os.environ["HYBRIDSIM_CACHE"] = tmp  # a cold cache: the first compiled run compiles
        t0 = time.perf_counter()
        hs.build(ROOT / "diagrams" / "fig9_force_and_position.yaml", compiled=True, log_period=1 / 120,
                 step=h)[1].run(0.01)
        cold = time.perf_counter() - t0
        c_run = c_loop(tmp)
        print(f"RK4 h = {h * 1e3:.3f} ms, times in ms (CPU time, median). C: fig9_loop.c -O2; lean: the leanest "
              "plain-Python float loop (lean_run); engine paths: compiled (numba), fused (Python), generic")
        print(f"{'rate':>5} {'C':>7} {'lean':>7} {'compiled':>9} {'fused':>7} {'generic':>8} "
              f"{'compiled/C':>11} {'fused/lean':>11}   compiled vs C, lean vs C: force 0-0.25 s")
        for rate in (60, 120):
            tc, fc = c_run(rate, args.t_end, h, args.repeat) if c_run else (float("nan"), None)
            tb, fl = timed(lambda: lean_run(rate, args.t_end, h), args.repeat)
            sims = [engine(rate, args.t_end, "rk4", step=h, compiled=True), engine(rate, args.t_end, "rk4", step=h),
                    engine(rate, args.t_end, "rk4", step=h, fused=False)]
            tx, res = timed(lambda: sims[0].run(args.t_end), args.repeat)
            tf, _ = timed(lambda: sims[1].run(args.t_end), args.repeat)
            tg, _ = timed(lambda: sims[2].run(args.t_end), args.repeat)
            n = int(0.25 * rate)
            diff = np.max(np.abs(res["ctrl.ft.CF[0]"][:n] - fc[:n])) if fc is not None else float("nan")
            dlean = np.max(np.abs(fl[:n] - fc[:n])) if fc is not None else float("nan")
            print(f"{rate:>5} {tc * 1e3:7.2f} {tb * 1e3:7.1f} {tx * 1e3:9.2f} {tf * 1e3:7.1f} {tg * 1e3:8.1f} "
                  f"{tx / tc:11.2f} {tf / tb:11.2f}   {diff:.1e} N, {dlean:.1e} N")
        print(f"compiled path, first run of the diagram (numba compiles, cold cache): {cold:.1f} s")
        for name, kw in (("compiled", dict(compiled=True)), ("fused", {}), ("generic", dict(fused=False))):
            tb, _ = timed(lambda: engine(120, args.t_end, "rk4", step=h, **kw), args.repeat)
            print(f"building the simulator from YAML ({name}): {tb * 1e3:.1f} ms")
    print(f"\n{'rate':>5} {'path':>8} {'plain s':>9} {'engine s':>9} {'ratio':>6}  force diff 0-0.25 s"
          "   (plain numpy script; RK4 h = 0.1 ms)")
    for rate in (60, 120):
        for method in ("rk4", "dop853"):
            tp, fp = timed(lambda: plain_run(rate, args.t_end, method), args.repeat)
            sim = engine(rate, args.t_end, method)
            te, res = timed(lambda: sim.run(args.t_end), args.repeat)
            # engine force at the controller ticks, before contact is lost
            ticks = np.arange(int(0.25 * rate)) / rate
            fe = res["ctrl.ft.CF[0]"][: ticks.size]  # logged at the ticks
            diff = np.max(np.abs(fe - fp[: ticks.size]))
            print(f"{rate:>5} {method:>8} {tp:9.3f} {te:9.3f} {te / tp:6.2f}  {diff:.2e} N")
    from hybridsim.fmus.build import build_plant_fmu

    with tempfile.TemporaryDirectory() as tmp:
        fmu = build_plant_fmu(Path(tmp) / "plant.fmu")
        print(f"\n{'rate':>5} {'Python plant s':>15} {'FMU (CS) plant s':>17} {'ratio':>6}   same run, RK4 1e-4 s, logged at the ticks")
        for rate in (60, 120):
            sim = hs.build(ROOT / "diagrams" / "fig9_force_and_position.yaml", rate=rate,
                           t_end=args.t_end, log_period=1 / rate)[1]
            tpy, _ = timed(lambda: sim.run(args.t_end), args.repeat)
            fsim = fmu_sim(rate, args.t_end, fmu)
            tf, _ = timed(lambda: fsim.run(args.t_end), args.repeat)
            print(f"{rate:>5} {tpy:15.3f} {tf:17.3f} {tpy / tf:6.1f}x")


if __name__ == "__main__":
    from results import recorded  # benchmarks/results.py: the dated section in RESULTS.md

    with recorded("Fig 9 run time by path (C loop, bare Python, compiled, fused, generic)"):
        main()
