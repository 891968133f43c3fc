"""CVODE (SUNDIALS' variable-order BDF) for the continuous states, through scikit-sundae.

:class:`CVode` has the interface of :class:`~hybridsim.engine.solvers.ScipySolver`
(``advance`` and ``advance_to_event``), so it runs wherever a scipy solver
does: the generic path and Model Exchange FMUs. Between two stops (sample
hits, events) one CVODE integration runs:

* log times inside the interval come from CVODE's own interpolant (its
  ``CV_NORMAL`` output, never a step landed on purpose), so logging does not
  change the steps taken;
* zero crossings are found by CVODE's root finding (Hairer-style Illinois
  iteration to a few units of round-off in t); a crossing of an event with an
  action returns to the caller (the actions run and CVODE restarts there, at
  order 1), a crossing without one restarts CVODE in place, so a switch is
  never stepped across;
* ``tstop`` is the next stop: CVODE never integrates past a sample hit, where
  the held inputs change.

Its Newton iteration uses a dense finite-difference Jacobian, which suits the
stiff contact and friction laws and an FMU that gives no Jacobian; one call of
the right-hand side per Newton iteration rather than per stage is why it is
the solver to use for Model Exchange FMUs.
"""
import contextlib
import io
import re
import sys

import numpy as np

from hybridsim.errors import SimulationError
from hybridsim.engine.events import MAX_REPEATS

#: internal steps CVODE may take between two requested outputs
MAX_STEPS = 1_000_000
#: restarts at switches without actions within one interval (more: the switch chatters)
MAX_RESTARTS = 10_000


