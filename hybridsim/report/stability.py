"""Stability report: one self-contained HTML page plus PNG and SVG figures.

``write_report(path, outdir)`` analyses every variant of a diagram (e.g. Fig 9
at 60, 80, 120 Hz), as printed and under each ``analysis.compare`` setting
(e.g. a damped model), and writes ``report.html`` with: the diagram picture;
Bode plots of each loop with margins marked; root locus against the force
gain with the Appendix A gains marked; the pole map in the unit circle; the
largest ``|z|`` against servo rate and against each gain scale; the linear step
response beside the nonlinear simulation; and the numbers in tables.
"""
import base64
import html
import io
import json
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import control  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hybridsim.analysis import stability as an  # noqa: E402
from hybridsim.api import build, load  # noqa: E402
from hybridsim.runs.experiment import Experiment  # noqa: E402
from hybridsim.files import atomic_dir  # noqa: E402
from hybridsim.analysis.linearize import Linearization, LinearizationError  # noqa: E402
from hybridsim.report.picture import draw_diagram  # noqa: E402


def _unit_circle(ax):
    th = np.linspace(0, 2 * np.pi, 400)
    ax.plot(np.cos(th), np.sin(th), "k-", lw=0.8)
    for zeta in (0.1, 0.3, 0.5, 0.7):  # constant-damping spirals, upper half
        wn = np.linspace(0, np.pi / np.sqrt(1 - zeta**2), 200)
        s = -zeta * wn + 1j * wn * np.sqrt(1 - zeta**2)
        z = np.exp(s)
        ax.plot(z.real, z.imag, ":", color="0.7", lw=0.6)
        ax.plot(z.real, -z.imag, ":", color="0.7", lw=0.6)
    ax.axhline(0, color="0.8", lw=0.5)
    ax.axvline(0, color="0.8", lw=0.5)
    ax.set_aspect("equal")
    ax.set_xlabel("Re z")
    ax.set_ylabel("Im z")


def _s_plane(ax, poles):
    """Axes of the s-plane around ``poles`` with lines of damping 0.1, 0.3, 0.5, 0.7."""
    r = max(1.0, float(np.max(np.abs(poles)))) * 1.1 if len(poles) else 1.0
    for zeta in (0.1, 0.3, 0.5, 0.7):
        x, y = -zeta * r, np.sqrt(1 - zeta**2) * r
        ax.plot([0, x], [0, y], ":", color="0.7", lw=0.6)
        ax.plot([0, x], [0, -y], ":", color="0.7", lw=0.6)
    ax.axhline(0, color="0.8", lw=0.5)
    ax.axvline(0, color="k", lw=0.8)
    ax.set_xlim(-r, 0.25 * r)
    ax.set_ylim(-r, r)
    ax.set_xlabel("Re s (1/s)")
    ax.set_ylabel("Im s (rad/s)")


def pole_map(models):
    """Closed-loop poles of several (label, model) in the unit circle (sampled) or the s-plane (continuous)."""
    fig, ax = plt.subplots(figsize=(5.5, 5.5))
    sampled = all(cl.period for _, cl in models)
    if sampled:
        _unit_circle(ax)
    else:
        _s_plane(ax, np.concatenate([cl.poles for _, cl in models]))
    for label, cl in models:
        p = cl.poles
        ax.plot(p.real, p.imag, "x", ms=8, mew=1.5, label=f"{label} ({cl.growth_label} {cl.growth:.3g})")
    if sampled:
        lim = max(1.15, max((float(np.max(np.abs(cl.poles))) for _, cl in models if len(cl.poles)), default=0.0) * 1.05)
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
    ax.legend(fontsize=7, loc="lower left")
    ax.set_title("closed-loop poles (grid: damping 0.1, 0.3, 0.5, 0.7)", fontsize=9)
    fig.tight_layout()
    return fig


