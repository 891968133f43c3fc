"""The paper's claims, figure by figure, and how each is judged on runs of the shipped diagrams.

Each experiment of Raibert & Craig (1981) - Figs 7-10 and eq 18 - is a shipped diagram
(:data:`EXPERIMENTS`) and a claim function that judges the paper's measured claims
(docs/model.md's table) against explicit criteria on the runs' metrics and traces
(:class:`Claim`: the verdict and a margin). :func:`judge` runs many (experiment,
overrides) items through :func:`~hybridsim.runs.many.run_many` and judges each;
:mod:`hybridsim.paper.reproduce`, :mod:`hybridsim.paper.hinges` and :mod:`hybridsim.paper.joint_search` ask it.
"""
import math

import numpy as np

from hybridsim.shipped import diagrams_folder
from hybridsim.blocks.paper.surface import Surface
from hybridsim.blocks.paper.wrist import Wrist
from hybridsim.engine.registry import default
from hybridsim.errors import SimulationError
from hybridsim.runs.executor import using
from hybridsim.runs.experiment import Experiment
from hybridsim.runs.grid import point, point_key
from hybridsim.runs.many import Failure, run_many

DIAGRAMS = diagrams_folder()  # the shipped diagrams, installed with the package


# the model's constants are read from the blocks that own them (Appendix A)
KW, M3 = default(Wrist, "Kw"), default(Wrist, "M3")  # wrist stiffness N/m, hand mass kg
KR = default(Surface, "Kr")  # surface stiffness, N/m
#: the one-parameter damping families: s -> overrides (joints b = s (10 N m s/rad, 100 N s/m), wrist bw = s 20 N s/m)
FAMILIES = {
    "joint": lambda s: {"joint_damping": [10.0 * s, 100.0 * s]},
    "wrist": lambda s: {"wrist_damping": 20.0 * s},
}


# -- the claims -------------------------------------------------------------------
class Claim(tuple):
    """A judged claim: ``(text, criterion, ours, holds)``, and ``margin``: how far the worst measured
    value lies inside its criterion, relative to the threshold (> 0 holds, < 0 fails; the joint
    search ranks how close a failing claim came by it)."""

    def __new__(cls, text, criterion, ours, holds, margin=None):
        self = super().__new__(cls, (text, criterion, ours, bool(holds)))
        self.margin = float(margin) if margin is not None else (1.0 if holds else -1.0)
        return self

    def __getnewargs__(self):
        return (*self, self.margin)


def _inside(values, lo=None, hi=None):
    """The worst relative distance of ``values`` inside [lo, hi] (None counts as -1: not measured)."""
    out = math.inf
    for x in values:
        if x is None:
            return -1.0
        if lo is not None:
            out = min(out, (x - lo) / abs(lo))
        if hi is not None:
            out = min(out, (hi - x) / abs(hi))
    return out if out != math.inf else -1.0


def _kept(runs):
    """Margin of "contact kept" over ``runs``' metrics: 1 when never lost, else minus the longest time out
    of contact (s; 1 where a run does not say)."""
    worst = max((r.get("time_out_of_contact_s", 1.0) if r["contact_lost"] else 0.0 for r in runs), default=0.0)
    return 1.0 if worst == 0 else -(worst or 1.0)


def _runs_at(runs, **match):
    return [r for r in runs if all(r["overrides"].get(k) == v for k, v in match.items())]


def _window_max(res, sig, ref, t0, t1):
    t = res.t
    m = (t >= t0) & (t <= t1)
    return float(np.max(np.abs(res[sig][m] - res[ref][m]))) if m.any() else float("nan")


def claims_fig7(runs):
    """Fig 7's claims (rise ~0.15 s, little overshoot, steady error < 1 N) judged on ``runs``: (claim, paper, ours, holds) rows."""
    r60 = _runs_at(runs, rate=60) or runs
    rise = [r["metrics"]["rise_time_s"] for r in r60]
    over = [r["metrics"]["overshoot_pct"] for r in r60]
    sse = [r["metrics"]["ss_force_error_filtered_N"] for r in r60]
    lost = [r["metrics"]["contact_lost"] for r in r60]
    fmt = lambda xs, f: ", ".join("–" if x is None else f.format(x) for x in xs)  # noqa: E731
    return [
        Claim("rise time ≈ 0.15 s (1, 5, 10 N at 60 Hz)", "0.075–0.30 s",
              fmt(rise, "{:.3f} s"), all(x is not None and 0.075 <= x <= 0.30 for x in rise),
              _inside(rise, 0.075, 0.30)),
        Claim("little or no overshoot", "≤ 15 %", fmt(over, "{:.0f} %"), all(x is not None and x <= 15 for x in over),
              _inside(over, hi=15.0)),
        Claim("steady-state error < 1.0 N (12 Hz filtered, last 1 s)", "< 1.0 N", fmt(sse, "{:.2f} N"),
              all(x < 1.0 for x in sse), _inside(sse, hi=1.0)),
        Claim("contact kept", "never lost", ", ".join("lost" if x else "kept" for x in lost), not any(lost),
              _kept([r["metrics"] for r in r60])),
    ]


