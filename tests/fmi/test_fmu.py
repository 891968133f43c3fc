"""FMU export and import: a valid FMU, the same answers as the Python plant,
a plain C host and a second importer (libcosimpy) run it, foreign FMUs import."""
import ctypes
import os
import shutil
import subprocess
import sys
import zipfile

import numpy as np
import pytest

import hybridsim as hs
from hybridsim.app.cli import main
from hybridsim.errors import FMUError
from hybridsim.fmi.fmu_block import FMUBlock, build_fmu, fmi_headers
from hybridsim.fmus.build import build_plant_fmu

from conftest import DIAGRAMS, ROOT

pytestmark = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                                reason="no C compiler")


@pytest.fixture(scope="module")
def plant(tmp_path_factory):
    return build_plant_fmu(tmp_path_factory.mktemp("fmu") / "plant.fmu")


@pytest.fixture(scope="module")
def plant3(tmp_path_factory):
    return build_plant_fmu(tmp_path_factory.mktemp("fmu3") / "plant3.fmu", fmi=3)


@pytest.fixture(params=[2, 3], ids=["fmi2", "fmi3"])
def any_plant(request, plant, plant3):
    """The plant FMU as FMI 2.0 and as FMI 3.0."""
    return plant if request.param == 2 else plant3


@pytest.fixture(scope="module", params=["vdp", "vdp3"], ids=["fmi2", "fmi3"])
def vdp(request, tmp_path_factory):
    """The same Van der Pol oscillator as an FMI 2.0 and as an FMI 3.0 FMU."""
    name = request.param
    d = ROOT / "tests" / "data" / name
    sources = sorted(d.glob("*.c"))
    return build_fmu(tmp_path_factory.mktemp(name) / f"{name}.fmu", name, sources,
                     (d / "modelDescription.xml").read_text(), {})


def test_fmpy_validation_finds_no_problem(plant, plant3):
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(plant)) == [] and validate_fmu(str(plant3)) == []
    names = zipfile.ZipFile(plant).namelist()
    assert "sources/plant.c" in names and "sources/plant_vars.h" in names and "sources/plant_core.h" in names
    assert any(n.startswith("binaries/linux64/") for n in names)
    names = zipfile.ZipFile(plant3).namelist()
    assert {"sources/plant3.c", "sources/buildDescription.xml", "sources/plant_core.h"} <= set(names)
    assert any(n.startswith("binaries/x86_64-linux/") for n in names)


def test_fmi2_and_fmi3_plants_give_the_same_answer_in_fmpy(plant, plant3):
    import fmpy

    for mode in ("CoSimulation", "ModelExchange"):
        kw = dict(stop_time=0.3, fmi_type=mode, output=["F[1]", "q[2]", "contact"], output_interval=1 / 600)
        r2, r3 = fmpy.simulate_fmu(str(plant), **kw), fmpy.simulate_fmu(str(plant3), **kw)
        assert np.array_equal(r2["F[1]"], r3["F[1]"]) and np.array_equal(r2["contact"], r3["contact"]), mode
        # unforced, the hand sits on the surface at the 10 N preload: F1 = 10 cos(q1) N in the hand frame
        assert r3["F[1]"][0] == pytest.approx(10.0 * np.cos(np.arctan2(0.153, np.sqrt(0.50002361111 ** 2 - 0.153 ** 2))), rel=1e-9)


def test_xml_and_c_table_come_from_one_source():
    from hybridsim.fmus import plant_model as pm

    xml, header = pm.model_description(), pm.vars_header()
    for k, v in enumerate(pm.all_variables()):
        assert f'name="{v[0]}" valueReference="{k}"' in xml
        assert f"#define {pm.c_name(v[0])} {k} " in header
    assert pm.guid() in xml and pm.guid() in header


@pytest.mark.slow
@pytest.mark.parametrize("extra", [{}, {"friction": False, "joint_damping": [100.0, 1000.0],
                                        "wrist_damping": 50.0, "surface_damping": 50.0}],
                         ids=["friction-on", "friction-off-damped"])
