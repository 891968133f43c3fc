"""Stability report: one self-contained HTML page plus PNG and SVG figures.

``write_report(path, outdir)`` analyses every variant of a diagram (e.g. one per
servo rate), as given and under each ``analysis.compare`` setting (e.g. a damped
model), and writes ``report.html`` with: the diagram picture; Bode plots of each
loop with margins marked; the root locus against the first of the analysis's
gains, the gains as given marked; the pole map; the growth of the closed loop
against servo rate and against each gain scale; the linear step response beside
the nonlinear simulation; and the numbers in tables. The figures are drawn by
:mod:`hybridsim.report.stability_figures`, the page by :mod:`hybridsim.report.html`.
``write_analysis(path, outdir)`` writes the analysis alone, as ``analysis.json``.
"""
import json
import warnings
from pathlib import Path

import numpy as np

from hybridsim.analysis import extras
from hybridsim.analysis import stability as an
from hybridsim.analysis.linearize import LinearizationError
from hybridsim.format.build import build, load
from hybridsim.files import atomic_dir, atomic_file, check_output_dir, check_planned, output_dir, safe_name
from hybridsim.format import DiagramFile
from hybridsim.report import html
from hybridsim.report.picture import draw_diagram


def json_default(v):
    """JSON for what analysis results hold besides plain data: complex numbers as [re, im],
    numpy numbers and arrays as numbers and lists, anything else as its text."""
    if isinstance(v, complex):
        return [v.real, v.imag]
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    return str(v)


def write_analysis(source, outdir=None, at=None, **overrides):
    """Linearize a diagram - poles, loop margins, rate and gain sweeps - and, with ``outdir``, write
    ``outdir/analysis.json``; ``hybridsim analyze``.

    Parameters
    ----------
    source : str, Path or DiagramFile
        The diagram (its ``analysis`` section says what to compute).
    outdir : path-like, optional
        The folder of ``analysis.json`` (checked before the analysis starts).
    at : float, optional
        Linearize about the state after ``at`` s of simulation (default: ``analysis: at``, else
        the initial state).
    **overrides
        As ``hybridsim --set`` gives them.

    Returns
    -------
    dict
        :func:`hybridsim.analysis.stability.analyze`'s results (``_objects`` holds the
        python-control closed loop and loop transfers; the file has the rest).
    """
    if outdir is not None:
        check_output_dir(outdir)
    res = an.analyze(source, at=at, **overrides)
    if outdir is not None:
        with atomic_file(Path(outdir) / "analysis.json") as fh:
            fh.write(json.dumps({k: v for k, v in res.items() if k != "_objects"}, indent=2,
                                default=json_default) + "\n")
    return res


def _analyse(at, cfg, f):
    """The report's data and the models and loops its figures draw (``f``: the diagram with the
    user's overrides; each variant and comparison over them)."""
    variants = f.variants()
    compare = {"as printed": {}}
    compare.update(cfg.get("compare") or {})
    data = {"diagram": f.name, "description": f.description, "configurations": []}
    models, loops, known, full = [], [], {}, None
    main_ov = dict(variants[0][1])
    for cname, cov in compare.items():
        for vlabel, vov in variants:
            label = " ".join(x for x in (cname, vlabel) if x)
            ov = {**vov, **cov}
            main = full is None and ov == main_ov  # the main configuration: with its sweeps, once
            res = an.analyze(f, at=at, sweeps=main, **ov)
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
                **{k: res.get(k) for k in extras.keys()},
                **{f"{k}_{m}": v.get(m) for k, v in res["loops"].items()
                   for m in ("gain_margin_db", "phase_margin_deg")},
                "poles": res["poles"][:8]})
    if full is None:
        full = an.analyze(f, at=at, **main_ov)
        full.pop("_objects")
    data["analysis"] = full
    return data, models, loops, known, main_ov


