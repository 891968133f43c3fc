"""Diagrams exported as Co-Simulation FMUs (hybridsim.fmi.export, pythonfmu / pythonfmu3).

Oracles: fmpy's validate_fmu; the Fig 6 controller FMU closed around the plant FMU by a
Gauss-Seidel master on fmpy's FMU classes, against the same loop built in hybridsim from
the controller's YAML; and hybridsim importing the controller FMU it exported.
"""
import shutil

import numpy as np
import pytest

import hybridsim as hs
from hybridsim.app.cli import main

from conftest import DIAGRAMS

pytest.importorskip("pythonfmu")
pytest.importorskip("pythonfmu3")
pytestmark = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                                reason="no C compiler (the plant FMU is compiled)")

CTRL = DIAGRAMS / "subsystems" / "fig6_controller.yaml"
H = 1 / 60  # the controller's rate
PLANT = {"balance": 1.0, "surface_x0": 0.5, "preload": 10.0, "max_substep": 1e-4}
X_D, F_D = [0.5, 0.0], [20.0, 0.0]  # hold Y at 0, push with 20 N (from the 10 N preload)


def initializing(path):
    """(fmpy's FMU2Slave of the FMU at ``path``, in initialization mode; its value references by name)."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(path))
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path)), modelIdentifier=md.coSimulation.modelIdentifier)
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    return fmu, {v.name: v.valueReference for v in md.modelVariables}


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    from hybridsim.fmi.export import export_fmu
    from hybridsim.fmus.build import build_plant_fmu

    d = tmp_path_factory.mktemp("export")
    return {"plant2": build_plant_fmu(d / "plant.fmu"), "plant3": build_plant_fmu(d / "plant3.fmu", fmi=3),
            "ctrl2": export_fmu(CTRL, d / "ctrl2.fmu", fmi=2), "ctrl3": export_fmu(CTRL, d / "ctrl3.fmu", fmi=3)}


def test_the_exported_fmus_validate_and_show_the_subsystems_ports(fmus):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    for v in (2, 3):
        path = str(fmus[f"ctrl{v}"])
        assert validate_fmu(path) == []
        md = read_model_description(path)
        by = {c: sorted(x.name for x in md.modelVariables if x.causality == c) for c in ("input", "output", "parameter")}
        assert by["input"] == sorted(f"{p}[{k}]" for p in ("q", "qd", "F", "X_d", "Xd_d", "F_d") for k in (1, 2))
        assert by["output"] == sorted(f"{p}[{k}]" for p in ("tau", "CF", "X") for k in (1, 2))
        assert by["parameter"] == ["S[1]", "S[2]", "rate"]  # the subsystem's params
        assert md.coSimulation.needsExecutionTool  # it needs a Python with hybridsim


def loop_diagram(tmp_path, plant, ctrl_fmu=None):
    """The controller closed around the plant FMU, in hybridsim (the controller from YAML or its FMU)."""
    ctrl = (f"{{type: fmu, path: {ctrl_fmu}, mode: cs, rate: 60}}" if ctrl_fmu else
            f"{{type: subsystem, file: {CTRL}}}")
    text = f"""
blocks:
  plant: {{type: fmu, path: {plant}, mode: cs, rate: 60, parameters: {PLANT}}}
  ctrl: {ctrl}
  xd: {{type: constant, value: {X_D}}}
  fd: {{type: constant, value: {F_D}}}
  xs: {{type: constant, value: 0.5}}
wires:
  - plant.q -> ctrl.q
  - plant.qd -> ctrl.qd
  - plant.F -> ctrl.F
  - xd.y -> ctrl.X_d
  - xd.dy -> ctrl.Xd_d
  - fd.y -> ctrl.F_d
  - ctrl.tau -> plant.tau
  - xs.y -> plant.x_surface
  - xs.dy -> plant.v_surface
