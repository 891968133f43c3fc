"""What a point measures: its runs' metrics, step responses and the linearized loop.

:func:`measure` runs one point (every variant of the tune file, and every
variant of the diagram) through the public API (:func:`hybridsim.runs.variants.run_experiment`,
:func:`hybridsim.analysis.stability.linearization` and :func:`hybridsim.analysis.margins.margins`)
and reduces each quantity to one number over the runs. It never raises for a
run that diverges (the point is "failed", with the message); a quantity that
cannot be measured at all (an unknown metric or signal) is a :class:`SpecError`.
"""
import math
import time

import numpy as np

from hybridsim.errors import HybridsimError, LoaderError
from hybridsim.tune.space import overrides as param_overrides
from hybridsim.tune.spec import STEP_MEASURES


class SpecError(LoaderError):
    """A quantity of the tune file that no run can measure (exit status 2)."""


def _number(v):
    if v is None:
        return math.nan
    if isinstance(v, (bool, np.bool_)):
        return float(v)
    return float(v)


def step_measure(t, y, q, reference=None):
    """One measure of the step response ``y(t)`` from :func:`control.step_info`.

    Parameters
    ----------
    t, y : array
        Time (s) and the response, from the run's log.
    q : Quantity
        ``metric`` (a key of :data:`~hybridsim.tune.spec.STEP_MEASURES`), ``after`` (s, when the
        step is applied), ``final`` (the value it should settle to; else the ``reference`` signal's
        last value, else the response's own), ``settling`` (band, fraction of the step; default 0.02).
    reference : array, optional
        The reference signal's samples.
    """
    import control

    t, y = np.asarray(t, float), np.asarray(y, float)
    if y.ndim == 2:
        y = y[:, 0]
    keep = t >= q.after
    t, y = t[keep] - q.after, y[keep]
    final = q.final if q.final is not None else (float(np.ravel(reference)[-1]) if reference is not None else None)
    if t.size < 3 or not np.all(np.isfinite(y)):
        return math.nan
    kw = {"SettlingTimeThreshold": float(q.settling or 0.02)}
    if final is not None:
        kw["yfinal"] = float(final)
    if q.metric == "steady_error":
        return abs(float(y[-1]) - (float(final) if final is not None else float(y[-1])))
    try:
        info = control.step_info(y, T=t, **kw)
    except IndexError:  # the response never reaches 90 % of the step: no rise, never settled
        from hybridsim.analysis.metrics import step_response

        yf = float(final) if final is not None else float(y[-1])
        info = {"RiseTime": None, "SettlingTime": math.nan, "Peak": float(np.max(np.abs(y))),
                "PeakTime": float(t[np.argmax(np.abs(y))]), "SteadyStateValue": yf, "Undershoot": math.nan,
                "Overshoot": step_response(t, y, 0.0, float(y[0]), yf)["overshoot_pct"]}
    if q.metric == "settling_time_s" and not np.isfinite(info["SettlingTime"]):
        return float(t[-1])  # not settled within the run: its length, a lower bound
    return _number(info[STEP_MEASURES[q.metric]])


def _run_values(spec, f_runs, quantities):
    out = {q.name: [] for q in quantities}
    for r in f_runs:
        res = r["result"]
        for q in quantities:
            if q.source == "metric":
                if q.metric not in r["metrics"]:
                    raise SpecError(f"metric {q.metric!r}: the runs measure "
                                    f"{', '.join(sorted(k for k in r['metrics'] if k != 'wall_time_s'))} "
                                    "(the diagram's signals and metrics sections say which)", spec.path, q.line)
                out[q.name].append(_number(r["metrics"][q.metric]))
            else:
                try:
                    y = res[q.signal]
                    ref = res[q.reference] if q.reference else None
                except (KeyError, ValueError, IndexError) as exc:
                    raise SpecError(f"signal {exc}: not logged by the diagram (add it to its 'log')",
                                    spec.path, q.line) from None
                out[q.name].append(step_measure(res.t, y, q, ref))
    return out


def _analysis_values(spec, ov, quantities):
    from hybridsim.analysis.stability import margins, settings_of
    from hybridsim.runs.experiment import Experiment
    from hybridsim.format.build import load
    from hybridsim.analysis.linearize import LinearizationError

    f = load(spec.diagram, **ov)
    cfg = settings_of(f)
    out = {q.name: [] for q in quantities}
    for _, variant in f.variants():
        try:
            # the point's values over the analysis section's set, as a layer of their own
            lin = Experiment.layered(spec.diagram, [cfg["set"], {**ov, **variant}]).linearization(at=cfg["at"])
            growth = lin.closed_loop().growth
        except LinearizationError:
            lin, growth = None, math.nan
        loops = {}
        for q in quantities:
            if q.analysis == "largest_abs_z":
                out[q.name].append(_number(growth))
                continue
            if lin is None:
                out[q.name].append(math.nan)
                continue
            if q.loop not in loops:
                sig = cfg["points"].get(q.loop, q.loop)
                try:
                    loops[q.loop] = margins(lin.loop(sig))
                except LinearizationError as exc:
                    raise SpecError(f"loop {q.loop!r}: {exc}", spec.path, q.line) from None
            m = loops[q.loop]
            v = m[q.analysis]  # margins() names its results as the tune file does
            if q.analysis.endswith(("_db", "_deg")) and not m["closed_loop_stable"]:
                v = -math.inf  # a margin of a loop that closes unstable: none to speak of
            # no crossing: an infinite margin (none at all), no crossover frequency
            out[q.name].append(math.inf if v is None and q.analysis.endswith(("_db", "_deg")) else _number(v))
    return out


def reduce(q, values):
    """A quantity's values over the runs, reduced (worst case by default); NaN if any run has none."""
    vals = np.asarray(values, float)
    if vals.size == 0 or np.any(np.isnan(vals)):
        return math.nan
    return float({"max": np.max, "min": np.min, "mean": np.mean}[q.reduce](vals))


def measure(spec, values=None):
    """Run one point and measure every objective and constraint.

    Parameters
    ----------
    spec : TuneSpec
    values : dict, optional
        ``{parameter path: value}``; None runs the diagram as it is (with ``set``).

    Returns
    -------
    dict
        ``status`` ("ok" or "failed"), ``message``, ``quantities`` ({name: number, NaN where a run
        gave none}), ``wall_s``.
    """
    from hybridsim.runs.variants import run_experiment

    t0 = time.perf_counter()
    ov = dict(spec.fixed)
    if values:
        ov.update(param_overrides(spec.parameters, values))
    every = spec.objectives + spec.constraints
    runq = [q for q in every if q.source != "analysis"]
    anq = [q for q in every if q.source == "analysis"]
    collected = {q.name: [] for q in every}
    try:
        for variant in spec.variants:
            point = {**ov, **variant}
            if runq:
                _, runs, _ = run_experiment(spec.diagram, jobs=1, **point)
                for k, v in _run_values(spec, runs, runq).items():
                    collected[k] += v
            if anq:
                for k, v in _analysis_values(spec, point, anq).items():
                    collected[k] += v
    except SpecError:
        raise
    except HybridsimError as exc:
        return {"status": "failed", "message": str(exc).splitlines()[0], "quantities": {},
                "wall_s": time.perf_counter() - t0}
    q = {qq.name: reduce(qq, collected[qq.name]) for qq in every}
    return {"status": "ok", "message": "", "quantities": q, "wall_s": time.perf_counter() - t0}
