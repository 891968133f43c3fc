"""The force-control wing: its metrics and modes on hand-checked numbers, and the generic layers without it."""
import numpy as np
import pytest

from conftest import GOOD, write
from hybridsim.analysis import extras
from hybridsim.analysis import metrics as generic
from hybridsim.forcecontrol.metrics import compute, contact_report, describe, display_filter
from hybridsim.forcecontrol.modes import hand_modes
from hybridsim.format import tables
from hybridsim.report import figures


def test_contact_report_finds_the_first_loss_after_contact_was_made():
    t = np.arange(6) * 0.1
    assert contact_report(t, [0, 1, 1, 0, 0, 1]) == {"contact_lost": True, "first_loss_s": pytest.approx(0.3),
                                                     "time_out_of_contact_s": pytest.approx(0.2)}
    assert contact_report(t, [0, 0, 1, 1, 1, 1])["contact_lost"] is False  # not yet made is not lost
    assert contact_report(t, [0] * 6)["contact_lost"] is True  # never made


def test_force_metrics_of_a_delayed_first_order_step():
    """A force following a 10 -> 20 N step at t = 1 s as 1 - exp(-t/tau): rise 10-90 % = tau ln 9."""
    tau, t = 0.05, np.arange(0, 3, 1e-4)
    fd = np.where(t < 1.0, 10.0, 20.0)
    f = 10.0 + 10.0 * np.where(t < 1.0, 0.0, 1 - np.exp(-(t - 1.0) / tau))
    m = compute(t, {"force": f, "force_desired": fd}, {"step_time": 1.0, "filter_cutoff": 1000.0, "ss_window": 1.9})
    assert m["rise_time_s"] == pytest.approx(tau * np.log(9), rel=0.02)  # the filter adds ~0.2 ms of lag
    assert m["overshoot_pct"] == pytest.approx(0.0, abs=0.01)
    t0 = t[t >= t[-1] - 1.9][0]  # the window's first sample (1.1 s); the error is largest there
    assert m["ss_force_error_raw_N"] == pytest.approx(10 * np.exp(-(t0 - 1.0) / tau), rel=1e-9)
    assert "contact_lost" not in m and "oscillation_hz" not in m  # no role, no metric
    assert m["rise_time_raw_s"] == pytest.approx(tau * np.log(9), abs=1e-4) and m["overshoot_raw_pct"] == 0.0
    assert describe({**m, "contact_lost": False})[:2] == [
        f"rise {m['rise_time_s']:.3f} s filtered ({m['rise_time_raw_s']:.3f} s raw)", "overshoot 0 % filtered (0 % raw)"]
    assert m["ss_command_held"] is True
    assert describe({"rise_time_s": 0.1, "contact_lost": True, "first_loss_s": 0.2})[0].startswith("contact LOST at 0.200 s")


def test_display_filter_passes_a_constant_and_halves_power_at_its_cutoff():
    t = np.arange(0, 4, 1e-3)
    assert display_filter(t, np.full_like(t, 3.0)) == pytest.approx(3.0)
    y = display_filter(t, np.sin(2 * np.pi * 12.0 * t))  # at the 12 Hz cutoff: |H| = 1/sqrt(2) (bilinear, prewarped by 12 vs 1000 Hz: ~1 %)
    assert np.max(np.abs(y[t > 2])) == pytest.approx(1 / np.sqrt(2), rel=0.02)


def test_hand_modes_of_an_undamped_oscillator():
    w = 2 * np.pi * 272.5
    A = np.array([[0.0, 1.0, 0, 0], [-w * w, 0.0, 0, 0], [0, 0, 0, 1.0], [0, 0, -(2 * np.pi * 50) ** 2, 0]])
    assert hand_modes(A) == pytest.approx([272.5, 50.0])
    assert hand_modes(A, near_hz=260.0) == pytest.approx(272.5)
    assert hand_modes(np.zeros((2, 2)), near_hz=260.0) is None