def write_report(path, outdir=None, at=None, **overrides):
    """Analyse a diagram and write ``outdir/report.html`` with its figures and ``analysis.json``.

    Every variant is analysed as given and under each ``analysis: compare`` setting; the
    first, as given, with its rate and gain sweeps (:func:`hybridsim.analysis.stability.analyze`).

    Parameters
    ----------
    path : str, Path or DiagramFile
        The diagram (a :class:`~hybridsim.format.DiagramFile` brings its overrides along).
    outdir : path-like, optional
        The folder (default ``out/<name>_report``, written only where every file in it is
        hybridsim's).
    at : float, optional
        Linearize about the state after ``at`` s of simulation (default: the diagram's
        ``analysis: at``, else the initial state).
    **overrides
        As ``hybridsim --set`` gives them.

    Returns
    -------
    dict
        The report's data: ``diagram``, ``description``, ``configurations`` (one row per
        variant and comparison), ``analysis`` (the first's full analysis), ``step`` (where the
        diagram has ``analysis: step``) and ``outdir``.
    """
    from hybridsim.report.stability_figures import bode, pole_map, root_locus, step_figure, sweep_chart

    f = load(path, **overrides)  # a DiagramFile's own overrides first, these over them
    outdir, _ = output_dir(outdir, Path("out") / f"{safe_name(f.name)}_report")
    cfg = an.settings_of(f)
    figs = ["diagram", "poles"] + [f"bode_{p}" for p in cfg["points"]] + \
        (["root_locus", "stability_vs_gain"] if cfg["gains"] else []) + (["stability_vs_rate"] if cfg["rates"] else [])
    check_planned(outdir, ["analysis.json", "report.html"] + [f"{n}.{e}" for n in figs for e in ("png", "svg")])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        data, models, loops, known, main_ov = _analyse(at, cfg, f)
    full = data["analysis"]
    base = {**cfg["set"], **main_ov}
    figures = {}
    with atomic_dir(outdir) as tmp:
        system = build(f, **main_ov)[0]
        _save(draw_diagram(system, f.description or f.name), "diagram", tmp, figures)
        for point in cfg["points"]:
            mine = [(lab.rsplit(": ", 1)[0], L) for lab, L in loops if lab.endswith(f": {point}")]
            if mine:
                fig = bode(mine, known)
                fig.suptitle(f"loop opened at {point} ({cfg['points'][point]})", fontsize=9)
                _save(fig, f"bode_{point}", tmp, figures)
        _save(pole_map(models), "poles", tmp, figures)
        first_gain = next(iter(cfg["gains"].items()), None)
        if first_gain:
            _, ref = first_gain
            value = an.param_value(f, ref)
            _save(root_locus(f, base, ref, value, np.logspace(-2, 1.5, 36)), "root_locus", tmp, figures)
        if full.get("rates"):
            _save(sweep_chart([("as printed", full["rates"])], "rate_hz", "servo rate (Hz)"),
                  "stability_vs_rate", tmp, figures)
        if full.get("gains"):
            _save(sweep_chart([(g, d["sweep"]) for g, d in full["gains"].items()], "scale",
                              "gain scale (1 = as given)"), "stability_vs_gain", tmp, figures)
        try:
            fig, step = step_figure(f, base, cfg)
        except LinearizationError:
            fig, step = None, None
        if fig is not None:
            _save(fig, "step_linear_vs_nonlinear", tmp, figures)
            data["step"] = step
        (tmp / "analysis.json").write_text(json.dumps(data, indent=2, default=json_default) + "\n")
        (tmp / "report.html").write_text(_page(data, figures, first_gain))
    data["outdir"] = outdir
    return data


def _save(fig, name, outdir, figures):
    """``fig`` as NAME.png and NAME.svg in ``outdir``, and as base64 PNG in ``figures``."""
    import matplotlib.pyplot as plt

    fig.savefig(outdir / f"{name}.png", dpi=110)
    fig.savefig(outdir / f"{name}.svg")
    figures[name] = html.png_base64(fig)
    plt.close(fig)


def _growth(c, digits=4):
    """A configuration's growth: |z| to ``digits`` decimals, Re s (often ~0) to ``digits`` figures."""
    return f"{c['growth']:.{digits}f}" if c["growth_label"] == "largest |z|" else f"{c['growth']:.{digits}g}"


def _verdicts(configurations):
    """The verdict list: the trend along each comparison's variants, then one line per configuration."""
    esc, out = html.escape, []
    for cname in dict.fromkeys(c["compare"] for c in configurations):
        group = [c for c in configurations if c["compare"] == cname]
        if len(group) > 1:
            first, last = group[0], group[-1]
            better = last["growth"] < first["growth"]
            trend = " → ".join(_growth(c, 3) for c in group)
            damp = " → ".join(html.fmt(c["least_damping"]) for c in group)
            out.append(f"<li><b>{esc(cname)}</b>, {esc(first['variant'])} … {esc(last['variant'])}: "
                       f"{esc(first['growth_label'])} {trend}; least damping ratio {damp}. The later variant "
                       f"{'improves' if better else 'does not improve'} the loop's damping.</li>")
    for c in configurations:
        out.append(f"<li><b>{esc(c['label'])}</b>: {esc(c['growth_label'])} {_growth(c)} "
                   f"({'stable' if c['stable'] else 'not stable'}); least damping ratio "
                   f"{html.fmt(c['least_damping'])}</li>")
    return "".join(out)


