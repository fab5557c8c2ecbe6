"""Everything of a document but its entries: the rest checked against the schema, and the valid document made into its
:class:`~btgen_pytrees.model.TestCase`."""

from __future__ import annotations

from types import MappingProxyType
from typing import Any, Mapping

from ..leaves import Registry
from ..model import DEFAULT_JOIN, DEFAULT_TICK, DEFAULT_TIMEOUT, Criterion, Entry, TestCase
from ..contracts.system import SystemSpec
from .schema import case_validator
from .warnings import overlapping_writes

__all__ = ["build_case", "rest_fits", "SMALL"]

def build_case(data: Mapping[str, Any], entries: list[Entry], criteria: list[Criterion], spec: SystemSpec,
          registry: Registry, source: str) -> TestCase:  # fmt: skip
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
    )




SMALL = 100
"""Criteria and signals up to which the rest of a document is checked by jsonschema itself (about a
millisecond) rather than by the compiled check, whose compilation (40 ms, once per process) would
cost more than it saves."""


def rest_fits(doc: dict[str, Any]) -> bool:
    """Whether *doc* fits the test-case schema (its entries stand-ins: each was checked in the entry loop)."""
    validator = case_validator()
    oracle, signals = doc.get("oracle"), doc.get("signals")
    criteria = oracle.get("criteria") if type(oracle) is dict else None
    size = (len(criteria) if type(criteria) is list else 0) + (len(signals) if type(signals) is dict else 0)
    if size <= SMALL and "fast" not in validator.__dict__:  # not compiled yet: jsonschema's own walk is cheaper
        return bool(validator.full.is_valid(doc))
    return next(iter(validator.iter_errors(doc)), None) is None
