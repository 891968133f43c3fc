"""Diagrams: blocks wired output port to input port, checked as a whole.

>>> d = Diagram("demo")
>>> d.add(SomeBlock("a")); d.add(OtherBlock("b"))
>>> d.connect("a.y", "b.u")
>>> system = d.build()          # raises DiagramError listing every problem

``build`` returns a :class:`~hybridsim.engine.system.System`, the checked, sorted,
ready-to-run form.
"""
from hybridsim.engine.block import Block
from hybridsim.errors import DiagramError, InputError
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.engine.registry import closest


class Wire:
    """One connection ``src_block.src_port -> dst_block.dst_port``."""

    __slots__ = ("src", "dst", "where")

    def __init__(self, src, dst, where=None):
        self.src, self.dst, self.where = src, dst, where

    def __repr__(self):
        return f"{self.src} -> {self.dst}"


def split_ref(ref):
    """'block.port' -> ('block', 'port'); a block inside a subsystem is 'sub.block'.

    Raises ValueError when malformed.
    """
    if not isinstance(ref, str) or "." not in ref:
        raise ValueError(f"{ref!r} is not of the form block.port")
    b, p = ref.rsplit(".", 1)
    if not p or not all(b.split(".")):
        raise ValueError(f"{ref!r} is not of the form block.port")
    return b, p


class Diagram:
    """A set of named blocks and the wires between them."""

    def __init__(self, name="diagram", source=None):
        self.name = name
        self.source = source
        self.blocks = {}
        self.wires = []
        self.problems = []  # problems found while adding (e.g. by a loader)

    def add(self, block):
        """Add a block (its ``name`` must be unique); returns it."""
        if not isinstance(block, Block):
            raise InputError(f"Diagram.add takes a block (such as lookup('gain')('g', K=2.0)), got {block!r}")
        if not isinstance(block.name, str) or not block.name.strip():
            raise InputError(f"a block's name is a non-empty text, got {block.name!r} "
                             f"({block.type_label})")
        if block.name in self.blocks:
            self.problems.append(f"two blocks are named {block.name!r}")
        else:
            self.blocks[block.name] = block
        return block

    def connect(self, src, dst, where=None):
        """Wire output ``src`` ('block.port') to input ``dst``."""
        self.wires.append(Wire(src, dst, where))

    # -- checking -------------------------------------------------------
    def port(self, ref, kind, where=None):
        """``(port, None)`` of the ``kind`` ("input", "output") reference 'block.port' of a wire
        (``where``: its place in a file), or ``(None, problem)``."""
        at = f" ({where})" if where else ""
        try:
            bname, pname = split_ref(ref)
        except ValueError as exc:
            return None, f"wire{at}: {exc}"
        block = self.blocks.get(bname)
        if block is None:
            return None, f"wire{at}: no block named {bname!r}{closest(bname, self.blocks)}"
        ports = block.outputs if kind == "output" else block.inputs
        for p in ports:
            if p.name == pname:
                return p, None
        names = [p.name for p in ports]
        listing = ", ".join(names) if names else "none"
        return None, (
            f"wire{at}: block {bname!r} ({block.type_label}) has no {kind} "
            f"{pname!r}{closest(pname, names)}; its {kind}s: {listing}"
        )

    def check(self):
        """All problems with this diagram, as a list of strings (empty if none)."""
        problems = list(self.problems)
        driven = {}
        for w in self.wires:
            src, p1 = self.port(w.src, "output", w.where)
            dst, p2 = self.port(w.dst, "input", w.where)
            problems += [p for p in (p1, p2) if p]
            if not (src and dst):
                continue
            at = f" ({w.where})" if w.where else ""
            if src.width != dst.width:
                problems.append(
                    f"wire{at}: width mismatch: {w.src} has {src.width} element(s) "
                    f"but {w.dst} expects {dst.width}"
                )
            key = (dst.block.name, dst.name)
            if key in driven:
                problems.append(
                    f"wire{at}: input {w.dst} is wired twice (already driven by "
                    f"{driven[key].src}); an input takes exactly one wire"
                )
            else:
                driven[key] = w
        for block in self.blocks.values():
            for p in block.inputs:
                if (block.name, p.name) not in driven and p.default is None:
                    problems.append(
                        f"input {block.name}.{p.name} ({p.width} wide) is not connected"
                    )
        return problems

    def unwired_defaults(self):
        """``[(block, port)]`` of the inputs no wire drives that take their default value."""
        driven = {tuple(w.dst.rsplit(".", 1)) for w in self.wires}
        return [(b.name, p.name) for b in self.blocks.values() for p in b.inputs
                if p.default is not None and (b.name, p.name) not in driven]

    #: a function diagram -> SVG text, for Jupyter; the engine draws nothing itself
    #: (:mod:`hybridsim.report.picture` sets it when imported, as ``import hybridsim`` does)
    to_svg = None

    def _repr_svg_(self):
        """The diagram as an SVG picture (Jupyter shows it when a diagram is a cell's value)."""
        return None if Diagram.to_svg is None else Diagram.to_svg(self)

    def build(self):
        """Check the diagram and return its runnable :class:`System`.

        An input that no wire drives and that has a default is fed by a
        :class:`DefaultValue` block added for it (named ``block:port=default``).
        """
        from hybridsim.engine.system import System

        problems = self.check()
        if problems:
            raise DiagramError(problems, self.source)
        unwired = self.unwired_defaults()
        if not unwired:
            return System(self)
        full = Diagram(self.name, self.source)
        full.blocks, full.wires = dict(self.blocks), list(self.wires)
        for bname, pname in unwired:
            port = self.blocks[bname].input_port(pname)
            src = full.add(DefaultValue(f"{bname}:{pname}=default", port.default))
            full.connect(f"{src.name}.y", f"{bname}.{pname}")
        return System(full)


class DefaultValue(Block):
    """The constant value of an input that no wire drives (its port's ``default``)."""

    def __init__(self, name, value):
        super().__init__(name)
        self.params = (tuple(float(v) for v in value),)
        self.declare_output("y", len(self.params[0]))


@kernel
def default_value_output(p, t, x, u):
    return (p[0],)


DefaultValue.kernels = Kernels(output=default_value_output)
