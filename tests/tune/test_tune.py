"""hybridsim tune: the parameter space, the measured quantities, the optimisers, resuming, bad tune files,
and the shipped PID example (its tuned gains re-run independently meet the constraints)."""
import json
import math

import control
import numpy as np
import pytest
import yaml

import hybridsim as hs
from hybridsim.app.cli import main
from hybridsim.errors import InputError, LoaderError
from hybridsim.tune import evaluate_point, load_tune, run_tune
from hybridsim.tune.outputs import pareto
from hybridsim.tune.quantities import step_measure
from hybridsim.tune.space import Parameter
from hybridsim.tune.spec import Quantity

from conftest import DIAGRAMS

MSD = DIAGRAMS / "examples" / "msd_pid.yaml"


def tune_file(tmp_path, body, name="t.yaml"):
    p = tmp_path / name
    p.write_text(f"diagram: {MSD}\nset: {{simulation.t_end: 5.0, simulation.step: 1.0e-3}}\n" + body)
    return p


PARAMS = """\
parameters:
  pid.Kp: {low: 1.0, high: 200.0, scale: log}
  pid.Ki: {low: 0.5, high: 200.0, scale: log}
  pid.Kd: {low: 0.1, high: 40.0, scale: log}
"""
SETTLE = "  - {name: settling, metric: settling_time_s, of: plant.y, final: 1.0, goal: minimize}\n"
OVER5 = "constraints:\n  - {name: overshoot, metric: overshoot_pct, of: plant.y, final: 1.0, max: 5.0}\n"


def independent_step(values, t_end=5.0):
    """The step response of the tuned loop from python-control alone: the plant sampled (ZOH) under the
    discrete PID's C(z) (blocks/discrete/basic.py's docstring), with the derivative on -y only when c = 0."""
    T = 0.01
    Pd = control.sample_system(control.tf([1.0], [1.0, 0.4, 4.0]), T, "zoh")
    z = control.tf([1, 0], [1], T)
    Kp, Ki, Kd, N = values["pid.Kp"], values["pid.Ki"], values["pid.Kd"], 40.0
    C_e = Kp + Ki * T * z / (z - 1)  # on the error r - y
    D = Kd * N * (z - 1) / ((1 + N * T) * z - 1)
    c = values.get("pid.c", 1.0)
    # u = C_e (r - y) + D (c r - y): y/r = Pd (C_e + c D) / (1 + Pd (C_e + D))
    G = control.ss(control.feedback(control.ss(Pd), control.ss(C_e + D))) * control.ss(C_e + c * D)
    t = np.arange(0, round(t_end / T) + 1) * T
    return control.step_response(G, t).outputs.ravel(), t


# -- the parameter space -----------------------------------------------------------------
def test_log_scale_maps_the_unit_interval_geometrically():
    p = Parameter("k", 1.0, 100.0, "log")
    assert p.from_unit(0.0) == pytest.approx(1.0) and p.from_unit(1.0) == pytest.approx(100.0)
    assert p.from_unit(0.5) == pytest.approx(10.0)  # the geometric middle
    assert p.to_unit(10.0) == pytest.approx(0.5) and p.to_unit(1000.0) is None


def test_integer_and_choice_parameters():
    n = Parameter("n", 0.0, 3.0, integer=True)
    assert [n.from_unit(u) for u in (0.0, 0.2, 0.5, 0.9, 1.0)] == [0, 1, 2, 3, 3]
    c = Parameter("m", values=["coulomb", "stribeck", "lugre"])
    assert [c.from_unit(u) for u in (0.0, 0.34, 0.99, 1.0)] == ["coulomb", "stribeck", "lugre", "lugre"]
    assert c.from_unit(c.to_unit("stribeck")) == "stribeck"
    assert Parameter("g", 1.0, 2.0, repeat=2).as_override(1.5) == [1.5, 1.5]