def _bode_grid(L):
    """Frequencies (rad/s) for L's Bode plot: up to Nyquist (sampled) or a decade past its fastest pole."""
    if L.dt:
        return np.logspace(np.log10(2 * np.pi * 0.05), np.log10(np.pi / L.dt) - 1e-3, 600)
    p = np.abs(L.poles())
    top = 10.0 * max(float(p.max()) if p.size else 1.0, 2 * np.pi)
    return np.logspace(np.log10(2 * np.pi * 0.05), np.log10(top), 600)


def bode(loops, known=None):
    """Bode plots of loop transfers (discrete or continuous) with the margins marked; ``known``:
    {id(L): margins} already computed (:func:`hybridsim.analysis.stability.margins`), the rest are computed."""
    known = known or {}
    fig, (am, ph) = plt.subplots(2, 1, sharex=True, figsize=(7, 5.5))
    for label, L in loops:
        w = _bode_grid(L)
        resp = an._response(L, w)
        f = w / (2 * np.pi)
        if not np.any(resp):  # nothing feeds back through this point (e.g. a position-controlled axis)
            am.plot([], [], label=f"{label} (no feedback: L = 0)")
            continue
        with np.errstate(divide="ignore"):  # exact zeros of L (-inf dB) are left out of the curve
            line, = am.semilogx(f, 20 * np.log10(np.abs(resp)), label=label)
        ph.semilogx(f, np.degrees(np.unwrap(np.angle(resp))), color=line.get_color())
        m = known.get(id(L)) or an.margins(L)
        inside = lambda hz: hz is not None and hz >= 0.05  # noqa: E731
        if inside(m["gain_crossover_hz"]):
            am.plot(m["gain_crossover_hz"], 0, "o", color=line.get_color())
            ph.annotate(f"PM {m['phase_margin_deg']:.0f}°", (m["gain_crossover_hz"], -180 + m["phase_margin_deg"]),
                        fontsize=7, color=line.get_color())
        if inside(m["phase_crossover_hz"]) and m["gain_margin_db"] is not None:
            am.annotate(f"GM {m['gain_margin_db']:.1f} dB", (m["phase_crossover_hz"], -m["gain_margin_db"]),
                        fontsize=7, color=line.get_color())
    am.axhline(0, color="k", lw=0.6)
    ph.axhline(-180, color="k", lw=0.5, ls=":")
    am.set_ylabel("|L| (dB)")
    ph.set_ylabel("phase (deg)")
    ph.set_xlabel("frequency (Hz)" + (", up to Nyquist" if all(L.dt for _, L in loops) else ""))
    am.legend(fontsize=7)
    am.grid(True, which="both", alpha=0.3)
    ph.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    return fig


def root_locus(path, base, ref, value, scales):
    """Poles as one gain is scaled; the Appendix A value (scale 1) marked. ``path``: a diagram file
    (built once with ``base``) or an :class:`~hybridsim.runs.experiment.Experiment`."""
    fig, ax = plt.subplots(figsize=(5.5, 5.5))
    exp = path if isinstance(path, Experiment) else Experiment(path, **base)  # built once; each scale at run time
    pts = [(s, exp.linearization({ref: (np.asarray(value) * s).tolist()}).closed_loop().poles) for s in scales]
    sampled = bool(exp.system.schedule.ticks)
    if sampled:
        _unit_circle(ax)
    else:
        _s_plane(ax, np.concatenate([p for _, p in pts]))
    cmap = plt.get_cmap("viridis")
    lo, hi = np.log(scales[0]), np.log(scales[-1])
    for s, p in pts:
        ax.plot(p.real, p.imag, ".", ms=5, color=cmap((np.log(s) - lo) / (hi - lo)))
    p1 = exp.linearization().closed_loop().poles
    ax.plot(p1.real, p1.imag, "rx", ms=9, mew=2, label=f"{ref} as given")
    sm = plt.cm.ScalarMappable(cmap=cmap, norm=matplotlib.colors.LogNorm(scales[0], scales[-1]))
    fig.colorbar(sm, ax=ax, shrink=0.7, label=f"scale of {ref}")
    if sampled:
        lim = min(3.0, max(1.2, max(np.max(np.abs(p)) for _, p in pts) * 1.05))
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
    ax.legend(fontsize=7, loc="lower left")
    ax.set_title(f"root locus against {ref}", fontsize=9)
    fig.tight_layout()
    return fig


