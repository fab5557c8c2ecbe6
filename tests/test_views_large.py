"""The JSON view is compact for large trees and indented for small ones, with the same data."""

from __future__ import annotations

import json

from helpers import case, entry

import btgen_pytrees
from btgen_pytrees.render import JSON_INDENT_LIMIT, render


def _comb(steps: int) -> dict:
    entries = []
    for i in range(steps):
        entries.append(entry(f"S{i}", [f"S{i - 1}"] if i else []))
        entries.append(entry(f"C{i}", [f"S{i}"], action="wait"))
    return case(*entries)


def _count(root) -> int:  # type: ignore[no-untyped-def]
    return sum(1 for _ in root.iterate())


def test_large_tree_is_compact_small_tree_indented() -> None:
    small = btgen_pytrees.load(_comb(5))
    large = btgen_pytrees.load(_comb(JSON_INDENT_LIMIT // 4))
    for loaded, indented in ((small, True), (large, False)):
        root = btgen_pytrees.generate(loaded)
        assert (_count(root) <= JSON_INDENT_LIMIT) is indented
        text = render(root, btgen_pytrees.timeline(loaded), "json")
        assert text.endswith("\n") and (text.count("\n") > 1) is indented
        chosen = render(root, btgen_pytrees.timeline(loaded), "json", indent=2 if not indented else None)
        assert json.loads(text) == json.loads(chosen) and len(text) != len(chosen)
