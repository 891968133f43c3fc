"""Force-control metrics of a run: the numbers the paper quotes, and their phrases.

Force is judged as logged ("raw": it carries the hand's ringing, ~272 Hz in the
paper's plant) and after the display filter ("filtered": a causal 2nd-order
Butterworth low-pass at ``metrics: filter_cutoff``, 12 Hz by default, started in
steady state); each figure's name and phrase say which. Registered with
:func:`hybridsim.analysis.metrics.register`.
"""
import numpy as np

from hybridsim.analysis import metrics as generic
from hybridsim.analysis.metrics import dominant_frequency, lowpass, max_abs_error, step_response
from hybridsim.forcecontrol.settings import DISPLAY_CUTOFF_HZ


def display_filter(t, y, cutoff=DISPLAY_CUTOFF_HZ):
    """The display filter: :func:`~hybridsim.analysis.metrics.lowpass` at ``cutoff`` Hz (default 12)."""
    return lowpass(t, y, cutoff)


def contact_report(t, contact):
    """Was contact lost after it was first made?

    Parameters
    ----------
    t : array
        Log times (s).
    contact : array
        1 in contact, 0 not (above 0.5 counts as contact).

    Returns
    -------
    dict
        ``contact_lost`` (bool; never made counts as lost), ``first_loss_s`` (s or None),
        ``time_out_of_contact_s`` (s, after contact was first made).
    """
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


def compute(t, sig, cfg):
    """The metrics the roles in ``sig`` allow (see :func:`hybridsim.analysis.metrics.register`).

    ``cfg`` (the diagram's ``metrics``) may hold ``step_time`` (s, when the force command
    steps), ``ss_window`` (s at the end of the run taken as steady state, default 0.5),
    ``error_window`` ([t0, t1] for the force tracking error), ``filter_cutoff`` (Hz, default 12).
    """
    out = {}
    if "force" in sig and "force_desired" in sig:
        f, fd = sig["force"], sig["force_desired"]
        ff = display_filter(t, f, float(cfg.get("filter_cutoff", DISPLAY_CUTOFF_HZ)))
        ss = float(cfg.get("ss_window", 0.5))
        win = (t[-1] - ss, t[-1])
        out["ss_force_error_filtered_N"] = max_abs_error(t, ff, fd, win)
        out["ss_force_error_raw_N"] = max_abs_error(t, f, fd, win)
        out["final_force_filtered_N"] = float(np.mean(ff[t >= win[0]]))
        held = np.asarray(fd[t >= win[0]], float)
        # a command that moves inside the window leaves no steady state to judge there
        out["ss_command_held"] = bool(held.size and np.ptp(held) <= 1e-9 * max(1.0, float(np.max(np.abs(held)))))
        if "step_time" in cfg:
            ts = float(cfg["step_time"])
            before = fd[t < ts]
            # a step at or before the first sample: from where the force starts
            y0 = float(before[-1]) if before.size else float(f[0])
            step = step_response(t, ff, ts, y0, float(fd[-1]))
            out["rise_time_s"] = step["rise_time_s"]
            out["overshoot_pct"] = step["overshoot_pct"]
            raw = step_response(t, f, ts, y0, float(fd[-1]))
            out["rise_time_raw_s"] = raw["rise_time_s"]
            out["overshoot_raw_pct"] = raw["overshoot_pct"]
        if "error_window" in cfg:
            w = [float(v) for v in cfg["error_window"]]
            out["force_error_max_filtered_N"] = max_abs_error(t, ff, fd, w)
            out["force_error_max_raw_N"] = max_abs_error(t, f, fd, w)
    if "position" in sig and "position_desired" in sig:
        out["max_position_error_m"] = max_abs_error(t, sig["position"], sig["position_desired"])
    if "contact" in sig:
        out.update(contact_report(t, sig["contact"]))
    if "oscillation" in sig:
        out["oscillation_hz"] = dominant_frequency(t, sig["oscillation"])
    return out


_PHRASES = (("rise_time_s", "rise {:.3f} s"), ("overshoot_pct", "overshoot {:.0f} %"),
            ("ss_force_error_filtered_N", "steady error up to {:.2f} N"),
            ("force_error_max_filtered_N", "max force error {:.2f} N"),
            ("max_position_error_m", "max position error {:.2f} mm"),
            ("oscillation_hz", "oscillation {:.1f} Hz"))
#: the unfiltered counterpart of a filtered figure, shown beside it
_RAW = {"rise_time_s": ("rise_time_raw_s", "{:.3f} s"), "overshoot_pct": ("overshoot_raw_pct", "{:.0f} %")}


def describe(m):
    """Phrases for the terminal: ``["rise 0.120 s filtered (0.110 s raw)", ..., "contact kept"]``; the
    figures of the force are those after the display filter, the raw ones beside them."""
    lost = m.get("contact_lost")
    parts = []
    for key, fmt in _PHRASES:
        v = m.get(key)
        if lost and key in ("rise_time_s", "overshoot_pct"):
            continue  # a bouncing hand has no meaningful step response (metrics.json keeps them)
        if v is None and m.get(_RAW.get(key, ("",))[0]) is None:
            continue
        phrase = fmt.format(v * 1000 if key.endswith("_m") else v) if v is not None else \
            fmt.split(" ")[0] + " not reached"  # the filtered force never got to 90 % of the step
        if key in _RAW:
            raw_key, raw_fmt = _RAW[key]
            raw = m.get(raw_key)
            phrase += " filtered" + ("" if raw is None else f" ({raw_fmt.format(raw)} raw)")
        if key == "ss_force_error_filtered_N" and m.get("ss_command_held") is False:
            phrase += " (the command moves in that window: no steady state to judge)"
        parts.append(phrase)
    if "contact_lost" in m:
        parts.append(f"contact LOST at {m['first_loss_s']:.3f} s (the force metrics then describe "
                     "a bouncing hand, not the force loop)" if lost else "contact kept")
    return parts


generic.register("forcecontrol", compute, describe,
                 headline=("ss_force_error_filtered_N", "overshoot_pct", "contact_lost"))
