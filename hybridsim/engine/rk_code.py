"""Python source of one explicit Runge-Kutta step, made from its tableau.

Every path takes its integration step from here, so a method is written once
(its tableau in :mod:`hybridsim.engine.solvers`) and every path performs the same
floating-point operations in the same order:

* :func:`vector_functions` - ``step(f, t, h, X)`` and ``dense(X, K, h, w)`` on
  numpy vectors, for the generic path;
* :func:`unrolled_lines` - the same expressions written out element by
  element on tuples of floats (``advance``), for the fused (Python) and
  compiled (numba) paths.

A stage's state is ``X + (h_a1 * k1 + h_a2 * k2 + ...)`` over the stage's
non-zero coefficients, each coefficient times ``h`` computed once per call
(``h_0 = 0.5 * h``); the step's result ``X + (h_b1 * k1 + ...)``; dense output at
``theta`` in [0, 1) of the step ``X + h * (w1 * k1 + ...)`` with the weights
``w = method.dense_weights(theta)`` computed once by the caller.
"""


#: the most items one generated tuple display holds: CPython builds a longer one through a
#: list, which numba's bytecode reader does not always take (AssertionError in its peephole)
TUPLE_CHUNK = 30


def tuple_source(items):
    """Source of a tuple of the expressions ``items``: ``(a, b, )``, written as a sum of
    displays of at most :data:`TUPLE_CHUNK` items when longer (the same tuple)."""
    items = list(items)
    if not items:
        return "()"
    chunks = [items[k:k + TUPLE_CHUNK] for k in range(0, len(items), TUPLE_CHUNK)]
    return " + ".join("(" + "".join(f"{x}, " for x in c) + ")" for c in chunks)


def _terms(coefs):
    return [(c, j) for j, c in enumerate(coefs) if c != 0.0]


def _factored(b):
    """``(f, multiples)`` when the weights ``b`` are whole multiples of their smallest, else None
    (RK4: 1/6 x (1, 2, 2, 1): the result is ``X + h_f * (k1 + 2.0 * k2 + 2.0 * k3 + k4)``)."""
    f = min(abs(c) for c in b if c != 0.0)
    multiples = [c / f for c in b]
    if all(abs(m - round(m)) < 1e-12 for m in multiples):
        return f, [float(round(m)) for m in multiples]
    return None


def _scaled(method):
    """``{coefficient: local name}``: each distinct coefficient of the tableau times h, computed
    once per call (``h_0 = 0.5 * h``); 1 is ``h`` itself."""
    fac = _factored(method.b)
    weights = {fac[0]} if fac else set(method.b)
    values = sorted({c for row in method.A for c in row if c not in (0.0, 1.0)}
                    | {c for c in weights if c not in (0.0, 1.0)} | {c for c in method.c if c not in (0.0, 1.0)})
    names = {c: f"h_{k}" for k, c in enumerate(values)}
    names[1.0] = "h"
    return names


def _scaled_lines(method, indent):
    return [f"{indent}{name} = {c!r} * h" for c, name in _scaled(method).items() if name != "h"]


def _combo(method, terms, elem=""):
    if not terms:
        return f"X{elem}"
    names = _scaled(method)
    return f"X{elem} + (" + " + ".join(f"{names[c]} * k{j + 1}{elem}" for c, j in terms) + ")"


def _result(method, elem=""):
    """The step's result, factored when the weights allow it (fewer products per state)."""
    fac = _factored(method.b)
    if fac is None:
        return _combo(method, _terms(method.b), elem)
    f, multiples = fac
    terms = " + ".join(f"k{j + 1}{elem}" if m == 1.0 else f"{m!r} * k{j + 1}{elem}"
                       for j, m in enumerate(multiples) if m != 0.0)
    return f"X{elem} + {_scaled(method)[f]} * ({terms})"


def _time(method, c):
    return "t" if c == 0.0 else f"t + {_scaled(method)[c]}"