def test_fmu_plant_matches_python_plant_fig9(any_plant, extra):
    plant = any_plant
    common = dict(rate=60, t_end=0.18, log_period=1 / 60, **extra)  # before the printed model loses contact
    for mode in ("cs", "me"):
        # an ME FMU's event indicators go through event mode, located: compare with the
        # Python plant locating the same switches (a CS FMU steps over them inside doStep)
        ref = hs.simulate(DIAGRAMS / "fig9_force_and_position.yaml", locate_switches=mode == "me", **common)
        res = hs.simulate(DIAGRAMS / f"fig9_fmu_{mode}.yaml", fmu=str(plant), **common)
        # measured: 7.5e-15 N (CS), 0 (ME); friction off, the FMU still reports its stick-band
        # indicators, whose (empty) events restart the step grid: 5.2e-8 N (ME)
        tol = 1e-6 if mode == "me" and extra else 1e-9
        # the row at t_end (off the log grid): a CS FMU's outputs there are the last hit's, held
        rows = res.t < 0.18 - 1e-9 if mode == "cs" else slice(None)
        assert np.max(np.abs(res["ctrl.ft.CF[0]"][rows] - ref["ctrl.ft.CF[0]"][rows])) < tol, mode
        assert np.max(np.abs(res["ctrl.fk.X[1]"][rows] - ref["ctrl.fk.X[1]"][rows])) < tol * 1e-3, mode


@pytest.mark.slow
def test_fmu_plant_matches_python_plant_fig7(any_plant):
    plant = any_plant
    ov = {"rate": 60, "force0": 0.0, "force_cmd.initial": [0.0, 0.0],
          "force_cmd.final": [5.0, 0.0], "force_cmd.time": 0.5, "pos_cmd.amplitude": [0.0, 0.0],
          "pos_cmd.offset": [0.5, 0.0], "t_end": 2.0, "log_period": 1 / 60}
    for mode, tol in (("cs", 1e-5), ("me", 1e-9)):
        ref = hs.simulate(DIAGRAMS / "fig9_force_and_position.yaml", locate_switches=mode == "me", **ov)
        res = hs.simulate(DIAGRAMS / f"fig9_fmu_{mode}.yaml", fmu=str(plant), **ov)
        # a CS FMU's outputs are samples held until its next hit, so the row at t_end
        # shows the last hit's value; before it, measured 1.6e-7 N (CS) and 0 (ME)
        before = res.t < 2.0 - 1e-9
        assert np.max(np.abs(res["ctrl.ft.CF[0]"][before] - ref["ctrl.ft.CF[0]"][before])) < tol, mode


def test_plant_fmu_computes_its_balanced_start(any_plant):
    import fmpy

    # balance = 1: the start endpoint is surface_x0 + preload (1/Kr + 1/Kw), endpoint0[1] unused
    start = {"balance": 1.0, "surface_x0": 0.6, "x_surface": 0.6, "preload": 5.0, "Kr": 1.0e6, "endpoint0[1]": 0.9}
    r = fmpy.simulate_fmu(str(any_plant), stop_time=0.01, output=["q[1]", "q[2]", "F[1]", "fx"],
                          start_values=start, output_interval=0.01)
    q1, q2 = r["q[1]"][0], r["q[2]"][0]
    assert q2 * np.cos(q1) + 0.153 * np.sin(q1) == pytest.approx(0.6 + 5.0 / 1e6 + 5.0 / 8e5, abs=1e-13)  # eq 1
    assert r["fx"][0] == pytest.approx(5.0, abs=1e-9)  # the surface carries the preload: in balance


def test_state_save_and_restore_reproduces_a_run(plant):
    import fmpy
    from fmpy.fmi2 import FMU2Slave
    from fmpy.model_description import read_model_description

    md = read_model_description(str(plant))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unz = fmpy.extract(str(plant))
    try:
        fmu = FMU2Slave(guid=md.guid, unzipDirectory=unz, modelIdentifier=md.coSimulation.modelIdentifier)
        fmu.instantiate()
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        fmu.setReal([vr["tau[1]"], vr["tau[2]"]], [-20.0, 12.0])  # breaks joint 1 loose: the state moves
        for k in range(5):
            fmu.doStep(k / 60, 1 / 60)
        saved = fmu.getFMUstate()
        first = []
        for k in range(5, 15):
            fmu.doStep(k / 60, 1 / 60)
            first.append(fmu.getReal([vr["fx"]])[0])
        fmu.setFMUstate(saved)
        again = []
        for k in range(5, 15):
            fmu.doStep(k / 60, 1 / 60)
            again.append(fmu.getReal([vr["fx"]])[0])
        fmu.freeFMUstate(saved)
        fmu.terminate()
        fmu.freeInstance()
    finally:
        shutil.rmtree(unz, ignore_errors=True)
    assert first == again and abs(first[0] - first[-1]) > 1e-3


