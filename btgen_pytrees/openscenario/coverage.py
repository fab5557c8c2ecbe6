"""Which elements of which OpenSCENARIO files the conversion supports (``python -m btgen_pytrees coverage DIR``).

Every ``.xosc`` file under a directory is read as the loader reads it (catalog files are counted
through the scenarios that use them, not on their own). For each file: its kind (scenario,
distribution, catalog), whether it converts, its problems; and over all files, per element name,
how often it occurs and how often the conversion used it. An element of a file that could not be
converted past a problem counts as *not reached* beyond that problem - neither supported nor known to be
unsupported (a file whose conversion stopped at its first problem says nothing of the elements after it:
``TeleportAction`` is no less supported for a road friction refused before it). An element that is read and
has no effect on a SUMO run (an ``EnvironmentAction`` and what it holds) is flagged ``no_effect``. The result is
data (:func:`coverage`), shown as a table (:func:`table`, :func:`markdown`) or as JSON
(``schemas/coverage.schema.json``).
"""

from __future__ import annotations

import json
import os
from collections import Counter
from typing import Any, Iterator

from ..errors import InvalidTestCase
from .catalogs import forget
from .convert import read_openscenario, scan
from .distributions import parse_distribution
from .parameters import Scope
from .scenario import Options, convert_scenario, header
from .xmltree import Node, XmlProblem, read_xml

__all__ = ["coverage", "table", "markdown", "to_json", "MAX_FILES"]

MAX_FILES = 10_000
# read, no effect on a SUMO run (actions.ENVIRONMENT_PARTS less the parts other elements have too: a BoundingBox, Properties)
NO_EFFECT = frozenset({"EnvironmentAction", "Environment", "TimeOfDay", "Weather", "Sun", "Fog", "Precipitation", "Wind",
                       "DomeImage", "DomeFile", "RoadCondition"})  # fmt: skip


def _files(top: str) -> Iterator[str]:
    if os.path.isfile(top):
        yield top
        return
    found = []
    for base, dirs, names in os.walk(top):
        dirs.sort()
        found.extend(os.path.join(base, n) for n in names if n.lower().endswith(".xosc"))
    yield from sorted(found)[:MAX_FILES]


def _tally(root: Node, into: dict[str, Counter[str]], stopped: bool = False, at: Node | None = None) -> None:
    """Count *root*'s elements: used ones supported; when the conversion *stopped* (at the element *at*, whose
    subtree is unsupported), the other unused ones not reached."""
    failed = {id(n) for n in at.walk()} if at is not None else set()
    for node in root.walk():
        into.setdefault(node.tag, Counter())["total"] += 1
        kind = "supported" if node.used else "unreached" if stopped and id(node) not in failed else "unsupported"
        into[node.tag][kind] += 1


def coverage(top: str) -> dict[str, Any]:
    """The coverage of the ``.xosc`` files under *top* (a directory or one file)."""
    files: list[dict[str, Any]] = []
    elements: dict[str, Counter[str]] = {}
    for path in _files(top):
        entry: dict[str, Any] = {"file": os.path.relpath(path, top) if os.path.isdir(top) else os.path.basename(path)}
        try:
            root = read_xml(path)
        except InvalidTestCase as exc:
            entry.update(kind="unreadable", converts=False, problems=[f"{p.pointer}: {p.message}" for p in exc.problems])
            files.append(entry)
            continue
        kinds = {c.tag for c in root.children}
        kind = "catalog" if "Catalog" in kinds else "distribution" if "ParameterValueDistribution" in kinds else "scenario"
        entry["kind"] = kind
        if kind == "catalog":
            continue  # counted through the scenarios that use its entries
        problems: list[str] = []
        catalogs = None
        stopped, at = False, None
        forget()  # this file's catalog entries only
        try:
            root.use()
            if kind == "distribution":
                header(root, Scope())
                parse_distribution(root, Scope())
            else:
                _, catalogs = convert_scenario(root, path, options=Options())
        except XmlProblem as exc:
            problems.append(f"{'/' + '/'.join(exc.node.path) if exc.node else '/'}: {exc.message}")
            stopped, at = True, exc.node
            if exc.node is not None:  # the element the conversion stopped at, and what it holds: not supported
                for node in exc.node.walk():
                    node.used = False
        except InvalidTestCase as exc:
            problems.extend(f"{p.pointer}: {p.message}" for p in exc.problems)
            stopped = True
        if not problems:
            from_scan = scan(root, catalogs) if catalogs is not None else scan(root, _NoCatalogs())
            problems.extend(f"{p.pointer}: {p.message}" for p in from_scan)
        if kind == "distribution" and not problems:  # it converts only if its scenario does (as `validate` reads it)
            problems.extend(_scenario_problems(path))
        _tally(root, elements, stopped, at)
        if catalogs is not None:
            for cat in catalogs.files:
                for catalog in cat.children:
                    for item in catalog.children:
                        if item.used:
                            _tally(item, elements, stopped, at)
        entry.update(converts=not problems, problems=problems)
        files.append(entry)
    rows = [{"element": tag, "occurrences": c["total"], "supported": c["supported"], "unsupported": c["unsupported"],
             "unreached": c["unreached"]} for tag, c in sorted(elements.items())]  # fmt: skip
    for r in rows:
        if r["element"] in NO_EFFECT and r["supported"]:
            r["no_effect"] = True
    converted = [f for f in files if f.get("kind") in ("scenario", "distribution")]
    return {"directory": os.path.basename(os.path.normpath(top)), "files": converted,
            "elements": rows, "summary": {"files": len(converted), "converting": sum(f["converts"] for f in converted),
                                          "elements": len(rows), "fully_supported": sum(r["unsupported"] == r["unreached"] == 0 for r in rows),
                                          "unreached": sum(r["unreached"] > 0 for r in rows)}}  # fmt: skip


