"""Stability analysis of a diagram file: poles, margins, rate and gain sweeps.

Reads an optional ``analysis`` section of the diagram::

    analysis:
      set: {friction: false}          # the branch to linearize on (overrides)
      points: {inner: "ctrl.dF.y[0]", outer: "ctrl.dX.y[1]"}   # loop openings
      rate_param: rate                # the parameter that sets the servo rate
      rates: [30, 45, 60, 80, 120, 240, 480]
      gains: {Kfp: ctrl.fpi.Kp, Kfi: ctrl.fpi.Ki, Kpp: ctrl.pid.Kp, Kpi: ctrl.pid.Ki, Kpd: ctrl.pid.Kd}
      scales: [0.125, 0.25, 0.5, 1, 2, 4, 8]
      cases: {limiter_saturated: {ctrl.fpi.Ki: [0, 0]}}

Every entry has a default; all results are plain data (numbers, lists) plus
python-control objects, so plotting and computing stay separate. A wing adds
settings to the section and results computed from the plant
(:mod:`hybridsim.analysis.extras`).
"""

import logging

import numpy as np

from hybridsim.errors import InputError
from hybridsim.format import tables
from hybridsim.format.build import check_analysis_branches, load
from hybridsim.runs.experiment import Experiment
from hybridsim.runs.grid import Grid
from hybridsim.runs.many import Linearize, run_many
from hybridsim.analysis.linearize import LinearizationError
from hybridsim.analysis import extras
from hybridsim.analysis.lti import oscillatory_modes
from hybridsim.analysis.margins import growing_modes, loop_response, loop_stability, margins  # noqa: F401 - public here too

DEFAULTS = {k: v for k, v in tables.defaults(tables.ANALYSIS).items() if k not in ("compare", "step")}
KEYS = tables.keys(tables.ANALYSIS)  # the table checks the section; "compare" and "step" are read by hybridsim.report.stability


def settings_of(f):
    """The diagram's analysis settings, checked against their table, over the defaults."""
    cfg = f.analysis_settings()
    cfg.pop("_lines", None)
    cfg.pop("_locs", None)
    return cfg


def linearization(path, at=None, **overrides):
    """A :class:`~hybridsim.analysis.linearize.Linearization` of a diagram file about its initial state,
    or about the state reached at ``at`` seconds of simulation."""
    return Experiment(path, **overrides).linearization(at=at)


def param_value(f, ref):
    """Current value of 'block.param' (from the file or the block's default); see
    :meth:`DiagramFile.param_value <hybridsim.format.diagram_file.DiagramFile.param_value>`."""
    return f.param_value(ref)


def _no_return(L):
    """Whether loop L is zero: nothing of the opened signal comes back (at five frequencies to Nyquist,
    or to 1e4 rad/s unsampled)."""
    top = np.pi / L.dt if L.dt else 1e4
    w = top * np.array([1e-4, 1e-3, 1e-2, 0.1, 0.5])
    return not np.any(np.abs(loop_response(L, w)) > 1e-12)


def least_damping(poles):
    """Smallest damping ratio among oscillatory poles: a complex pair (or, sampled, a pole on the
    negative real axis, an oscillation at Nyquist); real poles are not oscillations (a pole at
    z = 1e-11 read as 76 Hz with damping 0.99 hid a 0.45 Hz pair of 0.71)."""
    def oscillates(p):
        z = complex(p["re"], p["im"])
        return p["damping"] is not None and abs(z - 1) > 1e-7 and (abs(z.imag) > 1e-9 * abs(z) or z.real < 0)

    d = [p["damping"] for p in poles if oscillates(p)]
    return min(d) if d else None


def closed_loop(path, overrides, at=None):
    """A diagram file's closed loop (a :class:`~hybridsim.analysis.lti.DiscreteModel` or, nothing sampled,
    a :class:`~hybridsim.analysis.lti.ContinuousModel`), or None where it cannot be linearized; about the
    state reached at ``at`` s of simulation when given (as :func:`linearization`). ``path`` may be
    an :class:`~hybridsim.runs.experiment.Experiment`: ``overrides`` are then changes made to it."""
    if isinstance(path, Experiment):
        return path.closed_loop(overrides, at)
    try:
        return linearization(path, at=at, **overrides).closed_loop()
    except (LinearizationError, np.linalg.LinAlgError):  # no finite model there (e.g. expm overflowed): no verdict
        return None


