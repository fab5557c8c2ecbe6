"""A valid document made into its :class:`~btgen_pytrees.model.TestCase`."""

from __future__ import annotations

from types import MappingProxyType
from typing import Any, Mapping

from ..leaves import Registry
from ..model import DEFAULT_JOIN, DEFAULT_TICK, DEFAULT_TIMEOUT, Criterion, Entry, TestCase
from ..contracts.system import SystemSpec
from .warnings import overlapping_writes

__all__ = ["build_case"]

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


