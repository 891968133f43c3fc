"""The table of block types that diagrams refer to by name.

The engine knows no particular block: the library, :mod:`hybridsim.blocks`
(the repository's ``blocks/`` folder), registers its classes with
:func:`register`, and any user module can do the same. :func:`lookup` imports
the library on first use, and with it every plugin: a module another package
names in the ``hybridsim.blocks`` entry-point group, e.g. in its pyproject.toml::

    [project.entry-points."hybridsim.blocks"]
    mine = "my_package.blocks"

A module can also be loaded for one run with ``--plugin MODULE`` (:func:`load_plugin`).

A type name already registered is refused (:class:`~hybridsim.errors.PluginFault`)
unless the new class says it replaces it, ``@register("gain", replaces=True)``;
then every command warns that the type is replaced, and by which module.
A fault in a plugin's code (its import raising, even with ``SystemExit``; a
block's constructor or method raising) is reported as the plugin's, naming the
module and the block (:func:`plugin_fault`).
"""
import difflib
import importlib
import inspect
import logging

_TYPES = {}
_LIBRARIES = ["hybridsim.blocks", "hybridsim.fmi.fmu_block"]
ENTRY_POINT_GROUP = "hybridsim.blocks"
_loaded = []  # whether the library and the entry-point plugins were imported
_log = logging.getLogger("hybridsim")
PLUGIN_MODULES = set()  # top-level package names of the plugins imported in this process
REPLACED = {}  # type name -> (old class, new class), for the warning every command gives


def _is_ours(module):
    return module == "hybridsim" or module.startswith("hybridsim.")


def register(type_name, replaces=False):
    """Class decorator: make a Block subclass available as ``type: type_name``.

    Parameters
    ----------
    type_name : str
        The name diagrams use.
    replaces : bool
        Required to register a name that is already taken (a plugin's own
        version of a built-in block); every command then warns.
    """

    def deco(cls):
        old = _TYPES.get(type_name)
        same = old is not None and (old.__module__, old.__qualname__) == (cls.__module__, cls.__qualname__)
        if old is not None and not same:
            if not replaces:
                from hybridsim.errors import PluginFault

                raise PluginFault(f"{cls.__module__}.{cls.__qualname__} registers block type {type_name!r}, "
                                  f"which {old.__module__}.{old.__qualname__} already is; a plugin that "
                                  f"means to replace it says so: @register({type_name!r}, replaces=True)",
                                  plugin=cls.__module__, block=type_name)
            REPLACED[type_name] = (old, cls)
        if not _is_ours(cls.__module__):
            PLUGIN_MODULES.add(cls.__module__.split(".")[0])
        _TYPES[type_name] = cls
        cls.type_name = type_name
        return cls

    return deco


def replacement_warnings():
    """One line per block type a plugin replaced (every command shows them)."""
    return [f"warning: block type {name!r} is replaced by {new.__module__}.{new.__qualname__} "
            f"(was {old.__module__}.{old.__qualname__})" for name, (old, new) in sorted(REPLACED.items())]


