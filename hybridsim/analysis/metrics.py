"""Figures of merit of a run: the numbers the paper quotes.

All functions take uniformly sampled arrays (the simulator's log grid). Force
metrics are computed on the force as logged ("raw", it carries the ~272 Hz hand
oscillation) and after the paper's 12 Hz display filter ("filtered"): a causal
2nd-order Butterworth low-pass, started in steady state at the first sample.
"""
import functools

import numpy as np
from scipy import signal as _sig


@functools.lru_cache(maxsize=64)
def _butter2(wn):
    """Coefficients and unit initial state of the 2nd-order Butterworth low-pass (sweeps reuse them)."""
    b, a = _sig.butter(2, wn)
    return b, a, _sig.lfilter_zi(b, a)


def display_filter(t, y, cutoff=12.0):
    """Causal 2nd-order Butterworth low-pass of ``y`` at ``cutoff`` Hz."""
    y = np.asarray(y, float)
    if len(t) < 3:
        return y.copy()
    dt = float(np.median(np.diff(t)))
    wn = min(0.99, 2.0 * cutoff * dt)  # normalised to Nyquist
    b, a, zi = _butter2(wn)
    zi = zi * y[0]
    out, _ = _sig.lfilter(b, a, y, zi=zi)
    return out


def step_response(t, y, t_step, y0, y1):
    """Rise time (10-90 %, s), overshoot (% of the step) of ``y`` after ``t_step``.

    Returns a dict; rise time is None when 90 % is never reached.
    """
    t, y = np.asarray(t), np.asarray(y)
    after = t >= t_step
    tt, yy = t[after], y[after]
    span = y1 - y0
    if span == 0 or tt.size == 0:
        return {"rise_time_s": None, "overshoot_pct": None}
    frac = (yy - y0) / span
    i10 = np.argmax(frac >= 0.1) if np.any(frac >= 0.1) else None
    i90 = np.argmax(frac >= 0.9) if np.any(frac >= 0.9) else None
    rise = float(tt[i90] - tt[i10]) if i10 is not None and i90 is not None else None
    overshoot = float(max(0.0, (frac.max() - 1.0) * 100.0))
    return {"rise_time_s": rise, "overshoot_pct": overshoot}


def max_abs_error(t, y, y_d, window=None):
    """max ``|y - y_d|`` over ``window`` = (t0, t1) (whole run if None)."""
    t = np.asarray(t)
    m = np.ones_like(t, bool) if window is None else (t >= window[0]) & (t <= window[1])
    if not m.any():
        return None
    return float(np.max(np.abs(np.asarray(y)[m] - np.asarray(y_d)[m])))


def contact_report(t, contact):
    """Was contact lost after it was first made? Returns a dict."""
    c = np.asarray(contact) > 0.5
    if not c.any():
        return {"contact_lost": True, "first_loss_s": float(t[0]) if len(t) else None,
                "time_out_of_contact_s": float(t[-1] - t[0]) if len(t) else 0.0}
    first = int(np.argmax(c))
    lost = ~c[first:]
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    return {
        "contact_lost": bool(lost.any()),
        "first_loss_s": float(t[first:][lost][0]) if lost.any() else None,
        "time_out_of_contact_s": float(lost.sum() * dt),
    }


def dominant_frequency(t, y):
    """Frequency (Hz) of the main oscillation of ``y``, from its mean-crossings.

    Counts sign changes of y - mean(y) with linear interpolation of each
    crossing time; exact for a clean sinusoid sampled well above Nyquist.
    """
    t, y = np.asarray(t, float), np.asarray(y, float)
    z = y - y.mean()
    idx = np.nonzero(np.signbit(z[:-1]) != np.signbit(z[1:]))[0]
    if idx.size < 3:
        return None
    tc = t[idx] - z[idx] * (t[idx + 1] - t[idx]) / (z[idx + 1] - z[idx])
    return float((idx.size - 1) / (2.0 * (tc[-1] - tc[0])))


def compute(result, signals, config=None):
    """All metrics a diagram's ``signals`` roles allow, as a flat dict.

    ``config`` (the diagram's ``metrics`` section) may hold ``step_time``
    (s, when the force command steps), ``ss_window`` (s at the end of the run
    taken as steady state, default 0.5), ``error_window`` ([t0, t1] for the
    force tracking error), ``filter_cutoff`` (Hz, default 12).
    """
    cfg = dict(config or {})
    t = result.t

    def sig(role):
        v = result[signals[role]]
        return v[:, 0] if v.ndim == 2 else v

    out = {}
    cutoff = float(cfg.get("filter_cutoff", 12.0))
    if "force" in signals and "force_desired" in signals:
        f, fd = sig("force"), sig("force_desired")
        ff = display_filter(t, f, cutoff)
        ss = float(cfg.get("ss_window", 0.5))
        win = (t[-1] - ss, t[-1])
        out["ss_force_error_filtered_N"] = max_abs_error(t, ff, fd, win)
        out["ss_force_error_raw_N"] = max_abs_error(t, f, fd, win)
        out["final_force_filtered_N"] = float(np.mean(ff[t >= win[0]]))
        if "step_time" in cfg:
            ts = float(cfg["step_time"])
            before = fd[t < ts]
            y0 = float(before[-1]) if before.size else float(fd[0])
            step = step_response(t, ff, ts, y0, float(fd[-1]))
            out["rise_time_s"] = step["rise_time_s"]
            out["overshoot_pct"] = step["overshoot_pct"]
        if "error_window" in cfg:
            w = [float(v) for v in cfg["error_window"]]
            out["force_error_max_filtered_N"] = max_abs_error(t, ff, fd, w)
            out["force_error_max_raw_N"] = max_abs_error(t, f, fd, w)
    if "position" in signals and "position_desired" in signals:
        out["max_position_error_m"] = max_abs_error(
            t, sig("position"), sig("position_desired"))
    if "contact" in signals:
        out.update(contact_report(t, sig("contact")))
    if "oscillation" in signals:
        out["oscillation_hz"] = dominant_frequency(t, sig("oscillation"))
    return out