simulation: {{t_end: 1.0, log_period: {H}}}
log: [ctrl.CF, plant.F]
"""
    path = tmp_path / f"loop_{'fmu' if ctrl_fmu else 'yaml'}.yaml"
    path.write_text(text)
    return path


def master(plant, ctrl, t_end=1.0):
    """Gauss-Seidel co-simulation on fmpy: at t_k the plant's outputs feed the controller, whose
    torques (direct feedthrough) feed the plant; then both step. Returns (t, CF) at every t_k."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.fmi3 import FMU3Slave

    units = []
    for path in (plant, ctrl):
        md = read_model_description(str(path))
        cls = FMU3Slave if md.fmiVersion == "3.0" else FMU2Slave
        fmu = cls(guid=md.guid, unzipDirectory=extract(str(path)), modelIdentifier=md.coSimulation.modelIdentifier)
        fmu.instantiate()
        if md.fmiVersion == "3.0":
            fmu.enterInitializationMode(startTime=0.0)
        else:
            fmu.setupExperiment(startTime=0.0)
            fmu.enterInitializationMode()
        vr = {v.name: v.valueReference for v in md.modelVariables}
        get, put = (fmu.getFloat64, fmu.setFloat64) if md.fmiVersion == "3.0" else (fmu.getReal, fmu.setReal)
        units.append((fmu, vr, get, put, md.fmiVersion == "3.0"))
    (p, pv, pget, pput, p3), (c, cv, cget, cput, _) = units
    for name, value in PLANT.items():
        pput([pv[name]], [value])
    pput([pv["x_surface"], pv["v_surface"]], [0.5, 0.0])
    cput([cv["X_d[1]"], cv["X_d[2]"], cv["Xd_d[1]"], cv["Xd_d[2]"], cv["F_d[1]"], cv["F_d[2]"]], X_D + [0, 0] + F_D)
    p.exitInitializationMode()
    c.exitInitializationMode()
    names = ["q[1]", "q[2]", "qd[1]", "qd[2]", "F[1]", "F[2]"]
    ts, cf = [], []
    try:
        for k in range(round(t_end / H)):
            t = k / 60
            cput([cv[n] for n in names], pget([pv[n] for n in names]))
            tau = cget([cv["tau[1]"], cv["tau[2]"]])
            ts.append(t)
            cf.append(cget([cv["CF[1]"], cv["CF[2]"]]))
            pput([pv["tau[1]"], pv["tau[2]"]], tau)
            p.doStep(t, H)
            c.doStep(t, H)
    finally:
        for fmu, *_ in units:
            fmu.terminate()
            fmu.freeInstance()
    return np.array(ts), np.array(cf)


@pytest.mark.parametrize("fmi", [2, 3])
def test_the_exported_controller_around_the_plant_fmu_equals_the_loop_in_hybridsim(fmus, fmi, tmp_path):
    ref = hs.simulate(loop_diagram(tmp_path, fmus[f"plant{fmi}"]))
    t, cf = master(fmus[f"plant{fmi}"], fmus[f"ctrl{fmi}"])
    assert np.allclose(ref.t[:len(t)], t, atol=1e-12, rtol=0)
    got, want = cf[:, 0], ref["ctrl.ft.CF[0]"][:len(t)]  # the subsystem's CF is its ft.CF
    assert np.max(np.abs(got - want)) < 1e-9  # N
    assert abs(want[-1] - 20.0) < 3.0 and abs(want[0] - 10.0) < 0.1  # it did push from 10 N toward 20 N


@pytest.mark.parametrize("fmi", [2, 3])
def test_hybridsim_imports_the_controller_it_exported(fmus, fmi, tmp_path):
    ref = hs.simulate(loop_diagram(tmp_path, fmus[f"plant{fmi}"]))
    res = hs.simulate(loop_diagram(tmp_path, fmus[f"plant{fmi}"], ctrl_fmu=fmus[f"ctrl{fmi}"]))
    assert np.max(np.abs(res["ctrl.CF[0]"][:-1] - ref["ctrl.ft.CF[0]"][:-1])) < 1e-9


def test_a_closed_diagram_exports_with_its_logged_signals_as_outputs(tmp_path):
    import fmpy
    from fmpy.validation import validate_fmu

    from hybridsim.fmi.export import export_fmu

    fmu = export_fmu(DIAGRAMS / "bouncing_ball.yaml", tmp_path / "ball.fmu", fmi=2)
    assert validate_fmu(str(fmu)) == []
    ref = hs.simulate(DIAGRAMS / "bouncing_ball.yaml", t_end=1.0, log_period=0.01)
    name = next(k for k in ref.signals if ref.signals[k].shape[1] == 1)
    col = name.replace(".", "_")
    r = fmpy.simulate_fmu(str(fmu), stop_time=1.0, output_interval=0.01, output=[col])
    n = min(len(r), len(ref.t))
    assert np.max(np.abs(r[col][:n] - ref.signals[name][:n, 0])) < 1e-9


def test_cli_exports_and_refuses_a_bad_version(tmp_path, capsys):
    from fmpy import read_model_description

    assert main(["fmu", "export", str(CTRL), "--fmi", "3", "-o", str(tmp_path / "c.fmu")]) == 0
    assert read_model_description(str(tmp_path / "c.fmu")).fmiVersion == "3.0"
    with pytest.raises(SystemExit) as e:
        main(["fmu", "export", str(CTRL), "--fmi", "4", "-o", str(tmp_path / "c4.fmu")])
    assert e.value.code == 2


