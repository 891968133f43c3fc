"""ParamLayout: the blocks' numbers as two flat arrays, by a generated copy and by the checked walk."""
from collections import namedtuple

import numpy as np
import pytest

import hybridsim as hs
from hybridsim.engine.params import ParamLayout, ParamStructureError

from conftest import DIAGRAMS

NT = namedtuple("NT", "gain limits flags")


class _Block:
    def __init__(self, name, params):
        self.name, self.params = name, params


def _walk(layout, params):
    """flatten by the checked walk alone (the generated copy switched off)."""
    layout._fast = lambda *a: (_ for _ in ()).throw(ValueError)
    try:
        return layout.flatten(params)
    finally:
        layout._fast = None


def test_the_generated_copy_writes_what_the_walk_writes():
    params = [2.5, 3, True, np.arange(6.0).reshape(2, 3), np.array([1, 2], np.int32),
              NT(1.5, (0.0, np.array([4.0, 5.0])), (False, 7)), (), ((1.0,),)]
    blocks = [_Block(f"b{i}", p) for i, p in enumerate(params)]
    layout = ParamLayout(blocks)
    pf, pi = layout.flatten(params)
    assert layout._fast is not None
    wf, wi = _walk(layout, params)
    assert np.array_equal(pf, wf) and np.array_equal(pi, wi)
    # hand-checked: floats in order, then ints (True -> 1, the int32 array widened)
    assert pf.tolist() == [2.5, 0, 1, 2, 3, 4, 5, 1.5, 0.0, 4.0, 5.0, 1.0]
    assert pi.tolist() == [3, 1, 1, 2, 0, 7]


@pytest.mark.parametrize("change, message", [
    (lambda p: p[:3] + [np.zeros(4)] + p[4:], r"block 'b3'.*shape \(2, 3\) became \(4,\)"),
    (lambda p: [p[0], 3.5] + p[2:], "block 'b1'.*a whole number became a float"),
    (lambda p: p[:2] + [(1.0, 2.0)] + p[3:], "block 'b2'"),
])
def test_params_of_another_layout_are_refused_naming_the_block(change, message):
    params = [2.5, 3, 1.0, np.arange(6.0).reshape(2, 3)]
    layout = ParamLayout([_Block(f"b{i}", p) for i, p in enumerate(params)])
    layout.flatten(params)
    with pytest.raises(ParamStructureError, match=message):
        layout.flatten(change(params))


@pytest.mark.parametrize("name", ["fig9_force_and_position", "fig10_force_ramp"])
def test_the_copy_and_the_walk_agree_on_shipped_diagrams(name):
    _, sim, _ = hs.build(DIAGRAMS / f"{name}.yaml")
    blocks = sim.system.blocks
    layout = ParamLayout(blocks)
    params = tuple(b.params for b in blocks)
    pf, pi = layout.flatten(params)
    wf, wi = _walk(layout, params)
    assert np.array_equal(pf, wf) and np.array_equal(pi, wi)
