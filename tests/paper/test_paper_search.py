"""The joint search over the paper's unstated assumptions: models as overrides, the stated penalty, claim
margins that agree with the verdicts, and the summary's closest values and trade-offs."""
import math

import pytest
from hypothesis import given, settings, strategies as st

from hybridsim.paper import claims as cl
from hybridsim.paper import reproduce as rp
from hybridsim.paper.joint_search import PLAUSIBLE, PRINTED, model_overrides, penalty, summarize
from hybridsim.engine.registry import default
from hybridsim.blocks.paper.wrist import Wrist


def run(metrics, **ov):
    return {"label": "", "overrides": ov, "metrics": metrics, "result": None}


def test_a_model_as_overrides_hand_checked():
    assert model_overrides(PRINTED) == {"arm.stick_band": 1e-4}  # the printed model: the default band only
    m = {**PRINTED, "friction law": "stribeck", "Stribeck velocity": 0.01, "joint damping s": 4.0,
         "computation delay": 1, "actuator lag": 0.02}
    assert model_overrides(m) == {"arm.stick_band": 1e-4, "arm.friction_model": "stribeck",
                                  "arm.stribeck_velocity": [0.01, 0.01], "joint_damping": [40.0, 400.0],
                                  "delay_ticks": 1, "actuator_tau": 0.02}
    assert model_overrides({**PRINTED, "friction law": "lugre", "wrist damping s": 2.0}) == {
        "arm.stick_band": 1e-4, "arm.friction_model": "lugre", "wrist_damping": 40.0}


def test_the_stated_penalty_hand_checked():
    assert penalty(PRINTED) == 0.0
    # one claim per doubling above the limit: joint s 14 = 3.5 x 4 (2), sensor 20 ms = 10 ms x 2 (1)
    assert penalty({**PRINTED, "joint damping s": 14.0, "sensor filter": 0.02}) == pytest.approx(3.0)
    assert penalty({**PRINTED, "joint damping s": 64.0}) == pytest.approx(math.log2(64 / 3.5))
    # the wrist's limit: damping ratio 0.2 of the wrist flexure, bw = 20 s N s/m
    kw, m3 = default(Wrist, "Kw"), default(Wrist, "M3")
    assert PLAUSIBLE["wrist damping s"] * 20.0 == pytest.approx(0.2 * 2 * math.sqrt(kw * m3))


finite = st.floats(0.0, 5.0, allow_nan=False)


@settings(max_examples=150, deadline=None)
@given(rise=st.lists(st.floats(0.01, 0.6), min_size=3, max_size=3), over=st.lists(st.floats(0, 40), min_size=3,
                                                                                  max_size=3),
       sse=st.lists(finite, min_size=3, max_size=3), out=st.lists(st.sampled_from([0.0, 0.0, 0.02, 0.3]),
                                                                  min_size=3, max_size=3))
def test_claim_margins_agree_with_the_verdicts(rise, over, sse, out):
    runs = [run({"rise_time_s": r, "overshoot_pct": o, "ss_force_error_filtered_N": e, "contact_lost": t > 0,
                 "time_out_of_contact_s": t}, rate=60, force=f) for r, o, e, t, f in zip(rise, over, sse, out, (1, 5, 10))]
    for c in cl.claims_fig7(runs):
        if abs(c.margin) > 1e-12:  # on a threshold the verdict's < or <= decides
            assert (c.margin > 0) == c[3], (c, c.margin)


def test_fig8_and_fig10_margins_hand_checked():
    m = {"contact_lost": True, "first_loss_s": 1.0, "time_out_of_contact_s": 0.25, "force_error_max_filtered_N": 3.5}
    c8 = cl.claims_fig8([run(m)])
    assert [c.margin for c in c8] == [pytest.approx(-0.25), pytest.approx((1.75 - 3.5) / 1.75)]
    c10 = cl.claims_fig10([run({**m, "contact_lost": False, "force_error_max_filtered_N": 0.8})])
    assert [c.margin for c in c10] == [pytest.approx(0.2), 1.0] and all(c[3] for c in c10)