def sweep_chart(rows_by_label, xkey, xlabel, logx=True):
    """Largest ``|z|`` of the closed loop against ``xkey`` (servo rate or gain scale), one line per label; a Figure."""
    fig, ax = plt.subplots(figsize=(6, 3.6))
    for label, rows in rows_by_label:
        x = [r[xkey] for r in rows if r["spectral_radius"] is not None]
        y = [r["spectral_radius"] for r in rows if r["spectral_radius"] is not None]
        ax.plot(x, y, "o-", label=label)
    ax.axhline(1.0, color="r", lw=1, ls="--")
    if logx:
        ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("largest |z| (besides z = 1)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def step_figure(path, base, cfg):
    """Linear closed-loop step vs the nonlinear simulation (analysis.step)."""
    st = cfg.get("step")
    if not st:
        return None, None
    system, _, settings = build(path, **base)
    G = Linearization(system).io(st["input"], st["output"])
    n = int(st.get("ticks", 40))
    T = G.dt or float(settings["simulation"].get("log_period", 0.0005))  # nothing sampled: at the log points
    size = float(st["size"])
    lin = size * np.ravel(control.step_response(G, T=np.arange(n) * T).outputs)
    ref = st["output"]
    res = build(path, log=[ref], **{**base, **st["set"], "log_period": T, "t_end": n * T})[1].run(n * T)
    y0 = float(res[ref][0])
    nl = res[ref][:n] - y0
    fig, ax = plt.subplots(figsize=(6, 3.4))
    t = np.arange(n) * T
    if G.dt:
        ax.step(t, lin, where="post", label="linear model")
    else:
        ax.plot(t, lin, "-", label="linear model")
    ax.plot(t, nl, "o", ms=3, label="nonlinear simulation")
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"Δ {ref}")
    lim = max(3 * abs(size), 1.2 * np.max(np.abs(nl)))
    ax.set_ylim(-lim, lim)
    ax.legend(fontsize=7)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    err = float(np.max(np.abs(lin - nl)))
    return fig, {"step_size": size, "max_abs_difference": err, "ticks": n}


def _save(fig, name, outdir, figures):
    fig.savefig(outdir / f"{name}.png", dpi=110)
    fig.savefig(outdir / f"{name}.svg")
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    figures[name] = base64.b64encode(buf.getvalue()).decode()
    plt.close(fig)


def _table(rows, cols):
    head = "".join(f"<th>{html.escape(c)}</th>" for c in cols)
    body = ""
    for r in rows:
        body += "<tr>" + "".join(f"<td>{html.escape(_fmt(r.get(c)))}</td>" for c in cols) + "</tr>"
    return f"<table><tr>{head}</tr>{body}</table>"


