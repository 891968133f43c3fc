"""Continuous library blocks against hand-checked numbers."""
import numpy as np
import pytest

import hybridsim as hs
from hybridsim.blocks.continuous.basic import FilteredDerivative, Integrator, Relay, TransferFunction, tf_to_ss


def _run(blocks, wires, t_end, log, step=1e-3, **sim):
    d = hs.Diagram("t")
    for b in blocks:
        d.add(b)
    for a, b in wires:
        d.connect(a, b)
    return hs.Simulator(d.build(), hs.RK4(step), log=log, log_period=sim.pop("log_period", 0.01), **sim).run(t_end)


def test_integrator_integrates_and_stops_at_its_limit():
    c = hs.registry.lookup("constant")("c", value=1.0)
    res = _run([c, Integrator("i", K=2.0)], [("c.y", "i.u")], 1.0, ["i.y"])
    assert res["i.y[0]"][-1] == pytest.approx(2.0, rel=1e-12)  # 2 x 1 s
    res = _run([c, Integrator("i", K=2.0, upper=1.5)], [("c.y", "i.u")], 1.0, ["i.y"])
    assert res["i.y[0]"][-1] == 1.5  # stopped exactly at the limit
    assert res.meta["events"][0][0] == pytest.approx(0.75, abs=1e-12)  # located: 1.5 / 2


def test_integrator_reset_restores_the_initial_value():
    c = hs.registry.lookup("constant")("c", value=1.0)
    s = hs.registry.lookup("step")("s", initial=0.0, final=1.0, time=0.4)
    res = _run([c, s, Integrator("i", initial=0.25)], [("c.y", "i.u"), ("s.y", "i.reset")], 1.0, ["i.y"])
    assert res["i.y[0]"][-1] == pytest.approx(0.25 + 0.6, rel=1e-12)  # reset at 0.4 s, then 0.6 s at slope 1


def test_integrator_refuses_a_start_outside_its_limits():
    with pytest.raises(hs.ParameterError, match="initial"):
        Integrator(initial=2.0, upper=1.0)


def test_integrator_refuses_equal_limits():
    # lower = upper held a constant by changing mode at every reversal of its input: 2 or 4
    # events per reversal, and 2 at odd times on cvode, depending on the solver
    with pytest.raises(hs.ParameterError, match="lower.*below upper.*constant block"):
        Integrator(initial=0.5, lower=0.5, upper=0.5)
    with pytest.raises(hs.ParameterError, match="lower"):
        Integrator(lower=[0.0, 1.0], upper=[1.0, 1.0], width=2)


def test_filtered_derivative_of_a_ramp():
    r = hs.registry.lookup("ramp")("r", initial=0.0, slope=1.0, start=0.0)
    res = _run([r, FilteredDerivative("d", tau=0.1)], [("r.y", "d.u")], 0.5, ["d.y"], step=1e-4)
    assert res["d.y[0]"][-1] == pytest.approx(1 - np.exp(-5.0), abs=1e-10)  # 1 - exp(-t / tau)


def test_transfer_function_realization_and_step():
    A, B, C, D = tf_to_ss([2.0, 1.0], [1.0, 3.0, 2.0])  # (2s + 1) / ((s + 1)(s + 2))
    s = 0.7j
    H = (C @ np.linalg.solve(s * np.eye(2) - A, B) + D)[0, 0]
    assert H == pytest.approx((2 * s + 1) / (s * s + 3 * s + 2), rel=1e-12)
    c = hs.registry.lookup("constant")("c", value=1.0)
    res = _run([c, TransferFunction("g", num=[1.0], den=[1.0, 1.0])], [("c.y", "g.u")], 1.0, ["g.y"], step=1e-4)
    assert res["g.y[0]"][-1] == pytest.approx(1 - np.exp(-1.0), abs=1e-12)  # 1/(s+1): 1 - e^-t
    with pytest.raises(hs.ParameterError, match="proper"):
        TransferFunction(num=[1.0, 0.0, 0.0], den=[1.0, 1.0])


def test_relay_switches_with_hysteresis():
    w = hs.registry.lookup("cosine")("w", amplitude=1.0, frequency=1.0)  # u = cos(2 pi t)
    res = _run([w, Relay("r", switch_on=0.5, switch_off=-0.5, y_on=2.0, y_off=-1.0, initial=True)],
               [("w.y", "r.u")], 1.0, ["r.y"], log_period=0.05)
    times = [t for t, _ in res.meta["events"]]
    # off when cos falls through -0.5 (t = 1/3 s), on when it rises through 0.5 (t = 5/6 s)
    assert times == pytest.approx([1 / 3, 5 / 6], abs=1e-12)
    y = dict(zip(np.round(res.t, 6), res["r.y[0]"]))
    assert y[0.3] == 2.0 and y[0.5] == -1.0 and y[0.9] == 2.0
    with pytest.raises(hs.ParameterError, match="switch_off"):
        Relay(switch_on=0.0, switch_off=1.0)


def test_first_order_lag_and_its_pass_through():
    from hybridsim.blocks.continuous.basic import FirstOrder

    c = hs.registry.lookup("constant")("c", value=1.0)
    res = _run([c, FirstOrder("f", tau=0.1, initial=0.0)], [("c.y", "f.u")], 0.1, ["f.y"], step=1e-4)
    assert res["f.y[0]"][-1] == pytest.approx(1 - np.exp(-1.0), abs=1e-12)
    res = _run([c, FirstOrder("f", tau=0.1)], [("c.y", "f.u")], 0.1, ["f.y"])
    assert np.all(res["f.y[0]"] == 1.0)  # starts in balance with its input: y(0) = u(0)
    off = FirstOrder("f", tau=0.0, width=2)
    assert off.n_continuous == 0 and list(off.output(0, (), [np.array([3.0, 4.0])])[0]) == [3.0, 4.0]


def test_a_transfer_function_of_degree_zero_is_a_pure_gain():
    """num/den with a constant denominator (den: [2]) is the gain num/den, without state (it was a
    numpy reshape error)."""
    import numpy as np

    from hybridsim.engine.registry import lookup

    tf = lookup("transfer_function")("p", num=[1.0], den=[2.0])
    assert tf.n_continuous == 0
    (y,) = tf.kernels.output(tf.params, 0.0, np.zeros(0), (np.array([3.0]),))
    assert y[0] == 1.5


@pytest.mark.parametrize("u, mode", [(1.0, 1.0), (0.0, 1.0), (-1.0, 0.0)])
def test_a_reset_to_a_limit_is_held_there_unless_the_input_points_inside(u, mode):
    # initial = upper = 0.5: a reset while K u >= 0 holds it at once (no second event a moment
    # later to enter the limit); one while K u < 0 leaves it free to integrate down
    from hybridsim.blocks.continuous.basic import integrator_event

    b = Integrator("i", K=2.0, initial=0.5, upper=0.5)
    fired = (True, False, False, False, False)  # reset; enter upper, lower; leave upper, lower
    out = integrator_event(b.params, 0.3, (0.2, 0.0), ((u,), (1.0,)), fired)
    assert list(out) == [0.5, mode]


def test_a_zero_numerator_is_a_zero_system_without_scipys_warning():
    """num: [0] (and a zero_pole_gain of gain 0) printed scipy's BadCoefficients warning to stderr."""
    import warnings

    from hybridsim.engine.registry import lookup

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tf = lookup("transfer_function")("p", num=[0.0], den=[1.0, 1.0])
        lookup("zero_pole_gain")("z", zeros=[], poles=[-1.0], gain=0.0)
    assert tf.n_continuous == 1
