"""A loop's margins and what they do not say alone: gain and phase margins of an opened loop
(python-control's, checked against the loop's own frequency response), its growing modes and
whether it closes stable. Each function takes a python-control system."""
import control
import numpy as np


def loop_response(L, w):
    """L's frequency response (complex) at ``w`` (rad/s, a number or an array), discrete or continuous."""
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
    """Whether python-control's polynomial margins describe L's own frequency response (to 1 %); not
    where L has no finite response there (a crossover on a pole: a PID's unused integrator at z = 1
    over an integrating plant put one at 0 Hz)."""
    if np.isfinite(pm) and np.isfinite(wp) and not abs(abs(loop_response(L, wp)) - 1.0) <= 0.01:
        return False
    return not (np.isfinite(gm) and np.isfinite(wg) and not abs(abs(loop_response(L, wg)) * gm - 1.0) <= 0.01)


def _grid_margins(L, n=20000):
    """(gm, pm deg, phase-crossover rad/s, gain-crossover rad/s) of a discrete L from its response on a
    dense grid up to Nyquist, crossings interpolated linearly; the crossing nearest instability wins."""
    nyq = np.pi / L.dt
    w = np.unique(np.concatenate([np.logspace(np.log10(nyq) - 5, np.log10(nyq), n // 4), np.linspace(0, nyq, n)]))
    w = w[(w > 0) & (w < nyq * (1 - 1e-9))]
    r = loop_response(L, w)

    def at(x):
        return loop_response(L, x)

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


def growing_modes(sys, marginal=False, hidden=False):
    """How many of ``sys``'s poles grow - ``|z| > 1`` (sampled) or Re s > 0, poles at z = 1 / s = 0 left
    out - and are modes of its input-output path (the PBH test: neither uncontrollable from its input
    nor unobservable at its output; a state elsewhere in the diagram is no pole of this loop).
    ``marginal``: poles on the unit circle (the imaginary axis) count too, z = 1 (s = 0) included: a
    closed loop with one does not settle. ``hidden``: count instead the modes the input reaches or the
    output sees, but not both (a pole-zero cancellation hides them from the transfer function; so is a
    branch the loop feeds that does not feed back)."""
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
        if marginal:
            grows = abs(lam) >= 1.0 - 1e-9 if ss.dt else lam.real >= -1e-9 * scale
        else:
            grows = (abs(lam) > 1.0 + 1e-9 and abs(lam - 1.0) >= 1e-7) if ss.dt else \
                (lam.real > 1e-9 * scale and abs(lam) > 1e-7 * scale)
        if not grows:
            continue
        shifted = A - lam * np.eye(n)
        reach = np.linalg.svd(np.hstack([shifted, B]), compute_uv=False)
        seen = np.linalg.svd(np.vstack([shifted, C]), compute_uv=False)
        reached, shown = reach[-1] > 1e-12 * reach[0], seen[-1] > 1e-12 * seen[0]
        count += bool(reached != shown if hidden else reached and shown)
    return count


def loop_stability(L):
    """What the margins of L do not say alone: ``open_loop_unstable_poles`` (the loop opened, its poles
    that grow; with any, the margins say nothing of stability without counting Nyquist's
    encirclements), ``closed_loop_stable`` (1/(1 + L), the loop closed again: no pole of its path on or
    outside the unit circle, or on or right of the imaginary axis) and ``hidden_unstable_modes`` (such
    poles of modes the loop drives or sees but not both: a pole-zero cancellation in the loop, or a
    branch it feeds; the margins do not cover them). Modes elsewhere in the diagram do not count."""
    closed = control.feedback(L, 1)
    return {"open_loop_unstable_poles": growing_modes(L),
            "closed_loop_stable": growing_modes(closed, marginal=True) == 0,
            "hidden_unstable_modes": growing_modes(closed, marginal=True, hidden=True)}