def _fmt(v):
    if v is None:
        return "–"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def write_report(path, outdir, at=None, **overrides):
    """Analyse ``path`` and write ``outdir/report.html`` with figures; returns the data.

    ``at``: linearize about the state after ``at`` s of simulation (default:
    the diagram's ``analysis: at``, else the initial state).
    """
    f = load(path, **overrides)
    cfg = an.settings_of(f)
    variants = f.variants()
    compare = {"as printed": {}}
    compare.update(cfg.get("compare") or {})
    data = {"diagram": f.name, "description": f.description, "configurations": []}
    models, loops, known, full = [], [], {}, None
    main_ov = {**overrides, **variants[0][1]}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for cname, cov in compare.items():
            for vlabel, vov in variants:
                label = " ".join(x for x in (cname, vlabel) if x)
                ov = {**overrides, **vov, **cov}
                main = full is None and ov == main_ov  # the main configuration: with its sweeps, once
                res = an.analyze(path, at=at, sweeps=main, **ov)
                objs = res.pop("_objects")
                if main:
                    full = dict(res)
                models.append((label, objs["closed_loop"]))
                loops += [(f"{label}: {k}", L) for k, L in objs["loops"].items()]
                known.update({id(L): res["loops"][k] for k, L in objs["loops"].items()})
                data["configurations"].append({
                    "label": label, "compare": cname, "variant": vlabel, "set": {**vov, **cov},
                    "growth_label": res["growth_label"], "growth": res["growth"], "stable": res["stable"],
                    "integrator_modes": res["integrator_modes"],
                    "least_damping": an.least_damping(res["poles"]),
                    "hand_mode_hz": res.get("hand_mode_hz"),
                    **{f"{k}_{m}": v.get(m) for k, v in res["loops"].items()
                       for m in ("gain_margin_db", "phase_margin_deg")},
                    "poles": res["poles"][:8]})
        if full is None:
            full = an.analyze(path, at=at, **main_ov)
            full.pop("_objects")
        data["analysis"] = full
    base = {**cfg["set"], **main_ov}
    figures = {}
    with atomic_dir(Path(outdir)) as tmp:
        system = build(path, **main_ov)[0]
        _save(draw_diagram(system, f.description or f.name), "diagram", tmp, figures)
        for point in cfg["points"]:
            mine = [(lab.rsplit(": ", 1)[0], L) for lab, L in loops if lab.endswith(f": {point}")]
            if mine:
                fig = bode(mine, known)
                fig.suptitle(f"loop opened at {point} ({cfg['points'][point]})", fontsize=9)
                _save(fig, f"bode_{point}", tmp, figures)
        _save(pole_map(models), "poles", tmp, figures)
        force_gain = next(iter(cfg["gains"].items()), None)
        if force_gain:
            name, ref = force_gain
            value = an.param_value(f, ref)
            _save(root_locus(path, base, ref, value, np.logspace(-2, 1.5, 36)), "root_locus", tmp, figures)
        if full.get("rates"):
            _save(sweep_chart([("as printed", full["rates"])], "rate_hz", "servo rate (Hz)"),
                  "stability_vs_rate", tmp, figures)
        if full.get("gains"):
            _save(sweep_chart([(g, d["sweep"]) for g, d in full["gains"].items()], "scale",
                              "gain scale (1 = as given)"), "stability_vs_gain", tmp, figures)
        try:
            fig, step = step_figure(path, base, cfg)
        except LinearizationError:
            fig, step = None, None
        if fig is not None:
            _save(fig, "step_linear_vs_nonlinear", tmp, figures)
            data["step"] = step
        (tmp / "analysis.json").write_text(json.dumps(data, indent=2, default=_json) + "\n")
        (tmp / "report.html").write_text(_html(data, figures, cfg))
    return data


def _json(v):
    if isinstance(v, complex):
        return [v.real, v.imag]
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    return str(v)


def _growth(c, digits=4):
    """A configuration's growth: |z| to ``digits`` decimals, Re s (often ~0) to ``digits`` figures."""
    return f"{c['growth']:.{digits}f}" if c["growth_label"] == "largest |z|" else f"{c['growth']:.{digits}g}"


