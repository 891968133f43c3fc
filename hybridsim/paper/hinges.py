"""What each of the paper's claims hinges on: assumptions the paper does not state, varied one at a time.

For every claim of Figs 7-10 (the claims of :mod:`hybridsim.paper.reproduce`) and
every *assumption family* below, the claim is judged over a grid of the
assumption's values; where its verdict flips between neighbours, the
threshold is located by bisection. A claim then reads: holds as printed;
holds if <assumption> (with the threshold); or not found within the ranges
tried. A few *stated models* (combinations of the assumptions that made
claims hold) are then judged at 60, 80 and 120 Hz, and the one under which
the most claims hold is the "best stated model" (each assumption enters at the largest threshold
it showed, so that every claim it made hold on its own, where that is monotone, holds). Each as-printed verdict is
also re-judged with the step halved and the runs 0.5 s longer (the
steady-state windows move by 0.5 s): a verdict that changes is "fragile".
"""
import math
from typing import Callable, NamedTuple

from hybridsim.format.build import load
from hybridsim.paper.claims import FAMILIES, conventions, file_of, judge
from hybridsim.runs.executor import using


class Assumption(NamedTuple):
    """An assumption the paper does not state: the values tried, the diagram overrides of a value, the
    value as printed (None: not a value of this family), its unit and whether it varies continuously
    (then a flip is bisected). For an on/off assumption the value 1 is on and 0 (as printed) off."""

    values: list
    overrides: Callable
    printed: object
    unit: str
    continuous: bool


def _stribeck(v):
    return {"arm.friction_model": "stribeck", "arm.stribeck_velocity": [v, v]}


ASSUMPTIONS = {
    "stick band": Assumption([1e-4, 2e-4, 4e-4, 8e-4], lambda v: {"arm.stick_band": v}, 1e-4, "rad/s, m/s", True),
    "Stribeck velocity": Assumption([1e-3, 3e-3, 1e-2, 3e-2], _stribeck, None, "rad/s, m/s", True),
    "LuGre friction": Assumption([1.0], lambda v: {"arm.friction_model": "lugre"}, 0.0, "", False),
    "joint damping s": Assumption([1.0, 4.0, 16.0, 64.0], FAMILIES["joint"], 0.0, "x (10 N m s/rad, 100 N s/m)",
                                  True),
    "wrist damping s": Assumption([1.0, 4.0, 16.0, 64.0], FAMILIES["wrist"], 0.0, "x 20 N s/m", True),
    "sensor filter": Assumption([0.002, 0.005, 0.01, 0.02], lambda v: {"sensor_tau": v}, 0.0, "s", True),
    "computation delay": Assumption([1], lambda v: {"delay_ticks": v}, 0, "ticks", False),
    "actuator lag": Assumption([0.005, 0.01, 0.02, 0.04], lambda v: {"actuator_tau": v}, 0.0, "s", True),
}
#: the experiments judged (eq 18 has no controller: nothing here moves it)
JUDGED = {"Fig 7": {"rate": 60}, "Fig 8": {}, "Fig 9": {}, "Fig 10": {}}


def _verdicts(results):
    return [[c[3] for c in claims] for claims, _, _ in results]


