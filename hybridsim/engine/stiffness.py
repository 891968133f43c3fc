"""Is a fixed step stable on the system's fastest modes? Checked before a fixed-step run.

An explicit Runge-Kutta step multiplies a mode ``exp(lam t)`` by ``R(h lam)``,
the method's stability function (from its Butcher tableau), instead of
``exp(h lam)``. Where ``|R(h lam)|`` is well above both 1 and ``|exp(h lam)|``
the run diverges or, when events chop its steps (an integrator that enters
and leaves a limit at every step), goes on with a meaningless answer.
:func:`check_step` linearizes the right-hand side at the initial state and
refuses such a step, naming the mode, the block whose states carry it and the
longest step that would do.

The Jacobian is taken by forward and by backward differences, each at two
step sizes: an entry on which the step sizes disagree (a jump such as
``sgn(v)`` at ``v = 0``, which differences would read as an enormous
stiffness) is left out, and where the two sides differ (a kink: a lookup's
breakpoint, a contact about to open) both are judged. The check sees the initial state only; a mode that
becomes fast later (contact made) is caught, if it diverges, by ``max_state``.
"""
import numpy as np

from hybridsim.errors import SimulationError

#: a step counts as unstable on a mode when it grows the mode by more than this factor over
#: what the exact solution does in one step (and over 1)
GROWTH = 1.05


def stability_function(A, b, z):
    """``R(z) = 1 + z b^T (I - z A)^-1 1`` of an explicit Runge-Kutta tableau (``A`` the rows of its
    strictly lower triangle), for each complex ``z``."""
    s = len(b)
    M = np.zeros((s, s))
    for i, row in enumerate(A):
        M[i, :len(row)] = row
    z = np.atleast_1d(np.asarray(z, complex))
    out = np.empty(z.shape, complex)
    for k, zk in enumerate(z):
        k_stages = np.linalg.solve(np.eye(s) - zk * M, np.ones(s))
        out[k] = 1.0 + zk * np.dot(b, k_stages)
    return out


def _unstable(A, b, h, lam):
    """True where a step ``h`` grows the modes ``lam`` by more than GROWTH over the exact step."""
    r = np.abs(stability_function(A, b, h * lam))
    with np.errstate(over="ignore"):
        exact = np.exp(np.minimum(h * lam.real, 700.0))
    return r > GROWTH * np.maximum(1.0, exact)


def longest_stable_step(A, b, h, lam):
    """The longest step up to ``h`` on which the mode ``lam`` is not unstable (bisection; 2 % close)."""
    lo, hi = 0.0, h
    while hi - lo > 0.02 * hi:
        mid = 0.5 * (lo + hi)
        if _unstable(A, b, mid, np.array([lam]))[0]:
            hi = mid
        else:
            lo = mid
    return lo


def one_sided_jacobians(f, t, x):
    """``(J+, J-)``: the Jacobians of ``f(t, x)`` from forward and from backward differences, each at two
    step sizes; an entry on which the two disagree (a jump, such as ``sgn(v)`` at ``v = 0``, where a
    difference grows as the step shrinks) is 0. The two sides differ at a kink (a lookup's breakpoint,
    a contact about to open): the motion may go either way, so both are judged."""
    n = x.size
    f0 = f(t, x)
    sides = []
    for sign in (1.0, -1.0):
        J = np.zeros((2, n, n))
        for j in range(n):
            for k, scale in enumerate((1e-7, 1e-6)):
                d = sign * scale * max(1.0, abs(x[j]))
                e = np.zeros(n)
                e[j] = d
                J[k, :, j] = (f(t, x + e) - f0) / d
        fine, coarse = J
        same = np.abs(fine - coarse) <= 1e-2 * np.maximum(np.abs(fine), np.abs(coarse)) + 1e-6
        sides.append(np.where(same & np.isfinite(fine), fine, 0.0))
    return sides[0], sides[1]


def participation(vec, k):
    """How much each state takes part in mode ``k`` of the eigenvectors ``vec``: ``|w_i v_i|``, the left
    times the right eigenvector (a fast lag feeding an integrator moves the integrator's state too, but
    the integrator takes no part in the lag's mode); the right eigenvector alone where ``vec`` is singular."""
    try:
        left = np.linalg.inv(vec)[k]
    except np.linalg.LinAlgError:
        return np.abs(vec[:, k])
    return np.abs(left * vec[:, k])


def check_step(method, f, t, x, owner):
    """Raise :class:`SimulationError` when the fixed step of ``method`` (an ExplicitRK) is unstable on
    a mode of ``f`` linearized at ``(t, x)``; ``owner(k)`` names state ``k`` (its block and index).
    A right-hand side that raises at a perturbed state is not judged."""
    x = np.asarray(x, float)
    if not x.size or not np.isfinite(x).all():
        return
    try:
        with np.errstate(all="ignore"):
            sides = one_sided_jacobians(f, t, x)
    except Exception:  # noqa: BLE001 - a block that refuses a perturbed state: the run itself will say
        return
    worst = None
    for J in sides:
        if not np.isfinite(J).all():
            continue
        lam, vec = np.linalg.eig(J)
        bad = np.flatnonzero(_unstable(method.A, method.b, method.step, lam))
        if bad.size:
            k = bad[np.argmax(np.abs(lam[bad]))]
            if worst is None or abs(lam[k]) > abs(worst[0]):
                worst = (lam[k], int(np.argmax(participation(vec, k))))
    if worst is None:
        return
    mode, state = worst
    longest = longest_stable_step(method.A, method.b, method.step, mode)
    growth = abs(stability_function(method.A, method.b, method.step * mode)[0])
    text = f"{mode.real:.4g}" if abs(mode.imag) < 1e-9 * abs(mode) else f"{mode:.4g}"
    raise SimulationError(
        f"the step {method.step:g} s is too long for {method.name} on a mode of this system: "
        f"lambda = {text} 1/s at t = {t:g} s, mostly {owner(state)}. Each step multiplies "
        f"it by {growth:.3g}, so the run would diverge or, with events cutting the steps short, give a "
        f"meaningless answer. Use simulation.step <= {0.98 * longest:.2g} s, or a stiff solver (radau, bdf, cvode)")
