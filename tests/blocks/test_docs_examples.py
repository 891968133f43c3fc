"""Every example diagram of the block-family pages (docs/blocks/examples/) runs and equals an independent answer."""
from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import RegularGridInterpolator

import hybridsim as hs
from test_friction_delay import play
from test_noise import block_normals

DOCS = Path(__file__).resolve().parents[2] / "docs" / "blocks"
EXAMPLES = DOCS / "examples"


def sources(res, t):
    assert np.max(np.abs(res["wave.y[0]"] - 2.0 * np.sin(np.pi * t))) < 1e-12
    s = (t - 0.1) / 0.4
    gate = (t >= 0.1) & (s - np.floor(s) < 0.25)
    assert np.array_equal(res["gate.y[0]"], gate.astype(float))
    np.testing.assert_allclose(res["hiss.y[0]"][:-1], 0.2 * block_normals(7, t.size - 1, 0), rtol=1e-13, atol=1e-15)


def continuous(res, t):
    import control as ct

    s = ct.tf("s")
    loop = ct.feedback((4.0 + 3.0 / s + 0.5 * 50.0 * s / (s + 50.0)) * 2.0 / ((s + 1) * (s + 2)), 1)
    ref = ct.forced_response(loop, T=t, U=np.ones(t.size)).outputs
    assert np.max(np.abs(res["plant.y[0]"] - ref)) < 1e-9


def discrete(res, t):
    import control as ct

    z = ct.tf([1, 0], [1], 0.1)
    loop = ct.feedback((0.5 + 2.0 * 0.1 * (z + 1) / (2 * (z - 1))) * 0.1 / (z - 0.9), 1)
    k = np.arange(t.size - 1)
    ref = ct.forced_response(loop, T=k * 0.1, U=np.ones(k.size)).outputs
    assert np.max(np.abs(res["plant.y[0]"][:-1] - ref)) < 1e-12


def nonlinear(res, t):
    fine = np.linspace(0.0, 4.0, 400_001)
    assert np.max(np.abs(res["gear.y[0]"] - play(np.sin(fine), 0.1, 0.0)[::1000])) < 1e-9
    assert np.max(np.abs(res["friction.y[0]"] - (0.3 * np.sign(np.cos(t)) + 0.1 * np.cos(t)))) < 1e-12


def logic(res, t):
    w = np.sin(2 * np.pi * t)
    assert np.array_equal(res["above.y[0]"], (w > 0.5).astype(float))
    assert np.array_equal(res["hit.count[0]"], np.floor(t - 1 / 12) + 1)  # rising through 0.5 at 1/12 + k s
    assert res["hit.time[0]"][-1] == pytest.approx(1 + 1 / 12, abs=1e-11)
    assert np.max(np.abs(res["top.y[0]"] - np.maximum(w, 0.5 * t))) < 1e-12


def math(res, t):
    assert np.max(np.abs(res["split.y1[0]"] - (t + 1.0))) < 1e-12 and np.all(res["split.y2[0]"] == -2.0)
    rgi = RegularGridInterpolator(([0.0, 1.0, 2.0], [-2.0, 0.0]), np.array([[0.0, 1.0], [2.0, 3.0], [4.0, 8.0]]),
                                  bounds_error=False, fill_value=None)
    assert np.max(np.abs(res["table.y[0]"] - rgi(np.stack([t + 1.0, -2.0 + 0 * t], axis=1)))) < 1e-12


CHECKS = {f.__name__: f for f in (sources, continuous, discrete, nonlinear, logic, math)}


def test_every_example_has_a_check_and_a_page():
    assert sorted(p.stem for p in EXAMPLES.glob("*.yaml")) == sorted(CHECKS)
    for name in CHECKS:
        assert f"examples/{name}.yaml" in (DOCS / f"{name}.md").read_text(), name


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n == "continuous" else n
                                  for n in sorted(CHECKS)])  # 'continuous' runs 11 s
def test_example(name):
    res = hs.simulate(EXAMPLES / f"{name}.yaml")
    CHECKS[name](res, res.t)


def test_every_library_block_is_on_one_family_page():
    from hybridsim.engine.registry import lookup, types

    pages = {p.stem: p.read_text() for p in DOCS.glob("*.md")}
    families = ("sources", "continuous", "discrete", "nonlinear", "logic", "math")
    for name in types():
        cls = lookup(name)
        if hs.registry.group(cls) in ("paper", "robot", "robots", "examples", "FMU"):
            continue
        if not cls.__module__.startswith("hybridsim.blocks."):  # registered by another test or a plugin
            continue
        ref = f".. autoclass:: {cls.__module__}.{cls.__qualname__}"
        on = [f for f in families if ref in pages[f]]
        assert len(on) == 1, (name, on)
