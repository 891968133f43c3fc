"""The table of block types that diagrams refer to by name.

The engine knows no particular block: the library, :mod:`hybridsim.blocks`
(the repository's ``blocks/`` folder), registers its classes with
:func:`register`, and any user module can do the same. :func:`lookup` imports
the library on first use, and with it every plugin: a module another package
names in the ``hybridsim.blocks`` entry-point group, e.g. in its pyproject.toml::

    [project.entry-points."hybridsim.blocks"]
    mine = "my_package.blocks"

A module can also be loaded for one run with ``--plugin MODULE`` (:func:`load_plugin`).
"""
import difflib
import importlib
import inspect
import logging

_TYPES = {}
_LIBRARIES = ["hybridsim.blocks", "hybridsim.fmu"]
ENTRY_POINT_GROUP = "hybridsim.blocks"
_loaded = []  # whether the library and the entry-point plugins were imported
_log = logging.getLogger("hybridsim")


def register(type_name):
    """Class decorator: make a Block subclass available as ``type: type_name``."""

    def deco(cls):
        _TYPES[type_name] = cls
        cls.type_name = type_name
        return cls

    return deco


def _load_libraries():
    if _loaded:
        return
    _loaded.append(True)
    for mod in _LIBRARIES:
        importlib.import_module(mod)
    from importlib.metadata import entry_points

    for ep in entry_points(group=ENTRY_POINT_GROUP):
        try:
            ep.load()
        except Exception as exc:  # noqa: BLE001 - a broken plugin must not stop the built-in blocks
            _log.warning("plugin %r (%s) cannot be imported and is skipped: %s: %s", ep.name, ep.value,
                         type(exc).__name__, exc)


def load_plugin(module):
    """Import ``module`` (a dotted name) so that the blocks it registers can be used.

    Parameters
    ----------
    module : str
        e.g. ``"my_package.blocks"``; it must be importable (on ``sys.path``).

    Raises
    ------
    hybridsim.errors.PluginError
        When it cannot be imported (the reason named).
    """
    from .errors import PluginError

    _load_libraries()
    try:
        importlib.import_module(module)
    except Exception as exc:  # noqa: BLE001 - any failure of a user's module is theirs to see
        raise PluginError(f"cannot import plugin module {module!r}: {type(exc).__name__}: {exc}") from None


def types():
    """Sorted names of every registered block type."""
    _load_libraries()
    return sorted(_TYPES)


def lookup(type_name):
    """The class registered as ``type_name``, or None."""
    _load_libraries()
    return _TYPES.get(type_name)


#: the order `hybridsim blocks` lists groups in (others follow, sorted)
GROUP_ORDER = ["paper", "control", "math", "sources", "sinks", "FMU", "robots", "examples"]


def group(cls):
    """The group a block type is listed under: the class's ``group``, else its module's ``GROUP``.

    Parameters
    ----------
    cls : type
        A registered block class.

    Returns
    -------
    str
        e.g. ``"control"``; ``"other"`` when neither says.
    """
    import sys

    return getattr(cls, "group", None) or getattr(sys.modules.get(cls.__module__), "GROUP", "other")


def closest(name, candidates):
    """' (did you mean X?)' for the closest candidate, or ''."""
    match = difflib.get_close_matches(str(name), list(candidates), n=1, cutoff=0.5)
    return f" (did you mean {match[0]!r}?)" if match else ""


def parameters(cls):
    """(required, optional) parameter names of a block class's constructor."""
    sig = inspect.signature(cls.__init__)
    required, optional = [], []
    for p in list(sig.parameters.values())[1:]:
        if p.name == "name" or p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
            continue
        (required if p.default is p.empty else optional).append(p.name)
    return required, optional


def default(cls, name):
    """The default of constructor parameter ``name`` of block class ``cls`` (KeyError when it has none by that name)."""
    return inspect.signature(cls.__init__).parameters[name].default
