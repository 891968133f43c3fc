"""Python source of one explicit Runge-Kutta step, made from its tableau.

Every path takes its integration step from here, so a method is written once
(its tableau in :mod:`hybridsim.engine.solvers`) and every path performs the same
floating-point operations in the same order:

* :func:`array_source` - the stepping core's stepper on arrays, element by
  element (the generic path runs it in Python, the compiled core compiles it);
* :func:`inlined_lines` - the same expressions written out element by
  element on float locals (``advance``), with the right-hand side written into
  each stage, for the fused (Python) path.

A stage's state is ``X + (h_a1 * k1 + h_a2 * k2 + ...)`` over the stage's
non-zero coefficients, each coefficient times ``h`` computed once per call
(``h_0 = 0.5 * h``); the step's result ``X + (h_b1 * k1 + ...)``; dense output at
``theta`` in [0, 1) of the step ``X + h * (w1 * k1 + ...)`` with the weights
``w = method.dense_weights(theta)`` computed once by the caller.
"""
import re

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


def _arr(expr, k_name="kk"):
    """An element expression of the tuple forms (``X[e]``, ``k2[e]``) on the arrays of the core: the
    state ``x[e]``, stage j at ``kk[(j - 1) * n + e]``."""
    import re

    expr = expr.replace("X[e]", "x[e]")
    return re.sub(r"\bk(\d+)\[e\]", lambda m: f"{k_name}[{int(m.group(1)) - 1} * n + e]", expr)


def _stages(method, xvar, kname, tvar):
    """Per stage: ``(its time, the lines putting its state into xs)``; no lines: the state is ``xvar``."""
    out = []
    for c, row in zip(method.c, method.A):
        terms = _terms(row)
        lines = [] if not terms else [
            "for e in range(n):",
            f"    xs[e] = {_arr(_combo(method, terms, '[e]'), kname).replace('x[e]', xvar + '[e]')}"]
        out.append((_time(method, c).replace("t", tvar, 1), lines))
    return out


def _stage_lines(method, pad, xvar, kname, tvar, call, tail="y, z, pf, pi"):
    """Each stage: its state into ``xs``, then ``call`` its derivatives into stage j of ``kname``."""
    out = []
    for i, (tt, lines) in enumerate(_stages(method, xvar, kname, tvar)):
        out += [pad + line for line in lines]
        out.append(f"{pad}{call}({tt}, {'xs' if lines else xvar}, {kname}, {i} * n, {tail})")
    return out


def _step_body(method, call, tail="y, z, pf, pi"):
    """Lines of one step ``k`` of the grid (``num``: step, h, n, k, t0, t1) from ``x`` into ``xn``, its
    stages in ``kk`` (``xs`` the stages' states); returns the step's end time."""
    return (["    k = int(num[3])",
             "    h = num[1]",
             "    t = num[4] + k * h",
             "    n = x.size"] + _scaled_lines(method, "    ") + _stage_lines(method, "    ", "x", "kk", "t", call, tail) + [
            "    for e in range(n):",
            f"        xn[e] = {_arr(_result(method, '[e]'))}",
            "    num[3] = k + 1",
            "    return num[5] if k + 1 >= int(num[2]) else num[4] + (k + 1) * h"])


def _steps_body(method, call, tail="y, z, pf, pi"):
    """Lines of as many steps as end by ``t_lim`` (at least one) from ``x`` into ``xn`` (``xm`` the
    state between them): the steps written out in the loop, a call per step costing more than its
    arithmetic. Returns the last step's end time."""
    return (["    num[7] = num[3]",
             "    k = int(num[3])",
             "    h = num[1]",
             "    m = int(num[2])",
             "    t0 = num[4]",
             "    n = x.size",
             "    src = x"] + _scaled_lines(method, "    ") + [
            "    while True:",
            "        t = t0 + k * h"] + _stage_lines(method, "        ", "src", "kk", "t", call, tail) + [
            "        for e in range(n):",
            f"            xn[e] = {_arr(_result(method, '[e]')).replace('x[e]', 'src[e]')}",
            "        k += 1",
            "        if not (k < m and t0 + (k + 1) * h <= t_lim + 1e-9 * h):",
            "            break",
            "        for e in range(n):",
            "            xm[e] = xn[e]",
            "        src = xm",
            "    num[3] = k",
            "    return num[5] if k >= m else t0 + k * h"])


