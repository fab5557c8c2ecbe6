"""Everything of a document but its entries: the rest checked against the schema, and the valid document made into its
:class:`~btgen_pytrees.model.TestCase`."""

from __future__ import annotations

import json
from functools import lru_cache
from types import MappingProxyType
from typing import Any, Mapping

from ..leaves import Registry
from ..model import DEFAULT_JOIN, DEFAULT_TICK, DEFAULT_TIMEOUT, Criterion, Entry, StopCondition, TestCase
from ..contracts.system import SystemSpec
from .schema import case_validator
from .warnings import overlapping_writes

__all__ = ["build_case", "rest_fits", "SMALL"]

def build_case(data: Mapping[str, Any], entries: list[Entry], criteria: list[Criterion], spec: SystemSpec,
          registry: Registry, source: str, stop: tuple[StopCondition, ...] = ()) -> TestCase:  # fmt: skip
    """The :class:`TestCase` of a valid document, from its checked entries and criteria."""
    relation = data.get("oracle", {}).get("relation", "&&")
    if isinstance(relation, str):
        relation = {"record": relation, "others": relation}
    return TestCase(
        name=data["name"],
        description=data.get("description", ""),
        signals=MappingProxyType(dict(data.get("signals", {}))),
        declares_signals="signals" in data,
        tick=float(data.get("tick", DEFAULT_TICK)),
        timeout=float(data.get("timeout", DEFAULT_TIMEOUT)),
        join=data.get("join", DEFAULT_JOIN),
        entries=tuple(entries),
        criteria=tuple(criteria),
        relation=MappingProxyType({"record": relation.get("record", "&&"), "others": relation.get("others", "&&")}),
        source=source,
        system=spec,
        require_complete=bool(data.get("require_complete", False)),
        warnings=tuple(overlapping_writes(entries, registry)),
        stop=stop,
    )




SMALL = 100
"""Criteria and signals up to which the rest of a document is checked by jsonschema itself (about a
millisecond) rather than by the compiled check, whose compilation (40 ms, once per process) would
cost more than it saves."""

REMEMBERED = 64
"""Verdicts :func:`rest_fits` keeps (of small documents), the least recently used forgotten first."""


def rest_fits(doc: dict[str, Any]) -> bool:
    """Whether *doc* fits the test-case schema (its entries stand-ins: each was checked in the entry loop).

    The verdict for a small document is remembered by its canonical JSON text (sorted keys; the same
    text read back must equal the document, so a tuple, a key that is not a string or a NaN is never
    taken for the JSON it prints as): the variations of a sweep and the runs of a search differ in their
    entries' params, seldom in the rest, which jsonschema would otherwise walk again for every one
    (a quarter of a millisecond, more with cold caches between SUMO runs) - the same check, asked once.
    """
    validator = case_validator()
    oracle, signals = doc.get("oracle"), doc.get("signals")
    criteria = oracle.get("criteria") if type(oracle) is dict else None
    size = (len(criteria) if type(criteria) is list else 0) + (len(signals) if type(signals) is dict else 0)
    if size > SMALL or "fast" in validator.__dict__:  # compiled already, or worth compiling
        return next(iter(validator.iter_errors(doc)), None) is None
    key = _canonical(doc)
    if key is None:
        return bool(validator.full.is_valid(doc))
    return _fits(key)


@lru_cache(maxsize=REMEMBERED)
def _fits(text: str) -> bool:
    """Whether the document of canonical JSON *text* fits the schema: jsonschema's own walk (not compiled
    yet: cheaper for a small document)."""
    return bool(case_validator().full.is_valid(json.loads(text)))


def _canonical(doc: dict[str, Any]) -> str | None:
    """*doc* as JSON text with sorted keys, if that text stands for it exactly (else None)."""
    try:
        text = json.dumps(doc, sort_keys=True, ensure_ascii=False)
        return text if json.loads(text) == doc else None
    except (TypeError, ValueError, RecursionError):  # not JSON (a set, keys of mixed types, ...)
        return None
