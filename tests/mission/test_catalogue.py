"""The registry's views agree with it: catalogue, docs reference, JSON Schema."""

from pathlib import Path

import jsonschema
import pytest
import yaml

from autonomy.mission import BUILTINS, load_mission
from autonomy.mission.catalogue import catalogue_text, json_schema, with_reference
from tests.harness import mission_files

ROOT = Path(__file__).resolve().parents[2]
SCHEMA = json_schema(BUILTINS)
VALIDATOR = jsonschema.Draft202012Validator(SCHEMA)


def test_schema_is_a_valid_json_schema():
    jsonschema.Draft202012Validator.check_schema(SCHEMA)


@pytest.mark.parametrize("path", mission_files((ROOT / "missions").glob("*.yaml")), ids=lambda p: p.stem)
def test_every_shipped_mission_matches_the_schema(path):
    document = yaml.safe_load(path.read_text())
    # A mission with plugins is checked against the schema of its own registry (built-ins + plugins).
    validator = (
        jsonschema.Draft202012Validator(json_schema(load_mission(path).registry))
        if "plugins" in document
        else VALIDATOR
    )
    errors = list(validator.iter_errors(document))
    assert not errors, [e.message for e in errors]


@pytest.mark.parametrize(
    "tree",
    [
        {"trun": {"left": 90}},
        {"move": {"speed": 5}},
        {"move": {"sped": 2}},
        {"turn": {"left": 10, "right": 10}},
        {"turn": {}},
        {"sequence": []},
        {"beep": {"tones": [1, 2]}},
        "turn",
        {"move": {"speed": 1}, "turn": {"left": 1}},
    ],
)
def test_schema_rejects_what_the_validator_rejects(tree):
    assert list(VALIDATOR.iter_errors({"mission": "x", "tree": tree}))


def test_schema_accepts_short_and_long_forms():
    for tree in (
        {"sequence": ["stop", {"move": {"speed": 1, "name": "go"}}]},
        {"fallback": {"memory": True, "children": ["collided"]}},
        {"while": {"condition": "healthy", "do": {"wait": {"seconds": 1}}}},
        {"beep": None},
    ):
        assert not list(VALIDATOR.iter_errors({"mission": "x", "tree": tree})), tree


def test_docs_reference_is_up_to_date():
    document = (ROOT / "docs" / "missions.md").read_text()
    assert with_reference(document, BUILTINS) == document, "run `make docs`"


def test_catalogue_lists_every_node_type_and_parameter():
    text = catalogue_text(BUILTINS)
    for node_type in BUILTINS:
        assert f"  {node_type.name}" in text
        for param in node_type.params:
            assert f"      {param.name}" in text
    assert "speed setting, 1 slow .. 4 very fast (int, 1..4, required)" in text
