"""Friction, backlash, transport delay and memory against closed forms and recurrences, on every path."""
import numpy as np
import pytest

from paths import PATHS, block, check, run


def play(u, h, y0):
    """The play operator on a sampled input: y[k] = clip(y[k-1], u[k] - h, u[k] + h)."""
    y, out = y0, []
    for v in u:
        y = min(max(y, v - h), v + h)
        out.append(y)
    return np.array(out)


@pytest.mark.parametrize("path", PATHS)
def test_coulomb_viscous_friction_and_backlash(path):
    blocks = [block("sine", "s", amplitude=1.0, frequency=0.5, bias=0.2),
              block("coulomb_viscous", "f", coulomb=2.0, viscous=0.5),
              block("backlash", "b", deadband=0.6)]
    wires = [("s.y", "f.u"), ("s.y", "b.u"), ("s.dy", "b.du")]
    res = run(path, blocks, wires, 4.0, ["f.y", "b.y"], log_period=0.001)
    t = res.t
    u = 0.2 + np.sin(np.pi * t)
    check("coulomb_viscous", path, res["f.y[0]"], 2.0 * np.sign(u) + 0.5 * u, 1e-12)
    fine = np.linspace(0, 4.0, 400_001)  # the recurrence on a 10 us grid; it holds the peaks at t = 0.5 + k
    ref = play(0.2 + np.sin(np.pi * fine), 0.3, 0.2)[::100]
    check("backlash", path, res["b.y[0]"], ref, 1e-9)
    # contact from below when sin(pi t) = 0.3; then it leaves at each peak t = k + 1/2 and takes up the
    # play again 0.6 lower, where sin(pi t) = 1 - 0.6 or -1 + 0.6: t = k + 1/2 + acos(0.4) / pi
    times = [t for t, _ in res.meta["events"]]
    ref = [np.arcsin(0.3) / np.pi] + sorted([k + 0.5 for k in range(4)] + [k + 0.5 + np.arccos(0.4) / np.pi
                                                                       for k in range(4)])
    check("backlash", path, times, ref, 1e-9)


@pytest.mark.parametrize("path", PATHS)
def test_transport_delay_and_memory(path):
    tau, N = 0.3, 24  # a buffer other than the default (64 samples, tested below)
    blocks = [block("sine", "s", amplitude=1.0, frequency=1.0), block("clock", "clk"),
              block("transport_delay", "d", delay=tau, buffer=N, initial=0.25),
              block("pulse", "p", period=0.4, duty=0.5, delay=0.055), block("memory", "m", initial=-1.0)]
    wires = [("s.y", "d.u"), ("clk.y", "m.u"), ("p.y", "m.trigger")]
    res = run(path, blocks, wires, 2.0, ["d.y", "m.y"], step=1e-3)
    t = res.t
    ref = np.where(t >= tau, np.sin(2 * np.pi * (t - tau)), 0.25)
    # linear interpolation of samples Ts = tau / N apart: |err| <= Ts^2 / 8 max|u"| = 7.7e-4
    bound = (tau / N) ** 2 / 8 * (2 * np.pi) ** 2
    check("transport_delay", path, res["d.y[0]"], ref, bound)
    edges = 0.055 + 0.4 * np.floor((t - 0.055) / 0.4)  # off the log grid
    check("memory", path, res["m.y[0]"], np.where(t >= 0.055, edges, -1.0), 1e-11)


def test_transport_delay_of_a_ramp_is_exact():
    res = run("generic", [block("clock", "c"), block("transport_delay", "d", delay=0.1, buffer=7)],
              [("c.y", "d.u")], 0.5, ["d.y"], step=1e-3)
    check("transport_delay", "generic", res["d.y[0]"], np.maximum(res.t - 0.1, 0.0), 1e-12)


def test_backlash_refuses_a_start_outside_the_play():
    b = block("backlash", "b", deadband=0.2, initial=0.5)
    with pytest.raises(Exception, match="initial"):
        b.initial_state([np.array([0.0]), np.array([0.0])])