def _page(data, figures, first_gain):
    """The report page."""
    a = data["analysis"]
    conf_cols = ["label", "growth", "stable", "least_damping"] + extras.keys()
    conf_cols += sorted({k for c in data["configurations"] for k in c
                         if k.endswith("_margin_db") or k.endswith("_margin_deg")})

    def img(k, caption):
        return html.figure(figures[k], caption) if k in figures else ""

    rates = html.table(a.get("rates", []), ["rate_hz", "spectral_radius", "stable"])
    gains = html.table([{"gain": g, "parameter": d["param"], "value": d["value"],
                         "boundaries (scale of value)": an.describe_boundaries(d.get("boundaries", []))}
                        for g, d in a.get("gains", {}).items()],
                       ["gain", "parameter", "value", "boundaries (scale of value)"])
    cases = html.table([{"case": k, **v} for k, v in a.get("cases", {}).items()],
                       ["case", "set", "spectral_radius", "stable"])
    loops = html.table([{"loop": k, **v} for k, v in a.get("loops", {}).items()],
                       ["loop", "signal", "gain_margin_db", "phase_margin_deg", "gain_crossover_hz", "phase_crossover_hz",
                        "no_return", "closed_loop_stable", "open_loop_unstable_poles", "hidden_unstable_modes"])
    poles = html.table(a["poles"][:12], ["re", "im", "abs", "freq_hz", "damping"])
    if a.get("domain") == "continuous":
        method = ("nothing is sampled, so the closed loop is the continuous system x' = A x (poles in the "
                  "s-plane). \"Largest Re s\" leaves out poles at s = 0 (constant directions, "
                  f"{a['integrator_modes']} here).")
    else:
        method = ("the sampled-data closed loop is exact at the servo period (zero-order hold, lifted to the "
                  "hyperperiod for several rates). \"Largest |z|\" leaves out poles at exactly z = 1 "
                  f"(integrator directions no signal drives, {a['integrator_modes']} here).")
    step = data.get("step")
    step_txt = ""
    if step:
        why = (f" (the linear model is unstable, {step['linear_unstable_poles']} pole(s) growing: the two part "
               "as it grows, and only the nonlinear limits keep the simulation bounded)"
               if step.get("linear_unstable_poles") else "")
        step_txt = (f"<p>Step of {step['step_size']} at the input: linear and nonlinear differ by at most "
                    f"{step['max_abs_difference']:.3g} over {step['ticks']} samples{why}.</p>")
    locus = f"root locus against {first_gain[0]} ({first_gain[1]}); x = the gains as given" if first_gain else ""
    bodes = "".join(img(k, f"loop transfer L at {k[5:]}; margins marked") for k in figures if k.startswith("bode_"))
    body = f"""<h1>Stability report: {html.escape(data['diagram'])}</h1>
<p>{html.escape(data['description'])}</p>
<p>Linearized about the operating point (branch: {html.escape(json.dumps(a['branch']))}); {method}
Finite-difference error estimate {a['fd_error']:.1e}.</p>
<h2>Verdict per configuration</h2><ul>{_verdicts(data['configurations'])}</ul>
{html.table(data['configurations'], conf_cols)}
{img('diagram', 'the diagram (one colour per rate)')}
<h2>Loops</h2>{loops}{bodes}
<h2>Poles</h2>{poles}{img('poles', 'closed-loop poles of every configuration')}
{img('root_locus', locus)}
<h2>Stability against servo rate and gains</h2>{rates}{img('stability_vs_rate', 'largest |z| against servo rate')}
{gains}{img('stability_vs_gain', 'largest |z| against the scale of each gain')}
<h2>Nonsmooth cases</h2>{cases}
<h2>Linear model against the nonlinear simulation</h2>{step_txt}
{img('step_linear_vs_nonlinear', 'closed-loop step: linear model (steps) and nonlinear simulation (dots)')}"""
    return html.page(f"hybridsim stability report: {data['diagram']}", body)