def test_plain_c_host_runs_the_fmu(plant, tmp_path):
    from hybridsim.fmus import plant_model as pm

    cc = shutil.which("cc") or shutil.which("gcc")
    exe = tmp_path / "host"
    subprocess.run([cc, "-std=c99", "-I", str(fmi_headers()), str(ROOT / "tests" / "data" / "host.c"),
                    "-o", str(exe), "-ldl"], check=True)
    zipfile.ZipFile(plant).extractall(tmp_path / "x")
    lib = tmp_path / "x" / "binaries" / "linux64" / "hybridsim_plant.so"
    out = subprocess.run([str(exe), str(lib), pm.guid()], capture_output=True, text=True, check=True)
    fx = float(out.stdout.split()[1])
    assert fx == pytest.approx(10.0, abs=0.01)  # held in static balance at the 10 N preload


def test_libcosimpy_runs_the_fmu(plant):
    lc = pytest.importorskip("libcosimpy.CosimExecution")
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    ex = lc.CosimExecution.from_step_size(step_size=int(1e9 / 60))
    idx = ex.add_local_slave(CosimLocalSlave(fmu_path=str(plant), instance_name="plant"))
    obs = CosimObserver.create_last_value()
    ex.add_observer(obs)
    ex.real_initial_value(idx, 1, 9.52036156)  # tau[2]: the preload's joint force
    assert ex.simulate_until(int(0.5e9))
    q1, q2, fx = obs.last_real_values(idx, [4, 5, 12])
    assert fx == pytest.approx(10.0, abs=0.01) and q2 == pytest.approx(0.47604, abs=1e-4)


def test_foreign_fmu_in_a_diagram(vdp):
    from scipy.integrate import solve_ivp

    ref = solve_ivp(lambda t, z: [z[1], 1.5 * (1 - z[0] ** 2) * z[1] - z[0]], (0, 3), [2.0, 0.0],
                    rtol=1e-10, atol=1e-12, dense_output=True)
    for mode, extra, tol in (("me", {}, 1e-6), ("cs", {"rate": 100}, 1e-6)):
        d = hs.Diagram("vdp")
        d.add(FMUBlock("osc", path=str(vdp), mode=mode, parameters={"mu": 1.5}, **extra))
        res = hs.Simulator(d.build(), hs.RK4(1e-3), log=["osc.y"], log_period=0.01).run(3.0)
        m = res.t < 3.0 - 1e-9  # a CS output at t_end is the last hit's, held
        assert res["osc.y[0]"][m] == pytest.approx(ref.sol(res.t[m])[0], abs=tol), mode