def largest_abs_z(path, overrides, at=None):
    """The closed loop's growth - largest ``|z|`` besides z = 1 (sampled), largest Re s besides
    s = 0 (nothing sampled) - or None (see :func:`closed_loop`)."""
    cl = closed_loop(path, overrides, at)
    return None if cl is None else cl.growth


def _stability_row(cl, **key):
    """One row of a sweep: the growth and whether the loop is stable (None: not linearizable)."""
    return {**key, "spectral_radius": None if cl is None else cl.growth, "stable": cl is not None and cl.stable}


def critical_scale(path, base, param, value, lo=1.0, hi=None, tol=0.01, at=None):
    """Scale of ``param`` (relative to ``value``) at the stability boundary.

    Found by doubling/halving from 1, then bisection to ``tol`` (relative).
    Returns None when no boundary lies within 1e-4..1e4. ``path``: a diagram file (built once
    with ``base``) or an :class:`~hybridsim.runs.experiment.Experiment` (``base`` already in it);
    each trial is a run-time change of ``param``.
    """
    exp = path if isinstance(path, Experiment) else Experiment(path, **base)

    def unstable(s):
        cl = exp.closed_loop({param: (value * s).tolist()}, at)
        return cl is None or not cl.stable

    if unstable(lo):  # walk down to a stable scale
        while True:
            hi, lo = lo, lo / 2
            if lo < 1e-4:
                return None
            if not unstable(lo):
                break
    else:  # walk up to an unstable one
        hi = hi or lo * 2
        while not unstable(hi):
            hi *= 2
            if hi > 1e4:
                return None
    return _bisect(unstable, lo, hi, tol)


def _bisect(unstable, stable_at, unstable_at, tol):
    """The scale between ``stable_at`` and ``unstable_at`` (either side) where ``unstable`` turns,
    to ``tol`` relative (geometric bisection)."""
    a, b = stable_at, unstable_at
    while max(a, b) / min(a, b) > 1 + tol:
        mid = np.sqrt(a * b)
        if unstable(mid):
            b = mid
        else:
            a = mid
    return float(np.sqrt(a * b))


def boundaries(exp, param, value, rows, tol=0.01, at=None, lo=1e-4, hi=1e4):
    """The scales of ``param`` where the loop's stability changes, from the gain sweep's ``rows`` and
    x1: each pair of neighbouring scales that differ is bisected to ``tol``, and past the sweep's ends
    the walk goes on (doubling, halving) to ``hi`` / ``lo`` while the loop stays stable there (both
    ways while it is unstable at every scale, to the first stable one).
    Returns ``[{"scale", "unstable_above"}]`` in increasing scale (``unstable_above``: the loop is
    unstable just above it). ``exp``: an :class:`~hybridsim.runs.experiment.Experiment`."""
    def unstable(s):
        cl = exp.closed_loop({param: (value * s).tolist()}, at)
        return cl is None or not cl.stable

    seen = {float(r["scale"]): not r["stable"] for r in rows}
    seen.setdefault(1.0, unstable(1.0))
    top, bottom = max(seen), min(seen)
    while not seen[top] and top * 2 <= hi:  # stable at the sweep's top: walk up to where it is not
        top *= 2
        seen[top] = unstable(top)
    while not seen[bottom] and bottom / 2 >= lo:
        bottom /= 2
        seen[bottom] = unstable(bottom)
    if all(seen.values()):  # unstable at every scale of the sweep: look for a stable one beyond it
        while all(seen.values()) and (bottom / 2 >= lo or top * 2 <= hi):
            if bottom / 2 >= lo:
                bottom /= 2
                seen[bottom] = unstable(bottom)
            if top * 2 <= hi and seen[bottom]:
                top *= 2
                seen[top] = unstable(top)
    scales = sorted(seen)
    out = []
    for a, b in zip(scales, scales[1:]):
        if seen[a] != seen[b]:
            stable_at, unstable_at = (b, a) if seen[a] else (a, b)
            out.append({"scale": _bisect(unstable, stable_at, unstable_at, tol), "unstable_above": seen[b]})
    return out


def _nearest(bounds, unstable_above):
    """The boundary of that kind nearest x1 (in ratio), or None."""
    picked = [b["scale"] for b in bounds if b["unstable_above"] == unstable_above]
    return min(picked, key=lambda s: abs(np.log(s)), default=None)