def _load_libraries():
    if _loaded:
        return
    _loaded.append(True)
    for mod in _LIBRARIES:
        importlib.import_module(mod)
    from importlib.metadata import entry_points

    for ep in entry_points(group=ENTRY_POINT_GROUP):
        PLUGIN_MODULES.add(ep.value.split(":")[0].split(".")[0])
        try:
            ep.load()
        except (Exception, SystemExit) as exc:  # noqa: BLE001 - a broken plugin must not stop the built-in blocks
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
        When no such module can be found (exit 2).
    hybridsim.errors.PluginFault
        When its import raises (``SystemExit`` included: a plugin does not end the command).
    """
    from hybridsim.errors import HybridsimError, PluginError, PluginFault

    _load_libraries()
    if _find(module) is None:
        raise PluginError(f"cannot import plugin module {module!r}: no such module on the Python path "
                          "(a dotted name like my_package.blocks, on PYTHONPATH or installed)")
    PLUGIN_MODULES.add(module.split(".")[0])
    try:
        importlib.import_module(module)
    except PluginFault:
        raise
    except HybridsimError as exc:
        raise PluginFault(f"plugin {module!r}: its import raised {type(exc).__name__}: {exc}",
                          plugin=module) from None
    except (Exception, SystemExit) as exc:  # noqa: BLE001 - any failure of a user's module is theirs to see
        raise PluginFault(f"plugin {module!r}: its import raised {type(exc).__name__}: {exc}",
                          plugin=module) from None


def _find(module):
    """The import spec of ``module``, or None (a parent package that fails to import counts as found)."""
    import importlib.util

    if not module or module.startswith(".") or any(not part.isidentifier() for part in module.split(".")):
        return None
    try:
        return importlib.util.find_spec(module)
    except ModuleNotFoundError:
        return None
    except (Exception, SystemExit):  # noqa: BLE001 - its import raises: found, the fault is reported later
        return True


def plugin_fault(exc):
    """A :class:`~hybridsim.errors.PluginFault` for ``exc`` when a plugin's code raised it, else None.

    The traceback is searched for the innermost frame of a plugin module; the
    block is the ``self`` of that frame (or of the innermost frame that has a
    block as ``self``).
    """
    from hybridsim.errors import PluginFault

    if isinstance(exc, PluginFault):
        return exc
    tb, frames = exc.__traceback__, []
    while tb is not None:
        frames.append(tb)
        tb = tb.tb_next
    hit = None
    for f in reversed(frames):
        mod = f.tb_frame.f_globals.get("__name__", "")
        if mod.split(".")[0] in PLUGIN_MODULES and not _is_ours(mod):
            hit = f
            break
        written = _written_in_place(f, exc)
        if written is not None:
            return written if isinstance(written, PluginFault) else None
    if hit is None:
        return None
    code = hit.tb_frame.f_code
    block = _block_of(frames[:frames.index(hit) + 1])
    name = getattr(block, "name", None)
    tname = getattr(type(block), "type_name", type(block).__name__) if block is not None else None
    who = f"block {name!r} ({tname})" if name is not None else "its code"
    mod = hit.tb_frame.f_globals.get("__name__")
    text = str(exc).splitlines()[0] if str(exc) else ""
    return PluginFault(f"plugin {mod!r}: {who} raised {type(exc).__name__}: {text} "
                       f"(in {code.co_name}, {code.co_filename}:{hit.tb_lineno})", plugin=mod, block=name)


def _block_of(frames):
    """The block the innermost of ``frames`` works for: the ``self`` of the innermost frame that has
    a block as one (a plugin's kernel or helper function has none; the method that called it has)."""
    from hybridsim.engine.block import Block

    for f in reversed(frames):
        if isinstance(f.tb_frame.f_locals.get("self"), Block):
            return f.tb_frame.f_locals["self"]
    return None


def _written_in_place(tb, exc):
    """For a frame of the fused path's generated code (:mod:`hybridsim.engine.fused`): a
    :class:`~hybridsim.errors.PluginFault` when the line that raised is a plugin block's kernel
    written in place, True when it is a library block's, else None (not such a frame)."""
    import linecache

    from hybridsim.engine.floatcode import owner_of
    from hybridsim.errors import PluginFault

    blocks = tb.tb_frame.f_globals.get("__blocks__")
    if blocks is None:
        return None
    code = tb.tb_frame.f_code
    i = owner_of(linecache.getline(code.co_filename, tb.tb_lineno))
    if i is None or i >= len(blocks):
        return True
    block = blocks[i]
    mod = type(block).__module__
    if mod.split(".")[0] not in PLUGIN_MODULES or _is_ours(mod):
        return True
    text = str(exc).splitlines()[0] if str(exc) else ""
    tname = getattr(type(block), "type_name", type(block).__name__)
    return PluginFault(f"plugin {mod!r}: block {block.name!r} ({tname}) raised {type(exc).__name__}: {text} "
                       f"(in its kernels, written in place on the fused path at {code.co_filename}:{tb.tb_lineno}; "
                       "'simulation: {fused: false}' runs them as written)", plugin=mod, block=block.name)


def types():
    """Sorted names of every registered block type."""
    _load_libraries()
    return sorted(_TYPES)


def lookup(type_name):
    """The class registered as ``type_name``, or None."""
    _load_libraries()
    return _TYPES.get(type_name)


def type_name(block):
    """The type name ``block``'s class is registered as, or None."""
    return next((name for name, cls in _TYPES.items() if cls is type(block)), None)


#: the order `hybridsim blocks` lists groups in (others follow, sorted); see :func:`list_first`
GROUP_ORDER = ["control", "math", "sources", "sinks", "FMU", "robot", "examples"]


def list_first(group_name):
    """List block group ``group_name`` before the others (a library's own blocks first)."""
    if group_name in GROUP_ORDER:
        GROUP_ORDER.remove(group_name)
    GROUP_ORDER.insert(0, group_name)


def groups():
    """Every registered block type by group, in listing order.

    Returns
    -------
    dict
        ``{group: [type names, sorted]}``, the groups in :data:`GROUP_ORDER`'s order, then
        the others sorted.
    """
    by_group = {}
    for name in types():
        by_group.setdefault(group(lookup(name)), []).append(name)
    order = [g for g in GROUP_ORDER if g in by_group] + sorted(set(by_group) - set(GROUP_ORDER))
    return {g: by_group[g] for g in order}


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
    """' (did you mean X?)' for the closest candidate (the same name in other case first), or ''."""
    same = [str(c) for c in candidates if str(c).lower() == str(name).lower()]
    match = same or difflib.get_close_matches(str(name), [str(c) for c in candidates], n=1, cutoff=0.5)
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
