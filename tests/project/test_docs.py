"""The documentation site builds with Sphinx, warnings as errors, and documents every block type."""
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