def claims_fig8(runs):
    """Fig 8's claims (contact kept, force error <= 1.75 N) judged on ``runs``: (claim, paper, ours, holds) rows."""
    m = runs[0]["metrics"]
    return [
        Claim("contact never lost", "never lost",
              f"lost at {m['first_loss_s']:.3f} s" if m["contact_lost"] else "kept", not m["contact_lost"],
              _kept([m])),
        Claim("force error ≤ 1.75 N away from the ramp's ends (1.25–3.75 s)", "≤ 1.75 N",
              f"{m['force_error_max_filtered_N']:.2f} N", m["force_error_max_filtered_N"] <= 1.75,
              _inside([m["force_error_max_filtered_N"]], hi=1.75)),
    ]


def claims_fig9(runs):
    """Fig 9's claims (no position disturbance from the force step, less overshoot when faster): (claim, paper, ours, holds) rows."""
    by_rate = {r["overrides"].get("rate"): r for r in runs}
    dist = {}
    for rate, r in by_rate.items():
        res = r["result"]
        before = _window_max(res, "ctrl.fk.X[1]", "pos_cmd.y[1]", 0.5, 1.0)
        after = _window_max(res, "ctrl.fk.X[1]", "pos_cmd.y[1]", 1.0, 1.5)
        dist[rate] = (after - before) * 1000
    over = {k: r["metrics"]["overshoot_pct"] for k, r in by_rate.items()}
    pos = {k: r["metrics"]["max_position_error_m"] * 1000 for k, r in by_rate.items()}
    lost = {k: r["metrics"]["time_out_of_contact_s"] for k, r in by_rate.items()}
    lo, hi = min(by_rate), max(by_rate)
    less = (over[lo] - over[hi]) / max(abs(over[lo]), 1e-9)  # how much less overshoot at the fastest rate
    return [
        Claim("force step causes no noticeable position disturbance", "error grows < 2 mm in 0.5 s after the step",
              ", ".join(f"{k} Hz {v:+.1f} mm" for k, v in dist.items()), all(v < 2.0 for v in dist.values()),
              _inside(dist.values(), hi=2.0)),
        Claim("faster servo: less force overshoot", f"overshoot {hi} Hz < {lo} Hz, contact kept",
              ", ".join(f"{k} Hz {v:.0f} %" for k, v in over.items()),
              over[hi] < over[lo] and lost[hi] == 0 and lost[lo] == 0,
              min(less, -max(lost[hi], lost[lo]) if lost[hi] or lost[lo] else 1.0)),
        Claim("faster servo: better stability (less time out of contact)", f"{hi} Hz ≤ {lo} Hz",
              ", ".join(f"{k} Hz {v:.2f} s" for k, v in lost.items()), lost[hi] <= lost[lo] and lost[hi] < 0.01,
              min(_inside([lost[hi]], hi=0.01), 1.0 if lost[hi] <= lost[lo] else lost[lo] - lost[hi])),
        Claim("position unchanged by the servo rate", "max position errors within 2 mm",
              ", ".join(f"{k} Hz {v:.1f} mm" for k, v in pos.items()), max(pos.values()) - min(pos.values()) < 2.0,
              _inside([max(pos.values()) - min(pos.values())], hi=2.0)),
    ]


def claims_fig10(runs):
    """Fig 10's claim (faithful ramp tracking) judged on ``runs``: (claim, paper, ours, holds) rows."""
    m = runs[0]["metrics"]
    return [
        Claim("faithful ramp tracking (0.75–2.5 s)", "error ≤ 1.0 N (12 Hz filtered)",
              f"{m['force_error_max_filtered_N']:.2f} N", m["force_error_max_filtered_N"] <= 1.0,
              _inside([m["force_error_max_filtered_N"]], hi=1.0)),
        Claim("contact kept", "never lost", "lost" if m["contact_lost"] else "kept", not m["contact_lost"],
              _kept([m])),
    ]


