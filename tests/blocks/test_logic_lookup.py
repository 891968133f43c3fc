"""Relational, logical, MinMax, hit crossing and lookup tables against numpy and scipy, on every path."""
import numpy as np
import pytest
from scipy.interpolate import RegularGridInterpolator, interp1d

import hybridsim as hs
from paths import PATHS, block, check, run


@pytest.mark.parametrize("path", PATHS)
def test_comparisons_logic_and_minmax(path):
    blocks = [block("sine", "s", frequency=0.7, phase=0.1), block("cosine", "c", frequency=0.45),
              block("relational", "gt", op=">"), block("relational", "le", op="<="),
              block("logical", "and", op="and"), block("logical", "xor", op="xor", inputs=3),
              block("logical", "nor", op="nor"), block("logical", "not", op="not"),
              block("minmax", "mx", function="max"), block("minmax", "mn", function="min", inputs=3),
              block("mux", "m", widths=[1, 1]), block("minmax", "over", function="max", inputs=1, width=2)]
    wires = [("s.y", "gt.u1"), ("c.y", "gt.u2"), ("s.y", "le.u1"), ("c.y", "le.u2"),
             ("gt.y", "and.u1"), ("s.y", "and.u2"), ("gt.y", "xor.u1"), ("le.y", "xor.u2"), ("c.y", "xor.u3"),
             ("gt.y", "nor.u1"), ("le.y", "nor.u2"), ("gt.y", "not.u1"),
             ("s.y", "mx.u1"), ("c.y", "mx.u2"), ("s.y", "mn.u1"), ("c.y", "mn.u2"), ("s.dy", "mn.u3"),
             ("s.y", "m.u1"), ("c.y", "m.u2"), ("m.y", "over.u1")]
    log = ["gt.y", "le.y", "and.y", "xor.y", "nor.y", "not.y", "mx.y", "mn.y", "over.y"]
    res = run(path, blocks, wires, 2.0, log)
    t = res.t
    s, c = np.sin(2 * np.pi * 0.7 * t + 0.1), np.cos(2 * np.pi * 0.45 * t)
    ds = 2 * np.pi * 0.7 * np.cos(2 * np.pi * 0.7 * t + 0.1)
    gt, le = s > c, s <= c
    check("relational", path, res["gt.y[0]"], gt, 0.0)
    check("relational", path, res["le.y[0]"], le, 0.0)
    check("logical", path, res["and.y[0]"], gt & (s != 0), 0.0)
    check("logical", path, res["xor.y[0]"], (gt.astype(int) + le + (c != 0)) % 2 == 1, 0.0)
    check("logical", path, res["nor.y[0]"], ~(gt | le), 0.0)
    check("logical", path, res["not.y[0]"], ~gt, 0.0)
    check("minmax", path, res["mx.y[0]"], np.maximum(s, c), 1e-12)
    check("minmax", path, res["mn.y[0]"], np.minimum(np.minimum(s, c), ds), 1e-11)
    check("minmax", path, res["over.y[0]"], np.maximum(s, c), 1e-12)


@pytest.mark.parametrize("path", PATHS)
def test_hit_crossing_counts_and_times_its_crossings(path):
    blocks = [block("sine", "s", frequency=1.3, phase=0.2), block("hit_crossing", "up", offset=0.5, direction="rising"),
              block("hit_crossing", "any", offset=0.5)]
    res = run(path, blocks, [("s.y", "up.u"), ("s.y", "any.u")], 2.0, ["up.count", "up.time", "any.count"])
    # sin(2 pi 1.3 t + 0.2) = 0.5 rising at 2 pi 1.3 t + 0.2 = pi/6 + 2 pi k, falling at 5 pi/6 + 2 pi k
    rise = [(np.pi / 6 + 2 * np.pi * k - 0.2) / (2 * np.pi * 1.3) for k in range(1, 3)]
    fall = [(5 * np.pi / 6 + 2 * np.pi * k - 0.2) / (2 * np.pi * 1.3) for k in range(0, 3)]
    rise = [r for r in [(np.pi / 6 - 0.2) / (2 * np.pi * 1.3)] + rise if r <= 2.0]
    fall = [f for f in fall if f <= 2.0]
    t = res.t
    check("hit_crossing", path, res["up.count[0]"], [sum(r <= tk for r in rise) for tk in t], 0.0)
    check("hit_crossing", path, res["any.count[0]"], [sum(r <= tk for r in rise + fall) for tk in t], 0.0)
    check("hit_crossing", path, res["up.time[0]"][-1], rise[-1], 1e-11)


