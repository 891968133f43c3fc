"""A run's identity: a hash of everything it reads, and the checks of a sweep file.

:func:`run_files` lists what a diagram's runs read: the diagram and every file
it extends, every subsystem file (and what those extend), every file a block
was built from (URDFs with the meshes they name, FMUs: any block attribute
that is a path to a file), and the source files of the plugin modules loaded.
:func:`identity` hashes their contents with hybridsim's version and source and any
extra data. Sweep resume keys its manifest by it, so editing any of those
files (or a file named in the grid) makes the old points another sweep's.
"""
import functools
import hashlib
import json
import re
import sys
import weakref
from pathlib import Path

from hybridsim.errors import HybridsimError, LoaderError
from hybridsim.format import tables
from hybridsim.format.paths import ParamPath

_MESH = re.compile(r"""filename\s*=\s*["']([^"']+)["']""")


def _urdf_meshes(urdf):
    """The mesh files a URDF names that exist (``package://`` resolved by searching upward)."""
    try:
        text = Path(urdf).read_text(errors="replace")
    except OSError:
        return []
    out = []
    for name in _MESH.findall(text):
        if name.startswith("package://"):
            pkg, _, rest = name[len("package://"):].partition("/")
            found = None
            for folder in Path(urdf).resolve().parents:
                if (folder / pkg / rest).is_file():
                    found = folder / pkg / rest
                    break
                if folder.name == pkg and (folder / rest).is_file():
                    found = folder / rest
                    break
            if found:
                out.append(found)
            continue
        p = Path(name[len("file://"):] if name.startswith("file://") else name)
        p = p if p.is_absolute() else Path(urdf).parent / p
        if p.is_file():
            out.append(p)
    return out


def block_files(blocks):
    """Files the built ``blocks`` were made from: every attribute that is a path to an existing file."""
    out = set()
    for b in blocks:
        for v in vars(b).values():
            if isinstance(v, Path) and v.is_file():
                out.add(v.resolve())
                if v.suffix.lower() == ".urdf":
                    out.update(m.resolve() for m in _urdf_meshes(v))
    return out


def plugin_files():
    """Source files of the plugin modules imported in this process."""
    from hybridsim.engine.registry import PLUGIN_MODULES

    out = set()
    for name, mod in list(sys.modules.items()):
        if name.split(".")[0] in PLUGIN_MODULES and getattr(mod, "__file__", None):
            p = Path(mod.__file__)
            if p.is_file():
                out.add(p.resolve())
    return out


def named_files(values, *folders):
    """Files named by texts anywhere in ``values`` (relative to the working folder or ``folders``)."""
    out = set()

    def walk(v):
        if isinstance(v, str) and v and len(v) < 4096 and not v.startswith("$"):
            for base in (Path("."), *folders):
                try:
                    p = (Path(base) / v).expanduser()
                    if p.is_file():
                        out.add(p.resolve())
                        if p.suffix.lower() == ".urdf":
                            out.update(m.resolve() for m in _urdf_meshes(p))
                        break
                except (OSError, ValueError):
                    continue
        elif isinstance(v, dict):
            for x in v.values():
                walk(x)
        elif isinstance(v, (list, tuple)):
            for x in v:
                walk(x)

    walk(values)
    return out


def run_files(f, built=None):
    """Every file runs of DiagramFile ``f`` read (sorted, resolved); ``built``: its Diagram, if built."""
    files = {Path(p).resolve() for p in f.files} | set(f.subsystem_files())
    if built is None:
        built, _ = f.build(f.variants()[0][1])
    files |= block_files(built.blocks.values())
    files |= plugin_files()
    return sorted(files)


_FILE_IDENTITY = weakref.WeakKeyDictionary()


def file_identity(f):
    """:func:`identity` of :func:`run_files` of DiagramFile ``f``, hashed once per parsed file (a
    worker that kept an experiment built from other contents builds it anew)."""
    got = _FILE_IDENTITY.get(f)
    if got is None:
        try:
            files = run_files(f)
        except HybridsimError:  # it does not build: the files it names still say which it is
            files = {Path(p).resolve() for p in f.files} | set(f.subsystem_files())
        got = _FILE_IDENTITY[f] = identity(files)
    return got


