"""Where a crossing lies inside a step: the stepping core's event location, written once.

The located event functions are compared at the step's end and at scan points of its dense output;
the first sign change is bisected to ``time_tol``. Where the stepper takes fresh steps (a fixed-step
one), the state at the event is one whose every stage lies before the crossing (:func:`across`).
Numba compiles these with :mod:`hybridsim.engine.stepping`, as one module
(:mod:`hybridsim.engine.native`); the same subset of Python.
"""
import math


def crossed_any(a, b, dirs, fired):
    """Mark in ``fired`` the functions that crossed zero from ``a`` to ``b`` in their
    direction (rising: from <= 0 to > 0, falling: from >= 0 to < 0); True when any did."""
    hit = False
    for i in range(a.size):
        d = dirs[i]
        f = (d >= 0 and a[i] <= 0.0 and b[i] > 0.0) or (d <= 0 and a[i] >= 0.0 and b[i] < 0.0)
        fired[i] = f
        hit = hit or f
    return hit


def first_sign_change(a, b, dirs):
    """The first function that went from ``a`` to ``b`` across zero; -1 if none. A directed
    function counts when it ends on its firing side from the other side or from (numerically)
    zero, where piled-up events leave it; one without a direction (an FMU's indicator) only from
    a start clearly off zero (it sits at zero just after its own event)."""
    for i in range(a.size):
        d, near = dirs[i], abs(a[i]) <= 1e-9 * abs(b[i])
        if d > 0 and b[i] > 0.0 and (a[i] <= 0.0 or near) or d < 0 and b[i] < 0.0 and (a[i] >= 0.0 or near):
            return i
        if d == 0 and a[i] * b[i] < 0.0 and not near:
            return i
    return -1


def copy_into(dst, src):
    dst[:] = src


def mute(g, muted):
    for i in range(g.size):
        if muted[i]:
            g[i] = 1.0  # a muted switch reads +1: it never fires


def locate(ta, tb, gl, ops, s, lim, w, y, z, pf, pi):
    """The first crossing of the event functions inside the step [ta, tb] (``w.g`` at ta, ``w.gn``
    at tb): checked at scan points of the dense output, bisected to ``time_tol``. Returns
    ``(found, t_event)``; when found, ``w.xe`` holds the state there and ``w.fired`` the functions
    that crossed; else ``w.g`` takes ``w.gn``.

    Where the stepper takes fresh steps (a fixed-step one), the state at the event is one whose
    every stage lies before the crossing (:func:`across`): a step's stages past a jump there (of an
    input in time, or of the right-hand side at a switch's surface) bend its dense output and its
    own end to first order."""
    h = tb - ta
    m = max(1, int(math.ceil(h / lim.scan - 1e-9)))
    copy_into(w.glo, w.g)
    lo = 0.0
    for p in range(1, m + 1):
        if p < m:
            hi = p / m
            ops.dense(s, ta + hi * h, w.x, w, w.xm)
            gl.zc(ta + hi * h, w.xm, w.ghi, y, z, pf, pi)
            mute(w.ghi, w.muted)
        else:
            hi = 1.0
            copy_into(w.ghi, w.gn)
            copy_into(w.xm, w.xn)
        if crossed_any(w.glo, w.ghi, w.dirs, w.fired):
            copy_into(w.xe, w.xm)
            lo, hi = bisect(ta, h, lo, hi, False, gl, ops, s, lim, w, y, z, pf, pi)
            if lo > 0.0 and ops.restep(s, lo * h, w.x, w, gl, y, z, pf, pi, w.xm):
                gl.zc(ta + lo * h, w.xm, w.gm, y, z, pf, pi)
                mute(w.gm, w.muted)
                if crossed_any(w.g, w.gm, w.dirs, w.fired):  # fresh steps crossed before lo: the
                    copy_into(w.xe, w.xm)  # dense output, bent past a jump, crossed late
                    copy_into(w.ghi, w.gm)
                    return fresh_crossing(ta, tb, 0.0, lo, gl, ops, s, lim, w, y, z, pf, pi)
            early = across(ta, h, lo, hi, gl, ops, s, w, y, z, pf, pi)
            # a fresh step to the crossing (the method's own order) when it is past the surface too
            if not early and hi < 1.0 and ops.restep(s, hi * h, w.x, w, gl, y, z, pf, pi, w.xm):
                gl.zc(ta + hi * h, w.xm, w.gm, y, z, pf, pi)
                mute(w.gm, w.muted)
                if crossed_any(w.glo, w.gm, w.dirs, w.fired):
                    copy_into(w.xe, w.xm)
                    early = True
                elif unmoved(w.g, w.gm, w.glo, w.ghi, w.dirs):
                    # the dense output crossed where a fresh step has not even moved (a stage past a
                    # jump in time, a source's step at the step's end, bent it): the crossing is
                    # where fresh steps cross, after hi. One that a fresh step merely places later
                    # keeps the dense output's: a fresh step past a jump of the right-hand side at
                    # the surface is bent too, as often back across it (a PID leaving its clamp)
                    if not crossed_any(w.g, w.gn, w.dirs, w.fired):
                        copy_into(w.g, w.gn)
                        return False, tb
                    copy_into(w.xe, w.xn)
                    copy_into(w.ghi, w.gn)
                    return fresh_crossing(ta, tb, hi, 1.0, gl, ops, s, lim, w, y, z, pf, pi)
            if not early:  # the dense output's state and functions, then
                crossed_any(w.glo, w.ghi, w.dirs, w.fired)
            # (else fired holds the functions crossed at the state acted on: one that crossed on the
            # dense output only, a state's crossing a hair after a switch's, fires on its own later)
            return True, (ta + hi * h if hi < 1.0 else tb)
        copy_into(w.glo, w.ghi)
        lo = hi
    copy_into(w.g, w.gn)
    return False, tb