def test_a_missing_diagram_is_a_clear_error(tmp_path, capsys):
    code = main(["fmu", "export", str(tmp_path / "nope.yaml"), "-o", str(tmp_path / "n.fmu")])
    err = capsys.readouterr().err
    assert code == 2 and "nope.yaml" in err and "Traceback" not in err
    assert not (tmp_path / "n.fmu").exists()


def test_a_diagram_with_an_fmu_inside_is_refused(tmp_path, capsys):
    code = main(["fmu", "export", str(DIAGRAMS / "fig9_fmu_cs.yaml"), "-o", str(tmp_path / "x.fmu")])
    err = capsys.readouterr().err
    assert code == 2 and "block type fmu inside an exported diagram is not supported" in err
    assert "fig9_fmu_cs.yaml:" in err  # at the block's line (bad input, not an FMU's failure)


def test_a_bad_parameter_fails_initialization_in_the_fmus_own_words(fmus):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    path = str(fmus["ctrl2"])
    md = read_model_description(path)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(path), modelIdentifier=md.coSimulation.modelIdentifier)
    said = []
    from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
    from fmpy.fmi2 import defaultCallbacks as cb

    def log(env, name, status, category, message):
        said.append(message.decode())

    cbs = fmi2CallbackFunctions()
    cbs.logger = fmi2CallbackLoggerTYPE(log)
    cbs.allocateMemory, cbs.freeMemory = cb.allocateMemory, cb.freeMemory
    fmu.instantiate(callbacks=cbs, loggingOn=True)
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.setReal([vr["rate"]], [0.0])  # a number is a Real, a whole one too
    with pytest.raises(Exception):
        fmu.exitInitializationMode()
    assert any("cannot build the diagram" in m and "rate" in m for m in said), said
    fmu.freeInstance()


def test_the_controller_keeps_its_own_rate_whatever_the_communication_step(fmus):
    """60 Hz inside: stepped at 1/240 s or 1/20 s, its outputs at common times are those of 1/60 s
    steps (constant inputs; between its sample hits the outputs hold)."""
    import fmpy

    start = {"q[1]": 0.3, "q[2]": 0.5, "F[1]": 9.0, "X_d[1]": 0.5, "F_d[1]": 10.0}
    runs = {h: fmpy.simulate_fmu(str(fmus["ctrl2"]), stop_time=0.5, step_size=h, output_interval=h,
                                 start_values=start, output=["tau[1]", "tau[2]"]) for h in (1 / 60, 1 / 240, 1 / 20)}
    base = runs[1 / 60]
    for h in (1 / 240, 1 / 20):
        r = runs[h]
        k = np.round(r["time"] * 60, 6)
        on = k == np.round(k)  # the times that are 60 Hz sample hits
        want = dict(zip(np.round(base["time"] * 60).astype(int), base["tau[1]"]))
        got = r["tau[1]"][on]
        assert np.max(np.abs(got - [want[int(round(x))] for x in k[on]])) < 1e-12, h
    assert np.ptp(base["tau[1]"]) > 0.1  # the integrators move it


def test_a_subsystem_with_its_own_solver_and_a_continuous_state_exports_and_steps(tmp_path):
    """The subsystem's ``simulation`` section is the FMU's solver; its input drives a first-order lag
    integrated inside doStep: y = u (1 - e^(-t / tau))."""
    import math

    from hybridsim.fmi.export import export_fmu

    f = tmp_path / "lag.yaml"
    f.write_text("name: lag\nblocks:\n  lag: {type: first_order, tau: 0.2, initial: 0.0}\n"
                 "inputs: {x: lag.u}\noutputs: {y: lag.y}\nsimulation:\n  solver: heun\n  step: 1.0e-3\n")
    fmu, vr = initializing(export_fmu(f, tmp_path / "lag.fmu"))
    fmu.exitInitializationMode()
    try:
        fmu.setReal([vr["x"]], [2.0])
        for k in range(10):
            fmu.doStep(k * 0.1, 0.1)
        y = fmu.getReal([vr["y"]])[0]
    finally:
        fmu.terminate()
        fmu.freeInstance()
    assert y == pytest.approx(2.0 * (1.0 - math.exp(-1.0 / 0.2)), abs=1e-6)


