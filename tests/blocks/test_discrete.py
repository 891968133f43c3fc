"""Sampled library blocks against hand-checked numbers and python-control's z-domain answers."""
import numpy as np
import pytest

import hybridsim as hs
from hybridsim.blocks.discrete.basic import (DelayN, DiscreteIntegrator, DiscretePID, DiscreteStateSpace,
                             DiscreteTransferFunction, RateLimiter)


def sequence(block, inputs):
    """Outputs of ``block`` for the input samples ``inputs`` (each a list of port values)."""
    x, ys = block.initial_state(), []
    for k, u in enumerate(inputs):
        u = [np.atleast_1d(np.asarray(v, float)) for v in u]
        u += [np.asarray(port.default) for port in block.inputs[len(u):]]  # unwired: the port's default
        ys.append(np.array(block.output(k * block.period, x, u)[0], float))
        x = block.update(k * block.period, x, u)
    return np.array(ys)


def test_discrete_integrator_methods():
    ones = [[1.0]] * 4
    assert list(sequence(DiscreteIntegrator(rate=10, method="forward"), ones)[:, 0]) == pytest.approx([0, .1, .2, .3])
    assert list(sequence(DiscreteIntegrator(rate=10, method="backward"), ones)[:, 0]) == pytest.approx([.1, .2, .3, .4])
    assert list(sequence(DiscreteIntegrator(rate=10, method="trapezoidal"), ones)[:, 0]) == pytest.approx([.05, .15, .25, .35])


def test_discrete_transfer_function_and_state_space():
    y = sequence(DiscreteTransferFunction(num=[0.5], den=[1, -0.5], rate=10), [[1.0]] * 4)[:, 0]
    assert list(y) == pytest.approx([0, 0.5, 0.75, 0.875])  # y[k] = 0.5 y[k-1] + 0.5 u[k-1]
    y = sequence(DiscreteStateSpace(A=[[0.5]], B=[[1.0]], C=[[2.0]], D=[[1.0]], rate=10), [[1.0]] * 3)[:, 0]
    assert list(y) == pytest.approx([1.0, 3.0, 4.0])  # x: 0, 1, 1.5; y = 2x + u


def test_n_sample_delay():
    y = sequence(DelayN(N=3, initial=-1.0, rate=10), [[k] for k in range(6)])[:, 0]
    assert list(y) == [-1, -1, -1, 0, 1, 2]


def test_rate_limiter():
    y = sequence(RateLimiter(rising=1.0, falling=2.0, rate=10), [[1.0]] * 3 + [[-1.0]] * 2)[:, 0]
    assert list(y) == pytest.approx([0.1, 0.2, 0.3, 0.1, -0.1])


def test_discrete_pid_equals_its_z_transfer_function():
    import control as ct

    T, Kp, Ki, Kd, N = 0.01, 2.0, 5.0, 0.3, 40.0
    z = ct.tf([1, 0], [1], T)
    C = Kp + Ki * T * z / (z - 1) + Kd * N * (z - 1) / ((1 + N * T) * z - 1)
    e = np.sin(0.3 * np.arange(50)) + 0.2
    ref = ct.forced_response(C, T=np.arange(50) * T, U=e).outputs
    ours = sequence(DiscretePID(Kp=Kp, Ki=Ki, Kd=Kd, N=N, rate=1 / T), [[ek, 0.0] for ek in e])[:, 0]
    assert np.max(np.abs(ours - ref)) < 1e-12
    # no filter: D = Kd (e[k] - e[k-1]) / T
    ours = sequence(DiscretePID(Kp=0.0, Kd=1.0, rate=1 / T), [[1.0, 0.0], [3.0, 0.0]])[:, 0]
    assert list(ours) == pytest.approx([100.0, 200.0])


def test_discrete_pid_anti_windup():
    sat = dict(Kp=1.0, Ki=10.0, upper=1.0, lower=-1.0, rate=10)
    steps = [[5.0, 0.0]] * 5 + [[-5.0, 0.0]]
    none = sequence(DiscretePID(anti_windup="none", **sat), steps)[:, 0]
    clamp = sequence(DiscretePID(anti_windup="clamping", **sat), steps)[:, 0]
    assert list(none[:5]) == [1.0] * 5 and list(clamp[:5]) == [1.0] * 5
    # unclamped, the integrator wound up to 5 x 5 = 25: still +1 after the error reverses;
    # clamped it stayed at 0, so -5 - 5 = -10 saturates at -1 at once
    assert none[5] == 1.0 and clamp[5] == -1.0
    back = DiscretePID(anti_windup="back_calculation", Kb=10.0, **sat)
    assert back.params.Kb[0] == 10.0 and DiscretePID(Kp=2.0, Ki=4.0, rate=10).params.Kb[0] == 2.0  # Ki / Kp
    assert sequence(back, steps)[5, 0] == -1.0
    with pytest.raises(hs.ParameterError, match="anti_windup"):
        DiscretePID(anti_windup="magic", rate=10)


def test_a_zero_sample_delay_passes_samples_through():
    d = DelayN(N=0, rate=10, width=2)
    assert d.n_discrete == 0
    assert sequence(d, [[[1.0, 2.0]], [[3.0, 4.0]]]).tolist() == [[1.0, 2.0], [3.0, 4.0]]
