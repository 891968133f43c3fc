"""Sphinx configuration of hybridsim's documentation (built with warnings as errors by the tests).

The block library and the API reference are generated at build time, from the
block registry and the package's modules, into ``_generated/``: nothing there
is written by hand.
"""
import importlib
import inspect
import pkgutil
from pathlib import Path

HERE = Path(__file__).resolve().parent

project = "hybridsim"
author = "the hybridsim developers"
extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.napoleon"]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
exclude_patterns = ["_build"]
myst_heading_anchors = 3
napoleon_google_docstring = False
napoleon_numpy_docstring = True
autodoc_default_options = {"members": True, "undoc-members": False}
autodoc_member_order = "bysource"
suppress_warnings = ["myst.xref_missing"]
html_theme = "alabaster"
html_title = "hybridsim"


def _block_library():
    """docs/_generated/blocks.md: every registered block type by group, with its parameters and ports."""
    from hybridsim.engine.registry import GROUP_ORDER, group, lookup, parameters, types

    by_group = {}
    for name in types():
        by_group.setdefault(group(lookup(name)), []).append(name)
    order = [g for g in GROUP_ORDER if g in by_group] + sorted(set(by_group) - set(GROUP_ORDER))
    out = ["# The block library", "",
           "Generated from the block registry when the documentation is built "
           "(`hybridsim blocks -v` prints the same). Units are in each block's description.", ""]
    for g in order:
        out += [f"## {g}", ""]
        for name in sorted(by_group[g]):
            cls = lookup(name)
            req, opt = parameters(cls)
            sig = inspect.signature(cls.__init__).parameters
            out += [f"### `{name}`", ""]
            rows = [f"| `{p}` | {'required' if p in req else f'`{sig[p].default!r}`'} |" for p in req + opt]
            if rows:
                out += ["| parameter | default |", "| --- | --- |", *rows, ""]
            try:
                blk = cls(name="b")
                port = lambda p: f"`{p.name}[{p.width}]`"  # noqa: E731
                out += [f"Inputs {', '.join(map(port, blk.inputs)) or 'none'}; "
                        f"outputs {', '.join(map(port, blk.outputs)) or 'none'}"
                        + (f"; {blk.n_continuous} continuous states" if blk.n_continuous else "") + ".", ""]
            except Exception:  # noqa: BLE001 - a block that needs a file (an FMU) has no default ports
                pass
            out += ["```{eval-rst}", f".. autoclass:: {cls.__module__}.{cls.__qualname__}",
                    "   :no-members:", "   :no-index:", "```", ""]
    return "\n".join(out)


def _api():
    """docs/_generated/api.md: one section per module of the package."""
    import hybridsim
    import hybridsim.fmus

    names = ["hybridsim"]
    for pkg in (hybridsim, hybridsim.fmus):  # the package's own folder only (a checkout adds its root to __path__)
        here = [str(Path(pkg.__file__).parent)]
        names += ([pkg.__name__] if pkg is not hybridsim else []) + sorted(
            m.name for m in pkgutil.walk_packages(here, pkg.__name__ + "."))
    out = ["# API reference", "", "Generated from the numpy-style docstrings when the documentation is built.", ""]
    for name in names:
        importlib.import_module(name)
        opts = ["   :no-members:"] if name == "hybridsim" else []  # its names are documented where they live
        out += [f"## `{name}`", "", "```{eval-rst}", f".. automodule:: {name}", *opts, "```", ""]
    return "\n".join(out)


def _generate(app):
    gen = HERE / "_generated"
    gen.mkdir(exist_ok=True)
    for fname, text in (("blocks.md", _block_library()), ("api.md", _api())):
        path = gen / fname
        if not path.exists() or path.read_text() != text:  # unchanged files keep Sphinx's cache valid
            path.write_text(text)


def setup(app):
    app.connect("builder-inited", _generate)
