"""The documentation site builds with Sphinx, warnings as errors, documents every block type, and its YAML parses."""
from pathlib import Path

import pytest

from hybridsim.engine.registry import types

DOCS = Path(__file__).resolve().parents[2] / "docs"


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::DeprecationWarning", "ignore::PendingDeprecationWarning")  # Sphinx's own API
def test_the_docs_build_without_a_warning(tmp_path):
    from sphinx.cmd.build import build_main

    out = tmp_path / "html"
    code = build_main(["-W", "--keep-going", "-q", "-b", "html", "-d", str(tmp_path / "doctrees"), str(DOCS), str(out)])
    assert code == 0  # -W: any warning (a broken docstring, a dead link between pages) fails
    blocks = (out / "_generated" / "blocks.html").read_text()
    missing = [t for t in types() if f"<code class=\"docutils literal notranslate\"><span class=\"pre\">{t}</span>" not in blocks]
    assert not missing, missing
    api = (out / "_generated" / "api.html").read_text()
    assert "hybridsim.engine.simulator.Simulator" in api and "hybridsim.paper.reproduce" in api
    for page in ("tutorials/first-diagram", "tutorials/own-fmu", "tutorials/own-robot", "tutorials/dask-sweeps",
                 "tutorials/stability-report", "model", "diagram-format"):
        assert (out / f"{page}.html").exists(), page


def test_every_yaml_example_in_the_docs_parses():
    """A reader copies these: `points: {force: ctrl.dF.y[0]}` was a YAML syntax error ([ ] in { })."""
    import re

    import yaml

    bad = []
    for page in sorted(DOCS.rglob("*.md")) + [DOCS.parent / "README.md"]:
        text = page.read_text()
        for m in re.finditer(r"```ya?ml\n(.*?)```", text, re.S):
            try:
                yaml.safe_load(m.group(1))
            except yaml.YAMLError as exc:
                bad.append(f"{page.name}:{text[:m.start()].count(chr(10)) + 2}: {str(exc).splitlines()[0]}")
    assert not bad, bad