# -- the measured quantities ----------------------------------------------------------------
def test_step_measures_against_the_second_order_formulas():
    zeta, wn = 0.5, 10.0
    t = np.linspace(0, 3, 30001)
    G = control.tf([wn ** 2], [1, 2 * zeta * wn, wn ** 2])
    y = control.step_response(G, t).outputs.ravel()
    over = Quantity(name="o", metric="overshoot_pct", of="y", goal="min")
    peak_t = Quantity(name="p", metric="peak_time_s", of="y", goal="min")
    # Mp = exp(-zeta pi / sqrt(1 - zeta^2)), tp = pi / (wn sqrt(1 - zeta^2))
    assert step_measure(t, y, over) == pytest.approx(100 * math.exp(-zeta * math.pi / math.sqrt(1 - zeta ** 2)),
                                                     rel=1e-3)
    assert step_measure(t, y, peak_t) == pytest.approx(math.pi / (wn * math.sqrt(1 - zeta ** 2)), abs=2e-4)
    # a step applied at 0.5 s: 'after' moves the origin
    late = np.concatenate([np.zeros(5000), y[:-5000]])
    over.after = 0.5
    assert step_measure(t, late, over) == pytest.approx(100 * math.exp(-zeta * math.pi / math.sqrt(1 - zeta ** 2)),
                                                        rel=1e-3)


def test_a_response_that_never_settles_scores_the_run_length():
    t = np.linspace(0, 2, 201)
    y = 0.5 * (1 - np.exp(-t))  # never reaches 90 % of 1
    q = Quantity(name="s", metric="settling_time_s", of="y", final=1.0, goal="min")
    assert step_measure(t, y, q) == 2.0


def test_point_quantities_match_python_control(tmp_path):
    spec = load_tune(tune_file(tmp_path, PARAMS + "objectives:\n" + SETTLE + OVER5
                               + "  - {name: pm, analysis: phase_margin_deg, loop: 'pid.u[0]', min: 30}\n"
                               + "  - {name: gm, analysis: gain_margin_db, loop: 'pid.u[0]', min: 6}\n"))
    values = {"pid.Kp": 20.0, "pid.Ki": 15.0, "pid.Kd": 4.0}  # the example's own gains
    rec = evaluate_point(spec, values)
    y, t = independent_step(values)
    info = control.step_info(y, T=t, yfinal=1.0)
    assert rec["status"] == "ok"
    assert rec["quantities"]["overshoot"] == pytest.approx(info["Overshoot"], abs=0.05)
    assert rec["quantities"]["settling"] == pytest.approx(info["SettlingTime"], abs=0.011)  # one log sample
    # the loop opened at the PID's output: C(z) P(z), margins by python-control
    T = 0.01
    Pd = control.sample_system(control.tf([1.0], [1.0, 0.4, 4.0]), T, "zoh")
    z = control.tf([1, 0], [1], T)
    C = 20.0 + 15.0 * T * z / (z - 1) + 4.0 * 40.0 * (z - 1) / ((1 + 40.0 * T) * z - 1)
    with pytest.warns(UserWarning):
        gm, pm, *_ = control.stability_margins(C * Pd)
    assert rec["quantities"]["pm"] == pytest.approx(pm, abs=0.1)
    assert rec["quantities"]["gm"] == pytest.approx(20 * math.log10(gm), abs=0.05)


def test_worst_case_over_variants(tmp_path):
    spec = load_tune(tune_file(tmp_path, "variants: {rate: [50, 100]}\n" + PARAMS + "objectives:\n" + SETTLE + OVER5))
    both = evaluate_point(spec, {"pid.Kp": 20.0, "pid.Ki": 15.0, "pid.Kd": 4.0})["quantities"]["overshoot"]
    each = []
    for rate in (50, 100):
        r = hs.simulate(MSD, rate=rate, t_end=5.0, step=1e-3, **{"pid.Kp": 20.0, "pid.Ki": 15.0, "pid.Kd": 4.0})
        each.append(control.step_info(r["plant.y"].ravel(), T=r.t, yfinal=1.0)["Overshoot"])
    assert both == pytest.approx(max(each)) and each[0] != pytest.approx(each[1])


def test_pareto_front_by_hand():
    pts = [[1, 5], [2, 3], [3, 4], [4, 1], [2, 3.5], [5, 5]]
    assert pareto(pts) == [0, 1, 3]


