"""The search's objective, combined from the report's margins.

Each criterion's *margin* is the report's own (``OracleResult.margin``, a sweep
row's ``oracles[i].margin``: signal temporal logic's robustness, > 0 held with
room to spare, < 0 violated by that much; docs/semantics.md). The objective of
a run is each margin divided by its criterion's *scale*, combined within each
oracle group by the group's relation (``&&`` -> min, ``||`` -> max) and across
the two groups (records; periods and finals) by min, as the oracle root
combines them. Infinite margins (a truth value has no distance) and unknown
ones are left out.
"""

from __future__ import annotations

import math
from typing import Any, Collection, Mapping, Sequence

from ..model import TestCase

__all__ = ["row_margins", "combine", "groups_of"]


def row_margins(row: Mapping[str, Any]) -> dict[str, float | None]:
    """Each criterion's margin from a sweep row (its ``oracles``), by id."""
    out: dict[str, float | None] = {}
    for o in row.get("oracles", ()):
        m = o.get("margin")
        out[o["id"]] = float(m) if isinstance(m, (int, float)) and not isinstance(m, bool) else None
    return out


def groups_of(case: TestCase) -> dict[str, tuple[str, list[str]]]:
    """``{group: (relation, [criterion ids])}``: the oracle's two groups (Algorithm 2), as the tree has them."""
    groups: dict[str, tuple[str, list[str]]] = {}
    for c in case.criteria:
        group = "record" if c.type == "record" else "others"
        groups.setdefault(group, (case.relation.get(group, "&&"), []))[1].append(c.id)
    return groups


def combine(margins: Mapping[str, float | None], groups: Mapping[str, tuple[str, Sequence[str]]],
            scales: Mapping[str, float], graded: Collection[str] | None = None) -> float | None:  # fmt: skip
    """The objective: scaled margins, min/max within each group by its relation, min across groups.

    Criteria without a margin or with an infinite one (a truth value: no distance to measure) are left
    out, and when *graded* is given the criteria not in it whose margin is not negative (``None`` when
    nothing is left). An ``||`` group in which such a left-out criterion holds is left out too: it holds,
    by a margin the objective does not measure (its maximum), so its other criteria's margins, negative
    or not, say nothing of the run. Called once per run: one pass over the ids, no call per criterion.

    >>> combine({"R1": 2.0, "F1": -1.0, "F2": 3.0}, {"record": ("&&", ["R1"]), "others": ("||", ["F1", "F2"])}, {"R1": 2.0})
    1.0
    """
    totals = []
    isfinite = math.isfinite
    for relation, ids in groups.values():
        values = []
        held = False  # a criterion left out holds: an || group holds by it, with no distance to tell
        for i in ids:
            m = margins.get(i)
            if m is None or m != m:
                continue
            if isfinite(m) and (graded is None or i in graded or m < 0):
                values.append(m / scales.get(i, 1.0))
            elif m >= 0:
                held = True
        if relation == "||":
            if values and not held:
                totals.append(max(values))
        elif values:
            totals.append(min(values))
    return min(totals) if totals else None
