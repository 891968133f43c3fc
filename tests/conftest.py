from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DIAGRAMS = ROOT / "diagrams"


@pytest.fixture
def diagrams():
    return DIAGRAMS


def write(tmp_path, text, name="d.yaml"):
    p = tmp_path / name
    p.write_text(text)
    return p


@pytest.fixture(autouse=True, scope="session")
def _compiled_cache(tmp_path_factory):
    """Compiled-path modules go to a fresh folder: the suite compiles what it runs."""
    import os

    os.environ["HYBRIDSIM_CACHE"] = str(tmp_path_factory.mktemp("hybridsim_cache"))