# -- bad tune files: exit 2 with file and line ------------------------------------------------
@pytest.mark.parametrize("body, line, message", [
    (PARAMS + "objectives:\n  - {metric: settling_time_s, of: plant.y}\n", 8, "goal: minimize or maximize"),
    (PARAMS.replace("scale: log}\n  pid.Ki", "scale: lin}\n  pid.Ki", 1) + "objectives:\n" + SETTLE, 4,
     "scale must be one of"),
    (PARAMS.replace("low: 1.0, high: 200.0", "low: 300.0, high: 200.0") + "objectives:\n" + SETTLE, 4,
     "low < high"),
    (PARAMS.replace("{low: 0.1, high: 40.0, scale: log}", "{low: 0.0, high: 40.0, scale: log}")
     + "objectives:\n" + SETTLE, 6, "log scale needs low > 0"),
    (PARAMS + "objectives:\n" + SETTLE + "constraints:\n  - {metric: overshoot_pct, of: plant.y}\n", 10,
     "needs 'max' or 'min'"),
    (PARAMS + "objectives:\n" + SETTLE + "constraints:\n  - {metric: overshoot_pct, of: plant.y, min: 5, max: 1}\n",
     10, "min (5) exceeds its max (1)"),
    (PARAMS + "objectives:\n  - {analysis: phase_margin_deg, goal: max}\n", 8, "needs 'loop'"),
    (PARAMS + "objectives:\n  - {analysis: phase_margin_deg, loop: nosuchloop, goal: max}\n", 8,
     "loop 'nosuchloop': neither a name in msd_pid.yaml's analysis.points"),
    (PARAMS + "objectives:\n  - {analysis: phase_margin_deg, loop: 'plant.y[3]', goal: max}\n", 8,
     "loop 'plant.y[3]': plant.y has 1 element(s)"),
    (PARAMS + "objectives:\n" + SETTLE + "method: {name: simplex}\n", 9, "method 'simplex'"),
    (PARAMS + "objectives:\n" + SETTLE + "method: {name: tpe,\n  trials: 0}\n", 10, "trials must be"),
    (PARAMS + "objectives:\n" + SETTLE + "  - {metric: overshoot_pct, of: plant.y, goal: max}\n", 8,
     "two objectives need method tpe or nsga2"),
    (PARAMS + "objective:\n" + SETTLE, 7, "unknown tune key 'objective'"),  # the key's line, not its list's
    (PARAMS.replace("pid.Kd", "pid.Kx") + "objectives:\n" + SETTLE, 6, "pid.Kx"),
    (PARAMS + "objectives:\n  - {name: s, metric: rise_tim, goal: min}\n", 8, "metric 'rise_tim'"),
    # a run's metric the diagram's signal roles do not give: found by a run only, before
    (PARAMS + "objectives:\n  - {name: s, metric: rise_time_s, goal: min}\n", 8,
     "the runs of msd_pid.yaml measure wall_time_s"),
    (PARAMS + "objectives:\n  - {name: s, metric: settling_time_s, of: pid.v, goal: min}\n", 8, "pid.v"),
    (PARAMS + "objectives:\n" + SETTLE.replace("final: 1.0", "settling: 5"), 8, "'settling' is the band"),
    (PARAMS + "objectives:\n" + SETTLE.replace("final: 1.0", "after: -1"), 8, "'after' is when the step"),
    (PARAMS + "objectives:\n" + SETTLE.replace("final: 1.0", "after: 100"), 8, "not before the run's end"),
    (PARAMS + "objectives:\n" + SETTLE.replace("plant.y", "'plant.y[4]'"), 8, "plant.y has 1 element(s)"),
    (PARAMS + "objectives:\n" + SETTLE.replace("final: 1.0", "reference: nob.y"), 8, "reference 'nob.y'"),
    # a tuned parameter also given in 'set' or 'variants' was taken (the tuner's value won); a sweep
    # refused it
    ("variants: {pid.Kp: [3.0, 4.0]}\n" + PARAMS + "objectives:\n" + SETTLE, 5,
     "parameters 'pid.Kp' and variants 'pid.Kp' are the same parameter"),
    # a rate tuned over a range (its points incommensurate with the 100 Hz log), and a parameter that the
    # value using it cancels: check passed, every point failed, and tune exited 0
    ("parameters:\n  rate: {low: 40, high: 60}\nobjectives:\n" + SETTLE, 4,
     "needs whole values, integer: true"),
    ("variants:\n  rate: [0]\n" + PARAMS + "objectives:\n" + SETTLE, 4, "variant {'rate': 0}: "),  # had no line
    # a parameter whole and one of its elements: the element was dropped, and best.yaml held 'K[1]'
    (PARAMS.replace("pid.Kd:", "pid.Kp[0]:") + "objectives:\n" + SETTLE, 6,
     "parameters 'pid.Kp[0]' and parameters 'pid.Kp' both set pid.Kp"),
    ("parameters:\n  pid.rate: {low: 40, high: 60, integer: true}\n  rate: {low: 40, high: 60, integer: true}\n"
     "objectives:\n" + SETTLE, 5, "the parameters together: "),
    # a nested key was named at its parent's line, and no suggestion was made for a word in another case
    ("parameters:\n  pid.Kp:\n    low: 1\n    hihg: 10\nobjectives:\n" + SETTLE, 6,
     "unknown key 'hihg' (did you mean 'high'?)"),
    (PARAMS + "objectives:\n  - metric: settling_time_s\n    of: plant.y\n    goall: minimize\n", 10,
     "unknown key 'goall' (did you mean 'goal'?)"),
    (PARAMS + "objectives:\n  - metric: settling_time_s\n    of: plant.y\n    goal: Minimize\n", 10,
     "got 'Minimize' (did you mean 'minimize'?)"),
    (PARAMS.replace("scale: log}\n  pid.Ki", "scale: Log}\n  pid.Ki", 1) + "objectives:\n" + SETTLE, 4,
     "(did you mean 'log'?)"),
    (PARAMS + "objectives:\n" + SETTLE + "method:\n  name: tpe\n  trails: 3\n", 11,
     "unknown option 'trails' (did you mean 'trials'?)"),
    ("Parameters:\n  pid.Kp: {low: 1, high: 10}\n", 3, "unknown tune key 'Parameters' (did you mean 'parameters'?)"),
    (PARAMS + "objectives:\n" + SETTLE + "method: {nmae: tpe}\n", 9, "unknown option 'nmae' (did you mean 'name'?)"),
])
def test_bad_tune_files_exit_2_with_file_and_line(tmp_path, capsys, body, line, message):
    p = tune_file(tmp_path, body)
    code = main(["tune", str(p), "-o", str(tmp_path / "out"), "-q", "-j", "1"])
    out, err = capsys.readouterr()
    assert code == 2 and "Traceback" not in out + err
    assert f"t.yaml:{line}" in err and message in err, err


