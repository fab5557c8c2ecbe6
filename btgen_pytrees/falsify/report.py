"""The search's result as data (``--json``, ``schemas/falsify.schema.json``) and as a table.

Every report carries its own "better than random": from the failure boxes the
search found it estimates the failing share *p* of the box (each cluster's box
spans its failing runs and its boundary points, at least one resolution wide;
measured in the searched coordinates, so a normal prior's box is its
probability) and gives, for the same budget, uniform random sampling's
expected runs to the first failure (1/p) and its chance to see one
(1 - (1 - p)^budget), and where the grid at the declared resolution, run in
the sweep's order, meets its first failure (or that it steps over every box).
Without a failure it says what the budget covered: the share of grid cells at
the declared resolution that a run landed in, and the smallest failing share
that as many uniform runs would have missed with 5 % chance (3 / runs).
"""

from __future__ import annotations

import bisect
import json
import math
from typing import Any, Mapping, Sequence

from ..load.variations import format_value, label
from .search import Run, Search
from .space import Space

__all__ = ["report_data", "table", "failure_boxes", "union_share", "baselines", "SCHEMA_VERSION"]

SCHEMA_VERSION = 1


def _num(x: float | None) -> float | None:
    """A number for JSON: exactly as computed (its repr reads back the same float), None if not finite."""
    if x is None or not math.isfinite(x):
        return None
    return x + 0.0


def _margins(run: Run) -> dict[str, float | None]:
    return {k: _num(v) for k, v in (run.row.get("margins") or {}).items()}


def oracle_margin(run: Run) -> float | str | None:
    """The oracle's margin exactly as ``run`` reports it for the run's case (its row's ``margin``: the
    criteria's margins combined by the oracle's relations, unscaled; an infinite one as ``"inf"`` or
    ``"-inf"``, as ``run --json`` writes it) - not the search's scaled :attr:`~.search.Run.objective`."""
    m = run.row.get("margin")
    if not isinstance(m, (int, float)) or isinstance(m, bool) or m != m:
        return None
    return m + 0.0 if math.isfinite(m) else ("inf" if m > 0 else "-inf")


def _run_data(run: Run) -> dict[str, Any]:
    row = run.row
    return {
        "index": run.index, "phase": run.phase, "label": label(tuple(run.parameters.items())),
        "parameters": dict(run.parameters), "verdict": run.verdict, "objective": _num(run.objective),
        "margin": oracle_margin(run), "margins": _margins(run), "duration": row.get("duration", 0.0), "ticks": row.get("ticks", 0),
        "message": row.get("message", ""), "wall": round(float(row.get("wall", 0.0)), 6),
    }  # fmt: skip


def failure_boxes(search: Search) -> list[list[tuple[float, float] | set[int]]]:
    """Each cluster's box in unit coordinates: an interval per continuous parameter, a set of choices per list."""
    boxes = []
    space = search.space
    for c in search.clusters:
        points = [search.runs[i].unit for i in c.members]
        edges = []
        for b in c.boundary:
            p, f = search.runs[b.passing].unit, search.runs[b.failing].unit
            edges.append([(x + y) / 2 for x, y in zip(p, f)])
        box: list[tuple[float, float] | set[int]] = []
        for k, d in enumerate(space.dimensions):
            if d.continuous:
                xs = [p[k] for p in points + edges]
                lo, hi = min(xs), max(xs)
                w = d.unit_resolution((lo + hi) / 2)
                if hi - lo < w:
                    mid = (lo + hi) / 2
                    lo, hi = max(0.0, mid - w / 2), min(1.0, mid + w / 2)
                box.append((lo, hi))
            else:
                box.append({int(p[k]) for p in points})
        boxes.append(box)
    return boxes


def _volume(space: Space, box: Sequence[Any]) -> float:
    v = 1.0
    for d, part in zip(space.dimensions, box):
        v *= (part[1] - part[0]) if d.continuous else len(part) / len(d.choices)
    return v


