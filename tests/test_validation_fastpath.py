"""The fast yes/no schema check (fastjsonschema) agrees with jsonschema.

The loader trusts the fast check when it says *valid* and only then skips
jsonschema; a disagreement would let a malformed document through. Fuzzed
documents from ``test_fuzz.mutants`` and every test case in ``examples/`` are
checked with both.
"""

from __future__ import annotations

import json
import pathlib
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from test_fuzz import mutants

from btgen_pytrees.leaves import default_registry
from btgen_pytrees.load import case_validator, parse_json
from btgen_pytrees.errors import InvalidTestCase
from btgen_pytrees.validator import SchemaValidator

ROOT = pathlib.Path(__file__).resolve().parent.parent
pytest.importorskip("fastjsonschema")


def agree(validator: SchemaValidator, data: Any) -> None:
    assert validator.fast is not None
    try:
        validator.fast(data)
        fast = True
    except Exception:  # noqa: BLE001
        fast = False
    assert fast == validator.full.is_valid(data), json.dumps(data)[:500]


def test_the_test_case_schema_uses_the_fast_path() -> None:
    assert case_validator().fast is not None
    for name in ("set", "ramp", "hold", "wait", "until"):
        assert default_registry().get("constraint" if name in ("wait", "until") else "behavior", name).params_validator.fast is not None


@settings(max_examples=300, deadline=None, derandomize=True, database=None, suppress_health_check=list(HealthCheck))
@given(mutant=mutants())
def test_fast_and_full_agree_on_fuzzed_documents(mutant: tuple[bytes, list[str]]) -> None:
    raw, _ = mutant
    try:
        data = parse_json(raw)
    except InvalidTestCase:
        return
    agree(case_validator(), data)
    for entry in data.get("execute", []) if isinstance(data, dict) and isinstance(data.get("execute"), list) else []:
        if isinstance(entry, dict) and entry.get("action") in ("set", "ramp", "hold") and "params" in entry:
            agree(default_registry().get("behavior", entry["action"]).params_validator, entry["params"])


@pytest.mark.parametrize("path", sorted(ROOT.glob("examples/**/*.json")), ids=lambda p: p.name)
def test_examples(path: pathlib.Path) -> None:
    agree(case_validator(), json.loads(path.read_text()))


def test_schemas_beyond_draft7_skip_the_fast_path() -> None:
    assert SchemaValidator({"type": "object", "unevaluatedProperties": False}).fast is None
    assert SchemaValidator({"$defs": {"n": {"type": "number"}}, "$ref": "#/$defs/n"}).fast is None
    assert SchemaValidator({"type": "object"}).fast is not None


def test_the_test_case_schema_is_valid() -> None:
    # the loader builds its validator with checked=True (no metaschema check at run time): it is checked here
    import jsonschema

    from btgen_pytrees.load import inline_refs, schema

    jsonschema.Draft202012Validator.check_schema(schema())
    jsonschema.Draft202012Validator.check_schema(inline_refs(schema(), schema()))
