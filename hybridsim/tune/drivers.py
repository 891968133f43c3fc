"""The optimisers: scipy's differential evolution and Nelder-Mead, Optuna's TPE and NSGA-II.

Each driver asks an :class:`Evaluator`-like object (``batch(points) -> records``,
``score(record)``, ``objectives(record)``, ``violations(record)``, ``width``)
for points and feeds back what they measured; every point it sees is in the
evaluator's history. The penalty for the scalar methods: a feasible point
scores its objective (negated when maximised); one that breaks a constraint
scores :data:`INFEASIBLE` plus 1e6 times its summed relative violation
(capped), so any feasible point beats any infeasible one and a less
infeasible one beats a more infeasible one; a failed run scores :data:`FAILED`.
"""
import numpy as np

from hybridsim.tune.space import decode

INFEASIBLE = 1e9
FAILED = 1e12
#: the default budgets, when a tune file names none
DEFAULTS = {"differential_evolution": {"seed": 0, "maxiter": 10, "popsize": 5, "tol": 0.01},
            "nelder_mead": {"maxiter": 60},
            "tpe": {"seed": 0, "trials": 40},
            "nsga2": {"seed": 0, "trials": 40, "population": 8}}


def budget(method, options, n_params):
    """The most evaluations a method's options allow (for the progress bar)."""
    o = {**DEFAULTS[method], **options}
    if method == "differential_evolution":
        return o["popsize"] * n_params * (o["maxiter"] + 1)
    return o["maxiter"] if method == "nelder_mead" else o["trials"]


def run(method, options, params, ev, start=None):
    """Search with ``method`` over ``params``; ``start`` (unit vector or None) seeds it where the method can."""
    o = {**DEFAULTS[method], **options}
    if method == "differential_evolution":
        return _de(o, params, ev, start)
    if method == "nelder_mead":
        return _nelder_mead(o, params, ev, start)
    return _optuna(method, o, params, ev, start)


def _de(o, params, ev, start):
    from scipy.optimize import differential_evolution

    def energies(U):  # vectorized: one column per member of the population
        U = np.atleast_2d(U)
        U = U if U.shape[0] == len(params) else U.T
        recs = ev.batch([decode(params, U[:, k]) for k in range(U.shape[1])])
        return np.array([ev.score(r) for r in recs])

    differential_evolution(energies, [(0.0, 1.0)] * len(params), seed=o["seed"], maxiter=o["maxiter"],
                           popsize=o["popsize"], tol=o["tol"], polish=False, init="latinhypercube",
                           vectorized=True, updating="deferred", x0=start)


def _nelder_mead(o, params, ev, start):
    from scipy.optimize import minimize

    x0 = np.full(len(params), 0.5) if start is None else np.asarray(start, float)
    minimize(lambda u: ev.score(ev.batch([decode(params, u)])[0]), x0, method="Nelder-Mead",
             bounds=[(0.0, 1.0)] * len(params),
             options={"maxfev": o["maxiter"], "xatol": 1e-3, "fatol": 1e-9, "initial_simplex": _simplex(x0)})


def _simplex(x0):
    """A start simplex of 0.15 (of the range) per coordinate, stepping inward from a bound."""
    pts = [x0]
    for k in range(len(x0)):
        x = x0.copy()
        x[k] = x[k] + 0.15 if x[k] <= 0.5 else x[k] - 0.15
        pts.append(x)
    return np.array(pts)


def _optuna(method, o, params, ev, start):
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)

    native = hasattr(optuna.trial.Trial, "set_constraint")  # Optuna >= 5; before, a constraints_func

    def constraints(trial):
        return trial.user_attrs.get("violations", [0.0])

    kw = {} if native else {"constraints_func": constraints}
    if method == "tpe":
        sampler = optuna.samplers.TPESampler(seed=o["seed"], multivariate=True, **kw)
    else:
        sampler = optuna.samplers.NSGAIISampler(seed=o["seed"], population_size=o["population"], **kw)
    study = optuna.create_study(directions=["maximize" if q.goal == "max" else "minimize" for q in ev.objectives_q],
                                sampler=sampler)
    if start is not None:
        study.enqueue_trial(decode(params, start))
    left = o["trials"]
    while left > 0:
        trials = [study.ask() for _ in range(min(ev.width, left))]
        recs = ev.batch([{p.path: p.suggest(t) for p in params} for t in trials])
        for t, rec in zip(trials, recs):
            objs = ev.objectives(rec)
            if rec["status"] != "ok" or any(not np.isfinite(v) for v in objs):
                study.tell(t, state=optuna.trial.TrialState.FAIL)
                continue
            viol = [float(min(v, 1e6)) for v in ev.violations(rec)] or [0.0]  # <= 0: feasible
            if native:
                for k, v in enumerate(viol):
                    t.set_constraint(f"c{k}", v)
            else:
                t.set_user_attr("violations", viol)
            study.tell(t, objs)
        left -= len(trials)
