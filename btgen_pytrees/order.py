"""The topological order of a timeline's entries, written once (Kahn's algorithm).

Every function takes *after*: each entry's id mapped to the ids it comes after, in file order
(``{e.id: e.after for e in case.entries}``, or a networkx graph's ``_pred`` adjacency dict).
Every id named after must be a key. Ties are broken by file order, so the order is deterministic:
the order of ``networkx.lexicographical_topological_sort`` keyed by file index. When every entry
names only entries above it (the usual case) that order is the file order itself, found in one
linear pass; otherwise a heap of file indices gives it in O((n + e) log n).

>>> order({"A": (), "B": ("C",), "C": ("A",)})
['A', 'C', 'B']
>>> order({"A": ("B",), "B": ("A",)}) is None
True
"""

from __future__ import annotations

from heapq import heappop, heappush
from typing import Collection, Iterable, Mapping

__all__ = ["order", "positions", "is_acyclic"]


def _file_index(after: Mapping[str, Collection[str]]) -> tuple[dict[str, int], bool]:
    """Each id's file index, and whether every entry names only entries above it."""
    index = {v: i for i, v in enumerate(after)}
    return index, all(index[p] < i for i, preds in enumerate(after.values()) for p in preds)


def _kahn(
    after: Mapping[str, Collection[str]], index: dict[str, int], successors: Mapping[str, Iterable[str]] | None
) -> list[str] | None:
    if successors is None:
        built: dict[str, list[str]] = {v: [] for v in after}
        for v, preds in after.items():
            for p in preds:
                built[p].append(v)
        successors = built
    nodes = list(after)
    waiting = [len(preds) for preds in after.values()]
    heap = [i for i, d in enumerate(waiting) if d == 0]
    found = []
    while heap:
        i = heappop(heap)
        found.append(nodes[i])
        for s in successors[nodes[i]]:
            j = index[s]
            waiting[j] -= 1
            if not waiting[j]:
                heappush(heap, j)
    return found if len(found) == len(nodes) else None


def order(
    after: Mapping[str, Collection[str]], successors: Mapping[str, Iterable[str]] | None = None
) -> list[str] | None:
    """The ids in topological order, ties by file order; ``None`` when some of them form a cycle.

    *successors* (each id mapped to the ids that come after it, such as a graph's ``_succ``) saves
    building them when the file order is not an order.
    """
    index, forward = _file_index(after)
    return list(after) if forward else _kahn(after, index, successors)


def positions(
    after: Mapping[str, Collection[str]], successors: Mapping[str, Iterable[str]] | None = None
) -> dict[str, int] | None:
    """Each id's place in :func:`order` (the file index when that is the file order); ``None`` on a cycle."""
    index, forward = _file_index(after)
    if forward:
        return index  # the usual case, in one pass: no second dict
    found = _kahn(after, index, successors)
    return None if found is None else {v: i for i, v in enumerate(found)}


def is_acyclic(after: Mapping[str, Collection[str]]) -> bool:
    """Whether the entries can be ordered after their predecessors (no cycle)."""
    index, forward = _file_index(after)
    return forward or _kahn(after, index, None) is not None
