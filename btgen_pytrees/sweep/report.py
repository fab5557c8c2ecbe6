"""A sweep's result: one row per variation, a summary, JSON and JUnit.

Rows are kept in the sweep's order whatever order the runs finished in, and
hold only virtual times, so the same file gives the same report bytes on one
worker or forty.

"Worst first" (the summary and the map's legend): errors, then timeouts, then
failures, then passes; within a verdict, the smallest margin first (most
clearly failed, or closest to failing; rows without one after those with one),
then the earliest failure, then the sweep's order.
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

from ..errors import plural
from ..run.report import margin_text
from ..load.variations import Value
from .objective import objectives

__all__ = ["SweepReport", "VERDICTS", "worst_first"]

VERDICTS = ("pass", "fail", "timeout", "error")
"""Row verdicts, best to worst; ``error`` also stands for a run that could not complete."""

_RANK = {"error": 0, "timeout": 1, "fail": 2, "pass": 3}


def _json_margin(margin: Any) -> Any:
    return str(margin) if isinstance(margin, float) and math.isinf(margin) else margin


def _json_row(row: Mapping[str, Any]) -> dict[str, Any]:
    out = dict(row)
    if "margin" in out:
        out["margin"] = _json_margin(out["margin"])
    if "oracles" in out:
        out["oracles"] = [{**o, "margin": _json_margin(o.get("margin"))} if "margin" in o else o for o in out["oracles"]]
    return out


def worst_first(rows: Sequence[Mapping[str, Any]]) -> list[Mapping[str, Any]]:
    """*rows* from worst to best: verdict, then smallest margin, then earliest failure, then order."""

    def key(row: Mapping[str, Any]) -> tuple[int, int, float, float, int]:
        margin = row.get("margin")
        times = [o["at"] for o in row.get("oracles", ()) if o.get("verdict") == "fail" and o.get("at") is not None]
        failed_at = min(times) if times else row.get("duration", 0.0)
        return (_RANK.get(row["verdict"], 0), margin is None, margin if margin is not None else 0.0, failed_at, row["index"])

    return sorted(rows, key=key)


@dataclass
class SweepReport:
    """Every variation's outcome.

    Attributes:
        test: the case's name
        source: the case file
        defaults: every parameter's default
        varied: the varied parameters, in label order
        rows: one dict per variation, in order: ``index``, ``label``, ``parameters``
            (the varied values), ``verdict``, ``message``, ``duration``, ``ticks``,
            ``margin`` (the run's oracle margin, :attr:`Report.margin
            <btgen_pytrees.run.Report.margin>`, or None) and ``oracles`` (each
            criterion's ``id``, ``verdict``, ``margin``, ``at``, ``message``)
    """

    test: str
    source: str
    defaults: dict[str, Value]
    varied: tuple[str, ...]
    rows: list[dict[str, Any]] = field(default_factory=list)
    groups: dict[str, tuple[str, list[str]]] = field(default_factory=dict)
    """The oracle's groups (:func:`~.objective.document_groups`): what :meth:`objectives` combines."""

    def objectives(self) -> list[float | None]:
        """Each row's objective (:func:`~.objective.objectives`: the margins scaled and combined as a
        ``falsify`` search does, criteria without a gradient left out); all None when no criterion grades
        how close a passing run came (the verdict is all there is)."""
        return objectives(self.rows, self.groups)

    @property
    def counts(self) -> dict[str, int]:
        """Rows per verdict, in :data:`VERDICTS` order (zeros left out)."""
        counts = {v: sum(1 for r in self.rows if r["verdict"] == v) for v in VERDICTS}
        return {v: n for v, n in counts.items() if n}

    @property
    def verdict(self) -> str:
        """``pass`` when every variation passed, else the worst row's verdict."""
        return worst_first(self.rows)[0]["verdict"] if self.rows else "pass"

    @property
    def passed(self) -> bool:
        return all(r["verdict"] == "pass" for r in self.rows)

    def to_dict(self) -> dict[str, Any]:
        """The report as JSON data: rows as kept, but an infinite margin as ``"inf"``/``"-inf"``
        (JSON has no infinity; the run report writes them so too)."""
        return {
            "test": self.test, "source": self.source, "verdict": self.verdict,
            "parameters": dict(self.defaults), "varied": list(self.varied),
            "variations": len(self.rows), "counts": self.counts, "rows": [_json_row(r) for r in self.rows],
        }  # fmt: skip

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=2, ensure_ascii=False, allow_nan=False) + "\n"

    def summary(self, shown: int = 10) -> str:
        """Counts per verdict, then the worst variations with why they did not pass."""
        counts = ", ".join(f"{n} {v}" for v, n in self.counts.items())
        lines = [f"{self.test}: {plural(len(self.rows), 'variation')} of {' x '.join(self.varied) or 'nothing'}: {counts}"]
        bad = [r for r in worst_first(self.rows) if r["verdict"] != "pass"]
        if bad:
            lines.append("")
            lines.append("worst variations:" if len(bad) <= shown else f"worst {shown} of {len(bad)} variations that did not pass:")
            chosen = bad[:shown]
        else:  # the passing rows with the lowest objective (the search's quantity), not the oracle's margin:
            # a criterion without a gradient (a collision count) pins that at 0 on every passing run
            scores = self.objectives()
            ranked = sorted((x, r["index"], k) for k, (x, r) in enumerate(zip(scores, self.rows)) if x is not None)
            chosen = [self.rows[k] for _, _, k in ranked[: min(shown, 3)]]
            if chosen:
                lines.append("")
                lines.append("closest to failing (lowest objective, as falsify's):")
            score = {id(self.rows[k]): x for x, _, k in ranked}
        width = max([len(r["label"]) for r in chosen] + [0])
        for r in chosen:
            margin = f"margin {r['margin']:.6g}" if r.get("margin") is not None else ""  # rounded as in the run's messages
            if not bad:
                margin = f"objective {score[id(r)]:.4g}" + (", " + margin if margin else "")
            margin = f" ({margin})" if margin else ""
            lines.append(f"  {r['label'].ljust(width)}  {r['verdict'].upper():7s} {r['message']}{margin}".rstrip())
        return "\n".join(lines) + "\n"

    def to_junit(self) -> str:
        """JUnit XML: one testcase per variation, named by its label."""
        suite = ET.Element("testsuite", name=self.test, tests=str(len(self.rows)))
        failures = errors = 0
        total = 0.0
        for r in self.rows:
            total += r["duration"]
            el = ET.SubElement(suite, "testcase", classname=f"btgen.{self.test}", name=f"{self.test}[{r['label']}]",
                               time=f"{r['duration']:g}")  # fmt: skip
            if r.get("margin") is not None:
                ET.SubElement(ET.SubElement(el, "properties"), "property", name="margin", value=margin_text(r["margin"]))
            if r["verdict"] == "fail":
                failures += 1
                ET.SubElement(el, "failure", message=r["message"] or "failed").text = r["message"]
            elif r["verdict"] != "pass":
                errors += 1
                ET.SubElement(el, "error", message=r["message"] or r["verdict"]).text = r["message"] or r["verdict"]
        suite.set("failures", str(failures))
        suite.set("errors", str(errors))
        suite.set("time", f"{total:g}")
        root = ET.Element("testsuites")
        root.append(suite)
        ET.indent(root)
        return ET.tostring(root, encoding="unicode", xml_declaration=True) + "\n"
