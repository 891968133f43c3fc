"""The figures of the stability report: pole maps, Bode plots, root locus, sweeps, a linear step.

Each function returns a matplotlib Figure; :mod:`hybridsim.report.stability` puts them on
its page. Sampled loops are drawn in the z-plane, continuous ones in the s-plane.
"""
import control
import matplotlib
import numpy as np

from hybridsim.analysis import stability as an
from hybridsim.analysis.linearize import Linearization
from hybridsim.analysis.margins import loop_response
from hybridsim.format.build import build
from hybridsim.report.figures import pyplot
from hybridsim.runs.experiment import Experiment

plt = pyplot()


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
    {id(L): margins} already computed (:func:`hybridsim.analysis.margins.margins`), the rest are computed."""
    known = known or {}
    fig, (am, ph) = plt.subplots(2, 1, sharex=True, figsize=(7, 5.5))
    for label, L in loops:
        w = _bode_grid(L)
        resp = loop_response(L, w)
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
    """Poles as one gain is scaled, the value as given (scale 1) marked. ``path``: a diagram file
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
    y = np.asarray(res[ref], float).reshape(len(res.t), -1)[:, 0]  # 'plant.y' (one element) or 'plant.y[0]'
    nl = y[:n] - y[0]
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
    from hybridsim.analysis.stability import growing_modes

    return fig, {"step_size": size, "max_abs_difference": err, "ticks": n,
                 "linear_unstable_poles": growing_modes(G)}  # G is the closed loop: its own poles