class CVode:
    """SUNDIALS CVODE with restarts at sample hits and at zero crossings.

    Parameters
    ----------
    rtol : float
        Relative tolerance.
    atol : float or array_like
        Absolute tolerance, one for every state or one per state (in the
        states' units).
    max_step : float
        Longest internal step in s (inf: no limit).
    method : {"BDF", "Adams"}
        BDF (orders 1-5) for stiff systems, Adams-Moulton for smooth ones.
    """

    def __init__(self, rtol=1e-8, atol=1e-10, max_step=np.inf, method="BDF"):
        try:
            import sksundae  # noqa: F401
        except ImportError:  # pragma: no cover - a core dependency
            raise ImportError("solver cvode needs scikit-sundae: pip install scikit-sundae") from None
        if method not in ("BDF", "Adams"):
            raise ValueError(f"CVODE method must be 'BDF' or 'Adams', got {method!r}")
        self.rtol, self.atol, self.max_step, self.method = float(rtol), atol, float(max_step), method
        self.name = "cvode"

    #: the core takes the points CVODE returns (log times, crossings, the stop) as its steps
    returns_points = True

    def advance(self, f, t0, t1, x, t_out=(), events=None, check=None):
        """Integrate from ``t0`` to ``t1`` restarting at every zero crossing of ``events``;
        returns ``(x, states at t_out)``."""
        return self.advance_to_event(f, t0, t1, x, t_out, None, None, events=events, check=check)[1::2]

    def advance_to_event(self, f, t0, t1, x, t_out, g, directions, events=None, check=None, step=None):
        """Like :meth:`advance`, stopping at the first crossing of ``g`` (in ``directions``).

        Returns ``(t_stop, x_stop, fired, outs)`` as
        :meth:`~hybridsim.engine.solvers.ScipySolver.advance_to_event`: ``fired`` (a
        mask over the functions of ``g``) is None when ``t_stop`` is ``t1``.
        ``events`` (zero crossings without actions) restart CVODE without stopping;
        one that fires more than ``MAX_REPEATS`` times in the interval is stepped
        over for the rest of it (a solution sliding along the switch). ``check(t, x)``
        (the divergence check) sees the state at every point CVODE returns: log times,
        zero crossings and ``t1``, in order, before an error raised after them; so does
        ``step(t, x)`` when given, after ``check`` (True: a step event there, returned with
        ``fired`` a mask of no functions). CVODE's internal steps are not seen: ``step`` is
        called at the points it returns, not after each of its steps.
        """
        from sksundae.cvode import CVODE

        x = np.array(x, float)
        pending = sorted(float(tb) for tb in t_out)
        outs = []
        while pending and pending[0] <= t0:  # a log time at the start (after an event)
            pending.pop(0)
            outs.append(x.copy())
        n_a = len(directions) if g is not None else 0
        n_r = np.atleast_1d(events(t0, x)).size if events is not None else 0
        muted = np.zeros(n_r, dtype=bool)
        failed = []  # the exception a callback raised: CVODE then fails fast on NaN, the points
        # before it are checked in order, and the exception is raised after them

        def rhs(t, y, yp):
            if failed:
                yp.fill(np.nan)
                return
            try:
                np.copyto(yp, f(t, y))
            except Exception as exc:  # noqa: BLE001 - raised again after CVODE returns
                failed.append(exc)
                yp.fill(np.nan)

        def roots(t, y, out):
            if failed:
                out.fill(np.nan)
                return
            try:
                if not n_r:
                    np.copyto(out, g(t, y))
                    return
                if n_a:
                    out[:n_a] = g(t, y)
                out[n_a:] = np.where(muted, 1.0, events(t, y))
            except Exception as exc:  # noqa: BLE001 - as in rhs
                failed.append(exc)
                out.fill(np.nan)

        roots.terminal = [True] * (n_a + n_r)
        roots.direction = [int(d) for d in (directions if n_a else ())] + [0] * n_r
        opts = dict(method=self.method, rtol=self.rtol, atol=self.atol, max_num_steps=MAX_STEPS,
                    max_step=0.0 if not np.isfinite(self.max_step) else self.max_step)
        if n_a + n_r:
            opts.update(eventsfn=roots, num_events=n_a + n_r)
        cv = CVODE(rhs, **opts)
        hits = np.zeros(n_r, dtype=int)
        t, y = t0, x
        for _ in range(MAX_RESTARTS):  # one segment each: from (t, y) to t1 or a crossing
            if step is None and pending and pending[-1] < t1 and _increasing(pending):
                t, y, res = self._solve(cv, t, y, pending, t1, outs, check, failed)
                asked = False
            else:
                t, y, res, asked = self._steps(cv, t, y, pending, t1, outs, check, step, failed)
            if res.status != 2:  # t1, or a step event (asked) before it
                return (t, y, np.zeros(n_a, dtype=bool), outs) if asked else (t1, y, None, outs)
            which = np.asarray(res.i_events, float).reshape(-1, n_a + n_r)[-1] != 0
            while pending and pending[0] <= t:
                pending.pop(0)
                outs.append(y.copy())
            if which[:n_a].any() or asked:
                return t, y, which[:n_a].copy(), outs
            hits += which[n_a:]
            muted |= hits > MAX_REPEATS  # then restart at the switch, at order 1
        raise SimulationError(f"more than {MAX_RESTARTS} zero crossings before t={t1:.6g} s "
                              "(a switch is chattering)")

    def _solve(self, cv, t, y, pending, t1, outs, check, failed):
        """One segment through every log time in one CVODE call (no Python between them).

        Returns ``(t, y, result)`` at ``t1`` or at a crossing; the log times passed are
        moved from ``pending`` to ``outs``, each state seen by ``check`` first.
        """
        with _Words() as words:
            res = cv.solve(np.array([t, *pending, t1]), y)
        ts, ys = res.t, res.y
        last = len(ts) - 1  # rows 1 .. last-1: log times; row last: t1, a crossing or a failure
        end = last + (res.status >= 0 and not failed)
        ok = getattr(check, "ok", None)  # the engine's check without raising, on all rows at once
        if check is not None and not (ok is not None and end > 1 and ok(ys[1:end])):
            for k in range(1, end):
                check(float(ts[k]), ys[k])
        self._raise(res, t, failed, words.said)
        outs.extend(ys[1:last])
        del pending[:last - 1]
        return (float(ts[last]) if res.status == 2 else t1), ys[last].copy(), res

    def _steps(self, cv, t, y, pending, t1, outs, check, step, failed):
        """One segment one log time at a time, with ``step`` after each; returns
        ``(t, y, result, asked)`` at ``t1``, a crossing or a step event (``asked``)."""
        with _Words() as words:
            res = cv.init_step(t, y)
        self._raise(res, t, failed, words.said)
        while True:
            with _Words() as words:
                res = cv.step(pending[0] if pending else t1, tstop=t1)
            self._raise(res, t, failed, words.said)
            t, y = float(res.t), res.y
            if check is not None:
                check(t, y)
            asked = step is not None and bool(step(t, y))
            if res.status == 2 or asked:  # a log time here is logged after the step event
                return t, y, res, asked
            if pending and t >= pending[0]:
                pending.pop(0)
                outs.append(y)
            if t >= t1 or (not pending and res.status == 1):
                return t1, y, res, False

    @staticmethod
    def _raise(res, t, failed, said=""):
        """The exception a callback raised; else a :class:`SimulationError` for a failed CVODE
        call (``t``: where it started; ``said``: SUNDIALS' own words)."""
        if failed:
            raise failed[0]
        if res.status < 0:
            raise SimulationError(f"solver cvode failed after t={t:.6g} s: {res.message}"
                                  + (f" (SUNDIALS: {said})" if said else ""))

    def stepper(self):
        """CVODE for the stepping core (:mod:`hybridsim.engine.cvode_stepper`)."""
        from hybridsim.engine.cvode_stepper import CVodeStepper, cvode_ops

        return cvode_ops(), CVodeStepper(self)

    def __repr__(self):
        return f"CVode({self.method}, rtol={self.rtol:g})"


def _increasing(times):
    """True when ``times`` increase strictly (what one scikit-sundae ``solve`` call takes)."""
    return len(times) < 2 or bool(np.all(np.diff(times) > 0))


_SAYS = re.compile(r"\n\[(\w+), Error: (-?\d+)\] (.*?)\n\n", re.S)


class _Words(contextlib.redirect_stdout):
    """Around a scikit-sundae call: SUNDIALS' error messages (which it prints) go into
    ``said`` instead of the standard output; anything else printed there is passed on."""

    def __init__(self):
        super().__init__(io.StringIO())
        self.said = ""

    def __enter__(self):
        super().__enter__()
        return self

    def __exit__(self, *exc):
        super().__exit__(*exc)
        text = self._new_target.getvalue()
        if text:
            self.said = "; ".join(m.group(3).strip() for m in _SAYS.finditer(text))
            rest = _SAYS.sub("", text)
            if rest:
                sys.stdout.write(rest)
        return False
