"""Sinks: the recorder, whose inputs are all logged."""


from hybridsim.engine.block import Block
from hybridsim.errors import ParameterError
from hybridsim.engine.registry import register

from hybridsim.blocks._util import count


GROUP = "math"  # where `hybridsim blocks` lists this module's blocks

@register("recorder")
class Recorder(Block):
    """A sink whose inputs are all logged; ``inputs`` maps names to widths."""

    group = "sinks"

    log_inputs = True

    def __init__(self, name="scope", inputs=None):
        super().__init__(name)
        if inputs is not None and not isinstance(inputs, dict):
            raise ParameterError("inputs", f"must map input names to widths, got {inputs!r}")
        for k, w in (inputs or {"u": 1}).items():
            self.declare_input(str(k), count(w, "inputs"))


