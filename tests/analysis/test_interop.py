"""python-control systems as blocks (hybridsim.analysis.interop.from_control)."""
import numpy as np
import pytest

import hybridsim as hs

ct = pytest.importorskip("control")


def run(blocks, wires, t_end, log, step=1e-4, log_period=0.01):
    d = hs.Diagram("interop")
    for b in blocks:
        d.add(b)
    for a, b in wires:
        d.connect(a, b)
    return hs.Simulator(d.build(), hs.RK4(step), log=log, log_period=log_period).run(t_end)


def constant(value=1.0):
    return hs.registry.lookup("constant")("c", value=value)


def test_a_continuous_transfer_function_becomes_a_block():
    res = run([constant(), hs.from_control(ct.tf([1], [1, 1]), name="lag")], [("c.y", "lag.u")], 1.0, ["lag.y"])
    assert res["lag.y[0]"][-1] == pytest.approx(1 - np.exp(-1.0), abs=1e-12)


def test_a_discrete_transfer_function_keeps_its_sample_time():
    blk = hs.from_control(ct.tf([0.5], [1, -0.5], 0.1), name="d")
    assert blk.period == pytest.approx(0.1)
    res = run([constant(), blk], [("c.y", "d.u")], 0.35, ["d.y"], log_period=0.05)
    assert list(res["d.y[0]"][::2]) == pytest.approx([0.0, 0.5, 0.75, 0.875])  # t = 0, 0.1, 0.2, 0.3
    with pytest.raises(hs.ParameterError, match="sample time"):
        hs.from_control(ct.tf([1], [1, -0.5], True))


def test_a_python_control_loop_rebuilt_from_its_parts_gives_its_sampled_answer():
    T = 0.01
    plant = ct.tf([1.0], [1.0, 0.4, 4.0])
    z = ct.tf([1, 0], [1], T)
    pid = 20.0 + 15.0 * T * z / (z - 1) + 4.0 * 40.0 * (z - 1) / ((1 + 40.0 * T) * z - 1)
    err = hs.registry.lookup("sum")("e", signs="+-")
    res = run([constant(), err, hs.from_control(pid, name="C"), hs.from_control(plant, name="P")],
              [("c.y", "e.u1"), ("P.y", "e.u2"), ("e.y", "C.u"), ("C.y", "P.u")], 2.0, ["P.y"])
    k = np.arange(201)
    ref = ct.forced_response(ct.feedback(ct.sample_system(plant, T, "zoh") * pid, 1), T=k * T,
                             U=np.ones(k.size)).outputs
    assert np.max(np.abs(res["P.y[0]"] - ref)) < 1e-9


def test_a_mimo_state_space_keeps_its_widths():
    sys = ct.ss([[-1.0, 0.0], [0.0, -2.0]], [[1.0, 0.0], [0.0, 1.0]], [[1.0, 1.0]], [[0.0, 0.5]])
    blk = hs.from_control(sys, name="m")
    assert blk.input_port("u").width == 2 and blk.outputs[0].width == 1


def test_a_nonlinear_system_runs_on_the_generic_path():
    sys = ct.nlsys(lambda t, x, u, params: -params["a"] * x + u, lambda t, x, u, params: x,
                   states=1, inputs=1, outputs=1, params={"a": 2.0})
    res = run([constant(), hs.from_control(sys, name="nl", feedthrough=False)], [("c.y", "nl.u")], 1.0, ["nl.y"])
    assert res["nl.y[0]"][-1] == pytest.approx((1 - np.exp(-2.0)) / 2.0, abs=1e-12)
    disc = ct.nlsys(lambda t, x, u, params: 0.5 * x + u, lambda t, x, u, params: x, states=1, inputs=1,
                    outputs=1, dt=0.1)
    res = run([constant(), hs.from_control(disc, name="nd", feedthrough=False)], [("c.y", "nd.u")], 0.35,
              ["nd.y"], log_period=0.05)
    assert list(res["nd.y[0]"][::2]) == pytest.approx([0.0, 1.0, 1.5, 1.75])


def test_anything_else_is_refused():
    with pytest.raises(hs.ParameterError, match="not a python-control system"):
        hs.from_control("1/(s+1)")
