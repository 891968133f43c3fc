"""The exported FMU's engine (hybridsim.fmi.runtime.DiagramStepper) on every path."""
import math

import pytest

import hybridsim as hs
from hybridsim.fmi.runtime import DiagramStepper


@pytest.mark.parametrize("path", ["generic", "fused", "compiled"])
def test_an_input_into_a_continuous_state_steps_on_every_path(tmp_path, path):
    # the input block stands in for the constant: the fused and compiled code were written from the
    # constant's kernels, so the stepper runs on the generic path (it crashed on the fused one)
    f = tmp_path / "lag.yaml"
    f.write_text("name: lag\nblocks:\n  src: {type: constant, value: 0.0}\n  lag: {type: first_order, tau: 0.2, initial: 0.0}\n"
                 "wires: [src.y -> lag.u]\nlog: [lag.y]\nsimulation: {solver: rk4, step: 1.0e-3}\n")
    _, sim, _ = hs.build(f, **{"simulation.fused": path != "generic", "simulation.compiled": path == "compiled"})
    st = DiagramStepper(sim, {"src": [2.0]}, ["lag.y"])
    t = 0.0
    for _ in range(10):
        st.step(t, 0.1)
        t += 0.1
    assert st.outputs()[0] == pytest.approx(2.0 * (1.0 - math.exp(-1.0 / 0.2)), abs=1e-9)  # y = u (1 - e^(-t/tau))
    st.set_input("src", [0.0])
    st.step(t, 0.1)
    assert st.outputs()[0] == pytest.approx(2.0 * (1.0 - math.exp(-5.0)) * math.exp(-0.5), abs=1e-9)
