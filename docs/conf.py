"""Sphinx configuration of hybridsim's documentation (built with warnings as errors by the tests).

The block library and the API reference are generated at build time, from the
block registry and the package's modules, into ``_generated/``: nothing there
is written by hand.
"""
import importlib
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
    from hybridsim.format.catalog import catalog

    out = ["# The block library", "",
           "Generated from the block registry when the documentation is built "
           "(`hybridsim blocks -v` prints the same). Units are in each block's description.", ""]
    for g, infos in catalog().items():
        out += [f"## {g}", ""]
        for b in infos:
            out += [f"### `{b.type_name}`", ""]
            rows = [f"| `{p}` | required |" for p in b.required]
            rows += [f"| `{p}` | `{v!r}` |" for p, v in b.defaults.items()]
            if rows:
                out += ["| parameter | default |", "| --- | --- |", *rows, ""]
            if b.inputs is not None:
                port = lambda p: f"`{p[0]}[{p[1]}]`"  # noqa: E731
                out += [f"Inputs {', '.join(map(port, b.inputs)) or 'none'}; "
                        f"outputs {', '.join(map(port, b.outputs)) or 'none'}"
                        + (f"; {b.states} continuous states" if b.states else "") + ".", ""]
            out += ["```{eval-rst}", f".. autoclass:: {b.cls.__module__}.{b.cls.__qualname__}",
                    "   :no-members:", "   :no-index:", "```", ""]
    return "\n".join(out)


def _commands():
    """docs/_generated/commands.md: every command with its description and options, from the parser
    ``hybridsim --help`` prints (hybridsim/app: one module per command)."""
    import argparse

    from hybridsim.app.cli import build_parser

    def options(parser):
        rows = []
        for a in parser._actions:
            if isinstance(a, (argparse._HelpAction, argparse._SubParsersAction)):
                continue
            name = ", ".join(a.option_strings) or (a.metavar or a.dest).upper()
            if a.option_strings and a.nargs != 0:
                name += f" {a.metavar or a.dest.upper()}"
            text = (a.help or "").replace("|", "\\|").replace("<", "\\<")
            if a.choices:
                text += f" (one of {', '.join(map(str, a.choices))})"
            rows.append(f"| `{name}` | {text} |")
        return ["| argument | meaning |", "| --- | --- |", *rows, ""] if rows else []

    def commands(parser, prefix):
        sub = next((a for a in parser._actions if isinstance(a, argparse._SubParsersAction)), None)
        if sub is None:
            return []
        out = []
        for name, sp in sub.choices.items():
            full = f"{prefix} {name}"
            if any(isinstance(a, argparse._SubParsersAction) for a in sp._actions):
                out += [f"## `{full}`", "", sp.description or "", ""] + commands(sp, full)
                continue
            out += [f"## `{full}`", "", (sp.description or "").replace("<", "\\<"), "", "```text", sp.format_usage().strip(), "```", ""]
            out += options(sp)
        return out

    parser = build_parser()
    return "\n".join(["# Commands", "",
                       "Generated from the command's own parser when the documentation is built: the same text "
                       "as `hybridsim COMMAND --help`. Every command also takes `--plugin MODULE`.", "",
                       "```text", parser.format_usage().strip(), "```", ""] + commands(parser, "hybridsim"))


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
    for fname, text in (("blocks.md", _block_library()), ("commands.md", _commands()), ("api.md", _api())):
        path = gen / fname
        if not path.exists() or path.read_text() != text:  # unchanged files keep Sphinx's cache valid
            path.write_text(text)


def setup(app):
    app.connect("builder-inited", _generate)