def test_a_misspelled_section_in_set_is_named_at_its_own_line_with_the_section(tmp_path, capsys):
    # the tune file's set was named at its first key, and 'simulaton.step' got no suggestion
    p = tmp_path / "t.yaml"
    p.write_text(f"diagram: {MSD}\nset:\n  simulation.t_end: 5.0\n  simulaton.step: 1.0e-3\n" + PARAMS
                 + "objectives:\n" + SETTLE)
    assert main(["check", str(p)]) == 2
    err = capsys.readouterr().err
    assert "t.yaml:4: the diagram with set:" in err and "no block 'simulaton' (did you mean 'simulation'?)" in err


def test_a_set_the_diagram_refuses_and_a_subsystems_port_as_a_signal(tmp_path, capsys):
    # 'set: {simulation.stepp: 3}' was named with no line; 'of: ctrl.u' (a subsystem's declared port,
    # which a diagram's log and a run's result take) was refused as no output
    p = tmp_path / "t.yaml"
    p.write_text(f"diagram: {MSD}\nset: {{simulation.stepp: 3}}\n" + PARAMS + "objectives:\n" + SETTLE)
    assert main(["check", str(p)]) == 2
    assert "t.yaml:2: the diagram with set:" in capsys.readouterr().err
    (tmp_path / "sub.yaml").write_text("blocks:\n  g: {type: gain, K: 1.0}\ninputs: {e: g.u}\noutputs: {u: g.y}\n")
    d = tmp_path / "d.yaml"
    d.write_text(MSD.read_text().replace("blocks:\n", "blocks:\n  ctrl: {type: subsystem, file: sub.yaml}\n", 1)
                 .replace("wires:\n", "wires:\n  - plant.y -> ctrl.e\n", 1))
    d.write_text(d.read_text().replace("log: [", "log: [ctrl.u, ", 1))
    p.write_text(f"diagram: {d}\nset: {{simulation.t_end: 5.0}}\n" + PARAMS + "objectives:\n"
                 + SETTLE.replace("of: plant.y", "of: ctrl.u"))
    assert main(["check", str(p)]) == 0, capsys.readouterr().err


