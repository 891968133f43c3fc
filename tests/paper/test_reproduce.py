"""hybridsim reproduce: claims are judged by their stated criteria, metrics land in the report."""
import csv
import json
import math

import pytest

from hybridsim.paper import claims as cl
from hybridsim.paper import reproduce as rp


def run(metrics, **ov):
    return {"label": "", "overrides": ov, "metrics": metrics, "result": None}


def test_fig7_criteria_hand_checked():
    good = {"rise_time_s": 0.15, "overshoot_pct": 5.0, "ss_force_error_filtered_N": 0.5, "contact_lost": False}
    claims = cl.claims_fig7([run(good, rate=60, force=f) for f in (1, 5, 10)])
    assert [c[3] for c in claims] == [True, True, True, True]
    bad = dict(good, ss_force_error_filtered_N=1.2)
    claims = cl.claims_fig7([run(good, rate=60), run(bad, rate=60), run(bad, rate=120)])
    assert [c[3] for c in claims] == [True, True, False, True]
    assert "1.20 N" in claims[2][2]


@pytest.fixture(scope="module")
def small_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("repro") / "r"
    report = rp.reproduce(out, jobs=2, experiments=["Fig 10", "eq 18"], grid=[16.0], bisections=1,
                          sensitivities=[("servo 120 Hz", "Fig 10", {"rate": 120})],
                          assumptions=["stick band", "computation delay"])
    return out, report


@pytest.mark.slow
def test_metrics_land_in_report_csv_and_html(small_report):
    out, report = small_report
    names = [e["name"] for e in report["experiments"]]
    assert names == ["Fig 10", "eq 18"]
    rows = list(csv.DictReader(open(out / "metrics.csv")))
    assert {r["experiment"] for r in rows} >= {"Fig 10", "eq 18"}
    assert any(r["metric"] == "oscillation_hz" for r in rows)
    page = (out / "reproduce.html").read_text()
    assert "faithful ramp tracking" in page and "hand oscillation" in page
    assert json.loads((out / "reproduce.json").read_text())["wall_time_s"] > 0


@pytest.mark.slow
def test_claims_marked_reproduced_meet_the_papers_numbers(small_report):
    _, report = small_report
    for e in report["experiments"]:
        by_label = {m["label"]: m for m in e["metrics"]}
        for c in e["claims"]:
            if not c["reproduced"]:
                assert c["why"] != "" or e["name"] == "eq 18"
                continue
            if c["claim"].startswith("faithful ramp"):
                assert next(iter(by_label.values()))["force_error_max_filtered_N"] <= 1.0
            elif c["claim"] == "contact kept":
                assert not next(iter(by_label.values()))["contact_lost"]
            elif c["claim"].startswith("hand oscillation"):
                kr = 9.0e5 if "9.0e+05" in c["claim"] else 1.0e6
                hz = by_label[f"Kr={kr}"]["oscillation_hz"]
                assert hz == pytest.approx(math.sqrt((kr + 8e5) / 0.58) / (2 * math.pi), rel=0.01)


@pytest.mark.slow
def test_damping_search_reports_its_trials(small_report):
    _, report = small_report
    fig10 = report["experiments"][0]
    if all(c["reproduced"] for c in fig10["claims"]):
        pytest.skip("Fig 10 reproduced as printed: nothing to search")
    for s in fig10["searches"]:
        assert s["trials"] and all("passed" in t for t in s["trials"])
        if s["found"] is not None:
            assert any(t["passed"] and t["s"] == s["found"] for t in s["trials"])


@pytest.mark.slow
def test_compiled_reproduce_judges_the_same(small_report, tmp_path):
    pytest.importorskip("numba")
    _, report = small_report
    fast = rp.reproduce(tmp_path / "c", jobs=1, experiments=["eq 18"], grid=[16.0], bisections=1,
                        sensitivities=[], compiled=True, hinges=False)
    ref = next(e for e in report["experiments"] if e["name"] == "eq 18")
    assert fast["experiments"][0]["claims"] == ref["claims"]
    assert [m["oscillation_hz"] for m in fast["experiments"][0]["metrics"]] == \
           [m["oscillation_hz"] for m in ref["metrics"]]


@pytest.mark.slow
def test_the_report_says_what_each_claim_hinges_on(small_report):
    """Fig 10's ramp tracking fails as printed and holds from a stick band between 2e-4 and 3e-4
    (the issue measured the flip there at 60 Hz); the threshold is bisected and stated."""
    out, report = small_report
    rows = [r for r in report["hinges"]["rows"] if r["experiment"] == "Fig 10"]
    ramp = next(r for r in rows if r["claim"].startswith("faithful ramp tracking"))
    assert ramp["as_printed"] in ("fails", "fragile")
    stick = next(h for h in ramp["hinges_on"] if h.startswith("holds if stick band >="))
    threshold = float(stick.split(">=")[1].split()[0])
    assert 2e-4 < threshold <= 4e-4
    html = (out / "reproduce.html").read_text()
    assert "What each claim hinges on" in html and "Best stated model" in html
    best = report["hinges"]["best"]
    assert best is not None and best["held"][60][0] >= 1


@pytest.mark.slow
def test_each_claim_states_how_it_is_measured(small_report):
    """The convention is read from the diagram's settings: Fig 10 (3.5 s, 0.5 ms log) over 0.75-2.5 s filtered."""
    out, report = small_report
    fig10 = report["experiments"][0]
    ramp, contact = (c["convention"] for c in fig10["claims"])
    assert ramp == ("max |F - F_d| over 0.75-2.5 s, force through the causal 2nd-order Butterworth at 12 Hz; "
                    "3.5 s runs, logged every 0.5 ms")
    assert contact.startswith("surface contact at every logged sample")
    assert all(r["convention"] for r in report["hinges"]["rows"])
    assert "how it is measured" in (out / "reproduce.html").read_text()


def test_fig7_conventions_follow_its_settings():
    settings = {"simulation": {"t_end": 2.5, "step": 1e-4, "log_period": 0.0005},
                "metrics": {"step_time": 0.5, "ss_window": 1.0}}
    rise, over, steady, contact = cl.conventions("Fig 7", settings)
    assert rise.startswith("10-90 % of the step at 0.5 s") and "12 Hz" in rise
    assert "over the last 1 s (1.5-2.5 s)" in steady and "2.5 s runs, logged every 0.5 ms" in steady


def test_a_pair_grid_names_the_points_where_only_both_assumptions_make_a_claim_hold():
    from hybridsim.paper.hinges import describe_pair

    # claim 0 holds with joint damping 16 alone; claim 1 only with joint 16 and wrist 4 together
    grid = {"assumptions": ["joint damping s", "wrist damping s"], "grid": [
        (0.0, 0.0, [False, False]), (0.0, 4.0, [False, False]),
        (16.0, 0.0, [True, False]), (16.0, 4.0, [True, True])]}
    assert describe_pair(grid, 0) is None  # one alone suffices
    assert describe_pair(grid, 1) == ("holds only with both joint damping s and wrist damping s at "
                                      "(joint damping s, wrist damping s) = (16, 4)")


def test_a_claim_that_holds_at_one_value_tried_says_so():
    from hybridsim.paper.hinges import describe

    search = {"assumption": "actuator lag", "trials": [{"value": v, "verdicts": [ok]} for v, ok in
                                                       ((0.0, False), (0.005, False), (0.01, True), (0.02, False))]}
    assert describe(search, 0) == "holds at actuator lag = 0.01 s"  # not "from 0.01 to 0.01"