@pytest.mark.parametrize("path", PATHS)
def test_a_signal_starting_on_the_level_crosses_it_only_from_one_side_to_the_other(path):
    # sin(2 pi t) from 0: rising through 0 at 1 and 2 s, falling at 0.5, 1.5 s. Leaving 0 at the
    # start counted as a crossing (count 1 from t = 0, time 9e-16); a memory whose trigger starts
    # at 0.5 sampled at t = 0
    blocks = [block("sine", "s"), block("hit_crossing", "up", direction="rising"),
              block("hit_crossing", "down", direction="falling"), block("hit_crossing", "any"),
              block("sine", "trg", amplitude=0.5, bias=0.5), block("clock", "c"), block("memory", "m", initial=-7.0)]
    wires = [("s.y", "up.u"), ("s.y", "down.u"), ("s.y", "any.u"), ("trg.y", "m.trigger"), ("c.y", "m.u")]
    res = run(path, blocks, wires, 2.2, ["up.count", "down.count", "any.count", "up.time", "m.y"])
    t = res.t
    check("hit_crossing", path, res["up.count[0]"], (t >= 1.0) * 1.0 + (t >= 2.0), 0.0)
    check("hit_crossing", path, res["down.count[0]"], (t >= 0.5) * 1.0 + (t >= 1.5), 0.0)
    check("hit_crossing", path, res["any.count[0]"], np.floor(2 * t + 1e-9), 0.0)
    check("hit_crossing", path, res["up.time[0]"][-1], 2.0, 1e-11)
    check("memory", path, res["m.y[0]"], np.where(t >= 1.0, np.where(t >= 2.0, 2.0, 1.0), -7.0), 1e-11)


@pytest.mark.parametrize("path", PATHS)
def test_a_signal_that_sits_on_the_level_or_touches_it_and_turns_back_does_not_cross(path):
    # saturation(sin 2 pi t, 0, 1) sits on 0 over [0.5, 1] and leaves it upward: never below 0, no
    # crossing (it was counted, as a falling one too); 0.5 + that as a memory's trigger: no edge
    blocks = [block("sine", "s"), block("saturation", "sat", lower=0.0, upper=1.0),
              block("hit_crossing", "any"), block("hit_crossing", "down", direction="falling"),
              block("constant", "half", value=0.5), block("sum", "trg"), block("clock", "c"),
              block("memory", "m", initial=-7.0)]
    wires = [("s.y", "sat.u"), ("sat.y", "any.u"), ("sat.y", "down.u"), ("sat.y", "trg.u1"), ("half.y", "trg.u2"),
             ("trg.y", "m.trigger"), ("c.y", "m.u")]
    res = run(path, blocks, wires, 2.2, ["any.count", "down.count", "m.y"])
    check("hit_crossing", path, res["any.count[0]"], 0.0 * res.t, 0.0)
    check("hit_crossing", path, res["down.count[0]"], 0.0 * res.t, 0.0)
    check("memory", path, res["m.y[0]"], 0.0 * res.t - 7.0, 0.0)


