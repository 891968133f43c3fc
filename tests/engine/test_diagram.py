import pytest

from hybridsim import Diagram
from hybridsim.errors import DiagramError

from hybridsim.blocks.math.signals import Gain, Sum

from hybridsim.blocks.discrete.hold import UnitDelay
from hybridsim.blocks.sources.basic import Constant


def problems(d):
    with pytest.raises(DiagramError) as exc:
        d.build()
    return exc.value.problems


def test_unknown_block_and_port_suggest_closest():
    d = Diagram()
    d.add(Constant("src", value=1.0))
    d.add(Gain("g"))
    d.connect("srx.y", "g.u")
    d.connect("src.yy", "g.u")
    msgs = problems(d)
    assert any("no block named 'srx'" in m and "did you mean 'src'" in m for m in msgs)
    assert any("has no output 'yy'" in m and "did you mean 'y'" in m for m in msgs)


def test_width_mismatch_and_unconnected_and_double_wired_all_at_once():
    d = Diagram()
    d.add(Constant("a", value=[1.0, 2.0]))
    d.add(Constant("b", value=1.0))
    d.add(Gain("g"))
    d.add(Sum("s", signs="++"))
    d.connect("a.y", "g.u")
    d.connect("b.y", "s.u1")
    d.connect("b.dy", "s.u1")
    msgs = problems(d)
    assert any("width mismatch" in m and "a.y has 2" in m for m in msgs)
    assert any("s.u2" in m and "not connected" in m for m in msgs)
    assert any("s.u1 is wired twice" in m for m in msgs)
    assert len(msgs) == 3


def test_algebraic_loop_printed_port_by_port():
    d = Diagram()
    d.add(Constant("c", value=1.0))
    d.add(Sum("s", signs="+-"))
    d.add(Gain("g", K=2.0))
    d.connect("c.y", "s.u1")
    d.connect("s.y", "g.u")
    d.connect("g.y", "s.u2")
    (msg,) = problems(d)
    assert "algebraic loop" in msg and "g.y -> s.u2" in msg and "s.y -> g.u" in msg
    assert "insert a delay" in msg


def test_delay_breaks_the_loop():
    d = Diagram()
    d.add(Constant("c", value=1.0))
    d.add(Sum("s", signs="+-"))
    d.add(UnitDelay("z", rate=10))
    d.connect("c.y", "s.u1")
    d.connect("s.y", "z.u")
    d.connect("z.y", "s.u2")
    system = d.build()
    assert system.kind[system.index["z"]] == "discrete"


def test_a_loop_only_through_a_block_that_computes_its_outputs_together_says_so():
    """An FMU's y feeds back into its w, and only its d depends on w: no loop port by port, but the
    block computes y and d at once; the error said every output depends on its input."""
    from hybridsim import Block

    class Two(Block):
        def __init__(self, name):
            super().__init__(name)
            self.declare_input("w", 1)
            self.declare_output("y", 1, depends_on=())
            self.declare_output("d", 1, depends_on=("w",))
            self.declare_continuous_state(1)

    d = Diagram("t")
    d.add(Two("sub"))
    d.connect("sub.y", "sub.w")
    with pytest.raises(DiagramError, match=r"block 'sub' computes its outputs together: 'y' does not depend "
                                           r"on 'w', but 'd' does"):
        d.build()


def test_a_name_in_the_wrong_case_suggests_itself():
    from hybridsim.engine.registry import closest

    # 'N' for a random section's 'n' suggested nothing (one letter is too short for difflib)
    assert closest("N", ["n", "seed", "ranges"]) == " (did you mean 'n'?)"
    assert closest("Kp", ["kp", "Kp2"]) == " (did you mean 'kp'?)"


def test_adding_what_is_not_a_named_block_is_refused():
    # d.add("r") raised "'str' object has no attribute 'name'"; a block named None was built
    from hybridsim.errors import InputError

    d = Diagram("x")
    with pytest.raises(InputError, match="Diagram.add takes a block"):
        d.add("r")
    for name in (None, "", "  "):
        with pytest.raises(InputError, match="a block's name is a non-empty text"):
            d.add(Constant(name, 1.0))
    assert d.add(Constant("c", 1.0)).name == "c"
