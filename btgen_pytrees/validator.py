"""JSON Schema checks: jsonschema for the errors, fastjsonschema for the yes/no.

Most test cases are valid. For them the loader only needs to know *that* the
document fits the schema, and fastjsonschema (which compiles a schema to Python
code) answers that 10-25 times faster than jsonschema walks it (the schema
table of ``python -m benchmarks.run``, ``benchmarks/schemas.py``). Only a document it rejects is walked by jsonschema,
whose errors (with JSON paths, all of them) are what users see. Both use
Python's ``re`` for ``pattern``, so they agree on strings; the fast path is used
only for schemas written in the draft-07 vocabulary both implement the same way
(no ``$ref``, no 2019-09/2020-12 keywords), and ``tests/test_validation_fastpath.py``
checks the two agree on fuzzed documents.

>>> v = SchemaValidator({"type": "object", "required": ["a"]})
>>> [e.message for e in v.iter_errors({})]
["'a' is a required property"]
>>> list(v.iter_errors({"a": 1}))
[]

jsonschema writes the values in its messages as Python does (``None is not of type
'object'``); a test author wrote JSON, so they are given back as JSON (:func:`json_words`):

>>> [e.message for e in SchemaValidator({"type": "object"}).iter_errors(None)]
["null is not of type 'object'"]
"""

from __future__ import annotations

import json
from functools import cached_property, lru_cache
from typing import Any, Callable, Iterator, Mapping

import jsonschema

__all__ = ["SchemaValidator", "shared_validator", "json_words"]

_NEWER_KEYWORDS = frozenset({
    "$ref", "$dynamicRef", "$dynamicAnchor", "$recursiveRef", "$recursiveAnchor", "$anchor",
    "prefixItems", "unevaluatedProperties", "unevaluatedItems", "dependentRequired",
    "dependentSchemas", "minContains", "maxContains", "format",
})  # fmt: skip


def _draft7_compatible(node: Any) -> bool:
    stack = [node]
    while stack:
        item = stack.pop()
        if isinstance(item, dict):
            if _NEWER_KEYWORDS & item.keys() or isinstance(item.get("items"), list):
                return False
            stack.extend(v for k, v in item.items() if k not in ("enum", "const", "default", "examples"))
        elif isinstance(item, list):
            stack.extend(item)
    return True


def _compile_fast(schema: Mapping[str, Any]) -> Callable[[Any], Any] | None:
    try:
        import fastjsonschema
    except ImportError:  # optional speed-up: jsonschema alone gives the same answers
        return None
    if not _draft7_compatible(schema):
        return None
    draft7 = {**schema, "$schema": "http://json-schema.org/draft-07/schema#"}
    try:
        return fastjsonschema.compile(draft7)  # type: ignore[no-any-return]
    except Exception:  # noqa: BLE001 - anything it cannot compile is left to jsonschema
        return None


def _json_text(value: Any) -> str | None:
    """*value* as JSON text where Python writes it otherwise (``None``, ``True``, a dict's ``'key'``)."""
    if value is None or isinstance(value, (bool, dict, list)):
        try:
            return json.dumps(value, ensure_ascii=False, allow_nan=False)
        except (TypeError, ValueError, RecursionError):
            return None
    return None


def json_words(error: jsonschema.ValidationError) -> jsonschema.ValidationError:
    """*error* with the values its message shows (the instance, the schema's value) in their JSON form:
    ``null``, ``true``, ``{"a": null}``. Strings keep their quotes (``'dddd' is too long``), numbers are
    written alike in both."""
    message = error.message
    for value in (error.instance, error.validator_value):
        text = _json_text(value)
        python = repr(value) if text is not None else ""
        if python and python != text and python in message:
            message = message.replace(python, text, 1)  # type: ignore[arg-type]
    error.message = message
    return error


class SchemaValidator:
    """Validate against one schema; :meth:`iter_errors` as jsonschema's, but fast when valid."""

    def __init__(self, schema: Mapping[str, Any], *, checked: bool = False):
        """*checked*: the schema is known to be valid (the package's own, checked by its tests), so the
        check against the metaschema - 30 ms for the test-case schema, on every process start - is skipped."""
        cls = jsonschema.validators.validator_for(schema, default=jsonschema.Draft202012Validator)
        if not checked:
            cls.check_schema(schema)
        self.full = cls(schema)
        self._schema = schema

    @cached_property
    def fast(self) -> Callable[[Any], Any] | None:
        """The compiled yes/no check (``None`` if the schema is beyond it), compiled on first use:
        40 ms for the test-case schema, which a small document checked by ``full`` never needs."""
        return _compile_fast(self._schema)

    def is_valid(self, data: Any) -> bool:
        return next(iter(self.iter_errors(data)), None) is None

    def iter_errors(self, data: Any) -> Iterator[jsonschema.ValidationError]:
        if self.fast is not None:
            try:
                self.fast(data)
                return iter(())
            except Exception:  # noqa: BLE001 - rejected (or confused): let jsonschema say why
                pass
        return map(json_words, self.full.iter_errors(data))


def shared_validator(schema: Mapping[str, Any]) -> SchemaValidator:
    """One :class:`SchemaValidator` per distinct schema in this process.

    Every registry (``default_registry()`` makes a new one per load) registers the
    same built-in params schemas; checking each against the metaschema and compiling
    it again cost 15-20 ms per load of a small case. Schemas are keyed by their
    canonical JSON text; one that is not plain JSON gets a validator of its own.
    """
    try:
        text = json.dumps(schema, sort_keys=True, allow_nan=False)
        same = json.loads(text) == schema  # plain JSON (a tuple would come back a list: not the same schema)
    except (TypeError, ValueError):
        same = False
    return _shared(text) if same else SchemaValidator(schema)


@lru_cache(maxsize=256)
def _shared(text: str) -> SchemaValidator:
    return SchemaValidator(json.loads(text))