def test_fmu_errors_are_clear(plant, tmp_path):
    from hybridsim.errors import ParameterError

    # a path to nothing, or to a folder, is the user's input (exit 2), not the FMU's failing (4)
    with pytest.raises(ParameterError, match="'path' names no file"):
        FMUBlock(path=str(tmp_path / "nope.fmu"))
    with pytest.raises(ParameterError, match="'path' is a folder, not an .fmu file"):
        FMUBlock(path=str(tmp_path))
    (tmp_path / "x").mkdir()
    (tmp_path / "x" / "modelDescription.xml").write_text("<fmiModelDescription/>")
    with pytest.raises(ParameterError, match="an extracted FMU: zip its contents back into one"):
        FMUBlock(path=str(tmp_path / "x"))
    (tmp_path / "junk.fmu").write_text("not a zip")
    with pytest.raises(FMUError, match="not a zip"):
        FMUBlock(path=str(tmp_path / "junk.fmu"))
    with pytest.raises(ParameterError, match="a variable the FMU does not have: 'Kww' \\(did you mean 'Kw'"):  # the diagram's (exit 2)
        FMUBlock(path=str(plant), rate=60, parameters={"Kww": 1.0})
    with pytest.raises(ParameterError, match="Kw is one value: give a number, got \\[1.0, 2.0\\]"):  # check passed it
        FMUBlock(path=str(plant), rate=60, parameters={"Kw": [1.0, 2.0]})
    # no binary for this platform
    nobin = tmp_path / "nobin.fmu"
    with zipfile.ZipFile(plant) as src, zipfile.ZipFile(nobin, "w") as dst:
        for n in src.namelist():
            if not n.startswith("binaries/"):
                dst.writestr(n, src.read(n))
    with pytest.raises(FMUError, match="no binary for this platform"):
        FMUBlock(path=str(nobin), rate=60)
    # wrong FMI version
    old = tmp_path / "old.fmu"
    with zipfile.ZipFile(plant) as src, zipfile.ZipFile(old, "w") as dst:
        for n in src.namelist():
            data = src.read(n)
            if n == "modelDescription.xml":
                data = data.replace(b'fmiVersion="2.0"', b'fmiVersion="1.0"')
            dst.writestr(n, data)
    with pytest.raises(FMUError, match="FMI version|modelDescription"):
        FMUBlock(path=str(old), rate=60)


def test_fmu_call_error_carries_the_fmus_message_and_cleans_up(plant, capsys):
    code = main(["run", str(DIAGRAMS / "fig9_fmu_cs.yaml"), "-q", "--set", f"fmu={plant}",
                 "--set", "rate=60", "--set", "plant.parameters={stick_time: 0}",
                 "--set", "simulation.t_end=0.1", "-o", str(plant.parent / "out")])
    err = capsys.readouterr().err
    assert code == 4 and "exitInitializationMode failed" in err and "must be positive" in err
    assert "Traceback" not in err


def test_cli_builds_the_fmu(tmp_path, capsys):
    from fmpy import read_model_description

    assert main(["fmu", "build", "-o", str(tmp_path / "p.fmu")]) == 0
    assert read_model_description(str(tmp_path / "p.fmu")).fmiVersion == "2.0"
    assert main(["fmu", "build", "--fmi", "3", "-o", str(tmp_path / "p3.fmu")]) == 0
    assert read_model_description(str(tmp_path / "p3.fmu")).fmiVersion == "3.0"
    assert "FMI 3.0" in capsys.readouterr().out
    with pytest.raises(SystemExit) as e:
        main(["fmu", "build", "--fmi", "4", "-o", str(tmp_path / "p4.fmu")])
    assert e.value.code == 2 and not (tmp_path / "p4.fmu").exists()


def test_model_structure_feeds_the_algebraic_loop_check(plant):
    # fx depends directly on the x_surface input (model structure): fx -> x_surface is a loop
    d = hs.Diagram("loop")
    d.add(FMUBlock("p", path=str(plant), mode="me"))
    d.add(hs.registry.lookup("gain")("g", K=1e-9))
    d.add(hs.registry.lookup("constant")("c", value=[0.0, 0.0]))
    d.add(hs.registry.lookup("constant")("v", value=0.0))
    for a, b in [("c.y", "p.tau"), ("p.fx", "g.u"), ("g.y", "p.x_surface"), ("v.y", "p.v_surface")]:
        d.connect(a, b)
    with pytest.raises(hs.DiagramError, match="algebraic loop"):
        d.build()
    assert FMUBlock("p", path=str(plant), mode="me").outputs[0].depends_on == ()  # q: states only


def test_a_co_simulation_stop_request_ends_the_run_cleanly(vdp):
    d = hs.Diagram("vdp")
    d.add(FMUBlock("osc", path=str(vdp), mode="cs", rate=100, parameters={"mu": 1.5, "t_stop": 1.0}))
    res = hs.Simulator(d.build(), hs.RK4(1e-3), log=["osc.y"], log_period=0.01).run(3.0)
    assert res.meta["stopped"]["block"] == "osc" and res.meta["stopped"]["t"] == pytest.approx(1.0)
    assert res.meta["stopped"]["reason"] in ("terminateSimulation", "doStep discarded the step (fmi2Discard)")
    assert res.t[-1] == pytest.approx(1.0) and len(res.t) == 101  # every row up to the stop