def _html(data, figures, cfg):
    a = data["analysis"]
    conf_cols = ["label", "growth", "stable", "least_damping", "hand_mode_hz"]
    conf_cols += sorted({k for c in data["configurations"] for k in c
                         if k.endswith("_margin_db") or k.endswith("_margin_deg")})
    img = lambda k, cap: (f"<figure><img src='data:image/png;base64,{figures[k]}'/>"  # noqa: E731
                          f"<figcaption>{cap}</figcaption></figure>" if k in figures else "")
    verdict = []
    for cname in dict.fromkeys(c["compare"] for c in data["configurations"]):
        group = [c for c in data["configurations"] if c["compare"] == cname]
        if len(group) > 1:
            first, last = group[0], group[-1]
            better = last["growth"] < first["growth"]
            trend = " → ".join(_growth(c, 3) for c in group)
            damp = " → ".join(_fmt(c["least_damping"]) for c in group)
            verdict.append(
                f"<li><b>{html.escape(cname)}</b>, {html.escape(first['variant'])} … {html.escape(last['variant'])}: "
                f"{html.escape(first['growth_label'])} {trend}; least damping ratio {damp}. The later variant "
                f"{'improves' if better else 'does not improve'} the loop's damping.</li>")
    for c in data["configurations"]:
        verdict.append(f"<li><b>{html.escape(c['label'])}</b>: {html.escape(c['growth_label'])} {_growth(c)} "
                       f"({'stable' if c['stable'] else 'not stable'}); least damping ratio "
                       f"{_fmt(c['least_damping'])}</li>")
    rates = _table(a.get("rates", []), ["rate_hz", "spectral_radius", "stable"])
    gains = _table([{"gain": g, "parameter": d["param"], "value": d["value"], "boundary scale": d["critical_scale"]}
                    for g, d in a.get("gains", {}).items()], ["gain", "parameter", "value", "boundary scale"])
    cases = _table([{"case": k, **v} for k, v in a.get("cases", {}).items()], ["case", "set", "spectral_radius", "stable"])
    loops = _table([{"loop": k, **v} for k, v in a.get("loops", {}).items()],
                   ["loop", "signal", "gain_margin_db", "phase_margin_deg", "gain_crossover_hz", "phase_crossover_hz"])
    poles = _table(a["poles"][:12], ["re", "im", "abs", "freq_hz", "damping"])
    if a.get("domain") == "continuous":
        method = ("nothing is sampled, so the closed loop is the continuous system x' = A x (poles in the "
                  "s-plane). \"Largest Re s\" leaves out poles at s = 0 (constant directions, "
                  f"{a['integrator_modes']} here).")
    else:
        method = ("the sampled-data closed loop is exact at the servo period (zero-order hold, lifted to the "
                  "hyperperiod for several rates). \"Largest |z|\" leaves out poles at exactly z = 1 "
                  f"(integrator directions no signal drives, {a['integrator_modes']} here).")
    step = data.get("step")
    step_txt = (f"<p>Step of {step['step_size']} at the input: linear and nonlinear differ by at most "
                f"{step['max_abs_difference']:.3g} over {step['ticks']} samples.</p>" if step else "")
    return f"""<!DOCTYPE html><html><head><meta charset="utf-8">
<title>hybridsim stability report: {html.escape(data['diagram'])}</title>
<style>body{{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}}
table{{border-collapse:collapse;margin:1em 0}}td,th{{border:1px solid #ccc;padding:3px 8px;font-size:13px}}
th{{background:#f0f0f0}}figure{{display:inline-block;margin:0.5em}}img{{max-width:100%}}
figcaption{{font-size:12px;color:#555}}</style></head><body>
<h1>Stability report: {html.escape(data['diagram'])}</h1>
<p>{html.escape(data['description'])}</p>
<p>Linearized about the operating point (branch: {html.escape(json.dumps(a['branch']))}); {method}
Finite-difference error estimate {a['fd_error']:.1e}.</p>
<h2>Verdict per configuration</h2><ul>{''.join(verdict)}</ul>
{_table(data['configurations'], conf_cols)}
{img('diagram', 'the diagram (one colour per rate)')}
<h2>Loops</h2>{loops}{''.join(img(k, 'loop transfer L(z) at ' + k[5:] + '; margins marked') for k in figures if k.startswith('bode_'))}
<h2>Poles</h2>{poles}{img('poles', 'closed-loop poles of every configuration')}
{img('root_locus', 'root locus against the force gain; x = the gains as given')}
<h2>Stability against servo rate and gains</h2>{rates}{img('stability_vs_rate', 'largest |z| against servo rate')}
{gains}{img('stability_vs_gain', 'largest |z| against the scale of each gain')}
<h2>Nonsmooth cases</h2>{cases}
<h2>Linear model against the nonlinear simulation</h2>{step_txt}
{img('step_linear_vs_nonlinear', 'closed-loop step: linear model (steps) and nonlinear simulation (dots)')}
</body></html>
"""