def union_share(space: Space, boxes: Sequence[Sequence[Any]]) -> float:
    """The share of the box that the union of *boxes* covers (each box's :func:`_volume`, the overlaps
    counted once): exactly, slab by slab along each parameter in turn (the boxes' edges cut it into slabs;
    a slab's share is its width times the union of the boxes spanning it over the parameters after it). The
    clusters' boxes may overlap - a search once reported 37.86 % from their sum where their union was
    22.1 % - so their sum is no share."""
    dims = space.dimensions
    memo: dict[tuple[int, frozenset[int]], float] = {}

    def inside(a: Sequence[Any], b: Sequence[Any], k: int) -> bool:  # box a holds box b from parameter k on
        return all((x[0] <= y[0] and y[1] <= x[1]) if d.continuous else y <= x for d, x, y in zip(dims[k:], a[k:], b[k:]))

    def union(k: int, active: frozenset[int]) -> float:
        if not active:
            return 0.0
        if k == len(dims):
            return 1.0
        key = (k, active)
        if key in memo:
            return memo[key]
        chosen = [boxes[i] for i in sorted(active)]
        whole = next((b for b in chosen if all(inside(b, c, k) for c in chosen)), None)
        if whole is not None:  # one box holds the others (one box alone, too)
            total = _volume(Space(dims[k:]), whole[k:])
        elif dims[k].continuous:
            cuts = sorted({b[k][0] for b in chosen} | {b[k][1] for b in chosen})
            total = 0.0
            for lo, hi in zip(cuts, cuts[1:]):
                spanning = frozenset(i for i in active if boxes[i][k][0] <= lo and hi <= boxes[i][k][1])
                total += (hi - lo) * union(k + 1, spanning)
        else:
            n = len(dims[k].choices)
            total = sum(union(k + 1, frozenset(i for i in active if c in boxes[i][k])) for c in set().union(*(b[k] for b in chosen))) / n
        memo[key] = total
        return total

    return min(1.0, union(0, frozenset(range(len(boxes)))))


def _grid_first(space: Space, box: Sequence[Any]) -> int | None:
    """The 1-based position of the first grid point (sweep order) inside *box*; None if the grid misses it."""
    ks = []
    for d, part in zip(space.dimensions, box):
        if d.continuous:
            n = d.grid_size()
            # a grid point's unit coordinate grows with its number: bisect for the first at or past the box's
            # low end (a fine resolution is a grid of billions of points, never stepped through)
            first = bisect.bisect_left(range(n), True, key=lambda k: part[0] - 1e-12 <= (d.unit(d.low + k * d.resolution) or 0.0))
            if first == n or (d.unit(d.low + first * d.resolution) or 0.0) > part[1] + 1e-12:
                return None
            ks.append((first, n))
        else:
            if not part:
                return None
            ks.append((min(part), len(d.choices)))
    flat = 0
    for k, n in ks:
        flat = flat * n + k
    return flat + 1


def baselines(search: Search) -> dict[str, Any]:
    """Uniform random and the grid at the declared resolution, for the same budget (see the module notes)."""
    space, budget = search.space, search.settings.budget
    grid_points = space.grid_size()
    if not search.clusters:
        runs = len(search.runs)
        cells = set()
        for r in search.runs:
            cells.add(tuple(int(min(d.grid_size() - 1, round(u / d.unit_resolution(u)))) if d.continuous else int(u)
                            for d, u in zip(space.dimensions, r.unit)))  # fmt: skip
        return {
            "failing_share": None,
            "passing_runs_in_boxes": 0,
            "uniform_random": {"expected_runs": None, "chance_within_budget": None,
                               "missed_share_95": _num(min(1.0, 3.0 / runs)) if runs else None},
            "grid": {"points": grid_points, "first_failure": None, "within_budget": None,
                     "cells_visited": len(cells), "cells_share": _num(len(cells) / grid_points) if grid_points else None},
        }  # fmt: skip
    boxes = failure_boxes(search)
    p = union_share(space, boxes)
    firsts = [f for f in (_grid_first(space, b) for b in boxes) if f is not None]
    first = min(firsts) if firsts else None
    inside = sum(1 for r in search.runs if not r.failed and any(space.contains(b, r.unit) for b in boxes))
    return {
        "failing_share": _num(p),
        "passing_runs_in_boxes": inside,
        "uniform_random": {"expected_runs": _num(1.0 / p) if p > 0 else None,
                           "chance_within_budget": _num(1.0 - (1.0 - p) ** budget) if p > 0 else None,
                           "missed_share_95": None},
        "grid": {"points": grid_points, "first_failure": first, "within_budget": first is not None and first <= budget,
                 "cells_visited": None, "cells_share": None},
    }  # fmt: skip