@pytest.mark.slow
def test_transport_delay_default_buffer_is_64_samples_per_delay():
    """The default buffer: located samples every tau / 64 s, within that spacing's interpolation bound."""
    tau = 0.3
    blocks = [block("sine", "s", amplitude=1.0, frequency=1.0), block("transport_delay", "d", delay=tau)]
    res = run("generic", blocks, [("s.y", "d.u")], 1.0, ["d.y"], step=1e-3)
    times = [t for t, _ in res.meta["events"]]
    np.testing.assert_allclose(np.diff(times), tau / 64, rtol=1e-9)
    ref = np.where(res.t >= tau, np.sin(2 * np.pi * (res.t - tau)), 0.0)
    bound = (tau / 64) ** 2 / 8 * (2 * np.pi) ** 2  # 1.1e-4; 20 samples would give 1.1e-3
    err = check("transport_delay, default buffer", "generic", res["d.y[0]"], ref, bound)
    assert err > bound / 10  # the bound is tight: a finer buffer would pass far below it


@pytest.mark.slow
def test_a_long_run_of_a_transport_delay_is_not_taken_for_divergence():
    # its count of samples was a state: past 1e6 samples (156 s of a 0.01 s delay) it tripped
    # max_state, "diverged"; the state is now the next sample's time
    blocks = [block("sine", "s", amplitude=1.0, frequency=1.0), block("transport_delay", "d", delay=0.01, buffer=4)]
    res = run("generic", blocks, [("s.y", "d.u")], 3.0, ["d.y"], step=1e-3, max_state=100.0)
    assert len(res.meta["events"]) >= 1199
    assert abs(res["d.y[0]"][-1] - np.sin(2 * np.pi * (res.t[-1] - 0.01))) < 1e-4


@pytest.mark.parametrize("path", PATHS)
def test_states_that_grow_by_design_are_not_bounded_by_max_state(path):
    # a delay's next sample time and a hit_crossing's count and time are states: past max_state
    # (1e6 s of simulated time by default) the run stopped as "diverged"
    blocks = [block("sine", "s", amplitude=1.0, frequency=1.0), block("transport_delay", "d", delay=0.5, buffer=4),
              block("hit_crossing", "h")]
    res = run(path, blocks, [("s.y", "d.u"), ("s.y", "h.u")], 3.0, ["d.y", "h.count", "h.time"], step=1e-3,
              max_state=2.0)
    assert res["h.count[0]"][-1] == 5 and abs(res["h.time[0]"][-1] - 2.5) < 1e-9
    assert abs(res["d.y[0]"][-1] - np.sin(2 * np.pi * (3.0 - 0.5))) < 1e-9  # a sample falls on t - tau


@pytest.mark.slow
def test_a_delay_of_microseconds_runs_and_one_shorter_than_its_events_can_be_is_refused():
    # 50 us over 64 samples: events 0.78 us apart, evenly: it ended as "Zeno" (more than 100,000 events
    # under 1e-6 s apart); 1e-16 s ran without any event and gave 292 for a sine of amplitude 1
    blocks = [block("sine", "s", frequency=10.0), block("transport_delay", "d", delay=5e-5)]
    res = run("compiled", blocks, [("s.y", "d.u")], 0.08, ["d.y"], step=1e-5, log_period=0.01)
    assert abs(res["d.y[0]"][-1] - np.sin(2 * np.pi * 10 * (res.t[-1] - 5e-5))) < 1e-6
    with pytest.raises(Exception, match="need at least 1e-9 s between them"):
        block("transport_delay", "d", delay=1e-16)


def test_a_run_of_many_delay_samples_is_warned_of(tmp_path, caplog):
    """0.1 ms over 64 samples is an event every 1.6 us: 0.05 s took 97 s without a word."""
    import hybridsim as hs

    p = tmp_path / "d.yaml"
    p.write_text("name: d\nblocks:\n  s: {type: sine, frequency: 5.0}\n  d: {type: transport_delay, delay: 1.0e-4}\n"
                 "wires: [s.y -> d.u]\nsimulation: {t_end: 0.05}\n")
    hs.build(p)
    assert "d.yaml:4: block 'd' makes an event every 1.56e-06 s, 3.2e+04 of them to t_end 0.05 s" in caplog.text
    caplog.clear()
    hs.build(p, **{"d.buffer": 4})
    assert "makes an event" not in caplog.text
