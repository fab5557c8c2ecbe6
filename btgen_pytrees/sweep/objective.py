"""The objective: how close a run came to failing, one number - what ``falsify`` minimises and what a
sweep's map and its "closest to failing" show (docs/falsify.md, docs/sweeps.md).

Each criterion's *margin* is the report's own (``OracleResult.margin``, a sweep
row's ``oracles[i].margin``: signal temporal logic's robustness, > 0 held with
room to spare, < 0 violated by that much; docs/semantics.md). The objective of
a run is each margin divided by its criterion's *scale*, combined within each
oracle group by the group's relation (``&&`` -> min, ``||`` -> max) and across
the two groups (records; periods and finals) by min, as the oracle root
combines them. Infinite margins (a truth value has no distance) and unknown
ones are left out, and so are the criteria without a *gradient* - whose margin takes
one value wherever the run passes (a collision count ``sim.collisions == 0`` is 0
on every passing run): they cannot say how close a passing run came
(:func:`fit_scales`). Where no criterion is left, the objective is None and the
verdict is all there is. A failing run's objective is at most 0.
"""

from __future__ import annotations

import math
from typing import Any, Collection, Mapping, Sequence

from ..model import TestCase

__all__ = ["row_margins", "combine", "groups_of", "document_groups", "fit_scales", "objective", "objectives"]


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


def document_groups(document: Mapping[str, Any]) -> dict[str, tuple[str, list[str]]]:
    """:func:`groups_of` from a case document (a sweep's template): its criteria's ids and types, its
    oracle's ``relation``."""
    oracle = document.get("oracle") if isinstance(document.get("oracle"), Mapping) else {}
    relation = oracle.get("relation", "&&")
    if isinstance(relation, str):
        relation = {"record": relation, "others": relation}
    groups: dict[str, tuple[str, list[str]]] = {}
    for c in oracle.get("criteria", ()):
        if isinstance(c, Mapping) and isinstance(c.get("id"), str):
            group = "record" if c.get("type") == "record" else "others"
            groups.setdefault(group, (str(relation.get(group, "&&")), []))[1].append(c["id"])
    return groups


def fit_scales(runs: Sequence[tuple[Mapping[str, float | None], bool]], ids: Sequence[str],
               given: Mapping[str, float] | None = None) -> tuple[dict[str, float], list[str]]:  # fmt: skip
    """Each criterion's scale and which criteria are graded, from *runs* (``(margins, failed)``): the scale is
    *given*'s, else the standard deviation of its finite margins (1 when they do not vary); a criterion is
    graded when its finite margin takes more than one value over the passing runs (a count or a truth
    value is the same wherever the run passes)."""
    scales: dict[str, float] = {}
    graded = []
    for i in ids:
        seen = [m for margins, _ in runs if (m := margins.get(i)) is not None and math.isfinite(m)]
        passing = {round(m, 12) for margins, failed in runs if not failed and (m := margins.get(i)) is not None and math.isfinite(m)}
        if len(seen) > 1:
            mean = sum(seen) / len(seen)
            spread = math.sqrt(sum((m - mean) ** 2 for m in seen) / len(seen))
        else:
            spread = 0.0
        if len(passing) > 1:
            graded.append(i)
        g = (given or {}).get(i)
        scales[i] = float(g) if g is not None else (spread if spread > 1e-12 else 1.0)
    return scales, graded


def objective(margins: Mapping[str, float | None], failed: bool, groups: Mapping[str, tuple[str, Sequence[str]]],
              scales: Mapping[str, float], graded: Collection[str] | None) -> float | None:  # fmt: skip
    """One run's objective: :func:`combine`; at most 0 when the run *failed* (0 when nothing is left to
    combine, or the criteria left held); None for a passing run with nothing to combine."""
    value = combine(margins, groups, scales, graded)
    if failed:
        return 0.0 if value is None or value > 0 else value
    return value


def objectives(rows: Sequence[Mapping[str, Any]], groups: Mapping[str, tuple[str, Sequence[str]]]) -> list[float | None]:
    """The objective of each of a sweep's *rows* (its ``verdict`` and ``oracles``), the scales and the graded
    criteria fitted over all of them - the search's quantity, so a sweep's map and its "closest to failing"
    say what a search would. All None when no criterion is graded (the verdict is all there is). Without
    *groups* (rows whose case is not known), the rows' ``margin`` - the oracle's - is the one criterion."""
    if groups:
        runs = [(row_margins(r), r.get("verdict") != "pass") for r in rows]
    else:  # rows without their case (a report read back): the oracle's margin as the one criterion
        groups = {"others": ("&&", ["margin"])}
        runs = [({"margin": m if isinstance(m := r.get("margin"), (int, float)) and not isinstance(m, bool) else None},
                 r.get("verdict") != "pass") for r in rows]  # fmt: skip
    scales, graded = fit_scales(runs, [i for _, ids in groups.values() for i in ids])
    if not graded:
        return [None] * len(rows)
    chosen = frozenset(graded)
    return [objective(m, failed, groups, scales, chosen) for m, failed in runs]