def test_unwired_inputs_take_their_start_values_and_check_says_so(plant, tmp_path, capsys):
    from hybridsim.app.cli import main

    diagram = tmp_path / "alone.yaml"
    diagram.write_text(f"blocks:\n  plant: {{type: fmu, path: {plant}, mode: cs, rate: 100}}\n"
                       "simulation: {t_end: 0.05}\nlog: [plant.F]\n")
    assert main(["check", str(diagram)]) == 0
    err = capsys.readouterr().err
    assert "input plant.x_surface is not wired: it takes its default [0.5]" in err
    res = hs.simulate(diagram)
    assert np.all(np.isfinite(res["plant.F"]))


@pytest.mark.slow
def test_fmpy_rebuilds_the_plant_from_its_sources(any_plant, tmp_path):
    import fmpy

    plant = any_plant
    if shutil.which("cmake") is None:
        pytest.skip("fmpy rebuilds binaries with cmake")
    from fmpy.build import build_platform_binary

    bare = tmp_path / "bare.fmu"  # the FMU as another platform sees it: sources, no binary it can load
    with zipfile.ZipFile(plant) as z, zipfile.ZipFile(bare, "w") as out:
        for n in z.namelist():
            if not n.startswith("binaries/"):
                out.writestr(n, z.read(n))
    unzipped = fmpy.extract(str(bare), unzipdir=tmp_path / "x")
    build_platform_binary(unzipped)  # reads <SourceFiles> / buildDescription.xml (an IndexError without)
    ref = fmpy.simulate_fmu(str(plant), stop_time=0.05, fmi_type="CoSimulation", output=["F[1]"])
    got = fmpy.simulate_fmu(str(unzipped), stop_time=0.05, fmi_type="CoSimulation", output=["F[1]"])
    assert np.array_equal(ref["F[1]"], got["F[1]"])


def test_plant_fmu_answers_in_initialization_mode_and_keeps_fixed_parameters(any_plant):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.fmi3 import FMU3Slave

    plant = any_plant
    md = read_model_description(str(plant))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmi3 = md.fmiVersion == "3.0"
    fmu = (FMU3Slave if fmi3 else FMU2Slave)(
        guid=md.guid, unzipDirectory=extract(str(plant)), modelIdentifier=md.coSimulation.modelIdentifier)
    get, set_ = (fmu.getFloat64, fmu.setFloat64) if fmi3 else (fmu.getReal, fmu.setReal)
    fmu.instantiate()
    try:
        if fmi3:
            fmu.enterInitializationMode(startTime=0.0)
        else:
            fmu.setupExperiment(startTime=0.0)
            fmu.enterInitializationMode()
        q2 = get([vr["q[2]"]])[0]
        # q2 = sqrt(X^2 + Y^2 - l^2) of the start endpoint (0.5 + 10 (1/9e5 + 1/8e5), 0), l = 0.153 m: not 0 any more
        assert q2 == pytest.approx(np.sqrt((0.5 + 10 / 9e5 + 10 / 8e5) ** 2 - 0.153 ** 2), rel=1e-12)
        fmu.exitInitializationMode()
        with pytest.raises(Exception, match="status 3|fmi3Error|Error"):
            set_([vr["Kw"]], [1.0e5])  # fixed: refused after initialization
        if fmi3:
            assert fmu.getBoolean([vr["contact"]]) == [True]  # a Boolean output, not a Real
    finally:
        fmu.terminate()
        fmu.freeInstance()


def _fmu_folders():
    import tempfile

    return {p for p in os.listdir(tempfile.gettempdir()) if p.startswith("hybridsim-fmu-")}