@pytest.mark.parametrize("solver", ["rk4", "radau", "lsoda", "cvode"])
def test_a_peak_exactly_at_the_level_is_no_event_on_any_solver(solver):
    # sin(2 pi t) reaches 1 (and -1) exactly and turns back: no crossing. The touch was an event
    # (listed, the integration restarted) on every solver, and CVODE stopped: "stepped over a crossing"
    solvers = {"rk4": hs.RK4(1e-3), "radau": hs.ScipySolver("Radau"), "lsoda": hs.ScipySolver("LSODA"),
               "cvode": hs.CVode()}
    for level in (1.0, -1.0):
        d = hs.Diagram("t")
        d.add(block("sine", "s"))
        d.add(block("hit_crossing", "h", offset=level))
        d.connect("s.y", "h.u")
        res = hs.Simulator(d.build(), solvers[solver], log=["h.count"], log_period=0.01).run(2.0)
        assert res["h.count[0]"][-1] == 0 and res.meta["events"] == [], (level, res.meta["events"])
    # a memory's trigger peaking exactly at 0.5 (the same side-following function)
    d = hs.Diagram("m")
    for b in (block("clock", "c"), block("sine", "s", amplitude=0.5, frequency=0.25), block("memory", "m")):
        d.add(b)
    d.connect("c.y", "m.u")
    d.connect("s.y", "m.trigger")
    res = hs.Simulator(d.build(), solvers[solver], log=["m.y"], log_period=0.01).run(3.5)
    assert res["m.y[0]"][-1] == 0 and res.meta["events"] == [], res.meta["events"]


def test_relational_and_logical_refuse_unknown_operators():
    for name in ("relational", "logical"):
        with pytest.raises(Exception, match="op"):
            block(name, "b", op="~~")


@pytest.mark.parametrize("path", PATHS)
def test_lookup_tables_with_hold_and_linear_extrapolation(path):
    bp, vals = [0.0, 0.5, 1.5, 2.0], [1.0, 2.0, 0.0, 0.5]
    grid = ([0.0, 1.0, 2.5], [-1.0, 0.0, 1.0])
    table = [[0.0, 1.0, 3.0], [2.0, -1.0, 0.5], [4.0, 2.0, 1.0]]
    blocks = [block("ramp", "r", initial=-1.0, slope=2.0), block("sine", "s", amplitude=1.5, frequency=0.6),
              block("lookup_1d", "lin", x=bp, y=vals, extrapolation="linear"),
              block("lookup_1d", "hold", x=bp, y=vals),
              block("mux", "m", widths=[1, 1]),
              block("lookup_nd", "nd", breakpoints=grid, table=table),
              block("lookup_nd", "ndh", breakpoints=grid, table=table, extrapolation="hold")]
    wires = [("r.y", "lin.u"), ("r.y", "hold.u"), ("r.y", "m.u1"), ("s.y", "m.u2"), ("m.y", "nd.u"), ("m.y", "ndh.u")]
    res = run(path, blocks, wires, 2.0, ["lin.y", "hold.y", "nd.y", "ndh.y"])
    u = -1.0 + 2.0 * res.t  # from -1 to 3: past both ends
    w = 1.5 * np.sin(2 * np.pi * 0.6 * res.t)
    check("lookup_1d", path, res["lin.y[0]"], interp1d(bp, vals, fill_value="extrapolate")(u), 1e-12)
    check("lookup_1d", path, res["hold.y[0]"], np.interp(u, bp, vals), 1e-12)
    rgi = RegularGridInterpolator(grid, np.array(table), bounds_error=False, fill_value=None)
    check("lookup_nd", path, res["nd.y[0]"], rgi(np.stack([u, w], axis=1)), 1e-12)
    clipped = np.stack([np.clip(u, 0.0, 2.5), np.clip(w, -1.0, 1.0)], axis=1)
    check("lookup_nd", path, res["ndh.y[0]"], rgi(clipped), 1e-12)


def test_lookup_refuses_bad_tables():
    with pytest.raises(Exception, match="x"):
        block("lookup_1d", "l", x=[0.0, 0.0], y=[1.0, 2.0])
    with pytest.raises(Exception, match="shape"):
        block("lookup_nd", "l", breakpoints=[[0, 1], [0, 1, 2]], table=[[0, 1], [2, 3]])
    with pytest.raises(Exception, match="extrapolation"):
        block("lookup_1d", "l", extrapolation="clip")