def _rec(model, a, b, c):
    """A judged model with three claims at one rate: A fails unless its margin is > 0, B and C likewise."""
    cl = [["Fig 7", "A", f"a={a}", a > 0, a], ["Fig 7", "B", f"b={b}", b > 0, b], ["Fig 8", "C", f"c={c}", c > 0, c]]
    held = sum(x[3] for x in cl)
    return {"model": model, "claims": {"60": cl}, "held": {"60": held}, "total": {"60": 3}, "penalty": 0.0,
            "score": held + 0.01 * sum(max(x[4], -1) for x in cl if not x[3])}


def test_summary_names_the_closest_value_and_the_claim_it_trades_against():
    # A rises exactly as B falls (a trade-off); C moves with neither
    pts = [(-0.9, 0.9, 0.5), (-0.6, 0.6, 0.2), (-0.3, 0.3, 0.7), (-0.1, 0.1, 0.4), (-0.5, 0.8, 0.3)]
    done = [_rec({"k": k}, *p) for k, p in enumerate(pts)]
    res = summarize(done, 1.0)
    assert res["best"]["model"] == {"k": 3}  # B and C held everywhere: A's margin breaks the tie
    (fail,) = res["failing"]
    assert fail["claim"] == "A" and fail["closest_value"] == "a=-0.1" and fail["closest_model"] == {"k": 3}
    assert fail["trades_against"].startswith("Fig 7: B") and fail["spearman_rho"] == pytest.approx(-0.9)


@pytest.fixture(scope="module")
def printed_search(tmp_path_factory):
    """One trial of the search (the printed model) and the folder of its store."""
    from hybridsim.paper.joint_search import joint_search

    folder = tmp_path_factory.mktemp("js")
    return joint_search(1, 2, outdir=folder), folder


@pytest.mark.slow
def test_the_search_judges_the_printed_model_as_hinges_does(printed_search):
    """The first trial is the printed model, judged as :func:`hinges.judge_model` judges it; a
    rerun reads it back from the store. (The second seeded trial, joint damping s = 64, is judged
    the same way; one model keeps the suite short.)"""
    from hybridsim.paper.hinges import judge_model
    from hybridsim.paper.joint_search import joint_search

    res, folder = printed_search
    assert res["trials"][0]["model"] == PRINTED
    counts = judge_model((), 2)
    assert {int(r): k for r, k in res["trials"][0]["held"].items()} == {r: k for r, (k, _) in counts.items()}
    again = joint_search(1, 2, outdir=folder)
    assert again["wall_time_s"] < 5.0 and again["trials"] == res["trials"]


def test_the_report_section_states_the_best_model_and_each_failing_claim():
    from hybridsim.paper.joint_search import joint_html

    base = {**PRINTED}
    pts = [(-0.9, 0.9, 0.5), (-0.6, 0.6, 0.2), (-0.3, 0.3, 0.7), (-0.1, 0.1, 0.4), (-0.5, 0.8, 0.3)]
    done = [_rec({**base, "joint damping s": 1.0 + k}, *p) for k, p in enumerate(pts)]
    html = joint_html(summarize(done, 12.0))
    assert "Best model found" in html and "joint damping s 4" in html  # the k = 3 model
    assert "a=-0.1" in html and "Fig 7: B" in html and "Spearman rho = -0.90" in html
    assert "joint damping s ≤ 3.5" in html


@pytest.mark.slow
def test_reproduce_adds_the_joint_search_to_its_report(tmp_path, printed_search):
    import shutil

    shutil.copytree(printed_search[1], tmp_path / "r" / "joint_search")  # the model judged: read back
    report = rp.reproduce(tmp_path / "r", jobs=2, experiments=["eq 18"], grid=[16.0], bisections=1,
                          sensitivities=[], hinges=False, joint=1)
    js = report["joint_search"]
    assert js["evaluations"] == 1 and js["best"]["model"] == PRINTED
    html = (tmp_path / "r" / "reproduce.html").read_text()
    assert "The assumptions searched jointly" in html
    assert (tmp_path / "r" / "joint_search" / "evaluations.jsonl").exists()
