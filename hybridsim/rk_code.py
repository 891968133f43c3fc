"""Python source of one explicit Runge-Kutta step, made from its tableau.

Every path takes its integration step from here, so a method is written once
(its tableau in :mod:`hybridsim.solvers`) and every path performs the same
floating-point operations in the same order:

* :func:`vector_functions` - ``step(f, t, h, X)`` and ``dense(X, K, h, w)`` on
  numpy vectors, for the generic path;
* :func:`unrolled_lines` - the same expressions written out element by
  element on tuples of floats (``advance``), for the fused (Python) and
  compiled (numba) paths.

A stage's state is ``X + h * (a1 * k1 + a2 * k2 + ...)`` over the stage's
non-zero coefficients (a coefficient 1 is left out: ``k2`` rather than
``1.0 * k2``); the step's result ``X + h * (b1 * k1 + ...)``; dense output at
``theta`` in [0, 1) of the step ``X + h * (w1 * k1 + ...)`` with the weights
``w = method.dense_weights(theta)`` computed once by the caller.
"""


def _terms(coefs):
    return [(c, j) for j, c in enumerate(coefs) if c != 0.0]


def _sum(terms, k, elem=""):
    return " + ".join((f"{k}{j + 1}{elem}" if c == 1.0 else f"{c!r} * {k}{j + 1}{elem}") for c, j in terms)


def _combo(terms, elem=""):
    if not terms:
        return f"X{elem}"
    return f"X{elem} + h * ({_sum(terms, 'k', elem)})"


def _time(c):
    return "t" if c == 0.0 else ("t + h" if c == 1.0 else f"t + {c!r} * h")


def _dense_terms(method):
    """Stages whose dense-output weight is not identically zero."""
    return [j for j, poly in enumerate(method.dense) if any(p != 0.0 for p in poly)]


def vector_functions(method):
    """``(step, dense)`` for numpy state vectors (the generic path).

    ``step(f, t, h, X)`` returns ``(X_next, K)`` with ``K`` the stage
    derivatives; ``dense(X, K, h, w)`` the state inside the step for weights
    ``w = method.dense_weights(theta)``.
    """
    lines = ["def step(f, t, h, X):"]
    for i, (c, row) in enumerate(zip(method.c, method.A)):
        lines.append(f"    k{i + 1} = f({_time(c)}, {_combo(_terms(row))})")
    ks = ", ".join(f"k{i + 1}" for i in range(len(method.c)))
    lines.append(f"    return {_combo(_terms(method.b))}, ({ks},)")
    used = _dense_terms(method)
    lines += ["", "def dense(X, K, h, w):",
              "    return X + h * (" + " + ".join(f"w[{j}] * K[{j}]" for j in used) + ")"]
    env = {}
    exec(compile("\n".join(lines), f"<{method.name} step>", "exec"), env)  # noqa: S102 - from a tableau
    return env["step"], env["dense"]


def unrolled_lines(method, n, rhs, extra=""):
    """Source lines of ``advance`` on tuples of ``n`` floats.

    ``rhs`` is the name of the right-hand side ``rhs(t, X, H{extra})``.
    ``advance(t0, h, k0, k1, X, H, kobs, w{extra})`` takes steps
    ``k0 .. k1 - 1`` of size ``h`` from ``t0`` (step ``k`` starts at
    ``t0 + k * h``) and returns ``(X_end, X_obs, X_dense)``: the final state,
    and for step ``kobs`` (``-1``: none) the state at its start and at the
    fraction given by the dense-output weights ``w`` inside it. One function
    (one copy of the stages) for plain stepping and for log points.
    """
    def tup(expr):
        return "(" + "".join(expr(f"[{j}]") + ", " for j in range(n)) + ")"

    body = []
    for i, (c, row) in enumerate(zip(method.c, method.A)):
        terms = _terms(row)
        state = "X" if not terms else tup(lambda e, terms=terms: _combo(terms, e))
        body.append(f"k{i + 1} = {rhs}({_time(c)}, {state}, H{extra})")
    final = tup(lambda e: _combo(_terms(method.b), e))
    used = _dense_terms(method)
    dense = tup(lambda e: f"X{e} + h * (" + " + ".join(f"w[{j}] * k{j + 1}{e}" for j in used) + ")")
    lines = [f"def advance(t0, h, k0, k1, X, H, kobs, w{extra}):",
             "    Xs = X",
             "    Xo = X",
             "    for k in range(k0, k1):",
             "        t = t0 + k * h"]
    lines += ["        " + b for b in body]
    lines += ["        if k == kobs:",
              "            Xs = X",
              f"            Xo = {dense}",
              f"        X = {final}",
              "    return X, Xs, Xo"]
    return lines
