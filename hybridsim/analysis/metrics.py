"""Figures of merit of a run, from the signals a diagram names in its ``signals`` section.

The metrics are registered (:func:`register`), the way blocks are: each set
reads the roles it knows from ``signals`` (a dict role -> 1-D array on the log
grid) and the diagram's ``metrics`` settings, and returns a flat dict of numbers;
:func:`compute` runs every set and :func:`describe` turns the numbers into the
phrases ``hybridsim run`` prints. The generic layers register none (a diagram
without roles has none); :mod:`hybridsim.forcecontrol` registers those of force
control.

The signal functions below are the building blocks, on uniformly sampled arrays
(the simulator's log grid): a low-pass filter, a step's rise and overshoot, the
largest error in a window, the frequency of an oscillation.
"""
import functools
from dataclasses import dataclass

import numpy as np
from scipy import signal as _sig


@dataclass(frozen=True)
class MetricSet:
    """Metrics computed together: ``compute(t, signals, config) -> dict`` and ``describe(metrics) -> [phrase]``."""

    name: str
    compute: object
    describe: object = None
    headline: tuple = ()


METRIC_SETS = []


def register(name, compute, describe=None, headline=()):
    """Add a set of metrics that every run computes.

    Parameters
    ----------
    name : str
        A short name (a second registration under the same name replaces the first).
    compute : callable
        ``compute(t, signals, config) -> dict``: ``t`` the log times (s), ``signals`` the diagram's
        roles as ``{role: 1-D array}``, ``config`` its ``metrics`` settings. It returns ``{}`` when the
        roles it needs are not there.
    describe : callable, optional
        ``describe(metrics) -> list of str``: phrases for the terminal ("rise 0.120 s") from the
        metrics of a run (all sets' together).
    headline : tuple of str, optional
        The metrics a sweep's heat map shows first.
    """
    METRIC_SETS[:] = [m for m in METRIC_SETS if m.name != name] + [MetricSet(name, compute, describe,
                                                                            tuple(headline))]


def headline():
    """The registered sets' headline metrics, in registration order (what a sweep's heat map shows)."""
    return [h for m in METRIC_SETS for h in m.headline]


def compute(result, signals, config=None):
    """All metrics the registered sets can compute from a run, as a flat dict.

    Parameters
    ----------
    result : hybridsim.engine.result.Result
        The run.
    signals : dict
        The diagram's roles: ``{role: "block.port[i]"}`` (its ``signals`` section).
    config : dict, optional
        The diagram's ``metrics`` settings.

    Returns
    -------
    dict
        ``{metric name: number, bool or None}``.
    """
    cfg = dict(config or {})
    if len(result.t) and signals:
        cfg, notes = within_run(cfg, float(result.t[-1]), result.t)
        result.meta["metric_notes"] = notes
    arrays = {}
    for role, ref in signals.items():
        v = result[ref]
        arrays[role] = v[:, 0] if v.ndim == 2 else v
    out = {}
    for m in METRIC_SETS:
        out.update(m.compute(result.t, arrays, cfg))
    return out


def within_run(cfg, t_end, times=None):
    """``(cfg, notes)``: the metrics settings with the times the run does not reach (the ``in_run`` rows of
    the ``metrics`` table) taken out, a span longer than the run cut to it, and a note for each (not for a
    default: a default span longer than a short run is the whole run, as the table says)."""
    from hybridsim.format import tables

    cfg, notes = dict(cfg), []
    for key, why in tables.outside_run(tables.METRICS, cfg, t_end, times):
        row = next(r for r in tables.METRICS if r.key == key)
        if cfg[key] == row.default:
            continue
        if row.in_run == "span":
            cfg[key] = t_end
            notes.append(f"metrics {key}: {why}; the whole run is taken")
        else:
            del cfg[key]
            notes.append(f"metrics {key}: {why}; the metrics that need it are left out")
    cut = cfg.get("filter_cutoff")
    dt = float(np.median(np.diff(times))) if times is not None and len(times) > 2 else None
    if cut is not None and dt and 2.0 * cut * dt > 0.99:
        notes.append(f"metrics filter_cutoff: {cut:g} Hz is at or above 0.99 of the log's Nyquist frequency "
                     f"({0.5 / dt:g} Hz); the filter passes up to {0.99 * 0.5 / dt:g} Hz")
    elif cut is not None and cut * t_end < 1e-3:
        notes.append(f"metrics filter_cutoff: {cut:g} Hz is a time constant far longer than the run "
                     f"({t_end:g} s); the filtered signal stays at its first value")
    return cfg, notes


def describe(metrics):
    """The phrases of the registered sets for one run's ``metrics`` (see :func:`register`)."""
    return [p for m in METRIC_SETS if m.describe is not None for p in m.describe(metrics)]


@functools.lru_cache(maxsize=64)
def _butter2(wn):
    """Coefficients and unit initial state of the 2nd-order Butterworth low-pass (sweeps reuse them)."""
    b, a = _sig.butter(2, wn)
    return b, a, _sig.lfilter_zi(b, a)


def lowpass(t, y, cutoff):
    """Causal 2nd-order Butterworth low-pass of ``y`` at ``cutoff`` Hz, started in steady state at ``y[0]``.

    Parameters
    ----------
    t : array
        Uniform sample times (s); fewer than 3 leave ``y`` as it is.
    y : array
        The samples.
    cutoff : float
        Cutoff frequency (Hz); at or above Nyquist the filter passes up to 0.99 of Nyquist.
    """
    y = np.asarray(y, float)
    if len(t) < 3:
        return y.copy()
    dt = float(np.median(np.diff(t)))
    wn = min(0.99, 2.0 * cutoff * dt)  # normalised to Nyquist
    if wn * len(y) < 1e-6:  # its poles round to 1 (scipy's design is singular); started in steady
        return np.full_like(y, y[0])  # state it moves by about (wn n)^2 of a change: nothing
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