def _stage_switch_lines(method, pad, xvar, kname, tvar, call, tail):
    """:func:`_stage_lines` as one loop over the stages, each stage's state and time chosen by a
    branch and ``call`` written once (a compiled glue inlines the right-hand side once, not once per
    stage): the same expressions."""
    stages = _stages(method, xvar, kname, tvar)
    out = [f"{pad}for i in range({len(stages)}):"]
    for i, (tt, lines) in enumerate(stages):
        branch = "if" if i == 0 else ("elif" if i < len(stages) - 1 else "else")
        out.append(f"{pad}    {branch} i == {i}:" if branch != "else" else f"{pad}    else:")
        out += [f"{pad}        ts = {tt}"] + [f"{pad}        {line}" for line in lines]
        out.append(f"{pad}        v = {'xs' if lines else xvar}")
    out.append(f"{pad}    {call}(ts, v, {kname}, i * n, {tail})")
    return out


def glue_steps_lines(method, rhs, params):
    """Lines of ``steps(num, t_lim, x, xn, kk, xs, xm, y, z, pf, pi)``: the stepper's ``steps`` for a
    compiled glue, the diagram's right-hand side called directly as ``rhs(t, x, dx, at, y, z, PP)``
    from one place, in a loop over the stages (inlined once: no call through a pointer per stage),
    ``PP = params`` built once per call. The same expressions as :func:`array_source`'s
    ``rk_steps``; with ``t_lim = -inf`` it takes exactly one step."""
    body = _steps_body(method, rhs, "y, z, PP")
    start = body.index("        t = t0 + k * h") + 1
    end = start + len(_stage_lines(method, "        ", "src", "kk", "t", rhs, "y, z, PP"))
    body = body[:start] + _stage_switch_lines(method, "        ", "src", "kk", "t", rhs, "y, z, PP") + body[end:]
    return ["def steps(num, t_lim, x, xn, kk, xs, xm, y, z, pf, pi):", f"    PP = {params}"] + body


def array_source(method, glue_steps=False):
    """Source of the core's Runge-Kutta stepper for ``method`` on arrays (:class:`~.stepping.Ops`).

    ``step(s, x, xn, w, rhs, y, z, pf, pi)`` takes step ``k`` of the current grid
    (``s.num``: step, h, n, k, t0, t1) from ``x`` into ``xn``, its stages in ``w.k``
    (stage j at ``j n``), and returns its end time; ``steps`` as many as end by
    ``t_lim``; ``dense`` the state inside the last step; ``restep`` one fresh step of
    ``hh``; ``begin`` cuts [t0, t1] into equal steps; ``rewind`` goes back to the
    start of the last ``steps``. The same expressions, element by element, as
    :func:`unrolled_lines` writes on tuples. With ``glue_steps`` (the compiled core)
    ``step``, ``steps`` and ``restep`` call the glue's own steps (:func:`glue_steps_lines`,
    compiled with the diagram's right-hand side; one step: ``t_lim = -inf``; a restep: a grid
    of one step of ``hh``), so the compiled core never calls ``gl.rhs``.
    """
    scaled = _scaled_lines(method, "    ")
    used = _dense_terms(method)
    dense = " + ".join(f"wts[{j}] * kk[{j} * n + e]" for j in used)
    L = ["def rk_begin(s, t0, t1, x, times, j, j1):",
         "    num = s.num",
         "    m = max(1, int(math.ceil((t1 - t0) / num[0] - 1e-9)))",
         "    num[2] = m", "    num[1] = (t1 - t0) / m", "    num[3] = 0", "    num[7] = 0",
         "    num[4] = t0", "    num[5] = t1", "",
         "",
         "def rk_step(s, x, xn, w, gl, y, z, pf, pi):"] + (
        ["    return gl.steps(s.num, -math.inf, x, xn, w.k, w.xs, w.xm, y, z, pf, pi)"] if glue_steps else
        ["    num = s.num", "    kk = w.k", "    xs = w.xs"] + _step_body(method, "gl.rhs")) + [
         "",
         "",
         "def rk_steps(s, t_lim, x, xn, w, gl, y, z, pf, pi):"] + (
        ["    return gl.steps(s.num, t_lim, x, xn, w.k, w.xs, w.xm, y, z, pf, pi)"] if glue_steps else
        ["    num = s.num", "    kk = w.k", "    xs = w.xs", "    xm = w.xm"] + _steps_body(method, "gl.rhs")) + [
         "",
         "",
         "def rk_dense(s, t, x, w, xo):",
         "    num = s.num",
         "    h = num[1]",
         "    theta = (t - (num[4] + (int(num[3]) - 1) * h)) / h",
         "    wts = w.wts"]
    for j, poly in enumerate(method.dense):  # as ExplicitRK.dense_weights
        L += ["    q = theta", f"    wts[{j}] = {poly[0]!r} * theta"]
        for p_ in poly[1:]:
            L += ["    q = q * theta", f"    wts[{j}] = wts[{j}] + {p_!r} * q"]
    L += ["    n = x.size",
          "    kk = w.k  # a record's array read once: each read costs a reference count",
          "    for e in range(n):",
          f"        xo[e] = x[e] + h * ({dense})", "",
          "",
          "def rk_restep(s, hh, x, w, gl, y, z, pf, pi, xr):",
          "    num = s.num",
          "    t = num[4] + (int(num[3]) - 1) * num[1]"] + ([
          "    tmp = s.tmp  # a grid of one step of hh from t: the glue's steps take it",
          "    tmp[0] = num[0]", "    tmp[1] = hh", "    tmp[2] = 1.0", "    tmp[3] = 0.0", "    tmp[4] = t",
          "    tmp[5] = t + hh",
          "    gl.steps(tmp, -math.inf, x, xr, w.kr, w.xr, w.xr, y, z, pf, pi)"] if glue_steps else [
          "    h = hh",
          "    n = x.size",
          "    kk = w.kr",
          "    xs = w.xr"] + scaled + _stage_lines(method, "    ", "x", "kk", "t", "gl.rhs") + [
          "    for e in range(n):",
          f"        xr[e] = {_arr(_result(method, '[e]'))}"]) + [
          "    return True", "",
          "",
          "def rk_rewind(s):",
          "    s.num[3] = s.num[7]",
          "    return True", ""]
    return "import math\n\n\n" + "\n".join(L)