def test_a_key_is_added_once():
    row = tables.Setting("hand_mode_hz", tables.Number(0), None, "another meaning")
    with pytest.raises(ValueError, match="hand_mode_hz"):
        tables.extend("analysis", [row], "mine")
    before = list(tables.SIGNALS)
    tables.extend("signals", [r for r in tables.SIGNALS], "hybridsim.forcecontrol")  # the same rows again: nothing
    assert tables.SIGNALS == before


@pytest.fixture
def without_the_wing():
    """The generic registries as they are without hybridsim.forcecontrol."""
    saved = {id(x): (x, list(x)) for x in (tables.SIGNALS, tables.METRICS, tables.PLOT, tables.ANALYSIS,
                                           generic.METRIC_SETS, figures.LAYOUTS, extras.EXTRAS)}
    for table in (tables.SIGNALS, tables.METRICS, tables.PLOT, tables.ANALYSIS):
        table[:] = [s for s in table if s.owner != "hybridsim.forcecontrol"]
    for reg in (generic.METRIC_SETS, figures.LAYOUTS, extras.EXTRAS):
        reg.clear()
    yield
    for x, rows in saved.values():
        x[:] = rows


def test_the_generic_layers_work_without_the_wing(without_the_wing, tmp_path, capsys):
    from hybridsim.app.cli import main

    plain = write(tmp_path, GOOD)
    assert main(["run", str(plain), "-q", "-o", str(tmp_path / "o")]) == 0  # a scope figure, no metrics
    assert "s wall" in capsys.readouterr().out and (tmp_path / "o" / "d.png").exists()
    roles = write(tmp_path, GOOD + "signals: {force: g.y}\n", name="r.yaml")
    assert main(["check", str(roles)]) == 2
    assert "unknown signal role 'force'; roles: none are registered" in capsys.readouterr().err
    assert "hand_mode_hz" not in tables.keys(tables.ANALYSIS)


def test_the_wing_fills_the_generic_registries():
    assert {"force", "force_desired", "contact", "hand"} <= set(tables.keys(tables.SIGNALS))
    assert {s.owner for s in tables.SIGNALS} == {"hybridsim.forcecontrol"}
    assert "forcecontrol" in [m.name for m in generic.METRIC_SETS]
    assert "forcecontrol" in [lay.name for lay in figures.LAYOUTS]
    assert "hand_mode_hz" in extras.keys()


def test_a_fast_loop_has_its_raw_overshoot_beside_the_filtered_one():
    """A 30 Hz, zeta 0.2 second-order step (a helper's loop): overshoot exp(-pi z / sqrt(1 - z^2)) = 52.7 %
    raw; the 12 Hz display filter shows a fraction of it, and the phrase gives both."""
    from scipy import signal

    wn, z = 2 * np.pi * 30, 0.2
    t = np.arange(0, 1.0, 1e-4)
    _, y = signal.step(([wn ** 2], [1, 2 * z * wn, wn ** 2]), T=t)
    f = np.concatenate([np.zeros(1000), y[:-1000]])
    fd = np.where(t < 0.1, 0.0, 1.0)
    m = compute(t, {"force": f, "force_desired": fd}, {"step_time": 0.1})
    assert m["overshoot_raw_pct"] == pytest.approx(100 * np.exp(-np.pi * z / np.sqrt(1 - z * z)), abs=0.05)
    assert m["overshoot_pct"] < 20
    assert describe(m)[1] == f"overshoot {m['overshoot_pct']:.0f} % filtered ({m['overshoot_raw_pct']:.0f} % raw)"


def test_a_command_moving_in_the_steady_window_is_said():
    t = np.arange(0, 1.2, 1e-3)
    fd = np.where(t < 0.5, 0.0, 5.0)
    m = compute(t, {"force": np.zeros_like(t), "force_desired": fd}, {"ss_window": 1.0})
    assert m["ss_command_held"] is False
    assert "no steady state to judge" in next(p for p in describe(m) if p.startswith("steady error"))


def test_a_raw_rise_is_shown_where_the_filtered_force_never_rises():
    m = {"rise_time_s": None, "rise_time_raw_s": 0.008, "overshoot_pct": 0.0, "overshoot_raw_pct": 12.0}
    assert describe(m)[:2] == ["rise not reached filtered (0.008 s raw)", "overshoot 0 % filtered (12 % raw)"]
