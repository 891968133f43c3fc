"""Periodic sources and the clock against scipy.signal and closed forms, on every path."""
import numpy as np
import pytest
from scipy import signal

from paths import PATHS, block, check, run


@pytest.mark.parametrize("path", PATHS)
def test_periodic_sources(path):
    f, ph = 0.7, 0.3
    blocks = [block("sine", "sin", bias=0.5, amplitude=2.0, frequency=f, phase=ph),
              block("square", "sq", bias=0.1, amplitude=1.5, frequency=f, phase=ph),
              block("sawtooth", "saw", amplitude=[1.0, 2.0], frequency=f, phase=ph),
              block("pulse", "pul", amplitude=3.0, period=0.9, duty=0.3, delay=0.25),
              block("chirp", "lin", f0=0.5, f1=3.0, t1=2.0, amplitude=1.2, phase=0.4),
              block("chirp", "log", f0=0.5, f1=3.0, t1=2.0, method="logarithmic"),
              block("clock", "clk")]
    log = ["sin.y", "sin.dy", "sq.y", "saw.y", "saw.dy", "pul.y", "lin.y", "lin.dy", "log.y", "clk.y"]
    res = run(path, blocks, [], 2.0, log, log_period=0.01)
    t = res.t
    a = 2 * np.pi * f * t + ph
    check("sine", path, res["sin.y[0]"], 0.5 + 2.0 * np.sin(a), 1e-12)
    check("sine", path, res["sin.dy[0]"], 2.0 * 2 * np.pi * f * np.cos(a), 1e-11)
    check("square", path, res["sq.y[0]"], 0.1 + 1.5 * signal.square(a), 1e-12)
    check("sawtooth", path, res["saw.y[1]"], 2.0 * signal.sawtooth(a), 1e-11)
    assert np.all(res["saw.dy[0]"] == 2 * f)
    # exact on the log grid t = k / 100 s: high while (k - 25) mod 90 < 27 (scipy's square, from the
    # rounded phase, read an edge instant such as 0.52 s on either side)
    k = np.rint(t * 100).astype(int)
    ref = np.where((k >= 25) & ((k - 25) % 90 < 27), 3.0, 0.0)
    check("pulse", path, res["pul.y[0]"], ref, 1e-12)
    check("chirp", path, res["lin.y[0]"], 1.2 * signal.chirp(t, 0.5, 2.0, 3.0, phi=np.degrees(0.4)), 1e-11)
    # d/dt A cos(phi + ph) = -A 2 pi f(t) sin(phi + ph), and sin x = cos(x - 90 deg)
    dref = -1.2 * 2 * np.pi * (0.5 + 2.5 * t / 2.0) * signal.chirp(t, 0.5, 2.0, 3.0, phi=np.degrees(0.4) - 90)
    check("chirp", path, res["lin.dy[0]"], dref, 1e-10)
    check("chirp", path, res["log.y[0]"], signal.chirp(t, 0.5, 2.0, 3.0, method="logarithmic"), 1e-10)
    check("clock", path, res["clk.y[0]"], t, 0.0)


def test_edges_are_zero_crossings():
    sq = block("square", "sq", frequency=2.0)
    g = [sq.zero_crossings(t, (), [])[0] for t in (0.2, 0.3)]
    assert g[0] > 0 > g[1]  # the edge at 0.25 s lies between
    p = block("pulse", "p", period=1.0, duty=0.25, delay=0.5)
    signs = [np.sign(p.zero_crossings(t, (), [])[0]) for t in (0.6, 0.8, 1.6)]
    assert signs[0] != signs[1] != signs[2]
    # before the delay the output stays 0: no edge there (the function changed sign at every
    # would-be edge, 0.25 s apart, and the variable-step solvers stopped at each), one at 0.5 s
    early = [p.zero_crossings(t, (), [])[0] for t in np.linspace(-2.0, 0.499, 400)]
    assert max(early) < 0 and p.zero_crossings(0.501, (), [])[0] > 0  # signed by the level: + high
    # an edge at t = 0 is no event: its function is already past zero there (it fired on leaving
    # zero, 1e-15 s on, though the output did not change)
    for b in (block("square", "sq", frequency=2.0), block("pulse", "p", period=1.0, duty=0.25)):
        assert b.zero_crossings(0.0, (), [])[0] > 0
    with pytest.raises(Exception, match="duty"):
        block("pulse", "p", duty=1.0)


@pytest.mark.parametrize("path", PATHS)
def test_an_edge_at_a_sample_hit_is_read_on_its_own_side(path):
    # high on [0, 0.2), [0.4, 0.6), [0.8, 1.0): 0.6 / 0.4 is 1.4999999999999998 in floats, so the
    # 10 Hz zoh read the pulse at 0.6 s as still high, and the square (1.25 Hz, the same edges) too
    blocks = [block("pulse", "p", period=0.4, duty=0.5), block("square", "sq", frequency=2.5),
              block("zoh", "zp", rate=10), block("zoh", "zs", rate=10)]
    res = run(path, blocks, [("p.y", "zp.u"), ("sq.y", "zs.u")], 1.0, ["zp.y", "zs.y"], log_period=0.1)
    high = np.array([1, 1, 0, 0, 1, 1, 0, 0, 1, 1, 1], float)  # (no hit at t_end: 0.9 s held)
    assert np.array_equal(np.ravel(res["zp.y"]), high)
    assert np.array_equal(np.ravel(res["zs.y"]), 2 * high - 1)