def test_the_overlay_keeps_the_variants_the_point_was_scored_over(tmp_path):
    # best.yaml left out the tune's variants: run, it gave the 100 Hz value of a point scored as the
    # worst of 50 and 100 Hz
    from hybridsim.tune.outputs import overlay
    from hybridsim.tune.spec import load_tune

    p = tune_file(tmp_path, "variants: {rate: [50, 100], pid.N: [20, 40]}\n" + PARAMS + "objectives:\n" + SETTLE)
    text = overlay(load_tune(p), {"pid.Kp": 10.0, "pid.Ki": 5.0, "pid.Kd": 1.0}, tmp_path)
    assert "rate: [50, 100]" in text and "variants of pid.N too" in text
    # an element tuned (g.K[1]) is written as the whole value a diagram file takes ('K[1]' was refused)
    p = tune_file(tmp_path, "parameters:\n  pid.Kp[0]: {low: 1.0, high: 30.0}\nobjectives:\n" + SETTLE)
    assert "Kp: [12.5]" in overlay(load_tune(p), {"pid.Kp[0]": 12.5}, tmp_path)


# -- optimisers, outputs, resuming -------------------------------------------------------------
@pytest.mark.slow
def test_nelder_mead_improves_and_resumes(tmp_path):
    p = tune_file(tmp_path, PARAMS + "objectives:\n" + SETTLE + OVER5 + "method: {name: nelder_mead, maxiter: 12}\n")
    res = run_tune(p, tmp_path / "out", jobs=1, progress=False)
    assert 12 <= res["evaluations"] <= 14
    # from the example's gains (25 % overshoot) to a point within the 5 % bound
    assert res["before"]["quantities"]["overshoot"] > 20 and not res["before"]["feasible"]
    assert res["best"]["feasible"] and res["best"]["quantities"]["overshoot"] <= 5.0
    again = run_tune(p, tmp_path / "out", jobs=1, progress=False)
    assert again["ran"] == 0 and again["best"]["values"] == res["best"]["values"]
    # another search into the same folder is refused, or started afresh with force
    other = tune_file(tmp_path, PARAMS + "objectives:\n" + SETTLE + "method: {name: nelder_mead, maxiter: 3}\n",
                      "u.yaml")
    with pytest.raises(InputError, match="different search"):
        run_tune(other, tmp_path / "out", jobs=1, progress=False)
    fresh = run_tune(other, tmp_path / "out", jobs=1, progress=False, restart=True)
    assert fresh["ran"] >= 3 and (tmp_path / "out" / "evaluations.jsonl.old").exists()


@pytest.mark.slow
def test_two_objectives_give_a_pareto_front(tmp_path):
    p = tune_file(tmp_path, PARAMS + "objectives:\n" + SETTLE
                  + "  - {name: effort, metric: peak, of: 'pid.u', goal: minimize}\n"
                  + "method: {name: nsga2, seed: 3, trials: 16, population: 8}\n")
    res = run_tune(p, tmp_path / "out", jobs=2, progress=False)
    assert (tmp_path / "out" / "pareto.png").stat().st_size > 1000
    front = [[r["quantities"]["settling"], r["quantities"]["effort"]] for r in res["front"]]
    every = [[r["quantities"]["settling"], r["quantities"]["effort"]] for r in
             (json.loads(line)["value"] for line in (tmp_path / "out" / "evaluations.jsonl").read_text().splitlines())
             if r["quantities"]]
    assert front and len(pareto(every)) >= 1
    for f in front:  # nothing evaluated dominates a front point
        assert not any(e[0] <= f[0] and e[1] <= f[1] and e != f for e in every)