def hinge_search(name, assumption, executor=None, extra=None, bisections=2, values=None, printed=None):
    """Per claim of experiment ``name``: where its verdict flips as ``assumption`` varies.

    Parameters
    ----------
    name : str
        An experiment of :data:`JUDGED` ("Fig 7", ...).
    assumption : str
        A key of :data:`ASSUMPTIONS`.
    executor : Executor or int, optional
        Where the runs go (:class:`~hybridsim.runs.executor.Executor`, or a number of processes).
    extra : dict, optional
        Overrides added to every run (e.g. ``{"compiled": True}``).
    bisections : int
        Bisection steps on a flip between two tried values (geometric for
        positive values).
    values : list, optional
        Values to try instead of the assumption's own.
    printed : list of bool, optional
        The claims' verdicts as printed: a trial at the assumption's printed
        value (0 damping, LuGre off, ...), so a flip from it is found too.

    Returns
    -------
    dict
        ``claims``: the claim texts; ``trials``: [(value, [verdict per claim])];
        ``flips``: per claim None or {"from": value, "to": value, "holds_above": bool}.
    """
    grid, ov, at, _, continuous = ASSUMPTIONS[assumption]
    grid = list(values or grid)
    base = JUDGED[name]
    results = judge([(name, {**base, **ov(v)}) for v in grid], executor, extra)
    claims = [c[0] for c in results[0][0]]
    seen = dict(zip(grid, _verdicts(results)))  # value -> verdicts: each value runs once
    if printed is not None and at is not None:
        seen.setdefault(at, list(printed))

    def verdicts(v):
        if v not in seen:
            seen[v] = _verdicts(judge([(name, {**base, **ov(v)})], executor, extra))[0]
        return seen[v]

    tried = sorted(seen.items())
    flips = []
    for c in range(len(claims)):
        flip = None
        for (v0, a), (v1, b) in zip(tried, tried[1:]):
            if c < len(a) and c < len(b) and a[c] != b[c]:
                lo, hi, ok_hi = v0, v1, b[c]
                for _ in range(bisections if continuous else 0):
                    mid = math.sqrt(lo * hi) if lo > 0 else (lo + hi) / 2
                    got = verdicts(mid)
                    if c >= len(got):
                        break
                    lo, hi = (lo, mid) if got[c] == ok_hi else (mid, hi)
                flip = {"from": lo, "to": hi, "holds_above": bool(ok_hi)}
                break
        flips.append(flip)
    return {"experiment": name, "assumption": assumption, "claims": claims,
            "trials": [{"value": v, "verdicts": vs} for v, vs in sorted(seen.items())], "flips": flips}


def describe(search, c, holds_as_printed=False):
    """A claim's line for one assumption, from every value tried, or None when it says nothing.

    A failing claim: "holds if stick band >= 0.000283", "holds for joint damping s from 1 to 16",
    "holds with LuGre friction", "holds at every Stribeck velocity tried (0.001 to 0.03)". A claim
    that holds as printed: "fails if sensor filter >= 0.02 s" (what breaks it).
    """
    name = search["assumption"]
    _, _, _, unit, continuous = ASSUMPTIONS[name]
    trials = [(t["value"], t["verdicts"][c]) for t in search["trials"] if c < len(t["verdicts"])]
    if not trials:
        return None
    want = not holds_as_printed  # the verdict worth reporting
    hits = [v for v, ok in trials if ok == want]
    verb = "holds" if want else "fails"
    unit = f" {unit}" if unit else ""
    if not hits:
        return None
    if not continuous:
        return f"{verb} with {name}" + (f" {hits[0]:g}{unit}" if hits[0] != 1.0 else "")
    values = [v for v, _ in trials]
    if len(hits) == len(values):
        return f"{verb} at every {name} tried ({values[0]:.3g} to {values[-1]:.3g}{unit})"
    first, last = values.index(hits[0]), values.index(hits[-1])
    contiguous = hits == values[first:last + 1]
    if contiguous and last == len(values) - 1:
        return f"{verb} if {name} >= {hits[0]:.3g}{unit}"
    if contiguous and first == 0:
        return f"{verb} if {name} <= {hits[-1]:.3g}{unit}"
    if contiguous and len(hits) > 1:
        return f"{verb} for {name} from {hits[0]:.3g} to {hits[-1]:.3g}{unit}"
    return f"{verb} at {name} = " + ", ".join(f"{v:.3g}" for v in hits) + unit


def fragile(name, printed, executor=None, extra=None, step=1e-4):
    """Which as-printed verdicts (``printed``) of ``name`` change with the step halved or the runs
    0.5 s longer.

    Returns
    -------
    list of bool
        One per claim: True when the verdict is fragile.
    """
    base = JUDGED[name]
    t_end = float(load(file_of(name)).data.get("simulation", {}).get("t_end", 1.0))
    half, longer = _verdicts(judge([(name, {**base, "step": step / 2}),
                                    (name, {**base, "t_end": t_end + 0.5})], executor, extra))
    return [not (printed[c] == half[c] == longer[c]) if c < min(len(half), len(longer)) else True
            for c in range(len(printed))]


