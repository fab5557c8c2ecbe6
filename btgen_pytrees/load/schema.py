"""The shipped test-case JSON Schema: as text, parsed, with every action's params for editors, inlined, compiled."""

from __future__ import annotations

import json
from functools import lru_cache
from importlib import resources
from typing import Any, Mapping

from ..leaves import Registry, default_registry
from ..validator import SchemaValidator

__all__ = ["schema_text", "schema", "schema_for", "inline_refs", "case_validator"]

def schema_text() -> str:
    """The test-case JSON Schema, as shipped in the package."""
    return resources.files(__name__.partition(".")[0]).joinpath("schemas/testcase.schema.json").read_text(encoding="utf-8")


@lru_cache(maxsize=1)
def schema() -> Mapping[str, Any]:
    return json.loads(schema_text())


def schema_for(registry: Registry | None = None) -> dict[str, Any]:
    """The test-case schema with each registered action's ``params`` schema, for editors.

    ``python -m btgen_pytrees schema`` prints this. Entries and criteria get one
    ``if``/``then`` per registered leaf: *if* ``kind`` and ``action`` (a criterion:
    ``type`` and ``action``, or no ``action``) match, *then* ``params`` must fit
    that leaf's schema - so an editor that knows JSON Schema flags a misspelt or
    mistyped parameter as it is typed. The loader checks the same params itself
    (with friendlier messages), so it does not validate against this larger
    schema.

    >>> s = schema_for()
    >>> rule = next(r for r in s["$defs"]["entry"]["allOf"] if r["if"]["properties"]["action"] == {"const": "hold"})
    >>> rule["then"]["properties"]["params"]["required"]
    ['duration']
    """
    registry = registry if registry is not None else default_registry()
    full = json.loads(schema_text())
    entry_rules, criterion_rules = [], []
    for kind in ("behavior", "constraint", "record", "period", "final", "temporal"):
        actions: list[str | None] = list(registry.actions(kind))
        if kind in ("record", "period", "final", "temporal"):
            actions.insert(0, None)
        for action in actions:
            leaf = registry.get(kind, action)
            if leaf is None or leaf.params_schema is None:
                continue
            params = {k: v for k, v in leaf.params_schema.items() if k != "$schema"}
            if leaf.description and "description" not in params:
                params["description"] = leaf.description
            then = {"properties": {"params": params}}
            if kind in ("behavior", "constraint"):
                rule_if: dict[str, Any] = {"properties": {"kind": {"const": kind}, "action": {"const": action}}, "required": ["kind", "action"]}
            elif action is None:
                rule_if = {"properties": {"type": {"const": kind}}, "required": ["type"], "not": {"required": ["action"]}}
            else:
                rule_if = {"properties": {"type": {"const": kind}, "action": {"const": action}}, "required": ["type", "action"]}
            (entry_rules if kind in ("behavior", "constraint") else criterion_rules).append({"if": rule_if, "then": then})
    full["$defs"]["entry"].setdefault("allOf", []).extend(entry_rules)
    full["$defs"]["criterion"].setdefault("allOf", []).extend(criterion_rules)
    # a sweep's "$name" stands for a number or a boolean where the loader substitutes it (docs/sweeps.md):
    # tick, timeout, signals' values, params, a criterion's from/to/at - so editors accept the project's sweeps
    full["$defs"]["parameter"] = {"type": "string", "pattern": "^[$][A-Za-z_][A-Za-z0-9_]*$",
                                  "description": "A sweep parameter, $name: replaced by its value before the case is checked."}  # fmt: skip
    for key in ("tick", "timeout", "signals"):
        full["properties"][key] = _or_parameter(full["properties"][key])
    full["$defs"]["seconds"] = _or_parameter(full["$defs"]["seconds"])
    for rule in entry_rules + criterion_rules:
        rule["then"]["properties"]["params"] = _or_parameter(rule["then"]["properties"]["params"])
    return full


_NOT_SCHEMAS = frozenset({"enum", "const", "default", "examples", "required", "description", "pattern", "$comment"})


def _or_parameter(schema: Any) -> Any:
    """*schema* where every number, integer or boolean may also be a sweep parameter ``"$name"``."""
    if isinstance(schema, list):
        return [_or_parameter(item) for item in schema]
    if not isinstance(schema, dict):
        return schema
    made = {key: value if key in _NOT_SCHEMAS else _or_parameter(value) for key, value in schema.items()}
    types = schema.get("type")
    types = [types] if isinstance(types, str) else types if isinstance(types, list) else []
    if any(t in ("number", "integer", "boolean") for t in types):
        return {"anyOf": [made, {"$ref": "#/$defs/parameter"}]}
    return made


def inline_refs(node: Any, root: Mapping[str, Any], depth: int = 0) -> Any:
    """*node* with every local ``$ref`` replaced by a copy of its target (``$defs`` dropped).

    jsonschema resolves a ``$ref`` through its referencing registry each time it
    meets one, i.e. several times per execute entry; a schema with the targets
    inlined validates the same documents with the same errors, 1.7 times faster.
    A sibling of ``$ref`` (only ``description`` in our schema) overrides the target's.

    >>> inline_refs({"$defs": {"n": {"type": "number"}}, "items": {"$ref": "#/$defs/n"}}, {"$defs": {"n": {"type": "number"}}})
    {'items': {'type': 'number'}}
    """
    if depth > 32:
        raise ValueError("recursive $ref in the schema")
    if isinstance(node, dict):
        if "$ref" in node:
            target: Any = root
            for part in node["$ref"].removeprefix("#/").split("/"):
                target = target[part]
            merged = {**target, **{k: v for k, v in node.items() if k != "$ref"}}
            return inline_refs(merged, root, depth + 1)
        return {k: inline_refs(v, root, depth + 1) for k, v in node.items() if k != "$defs"}
    if isinstance(node, list):
        return [inline_refs(v, root, depth + 1) for v in node]
    return node


@lru_cache(maxsize=1)
def case_validator() -> SchemaValidator:
    return SchemaValidator(inline_refs(schema(), schema()), checked=True)  # tests/test_validation_fastpath.py checks it

