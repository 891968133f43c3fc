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

import control
import numpy as np

from hybridsim.format import tables
from hybridsim.format.build import check_analysis_branches, load
from hybridsim.runs.experiment import Experiment
from hybridsim.runs.grid import Grid
from hybridsim.runs.many import Linearize, run_many
from hybridsim.analysis.linearize import LinearizationError
from hybridsim.analysis import extras
from hybridsim.analysis.lti import oscillatory_modes

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


def least_damping(poles):
    """Smallest damping ratio among oscillatory poles (above 0.5 Hz, not at z = 1)."""
    d = [p["damping"] for p in poles
         if p["freq_hz"] and p["freq_hz"] > 0.5 and abs(complex(p["re"], p["im"]) - 1) > 1e-7]
    return min(d) if d else None


def _response(L, w):
    """L's frequency response at ``w`` (rad/s, a number or an array), discrete or continuous."""
    s = np.exp(1j * np.asarray(w) * L.dt) if L.dt else 1j * np.asarray(w)
    if np.ndim(w) == 0 or L.ninputs != 1 or L.noutputs != 1 or not L.nstates:
        r = np.asarray(L(s))
        return complex(r.ravel()[0]) if np.ndim(w) == 0 else r.ravel()
    A, B, C = (np.asarray(m, complex) for m in (L.A, L.B, L.C))
    eye = np.eye(A.shape[0])
    out = np.empty(s.shape, complex)
    for a in range(0, s.size, 4096):  # C (sI - A)^-1 B + D, solves batched (python-control loops: 5x slower)
        part = s[a:a + 4096]
        try:
            x = np.linalg.solve(part[:, None, None] * eye - A, np.broadcast_to(B, (part.size,) + B.shape))
            out[a:a + 4096] = (C @ x)[:, 0, 0] + complex(np.asarray(L.D)[0, 0])
        except np.linalg.LinAlgError:  # a frequency on a pole
            out[a:a + 4096] = np.asarray(L(part)).ravel()
    return out


def _margins_hold(L, gm, pm, wg, wp):
    """Whether python-control's polynomial margins describe L's own frequency response (to 1 %)."""
    if np.isfinite(pm) and np.isfinite(wp) and abs(abs(_response(L, wp)) - 1.0) > 0.01:
        return False
    return not (np.isfinite(gm) and np.isfinite(wg) and abs(abs(_response(L, wg)) * gm - 1.0) > 0.01)


