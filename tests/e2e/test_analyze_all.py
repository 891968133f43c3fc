"""`hybridsim analyze` and `hybridsim report` on every shipped diagram (diagrams/*.yaml).

Each diagram runs under an extension of itself with small sweep settings (one servo rate, one
scale, no gain bisection, no comparison), so the test covers every diagram's points, cases and
step in seconds each; the gain references themselves are checked without linearizing.
"""
import json
import warnings

import pytest

from conftest import DIAGRAMS, write
from hybridsim.analysis import stability as an
from hybridsim.api import load
from hybridsim.app.cli import main

SHIPPED = sorted(DIAGRAMS.glob("*.yaml"))
FMU_DIAGRAMS = {"fig9_fmu_cs", "fig9_fmu_me"}


def small(tmp_path, path):
    """An extension of ``path`` with small analysis settings (the diagram's own servo rate only)."""
    f = load(path)
    cfg = an.settings_of(f)
    rate = f.params.get(cfg["rate_param"])
    text = (f"extends: {path}\nname: {path.stem}_small\nanalysis:\n"
            f"  rates: [{rate if isinstance(rate, (int, float)) else 60}]\n"
            "  scales: [1.0]\n  gains: {}\n  compare: {}\n")
    return write(tmp_path, text, name=f"{path.stem}_small.yaml")


@pytest.fixture(scope="module")
def plant_fmu(tmp_path_factory):
    from hybridsim.fmus.build import build_plant_fmu

    return build_plant_fmu(tmp_path_factory.mktemp("fmu") / "plant.fmu")


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_every_gain_and_case_names_a_parameter_the_diagram_has(path):
    """The sweeps' and the step's references resolve (fig9_generic and fig10_generic inherited the Fig 6 controller's)."""
    f = load(path)
    cfg = an.settings_of(f)
    for name, ref in cfg["gains"].items():
        assert an.param_value(f, ref).size, (name, ref)
    changes = [{**cfg["set"], **ov} for ov in cfg["cases"].values()]
    if cfg.get("step"):  # the report's step: its change applies to this diagram's blocks
        changes.append({**cfg["set"], **cfg["step"]["set"]})
    for ov in changes:
        f = load(path, **ov)
        if path.stem not in FMU_DIAGRAMS:  # (building those needs the FMU: the slow test below)
            f.build()  # an unknown block or parameter raises here


def one_variant(path):
    """--set options fixing every swept parameter to its first value (the report analyses each
    variant; one is enough here, except for the cheap continuous diagrams)."""
    if path.stem in ("eq18_hand_oscillation", "bouncing_ball"):
        return []
    out = []
    for key, values in (load(path).data.get("variants") or {}).items():
        out += ["--set", f"{key}={json.dumps(values[0])}"]
    return out


@pytest.mark.slow
@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_analyze_and_report_run_on_every_shipped_diagram(path, tmp_path, capsys, plant_fmu):
    d = small(tmp_path, path)
    extra = ["--set", f"fmu={plant_fmu}"] if path.stem in FMU_DIAGRAMS else []
    extra += one_variant(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        code = main(["analyze", str(d), "-o", str(tmp_path / "an"), *extra])
        out, err = capsys.readouterr()
        if path.stem == "fig9_fmu_cs":  # its plant's states are inside the FMU: refused, with the reason
            assert code == 2 and "keep their state inside (a Co-Simulation FMU)" in err
            assert main(["report", str(d), "-o", str(tmp_path / "rep"), *extra]) == 2
            return
        assert code == 0, err
        res = json.loads((tmp_path / "an" / "analysis.json").read_text())
        assert res["poles"] and res["domain"] in ("discrete", "continuous")
        assert "NOT STABLE" in out or "STABLE" in out
        for name, loop in res["loops"].items():
            assert "error" not in loop, (name, loop)  # every declared loop point opens
        assert main(["report", str(d), "-o", str(tmp_path / "rep"), *extra]) == 0, capsys.readouterr().err
    html = (tmp_path / "rep" / "report.html").read_text()
    assert "<h1>Stability report" in html and (tmp_path / "rep" / "poles.png").exists()
    for name in res["loops"]:
        assert (tmp_path / "rep" / f"bode_{name}.png").exists(), name


@pytest.mark.slow
def test_the_generic_controller_has_the_fig6_controllers_linear_loop():
    """Fig 9 through the generic 6-D controller (URDF kinematics, hybrid_control_6d) and through the
    Fig 6 subsystem: the same law, so the same closed-loop poles and loop margins."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        paper = an.analyze(DIAGRAMS / "fig9_force_and_position.yaml", sweeps=False)
        generic = an.analyze(DIAGRAMS / "fig9_generic.yaml", sweeps=False)
    assert generic["growth"] == pytest.approx(paper["growth"], rel=1e-6)
    for loop in ("force", "position"):
        for key in ("gain_margin_db", "phase_margin_deg"):
            a, b = paper["loops"][loop][key], generic["loops"][loop][key]
            assert (a is None and b is None) or b == pytest.approx(a, rel=1e-4, abs=1e-6), (loop, key)
    for case in ("friction_stuck", "limiter_saturated"):
        assert generic["cases"][case]["spectral_radius"] == pytest.approx(paper["cases"][case]["spectral_radius"], rel=1e-6)


@pytest.mark.slow
def test_the_model_exchange_fmu_plant_has_the_python_plants_linear_loop(plant_fmu):
    """Fig 9 with the plant as a Model Exchange FMU and with the Python plant: the same closed loop.
    (The linearization once took a fresh context's held values as zeros - the FMU's surface position
    input among them - and put the FMU's hand half a metre into the surface.)"""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        paper = an.analyze(DIAGRAMS / "fig9_force_and_position.yaml", sweeps=False)
        fmu = an.analyze(DIAGRAMS / "fig9_fmu_me.yaml", sweeps=False, fmu=str(plant_fmu))
    assert fmu["growth"] == pytest.approx(paper["growth"], rel=1e-6)
    for loop in ("force", "position"):
        for key in ("gain_margin_db", "phase_margin_deg"):
            a, b = paper["loops"][loop][key], fmu["loops"][loop][key]
            assert (a is None and b is None) or b == pytest.approx(a, rel=1e-4, abs=1e-6), (loop, key)
    for case in ("friction_stuck", "limiter_saturated"):
        assert fmu["cases"][case]["spectral_radius"] == pytest.approx(paper["cases"][case]["spectral_radius"], rel=1e-6)