def test_an_error_inside_an_exported_subsystem_names_the_users_file(tmp_path, capsys):
    f = tmp_path / "sub.yaml"
    f.write_text("name: sub\nblocks:\n  g: {type: gain, K: 2.0}\n  h: {type: gain, K: 1.0}\n"
                 "wires: [g.y -> h.nope]\ninputs: {u: g.u}\noutputs: {y: h.y}\nsimulation: {solver: rk4, step: 1.0e-3}\n")
    assert main(["fmu", "export", str(f), "-o", str(tmp_path / "s.fmu")]) == 2
    err = capsys.readouterr().err
    assert f"{f}:5" in err and "no input 'nope'" in err
    assert "hybridsim-export" not in err and "hybridsim_fmu.yaml" not in err


def test_a_subsystem_that_extends_one_with_a_simulation_section_exports(tmp_path, capsys):
    """The merged simulation section is the FMU's (the extended file's section was refused, at the
    child's path with the parent's line); a bad setting there is named at its file and line."""
    from fmpy import read_model_description

    (tmp_path / "base.yaml").write_text("name: base\nblocks:\n  lag: {type: first_order, tau: 0.2, initial: 0.0}\n"
                                        "inputs: {x: lag.u}\noutputs: {y: lag.y}\nsimulation:\n  solver: heun\n"
                                        "  step: 1.0e-2\n")
    child = tmp_path / "child.yaml"
    child.write_text("extends: base.yaml\nblocks:\n  lag: {tau: 0.1}\nsimulation: {step: 5.0e-3}\n")
    assert main(["fmu", "export", str(child), "-o", str(tmp_path / "c.fmu")]) == 0
    assert read_model_description(str(tmp_path / "c.fmu")).coSimulation is not None
    child.write_text("extends: base.yaml\nsimulation:\n  solver: rk5\n")
    assert main(["fmu", "export", str(child), "-o", str(tmp_path / "d.fmu")]) == 2
    assert f"{child}:3: unknown solver 'rk5'" in capsys.readouterr().err


def test_exported_variables_are_one_per_element_and_numbers_are_real(tmp_path, capsys, monkeypatch):
    # a log naming elements exported the port once per element (fmpy: "integ_y[1]" is not unique); a
    # whole-number param was an Integer, so Kp = 2.5 became 2; a param 'time' clashed with FMI 3.0's
    import fmpy
    from fmpy.validation import validate_fmu

    closed = tmp_path / "closed.yaml"
    closed.write_text("name: closed\nblocks:\n  c: {type: constant, value: [1.0, 2.0]}\n"
                      "  integ: {type: integrator, width: 2}\nwires: [c.y -> integ.u]\n"
                      "log: [\"integ.y[0]\", \"integ.y[1]\"]\nsimulation: {t_end: 1.0, step: 1.0e-3}\n")
    sub = tmp_path / "scaled.yaml"
    sub.write_text("name: scaled\nparams: {Kp: 2}\nblocks:\n  g: {type: gain, K: $Kp}\n"
                   "inputs: {u: [g.u]}\noutputs: {y: g.y}\n")
    monkeypatch.chdir(tmp_path)
    assert main(["fmu", "export", str(closed)]) == 0 and main(["fmu", "export", str(sub)]) == 0
    assert validate_fmu("closed.fmu") == []  # the default name: the diagram's own
    r = fmpy.simulate_fmu("closed.fmu", stop_time=0.5, output_interval=0.1, output=["integ_y[2]"])
    assert r["integ_y[2]"][-1] == pytest.approx(1.0, abs=1e-9)
    r = fmpy.simulate_fmu("scaled.fmu", stop_time=0.1, output_interval=0.1, start_values={"Kp": 2.5, "u": 1.0})
    assert r["y"][-1] == pytest.approx(2.5)
    (tmp_path / "timed.yaml").write_text(sub.read_text().replace("Kp", "time"))
    assert main(["fmu", "export", "timed.yaml", "--fmi", "3"]) == 2
    assert "timed.yaml:2: parameter 'time' would be an FMU variable of the same name" in capsys.readouterr().err
    (tmp_path / "wide.yaml").write_text("blocks:\n  h: {type: gain}\n  g: {type: gain, width: 2}\n"
                                        "inputs: {u: [h.u, g.u]}\noutputs: {y: h.y}\n")
    assert main(["check", "wide.yaml"]) == 2
    assert "wide.yaml:4: input 'u' feeds ports of different widths" in capsys.readouterr().err