@pytest.mark.parametrize("case", ["setup fails", "run diverges", "interrupted"])
def test_no_instance_or_folder_is_left_after_a_failure(plant, case, monkeypatch, tmp_path):
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))  # a folder of its own: other runs share /tmp
    before = _fmu_folders()
    extra = {"rate": 60, "t_end": 0.5, "fmu": str(plant)}
    if case == "setup fails":
        extra["plant.parameters"] = {"stick_time": 0.0}  # min="0" passes; the FMU refuses 0
        expected = hs.FMUError
    elif case == "run diverges":  # the plant FMU reports the divergence itself: an FMU error mid-run
        extra["ctrl.fpi.Ki"] = [1e9, 1e9]
        expected = (hs.FMUError, hs.SimulationError)
    else:
        from hybridsim.fmi.fmu_block import FMUBlock

        real = FMUBlock.update

        def interrupt(self, t, x, u):
            if t > 0.1:
                raise KeyboardInterrupt
            return real(self, t, x, u)

        monkeypatch.setattr(FMUBlock, "update", interrupt)
        expected = KeyboardInterrupt
    system, sim, _ = hs.build(DIAGRAMS / "fig9_fmu_cs.yaml", **extra)
    with pytest.raises(expected):
        sim.run(0.5)
    blk = system.block("plant")
    assert blk._fmu is None and blk._unzipdir is None  # terminated, freed, folder removed
    assert _fmu_folders() <= before


@pytest.mark.slow
def test_fmpy_keeps_its_own_logger_after_an_fmu_block_is_freed(plant):
    """fmpy's message formatter forwards to one global logger; a freed FMU block must not own it.

    Before the fix the formatter forwarded to the closed block's callback: the
    message was lost, or the process crashed (a segmentation fault in CI).
    """
    script = f"""
import gc
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from hybridsim.fmi.fmu_block import FMUBlock
from hybridsim.errors import FMUError

b = FMUBlock("p", path={str(plant)!r}, rate=60, parameters={{"stick_time": 0.0}})
try:
    b._instantiate()  # the plant refuses the parameter: its message reaches the block
except FMUError as e:
    assert "stick_time" in str(e), e
b.close(); del b; gc.collect()
md = read_model_description({str(plant)!r})
vr = {{v.name: v.valueReference for v in md.modelVariables}}
fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract({str(plant)!r}), modelIdentifier=md.coSimulation.modelIdentifier)
fmu.instantiate()
fmu.setupExperiment(startTime=0.0); fmu.enterInitializationMode(); fmu.exitInitializationMode()
try:
    fmu.setReal([vr["Kw"]], [1.0e5])
except Exception:
    pass
fmu.terminate(); fmu.freeInstance()
"""
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "[ERROR]" in r.stdout and "fixed parameter" in r.stdout  # fmpy printed the plant's message, formatted