@pytest.mark.slow
def test_tpe_on_a_dask_cluster(tmp_path):
    from distributed import Client, LocalCluster

    p = tune_file(tmp_path, PARAMS + "objectives:\n" + SETTLE + OVER5 + "method: {name: tpe, seed: 2, trials: 6}\n")
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        res = run_tune(p, tmp_path / "out", dask=client, progress=False)
    assert res["evaluations"] == 6 and res["ran"] == 7  # the diagram as it is, then six trials


@pytest.mark.slow
def test_shipped_pid_example_meets_its_constraint_when_rerun(tmp_path):
    """diagrams/tune/msd_pid.yaml with a smaller budget: the best gains, run again through the plain API and
    judged by python-control, settle faster than the example's own and overshoot at most 5 %."""
    shipped = yaml.safe_load((DIAGRAMS / "tune" / "msd_pid.yaml").read_text())
    shipped["diagram"] = str(MSD)
    shipped["method"]["maxiter"] = 2
    p = tmp_path / "msd.yaml"
    p.write_text(yaml.safe_dump(shipped))
    res = run_tune(p, tmp_path / "out", jobs=2, progress=False)
    best = res["best"]["values"]
    tuned = hs.simulate(tmp_path / "out" / "best.yaml")  # the overlay, through the plain API
    info = control.step_info(tuned["plant.y"].ravel(), T=tuned.t, yfinal=1.0)
    assert info["Overshoot"] <= 5.0
    assert info["SettlingTime"] < res["before"]["quantities"]["settling"]
    y, t = independent_step(best)  # and without hybridsim at all
    ref = control.step_info(y, T=t, yfinal=1.0)
    assert ref["Overshoot"] <= 5.0 + 0.05 and ref["SettlingTime"] == pytest.approx(info["SettlingTime"], abs=0.011)
    f = hs.load(tmp_path / "out" / "best.yaml")
    assert f.data["blocks"]["pid"]["Kp"] == pytest.approx(best["pid.Kp"])


@pytest.mark.slow
def test_tuned_for_a_phase_margin_meets_it_when_rerun(tmp_path):
    """The cheaper analogue of the UR5 force-gain example: the fastest loop (the highest gain crossover)
    with a phase margin of at least 45 deg and at most 5 % overshoot; the tuned gains' margin checked by
    python-control on C(z) P(z), the overshoot on the step response run again through the plain API."""
    p = tune_file(tmp_path, PARAMS + "objectives:\n"
                  + "  - {name: crossover, analysis: gain_crossover_hz, loop: 'pid.u[0]', goal: maximize}\n"
                  + OVER5 + "  - {name: pm, analysis: phase_margin_deg, loop: 'pid.u[0]', min: 45}\n"
                  + "method: {name: tpe, seed: 0, trials: 16}\n")
    res = run_tune(p, tmp_path / "out", jobs=2, progress=False)
    assert res["best"]["feasible"] and res["best"]["quantities"]["crossover"] > 0.0
    v = res["best"]["values"]
    T = 0.01
    Pd = control.sample_system(control.tf([1.0], [1.0, 0.4, 4.0]), T, "zoh")
    z = control.tf([1, 0], [1], T)
    C = v["pid.Kp"] + v["pid.Ki"] * T * z / (z - 1) + v["pid.Kd"] * 40.0 * (z - 1) / ((1 + 40.0 * T) * z - 1)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, pm, _, _, wc, _ = control.stability_margins(C * Pd)
    assert pm >= 45.0 - 0.1 and wc / (2 * math.pi) == pytest.approx(res["best"]["quantities"]["crossover"], rel=1e-3)
    r = hs.simulate(MSD, t_end=5.0, step=1e-3, **v)
    assert control.step_info(r["plant.y"].ravel(), T=r.t, yfinal=1.0)["Overshoot"] <= 5.0


