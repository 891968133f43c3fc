"""The block library as data: each registered type's group, description, parameters and ports.

``hybridsim blocks`` prints it and the documentation's block page is generated
from it (docs/conf.py), so both say the same.
"""
import inspect
from dataclasses import dataclass

from hybridsim.engine.registry import groups, lookup, parameters


@dataclass(frozen=True)
class BlockInfo:
    """One block type as the library lists it.

    ``required``: parameter names without a default; ``defaults``: ``{name: default}`` of the others;
    ``inputs``/``outputs``: ``[(port, width)]`` of the block built with its defaults (None
    when it cannot be built so, e.g. it needs a file); ``rate_hz``, ``states`` and ``held`` (of those, the
    modes and counts only events change) likewise.
    """

    type_name: str
    cls: type
    doc: str
    required: list
    defaults: dict
    inputs: list = None
    outputs: list = None
    rate_hz: float = None
    states: int = 0
    held: int = 0


def block_info(type_name, ports=True):
    """A :class:`BlockInfo` of registered block type ``type_name``.

    Parameters
    ----------
    type_name : str
        e.g. ``"gain"``.
    ports : bool
        Build the block with its defaults to read its ports, rate and states (else they are None/0).

    Returns
    -------
    BlockInfo
    """
    cls = lookup(type_name)
    req, opt = parameters(cls)
    sig = inspect.signature(cls.__init__).parameters
    lines = (cls.__doc__ or "").strip().splitlines()
    doc = lines[0] if lines else f"(no description: {cls.__module__}.{cls.__qualname__} has no docstring)"
    info = dict(type_name=type_name, cls=cls, doc=doc, required=req, defaults={p: sig[p].default for p in opt})
    if not ports:
        return BlockInfo(**info)
    # the ports of a block with its defaults (a sampled block given a rate, which its ports do not
    # depend on, and which is then not shown; a block that needs a file has none to show)
    blk, rate_hz = _built(cls), None
    if blk is not None:
        rate_hz = float(1 / blk.period) if blk.period else None
    elif "rate" in sig:
        blk = _built(cls, rate=1.0)
    if blk is None:
        return BlockInfo(**info)
    held = blk.continuous_held
    return BlockInfo(**info, inputs=[(p.name, p.width) for p in blk.inputs],
                     outputs=[(p.name, p.width) for p in blk.outputs], rate_hz=rate_hz,
                     states=blk.n_continuous, held=int(held.sum()) if held is not None else 0)


def _built(cls, **given):
    """An instance of block class ``cls`` with its defaults and ``given``, or None where it cannot be built."""
    try:
        return cls(name="b", **given)
    except Exception:  # noqa: BLE001 - only for showing
        return None


def catalog():
    """Every registered block type by group, in listing order.

    Returns
    -------
    dict
        ``{group: [BlockInfo, ...]}`` (types sorted within a group).
    """
    return {g: [block_info(name) for name in names] for g, names in groups().items()}