def _grid_margins(L, n=20000):
    """(gm, pm deg, phase-crossover rad/s, gain-crossover rad/s) of a discrete L from its response on a
    dense grid up to Nyquist, crossings interpolated linearly; the crossing nearest instability wins."""
    nyq = np.pi / L.dt
    w = np.unique(np.concatenate([np.logspace(np.log10(nyq) - 5, np.log10(nyq), n // 4), np.linspace(0, nyq, n)]))
    w = w[(w > 0) & (w < nyq * (1 - 1e-9))]
    r = _response(L, w)

    def at(x):
        return _response(L, x)

    def root(f, a, b):  # bisection of a sign change of f on [a, b], to 1e-12 relative
        fa = f(a)
        while b - a > 1e-12 * b:
            m = 0.5 * (a + b)
            fm = f(m)
            if np.sign(fm) == np.sign(fa):
                a, fa = m, fm
            else:
                b = m
        return 0.5 * (a + b)

    gm, pm, wg, wp = np.inf, np.inf, np.nan, np.nan
    lm = np.log(np.maximum(np.abs(r), 1e-300))
    for i in np.nonzero(np.sign(lm[:-1]) * np.sign(lm[1:]) < 0)[0]:  # |L| = 1
        x = root(lambda v: np.log(abs(at(v))), w[i], w[i + 1])
        p = 180.0 + np.degrees(np.angle(at(x)))  # phase margin of this crossing
        if abs(p) < abs(pm):
            pm, wp = p, x
    im = r.imag
    for i in np.nonzero((np.sign(im[:-1]) * np.sign(im[1:]) < 0) & (r.real[:-1] < 0))[0]:  # phase -180
        x = root(lambda v: at(v).imag, w[i], w[i + 1])
        if abs(at(x)) > 10.0 * max(abs(r[i]), abs(r[i + 1])):  # Im changed sign through a pole, not -180 deg
            continue
        g = 1.0 / abs(at(x).real)
        if abs(np.log(g)) < abs(np.log(gm)):
            gm, wg = g, x
    for x in (1e-9 * nyq, nyq):  # at DC and Nyquist L is real: no sign change of Im L there to find
        r0 = at(x)
        if r0.real < 0 and abs(r0.imag) < 1e-4 * abs(r0) and abs(np.log(abs(r0))) < abs(np.log(gm)):
            gm, wg = 1.0 / abs(r0), (0.0 if x < nyq else x)
    return gm, pm, wg, wp


def margins(L):
    """Gain margin (x and dB), phase margin (deg) and their frequencies (Hz) of L.

    python-control's polynomial method first; where its crossovers do not lie
    on L's own frequency response (it loses accuracy on high-order loops, e.g.
    a 6-DOF arm's with its many modes), the margins of the response sampled
    on a dense grid up to Nyquist; where it finds no crossover, the grid's
    where it finds one (a slow integrator's gain crossover it misses). The grid
    also reads L at DC and Nyquist, where a phase crossover makes Im L touch 0
    without changing sign. A gain margin past 1e9 or under 1e-9 is rounding
    (``|L|`` = 1e-16) or a pole on the circle: none. With them, what they do not
    say alone: :func:`loop_stability`.
    """
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        gm, pm, _, wg, wp, _ = control.stability_margins(L)
        if L.dt and not _margins_hold(L, gm, pm, wg, wp):
            gm, pm, wg, wp = _grid_margins(L)
        elif L.dt and not (np.isfinite(gm) and np.isfinite(pm)):  # a crossover it did not find (an
            ggm, gpm, gwg, gwp = _grid_margins(L)  # integrator's |L| crossing 1 at 0.012 Hz): the grid's
            if not np.isfinite(pm) and np.isfinite(gpm):
                pm, wp = gpm, gwp
            if not np.isfinite(gm) and np.isfinite(ggm):
                gm, wg = ggm, gwg
    if not 1e-9 < gm < 1e9:  # a phase crossover where |L| is rounding (1e-16 at 15 MHz) or a pole: none
        gm, wg = np.inf, np.nan
    dt = L.dt
    to_hz = (lambda w: None if w is None or not np.isfinite(w) else float(w / (2 * np.pi)))
    return {
        "gain_margin": float(gm) if np.isfinite(gm) else None,
        "gain_margin_db": float(20 * np.log10(gm)) if np.isfinite(gm) and gm > 0 else None,
        "phase_margin_deg": float(pm) if np.isfinite(pm) else None,
        "phase_crossover_hz": to_hz(wg),
        "gain_crossover_hz": to_hz(wp),
        "period_s": float(dt) if dt else None,
        **loop_stability(L),
    }


def growing_modes(sys):
    """How many of ``sys``'s poles grow - ``|z| > 1`` (sampled) or Re s > 0, poles at z = 1 / s = 0 left
    out - and are modes of its input-output path (the PBH test: neither uncontrollable from its input
    nor unobservable at its output; a state elsewhere in the diagram is no pole of this loop)."""
    from scipy.linalg import matrix_balance

    ss = control.ss(sys)
    A, B, C = (np.atleast_2d(np.asarray(m, float)) for m in (ss.A, ss.B, ss.C))
    if not A.size:
        return 0
    A, T = matrix_balance(A, permute=False)  # states of unlike units (um and N) made comparable
    t = np.diag(T)
    B, C = B / t[:, None], C * t[None, :]
    n = A.shape[0]
    scale = max(1.0, float(np.max(np.abs(A))))
    count = 0
    for lam in np.linalg.eigvals(A):
        grows = (abs(lam) > 1.0 + 1e-9 and abs(lam - 1.0) >= 1e-7) if ss.dt else \
            (lam.real > 1e-9 * scale and abs(lam) > 1e-7 * scale)
        if not grows:
            continue
        shifted = A - lam * np.eye(n)
        reach = np.linalg.svd(np.hstack([shifted, B]), compute_uv=False)
        seen = np.linalg.svd(np.vstack([shifted, C]), compute_uv=False)
        count += bool(reach[-1] > 1e-12 * reach[0] and seen[-1] > 1e-12 * seen[0])
    return count


def loop_stability(L):
    """What the margins of L do not say alone: ``open_loop_unstable_poles`` (the loop opened, its poles
    that grow; with any, the margins say nothing of stability without counting Nyquist's
    encirclements) and ``closed_loop_stable`` (1/(1 + L), the loop closed again). Only the modes of
    L's own path count."""
    return {"open_loop_unstable_poles": growing_modes(L),
            "closed_loop_stable": growing_modes(control.feedback(L, 1)) == 0}


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
    cl = exp.closed_loop(at=at)
    lin = exp.linearization(at=at)  # the one closed_loop used (this experiment unchanged)
    if cl is None:
        cl = lin.closed_loop()  # raises the reason it cannot be linearized
    A, _ = lin.continuous()
    out = {
        "diagram": f.name,
        "branch": cfg["set"],
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
        out["loops"][name] = {"signal": sig, **margins(L)}
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
    lines = [f"{res['diagram']}: {head} (branch {res['branch'] or 'as built'})",
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
        gm = "inf" if m["gain_margin_db"] is None else f"{m['gain_margin_db']:.2f} dB"
        pm = "inf" if m["phase_margin_deg"] is None else f"{m['phase_margin_deg']:.1f} deg"
        lines.append(f"  loop {name} ({m['signal']}): gain margin {gm}, phase margin {pm}")
        if not m.get("closed_loop_stable", True):
            lines.append("    closed through this opening the loop is NOT STABLE: these margins do not measure "
                         "a distance to instability")
        elif m.get("open_loop_unstable_poles"):
            lines.append(f"    opened here the loop has {m['open_loop_unstable_poles']} unstable pole(s): "
                         "margins alone do not show stability (count Nyquist's encirclements)")
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