def test_the_overlay_runs_the_tuned_point_and_nothing_else(tmp_path):
    """best.yaml extends the diagram: a subsystem's parameter, a vector given by 'repeat', and a 'set' that
    fixes names the diagram's variants sweep (so the overlay runs the one variant the search ran)."""
    from hybridsim.analysis.stability import param_value
    from hybridsim.tune.outputs import overlay

    p = tmp_path / "t.yaml"
    p.write_text(f"diagram: {DIAGRAMS / 'fig7_force_steps.yaml'}\nset: {{force: 5.0, rate: 60}}\n"
                 "parameters:\n  ctrl.fpi.Kp: {low: 0.1, high: 2.0, repeat: 2}\n  wrist_damping: {low: 0, high: 100}\n"
                 "objectives: [{metric: rise_time_s, goal: min}]\n")
    out = tmp_path / "out"
    out.mkdir()
    (out / "best.yaml").write_text(overlay(load_tune(p), {"ctrl.fpi.Kp": 0.7, "wrist_damping": 12.0}, out))
    f = hs.load(out / "best.yaml")
    assert f.variants() == [("force=5.0, rate=60", {"force": 5.0, "rate": 60})]
    assert param_value(f, "ctrl.fpi.Kp").tolist() == [0.7, 0.7] and f.params["wrist_damping"] == 12.0


def test_a_users_file_among_the_search_outputs_is_refused_before_any_evaluation(tmp_path):
    from hybridsim.errors import OutputError

    p = tune_file(tmp_path, PARAMS + "objectives:\n" + SETTLE + "method: {name: nelder_mead, maxiter: 2}\n")
    out = tmp_path / "out"
    out.mkdir()
    (out / "best.yaml").write_text("mine")  # was refused after the search
    with pytest.raises(OutputError, match="best.yaml' exists and hybridsim did not write it"):
        run_tune(p, out, jobs=1, progress=False)
    assert sorted(x.name for x in out.iterdir()) == ["best.yaml"]


def test_a_tune_key_left_empty_is_refused_at_its_line(tmp_path):
    # 'objectives:' left empty crashed (TypeError, exit 70); 'set:' and 'method:' were read as absent
    head = f"diagram: {MSD}\nparameters:\n  pid.Kp: {{low: 1, high: 10}}\n"
    for text, says in ((head + "objectives:\n", r"t.yaml:4: tune key 'objectives' is empty \(null\): give its value$"),
                       (head + "objectives:\n" + SETTLE + "method:\n",
                        r"t.yaml:6: tune key 'method' is empty \(null\): give its value, or leave the key out")):
        p = tmp_path / "t.yaml"
        p.write_text(text)
        with pytest.raises(LoaderError, match=says):
            load_tune(p)


@pytest.mark.slow
def test_a_search_into_an_earlier_ones_folder_leaves_none_of_its_results(tmp_path):
    # after a two-objective search, a --force one-objective search that met no constraint left the old
    # pareto.png, pareto.csv and best.yaml (which 'hybridsim run best.yaml' would run)
    two = tune_file(tmp_path, PARAMS + "objectives:\n" + SETTLE
                    + "  - {name: effort, metric: peak, of: 'pid.u', goal: minimize}\n"
                    + "method: {name: nsga2, seed: 3, trials: 4, population: 4}\n", "two.yaml")
    run_tune(two, tmp_path / "out", jobs=1, progress=False)
    assert all((tmp_path / "out" / n).is_file() for n in ("pareto.png", "pareto.csv", "best.yaml"))
    # every point of this one fails (a state past max_state at once: diverged): no best, no front
    one = tune_file(tmp_path, PARAMS + "objectives:\n" + SETTLE + "method: {name: tpe, seed: 1, trials: 2}\n",
                    "one.yaml")
    one.write_text(one.read_text().replace("simulation.t_end: 5.0", "simulation.t_end: 5.0, simulation.max_state: 1.0e-6"))
    res = run_tune(one, tmp_path / "out", jobs=1, progress=False, restart=True)
    assert res["best"] is None or not res["best"]["values"]
    assert not any((tmp_path / "out" / n).exists() for n in ("pareto.png", "pareto.csv", "best.yaml"))


def test_nsga2_with_one_objective_says_it_finds_no_front(tmp_path, caplog):
    # it ran without a word; the docs give it for two objectives
    import logging

    p = tune_file(tmp_path, PARAMS + "objectives:\n" + SETTLE + "method: {name: nsga2, trials: 4}\n")
    with caplog.at_level(logging.WARNING, logger="hybridsim"):
        assert load_tune(p).method == "nsga2"
    assert "t.yaml:9: nsga2 with one objective is a plain genetic search" in caplog.text