def test_the_plant_fmu_has_the_stribeck_friction_of_the_python_arm(any_plant):
    """Joint accelerations of a sliding arm with no wrist force: the FMU's and the Python block's."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Model
    from fmpy.fmi3 import FMU3Model

    from hybridsim.blocks.paper.manipulator import Manipulator

    dbl = ctypes.POINTER(ctypes.c_double)
    md = read_model_description(str(any_plant))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmi3 = md.fmiVersion == "3.0"
    fmu = (FMU3Model if fmi3 else FMU2Model)(guid=md.guid, unzipDirectory=extract(str(any_plant)),
                                             modelIdentifier=md.modelExchange.modelIdentifier)
    fmu.instantiate()
    try:
        if fmi3:
            fmu.enterInitializationMode(startTime=0.0)
            fmu.setBoolean([vr["stribeck"]], [True])
            fmu.setFloat64([vr["stribeck_velocity[2]"]], [2e-3])
        else:
            fmu.setupExperiment(startTime=0.0)
            fmu.enterInitializationMode()
            fmu.setBoolean([vr["stribeck"]], [True])
            fmu.setReal([vr["stribeck_velocity[2]"]], [2e-3])
        fmu.exitInitializationMode()
        (fmu.updateDiscreteStates if fmi3 else fmu.newDiscreteStates)()
        fmu.enterContinuousTimeMode()
        arm = Manipulator(q0=(0.3, 0.5), friction_model="stribeck", stribeck_velocity=(1e-3, 2e-3))
        get = fmu.getContinuousStateDerivatives if fmi3 else fmu.getDerivatives
        for v in (3e-3, -5e-3, 0.05):
            x = np.array([0.3, 0.5, 0.0, v, 0.0, 0.0, 0.0, 0.0])  # no wrist deflection: no wrist force
            fmu.setContinuousStates(x.ctypes.data_as(dbl), 8)
            dx = np.zeros(8)
            get(dx.ctypes.data_as(dbl), 8)
            ref = arm.derivatives(0, x[:4], [np.zeros(2), np.zeros(2)])
            assert dx[3] == pytest.approx(ref[3], rel=1e-12), v
    finally:
        fmu.terminate()
        fmu.freeInstance()


# -- the plant's model description and its checks (one test per item) ------------------------

def _md(plant):
    from fmpy.model_description import read_model_description

    return read_model_description(str(plant))


def test_plant_refuses_an_invalid_parameter_with_its_own_message(any_plant):
    with pytest.raises(FMUError, match=r"exitInitializationMode failed.*stick_time = 0 must be positive"):
        FMUBlock("p", path=str(any_plant), rate=60, parameters={"stick_time": 0.0})._instantiate()


def test_plant_refuses_a_non_finite_input_with_its_own_message(any_plant):
    from fmpy import extract
    from fmpy.fmi2 import FMU2Slave
    from fmpy.fmi3 import FMU3Slave

    md = _md(any_plant)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmi3 = md.fmiVersion == "3.0"
    said = []
    fmu = (FMU3Slave if fmi3 else FMU2Slave)(guid=md.guid, unzipDirectory=extract(str(any_plant)),
                                             modelIdentifier=md.coSimulation.modelIdentifier)
    if fmi3:
        fmu.instantiate(loggingOn=True, logMessage=lambda env, status, cat, msg: said.append(msg.decode()))
        fmu.enterInitializationMode(startTime=0.0)
    else:
        fmu.instantiate(loggingOn=True)
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    try:
        with pytest.raises(Exception, match="status 3|Error"):
            (fmu.setFloat64 if fmi3 else fmu.setReal)([vr["tau[1]"]], [float("nan")])
        if fmi3:
            assert said == ["tau[1] = nan: not a finite number (refused)"]
    finally:
        fmu.terminate()
        fmu.freeInstance()


def test_plant_declares_base_units(any_plant):
    units = {u.name: u.baseUnit for u in _md(any_plant).unitDefinitions}
    n = units["N"]
    assert (n.kg, n.m, n.s) == (1, 1, -2)
    assert (units["N.m.s/rad"].kg, units["N.m.s/rad"].m, units["N.m.s/rad"].s, units["N.m.s/rad"].rad) == (1, 2, -1, -1)
    assert all(u is not None for u in units.values())


def test_plant_positive_parameters_have_a_min(any_plant, capsys):
    by = {v.name: v for v in _md(any_plant).modelVariables}
    for name in ("Kw", "Kr", "M2", "M3", "stick_time", "stick_band", "max_substep", "bw"):
        assert float(by[name].min) == 0.0, name
    with pytest.raises(hs.ParameterError, match=r"max_substep = -1.0 is outside its range: min = 0"):
        FMUBlock("p", path=str(any_plant), rate=60, parameters={"max_substep": -1.0})
    with pytest.raises(hs.ParameterError, match=r"friction is a Boolean variable of the FMU: give true or false"):
        FMUBlock("p", path=str(any_plant), rate=60, parameters={"friction": 2})  # was set as true
    with pytest.raises(hs.ParameterError, match=r"friction is a Boolean variable of the FMU: give true or false"):
        FMUBlock("p", path=str(any_plant), rate=60, parameters={"friction": "yes"})  # said "a finite number"
    with pytest.raises(hs.ParameterError, match=r"balance is a (Real|Float64) variable of the FMU: give a number, got True"):
        FMUBlock("p", path=str(any_plant), rate=60, parameters={"balance": True})  # 'yes': set as 1.0, silently
    # an output array given one value was asked for its length; an index on a scalar suggested an output
    with pytest.raises(hs.ParameterError, match=r"q is an output variable of the FMU .*: it cannot be set"):
        FMUBlock("p", path=str(any_plant), rate=60, parameters={"q": 1.0})
    with pytest.raises(hs.ParameterError, match=r"Kw\[1\]: Kw is one value of the FMU, not an array: set it as Kw"):
        FMUBlock("p", path=str(any_plant), rate=60, parameters={"Kw[1]": 4.0})
    assert FMUBlock("p", path=str(any_plant), rate=60, parameters={"friction": 0}).parameters == {"friction": 0}


def test_plant_default_experiment_has_a_tolerance(any_plant):
    de = _md(any_plant).defaultExperiment
    assert float(de.tolerance) == 1e-6 and float(de.stopTime) == 4.0


def test_plant_names_its_generation_tool_date_and_version(any_plant):
    md = _md(any_plant)
    assert md.generationTool.startswith("hybridsim ") and md.generationDateAndTime.startswith("20")
    assert md.version


def test_plant_fmi2_model_exchange_needs_no_completed_integrator_step(plant):
    import xml.etree.ElementTree as ET

    with zipfile.ZipFile(plant) as z:
        me = ET.fromstring(z.read("modelDescription.xml")).find("ModelExchange")
    assert me.get("completedIntegratorStepNotNeeded") == "true"


def test_an_fmu_file_replaced_on_disk_is_read_again(plant, vdp, tmp_path):
    # the model description is read once per process for each version of the file (a sweep builds
    # the same block again and again); a new file at the same path is a new version
    path = tmp_path / "model.fmu"
    shutil.copy(plant, path)
    assert "tau" in [p.name for p in FMUBlock("a", path=str(path), mode="me").inputs]
    shutil.copy(vdp, path)
    assert [p.name for p in FMUBlock("b", path=str(path), mode="me").outputs] == ["y"]


def test_a_fractional_value_for_an_integer_parameter_is_refused_not_rounded():
    # parameters: {Kp: 2.7} on an Integer parameter ran with 3, silently
    from types import SimpleNamespace

    from hybridsim.errors import ParameterError
    from hybridsim.fmi.variables import _settable

    var = SimpleNamespace(name="Kp", type="Integer", causality="parameter", variability="fixed", initial=None,
                          start="2", min=None, max=None)
    assert _settable(var, 3) == 3 and _settable(var, 3.0) == 3.0
    with pytest.raises(ParameterError, match="Kp is an Integer variable of the FMU: give a whole number, got 2.7"):
        _settable(var, 2.7)


@pytest.mark.slow
def test_an_indicator_an_event_leaves_at_zero_is_in_fmis_nonpositive_domain(plant, tmp_path):
    # bilateral contact: after the contact event the plant's indicator is exactly 0, then negative.
    # Read as "leaving zero" that fired again and again: "events accumulate at t = 0.00634 s"
    # (CVODE at rtol 1e-9 and 1e-7); FMI's domains are z > 0 and z <= 0, and fmpy runs through.
    path = tmp_path / "bilateral.yaml"
    path.write_text(f"""