def _dense_terms(method):
    """Stages whose dense-output weight is not identically zero."""
    return [j for j, poly in enumerate(method.dense) if any(p != 0.0 for p in poly)]


def vector_functions(method):
    """``(step, dense)`` for numpy state vectors (the generic path).

    ``step(f, t, h, X)`` returns ``(X_next, K)`` with ``K`` the stage
    derivatives; ``dense(X, K, h, w)`` the state inside the step for weights
    ``w = method.dense_weights(theta)``.
    """
    lines = ["def step(f, t, h, X):"] + _scaled_lines(method, "    ")
    for i, (c, row) in enumerate(zip(method.c, method.A)):
        lines.append(f"    k{i + 1} = f({_time(method, c)}, {_combo(method, _terms(row))})")
    ks = ", ".join(f"k{i + 1}" for i in range(len(method.c)))
    lines.append(f"    return {_result(method)}, ({ks},)")
    used = _dense_terms(method)
    lines += ["", "def dense(X, K, h, w):",
              "    return X + h * (" + " + ".join(f"w[{j}] * K[{j}]" for j in used) + ")"]
    env = {}
    exec(compile("\n".join(lines), f"<{method.name} step>", "exec"), env)  # noqa: S102 - from a tableau
    return env["step"], env["dense"]


def unrolled_lines(method, n, rhs, extra=""):
    """Source lines of ``advance`` and ``advance_obs`` on tuples of ``n`` floats.

    ``rhs`` is the name of the right-hand side ``rhs(t, X, H{extra})``.
    ``advance(t0, h, ka, kb, X, H{extra})`` takes steps ``ka .. kb - 1`` of
    size ``h`` from ``t0`` (step ``k`` starts at ``t0 + k * h``) and returns
    the final state; ``advance_obs(t0, h, ka, kb, X, H, kobs, w{extra})``
    takes the same steps and returns ``(X_end, X_obs, X_dense)``: for step
    ``kobs`` also the state at its start and at the fraction given by the
    dense-output weights ``w`` inside it (one call per log point).
    """
    def tup(expr):
        return tuple_source(expr(f"[{j}]") for j in range(n))

    body = []
    for i, (c, row) in enumerate(zip(method.c, method.A)):
        terms = _terms(row)
        state = "X" if not terms else tup(lambda e, terms=terms: _combo(method, terms, e))
        body.append(f"k{i + 1} = {rhs}({_time(method, c)}, {state}, H{extra})")
    final = tup(lambda e: _result(method, e))
    used = _dense_terms(method)
    dense = tup(lambda e: f"X{e} + h * (" + " + ".join(f"w[{j}] * k{j + 1}{e}" for j in used) + ")")
    scaled = _scaled_lines(method, "    ")
    lines = [f"def advance(t0, h, ka, kb, X, H{extra}):"] + scaled + [
             "    for k in range(ka, kb):",
             "        t = t0 + k * h"]
    lines += ["        " + b for b in body]
    lines += [f"        X = {final}", "    return X", ""]
    lines += [f"def advance_obs(t0, h, ka, kb, X, H, kobs, w{extra}):"] + scaled + [
              "    Xs = X",
              "    Xo = X",
              "    for k in range(ka, kb):",
              "        t = t0 + k * h"]
    lines += ["        " + b for b in body]
    lines += ["        if k == kobs:",
              "            Xs = X",
              f"            Xo = {dense}",
              f"        X = {final}",
              "    return X, Xs, Xo", ""]
    # one step that keeps its stages, and the dense output from them: the same expressions
    ks = tuple_source(f"k{i + 1}" for i in range(len(method.c)))
    lines += [f"def step_stages(t, h, X, H{extra}):"] + scaled
    lines += ["    " + b for b in body]
    lines += [f"    return {final}, {ks}", "",
              "def dense_at(X, K, h, w):",
              "    " + ", ".join(f"k{i + 1}" for i in range(len(method.c))) + ", = K",
              f"    return {dense}"]
    return lines
