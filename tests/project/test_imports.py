"""No import circles between hybridsim's modules.

Every ``import`` and ``from ... import`` of the package's own modules counts, at module level
and inside functions alike (a function-level import is a dependency all the same, only a late
one). The package is ``hybridsim/`` with the folders it installs as ``hybridsim.blocks`` and
``hybridsim.fmus`` (``blocks/``, ``fmus/``). ``from a.b import c`` depends on ``a.b.c`` when that
is a module, else on ``a.b`` (its ``__init__``); importing ``a.b.c`` does not count as depending
on the parents ``a`` and ``a.b``, which Python imports on the way.
"""
import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: the package's folders and the names they install under (pyproject.toml's package-dir)
FOLDERS = {"hybridsim": ROOT / "hybridsim", "hybridsim.blocks": ROOT / "blocks", "hybridsim.fmus": ROOT / "fmus"}

#: circles known and being broken (a set of module names each); an entry whose circle is gone fails
#: the test, so the list only shrinks
PENDING = []


def modules():
    """{dotted module name: file} of every module of the package."""
    out = {}
    for name, folder in FOLDERS.items():
        for path in folder.rglob("*.py"):
            if "__pycache__" in path.parts:
                continue
            rel = path.relative_to(folder).with_suffix("").parts
            if rel[-1] == "__init__":
                rel = rel[:-1]
            out[".".join((name,) + rel)] = path
    return out


def _target(name, known):
    """The module ``name`` stands for: itself, else its longest known prefix (None: not ours)."""
    while name:
        if name in known:
            return name
        name = name.rpartition(".")[0]
    return None


def imports(module, path, known):
    """The package's modules that ``module`` imports anywhere in its file."""
    tree = ast.parse(path.read_text(), str(path))
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                parts = parts[:len(parts) - node.level + 1]
                base = ".".join(parts + ([base] if base else []))
            names = [f"{base}.{a.name}" if f"{base}.{a.name}" in known else base for a in node.names]
        else:
            continue
        out |= {t for t in (_target(n, known) for n in names) if t and t != module}
    return out


def graph():
    known = modules()
    return {m: imports(m, p, known) for m, p in known.items()}


def circles(edges):
    """The strongly connected components of more than one module (Tarjan), each a set."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = set()
            while True:
                w = stack.pop()
                on.discard(w)
                comp.add(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(comp)

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out


def test_the_finder_sees_circles_and_late_imports(tmp_path):
    assert circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [{"a", "b", "c"}]
    assert circles({"a": {"b"}, "b": set()}) == []
    known = {"hybridsim.x", "hybridsim.x.y", "hybridsim.z", "hybridsim.q"}
    path = tmp_path / "w.py"
    path.write_text("import os\nimport hybridsim.q.r\ndef f():\n    from hybridsim.x import y\n    from . import z\n")
    assert imports("hybridsim.w", path, known) == {"hybridsim.q", "hybridsim.x.y", "hybridsim.z"}


def test_no_import_circles():
    found = circles(graph())
    new = [sorted(c) for c in found if c not in PENDING]
    assert not new, "import circles (module -> module, function-level imports included):\n" + "\n".join(
        " <-> ".join(c) for c in new)
    gone = [sorted(c) for c in PENDING if c not in found]
    assert not gone, f"these circles are gone: delete them from PENDING: {gone}"
