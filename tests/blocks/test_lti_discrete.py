"""zero_pole_gain and transfer_function_mimo against scipy.signal, the limited and reset discrete
integrator and the per-element unit delay against recurrences, on every path."""
import numpy as np
import pytest
from scipy import signal

from paths import PATHS, block, check, run


@pytest.mark.parametrize("path", PATHS)
def test_zero_pole_gain_and_mimo_step_responses(path):
    zpk = dict(zeros=[-3.0], poles=[[-1.0, 2.0], [-1.0, -2.0], -4.0], gain=6.0)
    num = [[[1.0], [2.0, 1.0]], [[0.5, 0.0, 1.0], [3.0]]]
    den = [[[1.0, 1.0], [1.0, 3.0, 2.0]], [[1.0, 2.0, 5.0], [1.0, 0.5]]]
    blocks = [block("constant", "one", value=1.0), block("constant", "u", value=[1.0, -0.5]),
              block("zero_pole_gain", "z", **zpk), block("transfer_function_mimo", "m", num=num, den=den)]
    res = run(path, blocks, [("one.y", "z.u"), ("u.y", "m.u")], 3.0, ["z.y", "m.y"], step=1e-3)
    t = res.t
    _, ref = signal.step(signal.zpk2tf([-3.0], [-1 + 2j, -1 - 2j, -4.0], 6.0), T=t)
    check("zero_pole_gain", path, res["z.y[0]"], ref, 1e-10)
    for i in range(2):
        ref = sum(uj * signal.step((num[i][j], den[i][j]), T=t)[1] for j, uj in enumerate([1.0, -0.5]))
        check("transfer_function_mimo", path, res[f"m.y[{i}]"], ref, 1e-10)


def test_zero_pole_gain_refuses_unpaired_complex_roots():
    with pytest.raises(Exception, match="conjugate"):
        block("zero_pole_gain", "z", poles=[[-1.0, 2.0]])
    with pytest.raises(Exception, match="proper"):
        block("zero_pole_gain", "z", zeros=[-1.0, -2.0], poles=[-3.0])


@pytest.mark.parametrize("path", PATHS)
@pytest.mark.parametrize("method", ["forward", "backward", "trapezoidal"])
def test_discrete_integrator_with_limits_and_reset(path, method):
    T, K, lo, hi, x0 = 0.05, 2.0, -0.3, 0.4, 0.1
    blocks = [block("sine", "u", amplitude=1.0, frequency=0.4, phase=0.3),
              block("pulse", "r", period=1.3, duty=0.2, delay=0.72),
              block("discrete_integrator", "i", K=K, method=method, initial=x0, lower=lo, upper=hi, period=T),
              block("delay", "d", initial=[1.0, -2.0, 3.0], period=T), block("mux", "m", widths=[1, 1, 1])]
    wires = [("u.y", "i.u"), ("r.y", "i.reset"), ("u.y", "m.u1"), ("r.y", "m.u2"), ("i.y", "m.u3"), ("m.y", "d.u")]
    res = run(path, blocks, wires, 4.0, ["i.y", "d.y"], step=1e-3, log_period=T)
    t = res.t[:-1]  # the row at t_end holds the outputs of the hit before it (the run ends there)
    u = np.sin(2 * np.pi * 0.4 * t + 0.3)
    s = (t - 0.72) / 1.3
    r = np.where((t >= 0.72) & (s - np.floor(s) < 0.2), 1.0, 0.0)
    c = {"forward": 0.0, "backward": 1.0, "trapezoidal": 0.5}[method]
    x, r_prev, ys = x0, 0.0, []
    for uk, rk in zip(u, r):  # the recurrence of the docstring
        if rk > 0.5 >= r_prev:
            x = x0
        y = min(max(x + c * K * T * uk, lo), hi)
        x, r_prev = min(max(y + (1 - c) * K * T * uk, lo), hi), rk
        ys.append(y)
    check("discrete_integrator", path, res["i.y[0]"][:-1], ys, 1e-12)
    assert min(ys) == lo and max(ys) == hi and r.max() == 1.0  # both limits and a reset are exercised
    # the unit delay: y[k] = u[k-1], y[0] its per-element initial value
    got = np.stack([res[f"d.y[{j}]"][:-1] for j in range(3)], axis=1)
    ref = np.vstack([[1.0, -2.0, 3.0], np.stack([u, r, ys], axis=1)[:-1]])
    check("delay", path, got, ref, 1e-12)


@pytest.mark.parametrize("path", PATHS)
def test_mux_and_demux_route_elements_on_every_path(path):
    blocks = [block("constant", "a", value=[1.0, 2.0]), block("clock", "t"),
              block("mux", "m", widths=[2, 1]), block("demux", "d", widths=[1, 2]),
              block("constant", "e", value=[float(k) for k in range(8)]), block("demux", "d8", widths=[1] * 8)]
    wires = [("a.y", "m.u1"), ("t.y", "m.u2"), ("m.y", "d.u"), ("e.y", "d8.u")]
    res = run(path, blocks, wires, 0.5, ["d.y1", "d.y2", "d8.y8", "d8.y5"], log_period=0.1)
    assert np.all(res["d.y1[0]"] == 1.0) and np.all(res["d.y2[0]"] == 2.0)
    check("mux/demux", path, res["d.y2[1]"], res.t, 0.0)
    assert np.all(res["d8.y8[0]"] == 7.0) and np.all(res["d8.y5[0]"] == 4.0)
    assert block("demux", "x", widths=[1] * 8).kernels is not None and block("demux", "x", widths=[1] * 9).kernels is None