@functools.lru_cache(maxsize=1)
def code_identity():
    """A hash of hybridsim's own source (the package and its block library): an edited install
    computes other numbers under the same version."""
    import importlib.util

    h = hashlib.sha256()
    for name in ("hybridsim", "hybridsim.blocks"):
        top = Path(importlib.util.find_spec(name).origin).parent
        for p in sorted(top.rglob("*.py")):
            h.update(str(p.relative_to(top)).encode() + b"\0" + hashlib.sha256(p.read_bytes()).digest())
    return h.hexdigest()[:24]


def identity(files, extra=None):
    """A hash of the contents of ``files``, hybridsim's version and code, and the JSON of ``extra``."""
    from hybridsim.version import __version__

    h = hashlib.sha256()
    for p in sorted(Path(x) for x in files):
        h.update(str(p).encode() + b"\0")
        try:
            h.update(hashlib.sha256(p.read_bytes()).digest())
        except OSError:
            h.update(b"<unreadable>")
    h.update(json.dumps({"version": __version__, "code": code_identity(), "extra": extra}, sort_keys=True,
                        default=str).encode())
    return h.hexdigest()[:24]


def sweep_identity(sweep):
    """The identity of a sweep's points besides their own overrides (its resume fingerprint)."""
    from hybridsim.format.build import load

    f = load(sweep.diagram, **sweep.fixed)
    files = set(run_files(f))
    axes = [sweep.fixed, sweep.grid, sweep.scale, (sweep.random or {}).get("ranges", {})]
    files |= named_files(axes, sweep.path.parent, sweep.diagram.parent)
    return identity(files, {"set": sweep.fixed, "stability": sweep.stability, "traces": bool(sweep.traces)})


def check_sweep(data, path):
    """Check a parsed sweep file against its table; refuse one parameter given twice under two
    spellings (``k`` and ``params.k``) across set, grid, scale and random. Raises LoaderError."""
    got = tables.problems(tables.SWEEP, data, "sweep", path)
    if got:
        first = got[0].split(": ", 1)
        where = first[0].rsplit(":", 1)
        line = int(where[1]) if len(where) == 2 and where[1].isdigit() else None
        raise LoaderError(first[-1] + "".join(f"\n  also: {g}" for g in got[1:]), path, line)
    random = data.get("random") if isinstance(data.get("random"), dict) else {}
    given_once(path, [(s, data.get(s)) for s in ("set", "grid", "scale")] + [("random", random.get("ranges"))])


def given_once(path, sections):
    """Refuse one parameter given twice, in two sections or under two spellings (``k`` and
    ``params.k``), across ``sections``: ``(name, mapping)`` pairs of a sweep or tune file.
    Raises LoaderError at the second one's line."""
    seen, parts = {}, ({}, {})  # canonical key -> (key, section); given whole, given by element: base -> (key, section)
    for section, mapping in sections:
        for key in (mapping if isinstance(mapping, dict) else {}):
            try:
                p = ParamPath.parse(str(key))
            except ValueError:
                continue  # refused where it is applied, with the reason
            canon, base = p.key, p.without_index().key
            line = (getattr(mapping, "lines", None) or {}).get(key)
            if canon in seen and seen[canon] != (key, section):
                other, where = seen[canon]
                raise LoaderError(f"{section} {key!r} and {where} {other!r} are the same parameter ({canon}); "
                                  "give it once", path, line)
            # the whole value and one of its elements: the later one would overwrite the other
            clash = (parts[0] if p.index is not None else parts[1]).get(base)
            if clash is not None:
                raise LoaderError(f"{section} {key!r} and {clash[1]} {clash[0]!r} both set {base} (one whole, one "
                                  "element by element); give one of them", path, line)
            seen.setdefault(canon, (key, section))
            (parts[1] if p.index is not None else parts[0]).setdefault(base, (key, section))
