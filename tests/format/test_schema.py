"""The JSON Schema of the diagram format accepts every shipped diagram and refuses what it can see is wrong."""
import json

import pytest
import yaml

from hybridsim.app.cli import main
from hybridsim.format import NumberLoader
from hybridsim.format.schema import diagram_schema

from conftest import DIAGRAMS

jsonschema = pytest.importorskip("jsonschema")
SHIPPED = sorted(p for p in DIAGRAMS.rglob("*.yaml") if "sweeps" not in p.parts and "tune" not in p.parts)


@pytest.fixture(scope="module")
def validator():
    return jsonschema.Draft202012Validator(diagram_schema())


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_every_shipped_diagram_validates(validator, path):
    doc = yaml.load(path.read_text(), Loader=NumberLoader)
    assert [e.message for e in validator.iter_errors(doc)] == []


@pytest.mark.parametrize("blocks", [
    {"g": {"type": "gian", "K": 2.0}},                       # unknown block type
    {"g": {"type": "gain", "Kp": 2.0}},                      # unknown parameter
    {"g": {"type": "gain", "K": "two"}},                     # text where a number goes
    {"g": {"type": "relay", "initial": 3.0}},                # a number where true/false goes
    {"g.h": {"type": "gain"}},                               # a '.' in a block name
    {"s": {"type": "subsystem"}},                            # a subsystem without its file
])
def test_the_schema_refuses_the_loaders_error_cases(validator, blocks):
    assert list(validator.iter_errors({"blocks": blocks}))


def test_other_sections_are_checked(validator):
    assert list(validator.iter_errors({"blocks": {}, "simulation": {"solver": "euler"}}))
    assert list(validator.iter_errors({"blocks": {}, "simulaton": {}}))
    assert list(validator.iter_errors({"blocks": {}, "signals": {"forse": "a.y[0]"}}))
    assert not list(validator.iter_errors({"blocks": {"g": {"type": "gain", "K": "$k"}}, "params": {"k": 2}}))


def test_schema_command_writes_the_schema_with_plugin_blocks(tmp_path, capsys, monkeypatch):
    (tmp_path / "my_schema_blocks.py").write_text(
        "from hybridsim.engine.block import Block\nfrom hybridsim.engine.registry import register\n\n\n"
        "@register('schema_demo')\nclass Demo(Block):\n    \"\"\"A demo.\"\"\"\n\n"
        "    def __init__(self, name='d', gain=2.0):\n        super().__init__(name)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    out = tmp_path / "diagram.schema.json"
    assert main(["schema", "-o", str(out), "--plugin", "my_schema_blocks"]) == 0
    schema = json.loads(out.read_text())
    titles = {s.get("title") for s in schema["properties"]["blocks"]["additionalProperties"]["anyOf"]}
    assert {"gain", "discrete_pid", "fmu", "schema_demo", "subsystem"} <= titles
    assert "yaml-language-server: $schema=" in capsys.readouterr().out