def describe_boundaries(bounds):
    """'unstable below x0.25 and unstable from x10.1' for :func:`boundaries`' list."""
    words = []
    for k, b in enumerate(bounds):
        if b["unstable_above"]:
            words.append(f"unstable from x{b['scale']:.3g}")
        else:
            words.append(f"{'unstable below' if k == 0 else 'stable again from'} x{b['scale']:.3g}")
    return " and ".join(words) or "no stability boundary found in x1e-4..x1e4"


def analyze(path, at=None, sweeps=True, **overrides):
    """Run the whole analysis; returns a dict of plain results (see module doc).

    ``path``: a diagram file, or an :class:`~hybridsim.runs.experiment.Experiment` (then ``overrides``
    are changes made to it). The file is parsed and built once with the ``analysis: set`` branch;
    cases, gain points and the boundary search are run-time parameter changes of that build
    where they name block parameters; a servo rate or a ``params`` name rebuilds.
    """
    if not isinstance(sweeps, (bool, np.bool_)):
        raise InputError(f"sweeps is True or False, got {sweeps!r}")
    if isinstance(path, Experiment):
        f = path.file
        check_analysis_branches(f)  # a bad value in set, cases, compare or step: named at its line
        cfg = settings_of(f)
        exp, params = path.changed({**cfg["set"], **overrides})
        if params:
            exp = Experiment(exp.path, exp.variant, **{**exp.overrides, **params})
    else:
        f = load(path, **overrides)
        check_analysis_branches(f)
        cfg = settings_of(f)
        exp = Experiment(path, **{**cfg["set"], **overrides})
    at = cfg["at"] if at is None else at
    cl = exp.closed_loop(at=at)  # (checks at)
    if at:  # each rate and gain point runs the diagram to it first
        t_end = float(exp.settings["simulation"]["t_end"])
        logging.getLogger("hybridsim").info("linearizing about the state at t = %g s%s: every rate and gain point "
                                            "runs the diagram that far first", at,
                                            f" (past the diagram's t_end, {t_end:g} s)" if at > t_end else "")
    lin = exp.linearization(at=at)  # the one closed_loop used (this experiment unchanged)
    if cl is None:
        cl = lin.closed_loop()  # raises the reason it cannot be linearized
    A, _ = lin.continuous()
    out = {
        "diagram": f.name,
        "branch": cfg["set"],
        "at": float(at) if at else None,
        "domain": cl.domain,
        "growth_label": cl.growth_label,
        "period_s": cl.period,
        "poles": [{"re": float(r["pole"].real), "im": float(r["pole"].imag), "abs": r["abs"],
                   "freq_hz": r["freq_hz"], "damping": r["damping"]} for r in cl.pole_table()],
        "spectral_radius": cl.spectral_radius if cl.period else None,
        "spectral_abscissa": None if cl.period else cl.spectral_abscissa,
        "growth": cl.growth,
        "integrator_modes": cl.integrator_modes,
        "stable": cl.stable,
        "plant_modes_hz": oscillatory_modes(A),
        "fd_error": lin.fd_error,
        "loops": {},
        **extras.compute_all(cfg, A),
    }
    out["_objects"] = {"closed_loop": cl, "loops": {}}
    for name, sig in cfg["points"].items():
        try:
            L = lin.loop(sig)
        except LinearizationError as exc:
            out["loops"][name] = {"signal": sig, "error": str(exc)}
            continue
        out["loops"][name] = {"signal": sig, **margins(L), "no_return": _no_return(L)}
        out["_objects"]["loops"][name] = L
    loops = Linearize(at)  # each point's closed loop, a run-time change of this build where it can be
    cases = run_many(exp, Grid(cfg["cases"].values()), measure=loops)
    out["cases"] = {c: _stability_row(cl, set=cov) for (c, cov), cl in zip(cfg["cases"].items(), cases)}
    if not sweeps:
        return out
    rp = cfg["rate_param"]
    out["rates"] = []
    if rp in f.params:
        rates = run_many(exp, Grid.values({rp: cfg["rates"]}), measure=loops)
        out["rates"] = [_stability_row(cl, rate_hz=r) for r, cl in zip(cfg["rates"], rates)]
    out["gains"] = {}
    for gname, ref in cfg["gains"].items():
        value = param_value(f, ref)
        scaled = run_many(exp, Grid.scaled({ref: cfg["scales"]}, {ref: value}), measure=loops)
        rows = [_stability_row(cl, scale=s) for s, cl in zip(cfg["scales"], scaled)]
        bounds = boundaries(exp, ref, value, rows, at=at)
        out["gains"][gname] = {"param": ref, "value": value.tolist(), "sweep": rows, "boundaries": bounds,
                               "critical_scale": _nearest(bounds, True), "lower_scale": _nearest(bounds, False)}
    return out