def stated_models(searches):
    """Candidate models: for each assumption, the value from which every claim it made hold holds
    (the largest such threshold); and the friction x lag/damping pairs of those."""
    value = {}
    for s in searches:
        for flip in s["flips"]:
            if flip and flip["holds_above"]:
                value[s["assumption"]] = max(value.get(s["assumption"], 0.0), flip["to"])
    models = [((a, v),) for a, v in value.items()]
    friction = [m for m in models if m[0][0] in ("stick band", "Stribeck velocity", "LuGre friction")]
    lag = [m for m in models if m[0][0] in ("actuator lag", "joint damping s", "wrist damping s")]
    return (models + [f + g for f in friction for g in lag])[:12]


def judge_claims(ov, executor=None, extra=None, names=tuple(JUDGED)):
    """The claims judged under overrides ``ov`` per servo rate: {rate: [(experiment, Claim), ...]}.

    Figs 7, 8 and 10 run at each rate; Fig 9 compares its own three rates, so its claims count at each.
    """
    per_rate = [n for n in names if n != "Fig 9"]
    items = [(n, {**ov, "rate": rate}) for rate in (60, 80, 120) for n in per_rate]
    if "Fig 9" in names:
        items.append(("Fig 9", ov))
    results = judge(items, executor, extra)
    fig9 = [("Fig 9", c) for c in results[-1][0]] if "Fig 9" in names else []
    out = {}
    for k, rate in enumerate((60, 80, 120)):
        chunk = items[k * len(per_rate):(k + 1) * len(per_rate)]
        got = results[k * len(per_rate):(k + 1) * len(per_rate)]
        out[rate] = [(name, c) for (name, _), (claims, _, _) in zip(chunk, got) for c in claims] + fig9
    return out


def judge_model(model, executor=None, extra=None, names=tuple(JUDGED)):
    """Claims held under ``model`` (((assumption, value), ...)) per servo rate: {rate: (held, total)}."""
    ov = {}
    for assumption, value in model:
        ov.update(ASSUMPTIONS[assumption].overrides(value))
    return {rate: (sum(c[3] for _, c in claims), len(claims))
            for rate, claims in judge_claims(ov, executor, extra, names).items()}


#: the two-parameter searches: (assumption, values) x (assumption, values), on a coarse grid
PAIRS = [
    (("joint damping s", [0.0, 4.0, 16.0, 64.0]), ("wrist damping s", [0.0, 4.0, 16.0, 64.0])),
    (("stick band", [1e-4, 2e-4, 4e-4]), ("joint damping s", [0.0, 4.0, 16.0, 64.0])),
]


def pair_search(name, first, second, executor=None, extra=None):
    """Per claim of ``name``: its verdict over a grid of two assumptions at once.

    ``first`` and ``second`` are (assumption, values). Returns
    ``{"experiment", "assumptions", "claims", "grid": [(v1, v2, [verdict per claim])]}``.
    """
    (a1, v1s), (a2, v2s) = first, second
    base = JUDGED[name]
    points = [(v1, v2) for v1 in v1s for v2 in v2s]
    items = [(name, {**base, **ASSUMPTIONS[a1].overrides(v1), **ASSUMPTIONS[a2].overrides(v2)}) for v1, v2 in points]
    results = judge(items, executor, extra)
    claims = max(([c[0] for c in r[0]] for r in results), key=len)
    return {"experiment": name, "assumptions": [a1, a2], "claims": claims,
            "grid": [(v1, v2, vs) for (v1, v2), vs in zip(points, _verdicts(results))]}