def inline_names(line):
    return set(re.findall(r"[A-Za-z_]\w*", line))


def inlined_lines(method, n, stage, hoist, extra=""):
    """Source lines of ``advance``, ``step_stages`` and ``dense_at`` on ``n`` float locals.

    ``stage(t, xs)`` gives a stage's derivatives: ``(lines at no indent, names)`` for the time named
    ``t`` and the state's names ``xs``; ``hoist(lines)`` the lines to put before the steps (the
    params and held inputs those lines read). ``advance(t0, h, ka, kb, X, H{extra})`` takes steps
    ``ka .. kb - 1`` of size ``h`` from ``t0`` (step ``k`` starts at ``t0 + k * h``) and returns
    the final state (a tuple); ``step_stages(t, h, X, H{extra})`` takes one step and returns it
    with its stages; ``dense_at(X, K, h, w)`` is the state inside that step at the dense-output
    weights ``w``.
    """
    X = [f"X_{j}" for j in range(n)]

    def body(pad):
        out = []
        for i, (c, row) in enumerate(zip(method.c, method.A)):
            terms = _terms(row)
            xs = X if not terms else [f"S_{j}" for j in range(n)]
            out += [f"{pad}S_{j} = {_combo(method, terms, f'_{j}')}" for j in range(n) if terms]
            tt = _time(method, c)
            code, ds = stage("t" if tt == "t" else "ts", xs)
            if tt != "t" and any("ts" in inline_names(line) for line in code):
                out.append(f"{pad}ts = {tt}")
            out += [pad + line for line in code]
            out += [f"{pad}k{i + 1}_{j} = {d}" for j, d in enumerate(ds)]
        return out

    def tup(expr):
        return tuple_source(expr(f"[{j}]") for j in range(n))

    def flat(expr):
        return re.sub(r"\b(X|k\d+)\[(\d+)\]", r"\1_\2", expr)

    scaled = _scaled_lines(method, "    ")
    unpack = "    " + ", ".join(X) + ", = X"
    loop = body("        ")
    lines = [f"def advance(t0, h, ka, kb, X, H{extra}):"]
    lines += [line for line in hoist(loop)] + scaled + [unpack,
              "    for k in range(ka, kb):",
              "        t = t0 + k * h"] + loop
    lines += [f"        X_{j} = {flat(_result(method, f'[{j}]'))}" for j in range(n)]
    lines += [f"    return {tuple_source(X)}", ""]
    one = body("    ")
    ks = tuple_source(tuple_source(f"k{i + 1}_{j}" for j in range(n)) for i in range(len(method.c)))
    lines += [f"def step_stages(t, h, X, H{extra}):"] + hoist(one) + scaled + [unpack] + one
    lines += [f"    return {flat(tup(lambda e: _result(method, e)))}, ({ks})", ""]
    used = _dense_terms(method)
    dense = tup(lambda e: f"X{e} + h * (" + " + ".join(f"w[{j}] * k{j + 1}{e}" for j in used) + ")")
    lines += ["def dense_at(X, K, h, w):",
              "    " + ", ".join(f"k{i + 1}" for i in range(len(method.c))) + ", = K",
              f"    return {dense}"]
    return lines