def summary_lines(res):
    """Human-readable lines for the terminal."""
    sampled = res.get("domain", "discrete") == "discrete"
    g = res.get("growth_label", "largest |z|")
    at_one = "z = 1" if sampled else "s = 0"
    head = (f"closed loop at period {res['period_s'] * 1000:.3f} ms" if sampled
            else "continuous closed loop (nothing is sampled)")
    about = f"; about the state at t = {res['at']:g} s" if res.get("at") else ""
    lines = [f"{res['diagram']}: {head} (branch {res['branch'] or 'as built'}{about})",
             f"  {g} {res['growth']:{'.4f' if sampled else '.4g'}}"
             + (f" (besides {res['integrator_modes']} undriven integrator pole(s) at {at_one})"
                if res["integrator_modes"] else "")
             + f" -> {'STABLE' if res['stable'] else 'NOT STABLE'}"]
    if res.get("fd_error", 0.0) > 1e-4:  # a kink or switch at the operating point
        lines.append(f"  note: the finite differences agree only to {res['fd_error']:.2g} (relative): a kink or "
                     "switch at the operating point (a one-sided spring engaging there, a limit reached) makes "
                     "the numbers below that uncertain; linearize off it (analysis: at, or a set)")
    lines.append("  dominant poles:   " + ("|z|      f (Hz)   damping" if sampled else "|s|      f (Hz)   damping"))
    seen = 0
    for p in res["poles"]:
        if p["freq_hz"] is None or seen >= 6:
            continue
        damping = "   -" if p["damping"] is None else f"{p['damping']:+.4f}"  # at z = 1 (s = 0): none
        lines.append(f"    {p['re']:+.4f}{p['im']:+.4f}j  {p['abs']:.4f}  {p['freq_hz']:8.2f}  {damping}")
        seen += 1
    lines += [f"  {line}" for line in extras.lines(res)]
    for name, m in res["loops"].items():
        if "error" in m:
            lines.append(f"  loop {name} ({m['signal']}): {m['error']}")
            continue
        if m.get("no_return"):  # margins 'inf' read as "very robust" where there is no loop to judge
            lines.append(f"  loop {name} ({m['signal']}): opened here nothing comes back (L = 0): no feedback "
                         "through this signal here, or a block on the loop has slope 0 (a relay, a quantizer, a "
                         "saturation at its limit)")
            continue
        gm = "inf" if m["gain_margin_db"] is None else f"{m['gain_margin_db']:.2f} dB"
        pm = "inf" if m["phase_margin_deg"] is None else f"{m['phase_margin_deg']:.1f} deg"
        lines.append(f"  loop {name} ({m['signal']}): gain margin {gm}, phase margin {pm}")
        if not m.get("closed_loop_stable", True):
            lines.append("    closed through this opening the loop is NOT STABLE: these margins do not measure "
                         "a distance to instability")
        elif m.get("open_loop_unstable_poles"):
            lines.append(f"    opened here the loop has {m['open_loop_unstable_poles']} unstable pole(s): "
                         "margins alone do not show stability (count Nyquist's encirclements)")
        if m.get("hidden_unstable_modes"):
            lines.append(f"    {m['hidden_unstable_modes']} unstable mode(s) the loop drives or sees but its transfer "
                         "function does not show (a pole-zero cancellation, or a branch it feeds): the margins "
                         "do not cover them")
    for cname, c in res.get("cases", {}).items():
        lines.append(f"  case {cname} {c['set']}: {g} {_num(c['spectral_radius'])}"
                     f" ({'stable' if c['stable'] else 'not stable'})")
    if res.get("rates"):
        lines.append("  servo rate (Hz): " + "  ".join(
            f"{r['rate_hz']}:{_num(r['spectral_radius'], 3)}{'' if r['stable'] else '!'}" for r in res["rates"]))
    for name, d in res.get("gains", {}).items():
        lines.append(f"  {name} ({d['param']}): {describe_boundaries(d.get('boundaries', []))}")
    lines.append(f"  (numbers are the {g}{' over one period' if sampled else ''} besides {at_one}; ! = not stable)")
    return lines


def _num(v, digits=4):
    """A number for the summary, or 'n/a' where the loop could not be linearized."""
    return "n/a" if v is None else f"{v:.{digits}f}"
