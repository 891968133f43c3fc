"""One parsed type for a parameter path, used wherever one is read.

``k`` and ``params.k`` (a name in ``params``), ``g.K`` and ``blocks.g.K`` (a
block parameter), ``ctrl.pid.Kp`` (inside subsystem ``ctrl``), ``g.K[1]`` (one
element), ``simulation.t_end`` and ``metrics.step_time`` (a setting of a section in
:data:`SETTING_SECTIONS`). Two spellings of one parameter
have one :attr:`ParamPath.key`, so a sweep that names both is refused.
"""
import re
from dataclasses import dataclass

#: the sections whose keys a path may name as ``SECTION.KEY`` (its kind is the section's name)
SETTING_SECTIONS = ("simulation", "metrics")
_INDEX = re.compile(r"^(.*?)\[(\d+)\]$")
_PART = re.compile(r"^[^.\[\]\s=:]+$")


@dataclass(frozen=True)
class ParamPath:
    """A parsed parameter path.

    ``kind`` is ``"param"`` (a name in ``params``), ``"block"`` (a block
    parameter) or a section of :data:`SETTING_SECTIONS` (one of its settings); ``parts`` the names:
    ``("k",)``, ``("ctrl", "pid", "Kp")`` (blocks, then the parameter),
    ``("t_end",)``; ``index`` the element ``[i]`` of a vector parameter, or None.
    """

    kind: str
    parts: tuple
    index: object = None

    @classmethod
    def parse(cls, text):
        """The path ``text`` names; ValueError (with what is wrong) when it names none."""
        if not isinstance(text, str):
            raise ValueError(f"a parameter path is a text, got {text!r}")
        raw = text.strip()
        index = None
        m = _INDEX.match(raw)
        if m:
            raw, index = m.group(1), int(m.group(2))
        if re.search(r"\[\s*-\s*\d+\s*\]$", raw):
            raise ValueError(f"{text!r}: an element index counts from 0 at the first element (no negative "
                             "indexes; give the last one's number)")
        parts = raw.split(".")
        if not raw or not all(_PART.match(p) for p in parts):
            raise ValueError(f"{text!r} is not a parameter path ('name', 'block.param', 'sub.block.param', "
                             "'simulation.key' or 'metrics.key'; names without spaces, '[', ']', '=')")
        if parts[0] == "params":
            if len(parts) != 2:
                raise ValueError(f"{text!r}: 'params.NAME' names one parameter")
            return cls("param", (parts[1],), index)
        if parts[0] in SETTING_SECTIONS:
            if len(parts) != 2 or index is not None:
                raise ValueError(f"{text!r}: '{parts[0]}.KEY' names one setting")
            return cls(parts[0], (parts[1],), None)
        if parts[0] == "blocks":
            parts = parts[1:]
            if len(parts) < 2:
                raise ValueError(f"{text!r}: 'blocks.BLOCK.PARAM' names a block parameter")
        return cls("param" if len(parts) == 1 else "block", tuple(parts), index)

    @property
    def key(self):
        """The canonical spelling: ``k``, ``g.K``, ``ctrl.pid.Kp[1]``, ``simulation.t_end``."""
        base = (f"{self.kind}." if self.kind in SETTING_SECTIONS else "") + ".".join(self.parts)
        return base + (f"[{self.index}]" if self.index is not None else "")

    @property
    def block(self):
        """The first block name of a block path (the subsystem for a nested one), else None."""
        return self.parts[0] if self.kind == "block" else None

    @property
    def name(self):
        """The last part: the parameter's (or setting's) own name."""
        return self.parts[-1]

    @property
    def inner(self):
        """What a block path names inside its first block: 'pid.Kp' of 'ctrl.pid.Kp', 'K' of 'g.K'."""
        return ".".join(self.parts[1:])

    def without_index(self):
        return ParamPath(self.kind, self.parts, None)

    def __str__(self):
        return self.key


def canonical(text):
    """:attr:`ParamPath.key` of ``text``, or ``text`` itself when it is not a path."""
    try:
        return ParamPath.parse(text).key
    except ValueError:
        return str(text)


class OverrideLoc(str):
    """Where a value came from when an override set it (``--set k``, ``sweep k``), in place of a
    ``file:line``: messages print it, and a relative path it gives is read from the working folder."""
