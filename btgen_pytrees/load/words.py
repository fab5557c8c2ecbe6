"""jsonschema's errors in the words a test author reads, and the document's "did you mean" budget."""

from __future__ import annotations

import json
import threading
from typing import Any, Iterable, Iterator

from ..errors import PathPart, Problem
from ..text import did_you_mean, shorten
from .schema import case_validator

__all__ = ["shown", "described", "schema_problems", "MAX_SUGGESTIONS", "suggest", "new_document"]

def shown(value: Any) -> str:
    return shorten(json.dumps(value, ensure_ascii=False) if not isinstance(value, str) else repr(value))


def _resolve(data: Any, path: tuple[PathPart, ...]) -> Any:
    for part in path:
        data = data[part]
    return data


def schema_problems(data: Any) -> Iterator[Problem]:
    return described(case_validator().iter_errors(data), data)


def described(errors: Iterable[Any], data: Any, prefix: tuple[PathPart, ...] = (), cause: str = "schema") -> Iterator[Problem]:
    """jsonschema's *errors* about *data* (found at *prefix* in the document) in words a test author reads.

    The same wording serves the test-case schema and every action's ``params`` schema:
    unknown keys with "did you mean", missing keys, values outside an enumeration with
    "did you mean", negative durations, and a schema's ``description`` where it says
    what was expected.
    """
    for error in errors:
        path = (*prefix, *error.absolute_path)
        keyword = error.validator
        if keyword == "additionalProperties" and isinstance(error.instance, dict):
            allowed = sorted(error.schema.get("properties", {}))
            for key in error.instance:
                if key not in allowed:
                    tip = did_you_mean(key, allowed) or f" (allowed: {', '.join(allowed) or 'none'})"
                    yield Problem((*path, key), f"unknown key {shown(key)}{tip}", cause)
            continue
        if error.schema is False:  # from/to/at on a criterion of another type (if/else branches)
            criterion = _resolve(data, tuple(error.absolute_path))
            allowed = {"from": ("period", "temporal"), "to": ("period",), "at": ("final",)}
            for key, where in allowed.items():
                if isinstance(criterion, dict) and key in criterion and criterion.get("type") not in where:
                    yield Problem((*path, key), f"{key!r} is only allowed on {' and '.join(where)} criteria", cause)
            continue
        if keyword == "required":
            missing = error.message.split("'")[1] if "'" in error.message else error.message
            yield Problem(path, f"missing required key {missing!r}", cause)
            continue
        if keyword == "enum" and isinstance(error.instance, str):
            options = [v for v in error.validator_value if isinstance(v, str)]
            listed = ", ".join(repr(v) for v in options)
            yield Problem(path, f"{shown(error.instance)} is not one of {listed}{suggest(error.instance, options)}", cause)
            continue
        if keyword == "minimum" and error.validator_value == 0 and isinstance(error.instance, (int, float)):
            yield Problem(path, f"must not be negative (got {error.instance})", cause)
            continue
        description = error.schema.get("description") if isinstance(error.schema, dict) else None
        if keyword in ("pattern", "anyOf") and description:
            yield Problem(path, f"{shown(error.instance)} is not valid: expected {description}", cause)
            continue
        if keyword == "type" and description:
            yield Problem(path, f"{shorten(error.message)}: expected {description}", cause)
            continue
        yield Problem(path, shorten(error.message), cause)

MAX_SUGGESTIONS = 20
"""Unknown names (ids, signals, actions, keys) that get a "did you mean" per document; later ones get
none. Each suggestion compares the name with every known one: 20,000 unknown ids against 20,000
known ones took ten minutes before this bound."""

_suggestions = threading.local()


def new_document() -> None:
    """Start the "did you mean" budget of a new document."""
    _suggestions.left = MAX_SUGGESTIONS


def suggest(word: str, candidates: Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` for the closest of *candidates*, within the document's budget.

    Only candidates of about the same length are compared (:func:`~btgen_pytrees.text.closest`).
    """
    left = getattr(_suggestions, "left", MAX_SUGGESTIONS)
    if left <= 0:
        return ""
    _suggestions.left = left - 1
    return did_you_mean(word, candidates, similar_length=True)