def describe_pair(search, c):
    """A claim's line from a two-parameter grid, or None: the points where it holds only with both.

    Each grid starts at the assumptions' printed values, so the grid itself
    says where one alone (the other as printed) already makes the claim hold.
    """
    a1, a2 = search["assumptions"]
    ok = {(v1, v2): c < len(vs) and vs[c] for v1, v2, vs in search["grid"]}
    v10, v20 = search["grid"][0][0], search["grid"][0][1]
    both = [(v1, v2) for (v1, v2), held in ok.items()
            if held and v1 != v10 and v2 != v20 and not ok[(v1, v20)] and not ok[(v10, v2)]]
    if not both:
        return None
    pts = ", ".join(f"({v1:.3g}, {v2:.3g})" for v1, v2 in both)
    return f"holds only with both {a1} and {a2} at ({a1}, {a2}) = {pts}"


def _warm_up(names, chosen, executor, extra):
    """On the compiled path: one run of each diagram structure the analysis will use, all at once.

    Most assumptions change a diagram's structure (a friction kernel, a filter's
    state, a delay line), and each structure compiles once. Run one
    after another, both workers would compile the same module at the same
    time; warmed up together, the two compile different ones and every later
    run loads its module from the cache.
    """
    first = {a: ASSUMPTIONS[a].overrides(ASSUMPTIONS[a].values[0]) for a in chosen}
    items = [(n, {**JUDGED[n], **first[a]}) for n in names for a in chosen]
    lag = first.get("actuator lag")
    for friction in ("Stribeck velocity", "LuGre friction"):  # the stated models' friction x lag pairs
        if lag and friction in chosen:
            items += [(n, {**JUDGED[n], **first[friction], **lag}) for n in names]
    judge(items, executor, extra)


def hinges(executor=None, extra=None, experiments=None, assumptions=None, bisections=2, progress=None):
    """The whole analysis: searches, fragility, stated models and the best of them, on ``executor``
    (an :class:`~hybridsim.runs.executor.Executor` or a number of processes; one pool for all of it).

    Returns
    -------
    dict
        ``rows`` (per experiment and claim: as printed, fragile, what it hinges on),
        ``searches``, ``models`` (each with its claims held per rate) and ``best``.
    """
    with using(executor) as ex:
        return _hinges(ex, extra, experiments, assumptions, bisections, progress or (lambda msg: None))


def _hinges(ex, extra, experiments, assumptions, bisections, say):
    names = [n for n in JUDGED if experiments is None or n in experiments]
    chosen = [a for a in ASSUMPTIONS if assumptions is None or a in assumptions]
    searches, rows, pairs = [], [], []
    if (extra or {}).get("compiled"):
        say("compiling each structure the analysis uses, two at a time (numba; cached for later runs)")
        _warm_up(names, chosen, ex, extra)
    for name in names:
        say(f"{name}: what its claims hinge on ({len(chosen)} assumptions)")
        ((printed, _, settings),) = judge([(name, JUDGED[name])], ex, extra)
        how = conventions(name, settings) if settings else []
        verdicts = [c[3] for c in printed]
        weak = fragile(name, verdicts, ex, extra)
        mine = [hinge_search(name, a, ex, extra, bisections, printed=verdicts) for a in chosen]
        searches += mine
        grids = [pair_search(name, f, s, ex, extra) for f, s in PAIRS if f[0] in chosen and s[0] in chosen]
        pairs += grids
        for c, (text, criterion, ours, ok) in enumerate(printed):
            hinge = [d for d in (describe(s, c, ok) for s in mine if c < len(s["flips"])) if d]
            if not ok:  # what only two assumptions together do
                hinge += [d for d in (describe_pair(g, c) for g in grids) if d]
            nothing = ("nothing tried breaks it" if ok else
                       f"not found within the ranges tried ({', '.join(chosen)})")
            rows.append({"experiment": name, "claim": text, "criterion": criterion, "ours": ours,
                         "as_printed": "fragile" if weak[c] else ("holds" if ok else "fails"),
                         "convention": how[c] if c < len(how) else "", "hinges_on": hinge or [nothing]})
    say("judging the stated models at 60, 80 and 120 Hz")
    models = [{"model": [list(m) for m in model], "held": judge_model(model, ex, extra, names)}
              for model in stated_models(searches)]
    best = max(models, key=lambda m: (sum(h for h, _ in m["held"].values()), -len(m["model"])), default=None)
    return {"rows": rows, "searches": searches, "pairs": pairs, "models": models, "best": best}