blocks:
  tau: {{type: constant, value: [2.0, -1.0]}}
  xs: {{type: constant, value: 0.5}}
  plant: {{type: fmu, path: {plant}, mode: me,
          parameters: {{friction: false, unilateral: false, b: [1.0, 10.0], bw: 5.0}}}}
wires: [tau.y -> plant.tau, xs.y -> plant.x_surface, xs.dy -> plant.v_surface]
simulation: {{t_end: 0.05, solver: cvode, rtol: 1.0e-9}}
log: [plant.q]
""")
    ref = hs.simulate(path, **{"simulation.solver": "radau"})
    for rtol in (1e-9, 1e-7):
        res = hs.simulate(path, **{"simulation.rtol": rtol})
        assert np.abs(res["plant.q"][-1] - ref["plant.q"][-1]).max() < 1e-5
        assert len(res.meta["events"]) == len(ref.meta["events"])


def test_a_rate_on_a_model_exchange_fmu_is_refused(plant, tmp_path):
    # it was dropped silently: check said "rates none"
    p = tmp_path / "me.yaml"
    p.write_text(f"blocks:\n  plant: {{type: fmu, path: {plant}, mode: me,\n          rate: 100}}\n")
    with pytest.raises(hs.DiagramError) as err:
        hs.check(p)
    assert any("me.yaml:3" in m and "parameter 'rate' is a Co-Simulation FMU's (mode: cs)" in m
               for m in err.value.problems), err.value.problems