def claims_eq18(runs):
    """Eq 18's claim (hand oscillation near 280 Hz) against the measured frequency: (claim, paper, ours, holds) rows."""
    out = []
    for r in runs:
        kr = r["overrides"]["Kr"]
        pred = math.sqrt((kr + KW) / M3) / (2 * math.pi)  # eq 18
        hz = r["metrics"]["oscillation_hz"]
        out.append(Claim(f"hand oscillation at (1/2π)√((Kr+Kw)/M3), Kr = {kr:.1e}",
                         f"{pred:.1f} Hz (paper: 280, observed 286)", f"{hz:.1f} Hz", abs(hz - pred) / pred < 0.01,
                         _inside([abs(hz - pred) / pred], hi=0.01)))
    return out


def conventions(name, settings):
    """How each claim of experiment ``name`` is measured, read from its run ``settings``: one text per claim.

    Says the run length, the log grid, the window and whether the force is
    the 12 Hz display-filtered one (causal 2nd-order Butterworth, started in
    steady state: :func:`hybridsim.analysis.metrics.display_filter`) or raw.
    """
    sim, m = settings["simulation"], settings.get("metrics") or {}
    t_end, log = float(sim["t_end"]), float(sim.get("log_period") or sim["step"])
    run = f"{t_end:g} s runs, logged every {log * 1e3:g} ms"
    filt = f"force through the causal 2nd-order Butterworth at {float(m.get('filter_cutoff', 12.0)):g} Hz"
    contact = f"surface contact at every logged sample after first touch; {run}"
    if name == "Fig 7":
        ts, ss = float(m.get("step_time", 0.0)), float(m.get("ss_window", 0.5))
        return [f"10-90 % of the step at {ts:g} s, {filt}; 60 Hz runs; {run}",
                f"peak above the command after {ts:g} s, {filt}; 60 Hz runs; {run}",
                f"max |F - F_d| over the last {ss:g} s ({t_end - ss:g}-{t_end:g} s), {filt}; 60 Hz runs; {run}",
                contact]
    if name in ("Fig 8", "Fig 10"):
        w = [float(v) for v in m.get("error_window", (0.0, t_end))]
        err = f"max |F - F_d| over {w[0]:g}-{w[1]:g} s, {filt}; {run}"
        return [contact, err] if name == "Fig 8" else [err, contact]
    if name == "Fig 9":
        return [f"max |Y - Y_d| (raw) over 1-1.5 s minus over 0.5-1 s; {run}",
                f"overshoot of the step response {filt}, compared between the slowest and fastest rate; {run}",
                f"time out of contact, compared between the slowest and fastest rate; {run}",
                f"max |Y - Y_d| (raw) over the whole run, spread across the rates; {run}"]
    return [f"frequency from the mean crossings of the surface force (raw), one claim per Kr; {run}"]


EXPERIMENTS = [
    # name, file, overrides for the claims' runs, claim function
    ("Fig 7", "fig7_force_steps.yaml", {}, claims_fig7),
    ("Fig 8", "fig8_receding_surface.yaml", {}, claims_fig8),
    ("Fig 9", "fig9_force_and_position.yaml", {}, claims_fig9),
    ("Fig 10", "fig10_force_ramp.yaml", {}, claims_fig10),
    ("eq 18", "eq18_hand_oscillation.yaml", {}, claims_eq18),
]


def file_of(name):
    """The diagram file of experiment ``name`` ("Fig 7", ...)."""
    return DIAGRAMS / next(e[1] for e in EXPERIMENTS if e[0] == name)


def judge(items, executor=None, extra=None):
    """Run and judge each ``(experiment name, overrides)`` of ``items``, with ``extra`` overrides added
    to each (``{"compiled": True}``); ``[(claims, runs, settings)]`` in the order of ``items``.

    ``executor``: an :class:`~hybridsim.runs.executor.Executor` or a number of local processes
    (default: here). A run that diverges fails every claim of its item, and says why (no runs,
    settings None); any other error is raised.
    """
    pts = []
    for name, overrides in items:
        _, fname, base, _ = next(e for e in EXPERIMENTS if e[0] == name)
        ov = {**base, **overrides, **(extra or {})}
        exp = Experiment(DIAGRAMS / fname, **ov)
        pts.append(point(label={"experiment": name}, key=point_key([name, ov]), experiment=exp))
    with using(executor, jobs=1) as ex:
        got = run_many(None, pts, ex)
    out = []
    for (name, _), runs in zip(items, got):
        failed = [r.error for r in runs if isinstance(r, Failure)]
        if failed:
            if not isinstance(failed[0], SimulationError):
                raise failed[0]
            out.append(([Claim("the run completes", "no divergence", str(failed[0]).split(". ")[0], False, -10.0)],
                        [], None))
            continue
        fn = next(e[3] for e in EXPERIMENTS if e[0] == name)
        out.append((fn(runs), runs, runs[-1]["settings"]))
    return out
