"""The fused RK4 path gives the generic path's numbers, bit for bit."""
import numpy as np
import pytest

import hybridsim as hs
from hybridsim.engine import fused

from conftest import DIAGRAMS, ROOT, integrator_without_kernels


@pytest.mark.parametrize("path, extra", [
    (DIAGRAMS / "fig9_force_and_position.yaml", {"rate": 120, "t_end": 0.4}),
    (DIAGRAMS / "fig8_receding_surface.yaml", {"t_end": 1.2}),
    (ROOT / "tests" / "data" / "smooth_contact.yaml", {}),
    # three rates, one with an offset, a delay's held output read before the block computes it
    (ROOT / "tests" / "data" / "every_kernel_block.yaml", {}),
    (ROOT / "tests" / "data" / "library_blocks.yaml", {}),
], ids=["fig9", "fig8-moving-surface", "damped", "every-kernel-block", "library"])
def test_fused_equals_generic(path, extra):
    assert hs.build(path, **extra)[1]._fused is not None
    a = hs.simulate(path, fused=True, **extra)
    b = hs.simulate(path, fused=False, **extra)
    assert np.array_equal(a.t, b.t)
    assert np.array_equal(a.table(), b.table())


def test_fused_only_where_every_block_has_kernels():
    system, sim, _ = hs.build(DIAGRAMS / "fig9_force_and_position.yaml")
    assert sim._fused is not None
    assert not fused.eligible(system, hs.ScipySolver("Radau"))
    system, sim, _ = hs.build(DIAGRAMS / "fig9_force_and_position.yaml", fused=False)
    assert sim._fused is None
    # a block without kernels on the right-hand side path keeps the generic path
    d = integrator_without_kernels()
    assert not fused.eligible(d.build(), hs.RK4())
    # a width-generic block with numpy kernels is eligible (and still exact)
    d = hs.Diagram("lp")
    d.add(hs.registry.lookup("constant")("c", value=1.0))
    d.add(hs.registry.lookup("lowpass")("f"))
    d.connect("c.y", "f.u")
    assert fused.eligible(d.build(), hs.RK4())