def _counterexamples(search: Search) -> list[dict[str, Any]]:
    chosen: list[tuple[int, int, str]] = []  # (run, cluster, why)
    order = sorted(range(len(search.clusters)),
                   key=lambda k: search.space.distance(search.runs[search.clusters[k].shrunk].unit, search.nominal))  # fmt: skip
    for k in order:
        chosen.append((search.clusters[k].shrunk, k, "shrunk"))
    for k, c in enumerate(search.clusters):
        worst = min(c.members, key=lambda i: (search.runs[i].objective if search.runs[i].objective is not None else 0.0, i))
        if worst != c.shrunk:
            chosen.append((worst, k, "worst"))
    out = []
    for i, k, why in chosen:
        r = search.runs[i]
        out.append({"run": i, "cluster": k + 1, "kind": why, "label": label(tuple(r.parameters.items())),
                    "parameters": dict(r.parameters), "verdict": r.verdict, "objective": _num(r.objective),
                    "margin": oracle_margin(r), "margins": _margins(r), "message": r.row.get("message", ""),
                    "distance": _num(search.space.distance(r.unit, search.nominal))})  # fmt: skip
    return out


def _box_values(search: Search, box: Sequence[Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for d, part in zip(search.space.dimensions, box):
        if d.continuous:
            out[d.name] = [d.value(part[0]), d.value(part[1])]
        else:
            out[d.name] = [d.choices[i] for i in sorted(part)]
    return out


def report_data(search: Search, test: str, source: str) -> dict[str, Any]:
    """The ``--json`` report (``schemas/falsify.schema.json``)."""
    boxes = failure_boxes(search)
    worst = min((r for r in search.runs if r.objective is not None), key=lambda r: (r.objective, r.index), default=None)
    failures = [r.index for r in search.runs if r.failed]
    clusters = []
    for k, (c, box) in enumerate(zip(search.clusters, boxes)):
        clusters.append({"cluster": k + 1, "runs": len(c.members), "members": sorted(c.members), "box": _box_values(search, box),
                         "shrunk": c.shrunk, "refined": c.refined})  # fmt: skip
    boundary = []
    for k, c in enumerate(search.clusters):
        for b in c.boundary:
            p, f = search.runs[b.passing], search.runs[b.failing]
            mid = search.space.values([(x + y) / 2 for x, y in zip(p.unit, f.unit)])
            boundary.append({"cluster": k + 1, "along": b.parameter, "parameters": mid, "passing": b.passing,
                             "failing": b.failing})  # fmt: skip
    return {
        "falsify": SCHEMA_VERSION, "test": test, "source": source,
        "verdict": "falsified" if failures else "not-falsified",
        "method": search.method, "seed": search.settings.seed, "budget": search.settings.budget,
        "batch": search.settings.batch, "stop": search.settings.stop, "start": search.start,
        "interrupted": search.interrupted, "runs_done": len(search.runs), "failures": len(failures),
        "parameters": dict(search.nominal_values),
        "space": [_dimension(d) for d in search.space.dimensions],
        "scales": {k: _num(v) for k, v in search.scales.items()}, "graded": list(search.graded or []),
        "notes": list(search.notes),
        "first_failure": search.first_failure,
        "worst": None if worst is None else {"run": worst.index, "objective": _num(worst.objective), "margin": oracle_margin(worst),
                                             "parameters": dict(worst.parameters)},
        "counterexamples": _counterexamples(search), "clusters": clusters, "boundary": boundary,
        "baselines": baselines(search),
        "runs": [_run_data(r) for r in search.runs],
    }  # fmt: skip


def _dimension(d: Any) -> dict[str, Any]:
    if not d.continuous:
        return {"name": d.name, "kind": "list", "choices": list(d.choices)}
    out = {"name": d.name, "kind": d.kind, "low": _num(d.low), "high": _num(d.high), "resolution": _num(d.resolution)}
    if d.kind == "normal":
        out.update(mu=_num(d.mu), sigma=_num(d.sigma))
    return out


def to_json(data: Mapping[str, Any]) -> str:
    return json.dumps(data, indent=2, ensure_ascii=False, allow_nan=False) + "\n"


def _v(x: Any) -> str:
    if isinstance(x, float):
        return format_value(float(f"{x:.4g}") + 0.0)
    return "-" if x is None else format_value(x)


def table(data: Mapping[str, Any]) -> str:
    """The summary printed on stdout."""
    lines = []
    head = f"{data['test']}: "
    if data["failures"]:
        head += (f"FALSIFIED - {data['failures']} failing run{'s' if data['failures'] != 1 else ''} in "
                 f"{len(data['clusters'])} cluster{'s' if len(data['clusters']) != 1 else ''}")  # fmt: skip
    else:
        head += "no failure found"
    head += f" in {data['runs_done']} runs (budget {data['budget']}, {data['method']}, seed {data['seed']}, batch {data['batch']})"
    if data["interrupted"]:
        head += " - interrupted"
    lines.append(head)
    worst = data["worst"]
    lines.append(f"first failure: {'run ' + str(data['first_failure']) if data['first_failure'] else 'none'}; "
                 f"lowest objective: {_v(worst['objective']) if worst else '-'}"
                 + (f" (margin {_v(worst['margin'])}; {label(tuple(worst['parameters'].items()))})" if worst else ""))  # fmt: skip
    for note in data["notes"]:
        lines.append(f"note: {note}")
    if data["clusters"]:
        lines.append("")
        rows = [("cluster", "runs", "box", "shrunk counterexample", "distance", "objective", "margin")]
        shrunk = {c["cluster"]: c for c in data["counterexamples"] if c["kind"] == "shrunk"}
        for c in data["clusters"]:
            box = ", ".join(f"{k} {_v(v[0])}..{_v(v[-1])}" if len(v) == 2 and not isinstance(v[0], bool) else f"{k} {v}"
                            for k, v in c["box"].items())  # fmt: skip
            ce = shrunk.get(c["cluster"])
            rows.append((str(c["cluster"]), str(c["runs"]), box, ce["label"] if ce else "", _v(ce["distance"]) if ce else "",
                         _v(ce["objective"]) if ce else "", _v(ce["margin"]) if ce else ""))  # fmt: skip
        widths = [max(len(r[i]) for r in rows) for i in range(7)]
        lines += ["  ".join(x.ljust(w) for x, w in zip(r, widths)).rstrip() for r in rows]
    if data["boundary"]:
        lines.append("")
        lines.append("boundary (midpoints of pass/fail pairs at the declared resolution):")
        for b in data["boundary"]:
            along = b["along"] or "towards the nominal point"
            lines.append(f"  cluster {b['cluster']}, along {along}: {label(tuple(b['parameters'].items()))}")
    base = data["baselines"]
    lines.append("")
    lines.append(f"same budget ({data['budget']} runs):")
    if data["failures"]:
        ur = base["uniform_random"]
        share = base["failing_share"]
        lines.append(f"  this search:     first failure at run {data['first_failure']}")
        lines.append(f"  uniform random:  first failure expected at run {_v(ur['expected_runs'])}, "
                     f"{_v(100 * ur['chance_within_budget'] if ur['chance_within_budget'] is not None else None)} % chance within the budget "
                     f"(failing share taken as the clusters' boxes: {_v(100 * share if share is not None else None)} % of the box)")  # fmt: skip
        g = base["grid"]
        where = f"first point in a failure box: {g['first_failure']}" if g["first_failure"] else "steps over every failure box"
        lines.append(f"  grid ({g['points']} points at the declared resolution): {where}")
        if base["passing_runs_in_boxes"]:
            n = base["passing_runs_in_boxes"]
            lines.append(f"  (the boxes hold {n} passing run{'s' * (n != 1)}: the failing region is smaller than they are, "
                         "and both figures above are the boxes')")  # fmt: skip
    else:
        g, ur = base["grid"], base["uniform_random"]
        lines.append(f"  covered {g['cells_visited']} of {g['points']} grid cells at the declared resolution "
                     f"({_v(100 * g['cells_share'] if g['cells_share'] is not None else None)} %)")  # fmt: skip
        lines.append(f"  as many uniform runs miss a failing region of {_v(100 * ur['missed_share_95'] if ur['missed_share_95'] is not None else None)} % "
                     "of the box with 5 % chance; smaller ones more often")  # fmt: skip
    return "\n".join(lines) + "\n"
