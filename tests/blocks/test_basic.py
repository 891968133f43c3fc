import numpy as np
import pytest

from hybridsim.blocks.math.signals import Demux, Mux, Selection, Sum

from hybridsim.blocks.continuous.linear import LowPass

from hybridsim.blocks.discrete.hold import UnitDelay


def test_sum_signs():
    s = Sum(signs="+-+", width=2)
    y = s.output(0, None, [np.array([1.0, 2]), np.array([0.5, 0.5]), np.array([1.0, 1])])[0]
    assert y == pytest.approx((1.5, 2.5))


def test_selection_eq13():
    assert Selection(S=[1, 0]).output(0, None, [np.array([3.0, 4.0])])[0] == pytest.approx((3, 0))
    assert Selection(S=[1, 0], complement=True).output(0, None, [np.array([3.0, 4.0])])[0] == pytest.approx((0, 4))
    with pytest.raises(ValueError):
        Selection(S=[0.5, 1])


def test_mux_demux_round_trip():
    y = Mux(widths=[1, 2]).output(0, None, [np.array([1.0]), np.array([2.0, 3.0])])[0]
    parts = Demux(widths=[2, 1]).output(0, None, [y])
    assert list(parts[0]) == [1.0, 2.0] and list(parts[1]) == [3.0]


def test_delay_outputs_previous_sample():
    d = UnitDelay(rate=10, initial=7.0)
    x = d.initial_state()
    assert d.output(0, x, [np.array([1.0])])[0] == pytest.approx(7.0)
    x = d.update(0, x, [np.array([1.0])])
    assert d.output(0.1, x, [np.array([2.0])])[0] == pytest.approx(1.0)
    assert d.outputs[0].depends_on == ()


def test_lowpass_is_butterworth_at_cutoff():
    f = LowPass(cutoff=12.0)
    wc = 2 * np.pi * 12
    # state space of y'' + sqrt2 wc y' + wc^2 y = wc^2 u: |H(j wc)| = 1/sqrt(2)
    A = np.array([[0, 1], [-wc**2, -np.sqrt(2) * wc]])
    B = np.array([0, wc**2])
    # check derivatives agree with A x + B u
    x, u = np.array([0.3, -2.0]), 1.5
    assert f.derivatives(0, x, [np.array([u])]) == pytest.approx(A @ x + B * u)
    H = np.array([1, 0]) @ np.linalg.solve(1j * wc * np.eye(2) - A, B)
    assert abs(H) == pytest.approx(1 / np.sqrt(2))


def test_a_bad_number_is_shown_as_it_was_given():
    # tau_max: -10 said "got [-10.0, -10.0, ...]" (the broadcast), a scalar inf "got [inf]", a width of
    # one "must have 1 elements"
    from hybridsim.blocks._util import scalar, vector
    from hybridsim.errors import ParameterError

    with pytest.raises(ParameterError, match=r"must not be negative, got -10.0$"):
        vector(-10, "tau_max", 6, "nonnegative")
    with pytest.raises(ParameterError, match=r"must be finite, got inf$"):
        scalar(float("inf"), "K")
    with pytest.raises(ParameterError, match=r"must have 1 element, got 2$"):
        vector([1.0, 2.0], "K", 1)
    with pytest.raises(ParameterError, match=r"must not be negative, got \[1.0, -2.0\]$"):
        vector([1.0, -2.0], "b", 2, "nonnegative")


def test_a_sampled_block_says_whether_its_rate_is_missing_or_given_twice():
    # --set rate=null said "give exactly one of rate or period", as though both were given
    from hybridsim.errors import ParameterError
    from hybridsim.engine.registry import lookup

    for kind in ("discrete_pid", "discrete_integrator", "noise"):
        extra = {"sigma": 1.0} if kind == "noise" else {}
        with pytest.raises(ParameterError, match=r"neither has a value \(null, a value left empty, is none\)"):
            lookup(kind)("b", rate=None, **extra)
        with pytest.raises(ParameterError, match="not both"):
            lookup(kind)("b", rate=10, period=0.1, **extra)