def test_outputs_declare_the_inputs_they_feed_through_and_answer_in_initialization_mode(fmus):
    """fmpy reads each output's dependencies (pythonfmu wrote none: every output on every input,
    so an importer saw algebraic loops that are not there); FMI 3.0 takes variable communication
    steps, as the FMI 2.0 export says; outputs read in initialization mode were 0."""
    from fmpy import read_model_description

    for v in (2, 3):
        md = read_model_description(str(fmus[f"ctrl{v}"]))
        deps = {u.variable.name: sorted(d.name for d in u.dependencies) for u in md.outputs}
        assert deps["X[1]"] == deps["X[2]"] == ["q[1]", "q[2]"]  # forward kinematics of q alone
        assert deps["CF[1]"] == ["F[1]", "F[2]", "q[1]", "q[2]"]  # eq 3b: F turned by q
        assert md.coSimulation.canHandleVariableCommunicationStepSize
    fmu, vr = initializing(fmus["ctrl2"])
    fmu.setReal([vr["q[1]"], vr["q[2]"]], [0.3, 0.2])
    early = fmu.getReal([vr["X[1]"], vr["X[2]"]])
    fmu.setReal([vr["S[1]"]], [0.0])  # a parameter set after a read: built again with it
    fmu.exitInitializationMode()
    assert early == pytest.approx(fmu.getReal([vr["X[1]"], vr["X[2]"]])) and early != [0.0, 0.0]
    fmu.terminate()
    fmu.freeInstance()


def test_a_diagram_with_variants_exports_its_parameters_as_they_are_and_says_so(tmp_path, caplog):
    from fmpy import read_model_description

    from hybridsim.fmi.export import export_fmu

    d = tmp_path / "v.yaml"
    d.write_text("name: v\nparams: {k: 2.0}\nvariants: {k: [3.0, 4.0]}\nblocks:\n  c: {type: constant, value: $k}\n"
                 "log: [c.y]\nsimulation: {t_end: 0.1}\n")
    fmu = export_fmu(d, tmp_path / "v.fmu")
    assert "its 'variants' are not exported: the FMU runs the parameters as they are (k=2.0)" in caplog.text
    assert {v.name: v.start for v in read_model_description(str(fmu)).modelVariables}["k"] in ("2", "2.0")


def test_parameters_that_make_an_output_feed_through_an_undeclared_input_are_refused(tmp_path):
    """A lag's tau set to 0 passes u straight to y, which the model description says y does not
    depend on: an importer would order its loop wrong. Initialization fails, saying why."""
    from hybridsim.fmi.export import export_fmu

    f = tmp_path / "lag.yaml"
    f.write_text("name: lag\nparams: {tau: 0.2}\nblocks:\n  lag: {type: first_order, tau: $tau, initial: 0.0}\n"
                 "inputs: {u: lag.u}\noutputs: {y: lag.y}\n")
    fmu, vr = initializing(export_fmu(f, tmp_path / "lag.fmu"))
    try:
        fmu.setReal([vr["tau"]], [0.0])
        with pytest.raises(Exception):
            fmu.exitInitializationMode()
    finally:
        fmu.freeInstance()
    fmu, vr = initializing(tmp_path / "lag.fmu")
    fmu.setReal([vr["tau"]], [0.5])  # a lag still
    fmu.exitInitializationMode()
    fmu.terminate()
    fmu.freeInstance()


@pytest.mark.parametrize("fmi", [4, "2", True, None])
def test_a_bad_fmi_version_is_bad_input_not_an_fmu_failure(tmp_path, fmi):
    # export_fmu(..., fmi=4) raised FMUError (exit 4: "an FMU failed"); it is the caller's argument
    from fmus.build import build_plant_fmu
    from hybridsim.errors import InputError
    from hybridsim.fmi.export import export_fmu

    sub = tmp_path / "sub.yaml"
    sub.write_text("inputs: {u: g.u}\noutputs: {y: g.y}\nblocks:\n  g: {type: gain, K: 2}\n")
    with pytest.raises(InputError, match="FMI version"):
        export_fmu(sub, tmp_path / "x.fmu", fmi=fmi)
    with pytest.raises(InputError, match="FMI version"):
        build_plant_fmu(tmp_path / "p.fmu", fmi=fmi)
    assert not (tmp_path / "x.fmu").exists() and not (tmp_path / "p.fmu").exists()


def test_a_closed_diagram_with_nothing_logged_is_not_exported(tmp_path):
    # FMI 2.0: an FMU of no variable, which fmpy refuses ("Missing child element(s)"); exit 0 before
    from hybridsim.errors import InputError
    from hybridsim.fmi.export import export_fmu

    d = tmp_path / "closed.yaml"
    d.write_text("blocks:\n  s: {type: sine}\n  g: {type: gain, K: 2.0}\nwires: [s.y -> g.u]\n")
    with pytest.raises(InputError, match="nothing to export: the diagram has no outputs"):
        export_fmu(d, tmp_path / "x.fmu")
    assert not (tmp_path / "x.fmu").exists()
