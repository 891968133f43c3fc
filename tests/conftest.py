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