def across(ta, h, lo, hi, gl, ops, s, w, y, z, pf, pi):
    """Whether a fresh step to ``ta + lo h`` (every stage before the crossing), carried on to
    ``ta + hi h`` along its mean slope (hi - lo is a thousandth of time_tol), shows the crossing
    from ``w.glo``: then ``w.xe`` holds that state and ``w.fired`` the functions."""
    if not (lo > 0.0 and ops.restep(s, lo * h, w.x, w, gl, y, z, pf, pi, w.xm)):
        return False
    nudge(w.xm, w.x, (hi - lo) / lo)
    gl.zc(ta + hi * h, w.xm, w.gm, y, z, pf, pi)
    mute(w.gm, w.muted)
    if not crossed_any(w.glo, w.gm, w.dirs, w.fired):
        return False
    copy_into(w.xe, w.xm)
    return True


def nudge(x, x0, r):
    """``x`` carried on by ``r`` times its change from ``x0`` (a step's mean slope), in place."""
    for i in range(x.size):
        x[i] += r * (x[i] - x0[i])


def unmoved(ga, gb, glo, ghi, dirs):
    """True when every function that crossed from ``glo`` to ``ghi`` is the same in ``gb`` as in
    ``ga`` (a fresh step from ta did not move it at all)."""
    for i in range(glo.size):
        d = dirs[i]
        if (d >= 0 and glo[i] <= 0.0 and ghi[i] > 0.0) or (d <= 0 and glo[i] >= 0.0 and ghi[i] < 0.0):
            if ga[i] != gb[i]:
                return False
    return True


def fresh_crossing(ta, tb, lo, hi, gl, ops, s, lim, w, y, z, pf, pi):
    """``locate``'s answer from the first crossing of the functions ``w.g`` (at ta) on fresh steps
    from ``ta``, bisected on [ta + lo h, ta + hi h]: none crossed by lo; ``w.ghi`` and ``w.xe``
    hold the crossed functions and the state at hi."""
    h = tb - ta
    copy_into(w.glo, w.g)
    lo, hi = bisect(ta, h, lo, hi, True, gl, ops, s, lim, w, y, z, pf, pi)
    if not across(ta, h, lo, hi, gl, ops, s, w, y, z, pf, pi):  # the bisection's state at hi, then
        crossed_any(w.glo, w.ghi, w.dirs, w.fired)
    return True, (ta + hi * h if hi < 1.0 else tb)


def bisect(ta, h, lo, hi, fresh, gl, ops, s, lim, w, y, z, pf, pi):
    """Bisect [lo, hi] (fractions of the step [ta, ta + h]), where ``w.glo`` (the functions at lo)
    and ``w.ghi`` (at hi) lie on either side of a crossing, on the step's dense output or on fresh
    steps from ta (``fresh``), to a thousandth of time_tol or adjacent times (an event up to
    time_tol late would start the next one that late: a chain of resets would drift by time_tol per
    event). ``w.xe`` is left the state at hi; returns ``(lo, hi)``."""
    while (hi - lo) * h > 1e-3 * lim.time_tol:
        mid = 0.5 * (lo + hi)
        if not ta + lo * h < ta + mid * h < ta + hi * h:
            break
        if fresh:
            ops.restep(s, mid * h, w.x, w, gl, y, z, pf, pi, w.xm)
        else:
            ops.dense(s, ta + mid * h, w.x, w, w.xm)
        gl.zc(ta + mid * h, w.xm, w.gm, y, z, pf, pi)
        mute(w.gm, w.muted)
        if crossed_any(w.glo, w.gm, w.dirs, w.fired):
            hi = mid
            copy_into(w.xe, w.xm)
            copy_into(w.ghi, w.gm)
        else:
            lo = mid
            copy_into(w.glo, w.gm)
    return lo, hi