def _scenario_problems(path: str) -> list[str]:
    """The problems of the distribution *path* read as every command reads it: its scenario converted, its
    parameters declared there; a problem in the scenario file names that file (relative to the distribution's)."""
    forget()
    try:
        read_openscenario(path)
    except InvalidTestCase as exc:
        where = "" if os.path.abspath(exc.source) == os.path.abspath(path) else \
            f"{os.path.relpath(exc.source, os.path.dirname(os.path.abspath(path)))}: "  # fmt: skip
        return [f"{where}{p.pointer}: {p.message}" for p in exc.problems]
    return []


class _NoCatalogs:
    files: list[Node] = []


def table(data: dict[str, Any]) -> str:
    """Two plain-text tables: the files, then the elements."""
    lines = [f"{'file':<70} {'kind':<12} status"]
    for f in data["files"]:
        lines.append(f"{f['file'][:70]:<70} {f['kind']:<12} {'ok' if f['converts'] else str(len(f['problems'])) + ' problem(s)'}")
        lines.extend(f"    {p}" for p in f["problems"][:5])
    lines.append("")
    lines.append(f"{'element':<45} {'occurrences':>11} {'supported':>9} {'unsupported':>11} {'not reached':>11}")
    for r in data["elements"]:
        lines.append(f"{r['element']:<45} {r['occurrences']:>11} {r['supported']:>9} {r['unsupported']:>11} {r['unreached']:>11}")
    lines.append("")
    lines.append(_summary(data["summary"]))
    lines.extend(_no_effect(data["elements"]))
    return "\n".join(lines) + "\n"


def _no_effect(rows: list[dict[str, Any]]) -> list[str]:
    names = [r["element"] for r in rows if r.get("no_effect")]
    return [f"read, no effect on a SUMO run (light, weather, road surface: docs/openscenario.md): {', '.join(names)}"] if names else []


def _summary(s: dict[str, Any]) -> str:
    line = f"{s['converting']} of {s['files']} files convert; {s['fully_supported']} of {s['elements']} element names fully supported"
    if s["unreached"]:
        line += f"; {s['unreached']} not reached where a file's conversion stopped at its first problem"
    return line


def markdown(data: dict[str, Any]) -> str:
    """The elements table as Markdown (the table docs/openscenario.md shows)."""
    reached = not any(r["unreached"] for r in data["elements"])  # the column only where a conversion stopped
    lines = ["| element | occurrences | supported |" + ("" if reached else " not reached |"), "|---|---:|---:|" + ("" if reached else "---:|")]
    for r in data["elements"]:
        lines.append(f"| `{r['element']}` | {r['occurrences']} | {r['supported']} |" + ("" if reached else f" {r['unreached']} |"))
    lines.append("")
    lines.append(_summary(data["summary"]) + ".")
    lines.extend(_no_effect(data["elements"]))
    return "\n".join(lines) + "\n"


def to_json(data: dict[str, Any]) -> str:
    return json.dumps(data, indent=2, ensure_ascii=False) + "\n"
