"""The result of a run, as data, and its renderings (table, JSON, JUnit XML).

The JSON form is described by ``schemas/report.schema.json``.
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from dataclasses import asdict, dataclass, field, replace
from typing import TYPE_CHECKING, Any

from ..errors import xml_safe

if TYPE_CHECKING:  # pragma: no cover
    from .trace import RunTrace

__all__ = ["EntryResult", "OracleResult", "Report"]


@dataclass
class EntryResult:
    """What happened to one execute entry.

    ``status`` is ``success``, ``failure``, ``running`` (still running when the
    run timed out), ``stopped`` (interrupted when the run ended) or ``not-started``.
    """

    id: str
    kind: str
    status: str = "not-started"
    start: float | None = None
    end: float | None = None
    message: str = ""


@dataclass
class OracleResult:
    """The verdict of one criterion: ``pass``, ``fail`` or ``inconclusive``."""

    id: str
    type: str
    expect: str
    verdict: str = "inconclusive"
    at: float | None = None
    message: str = ""
    values: dict[str, Any] = field(default_factory=dict)
    samples: list[tuple[float, dict[str, Any]]] = field(default_factory=list, repr=False)


@dataclass
class Report:
    """A run's outcome.

    Attributes:
        test: the test case's name
        verdict: ``pass``, ``fail``, ``timeout`` or ``error``; ``running`` when a
            host-ticked tree's :class:`~btgen_pytrees.run.Collector` is asked before it finished
        duration: run time of the last tick, in virtual seconds
        ticks: number of ticks
        message: why the run failed, timed out or erred ("" on pass)
        execute: one :class:`EntryResult` per entry, in file order
        oracles: one :class:`OracleResult` per criterion, in file order
        trace: every node status and signal change of the run
            (:class:`~.trace.RunTrace`; not part of the JSON report)
    """

    test: str
    verdict: str
    duration: float
    ticks: int
    message: str = ""
    execute: list[EntryResult] = field(default_factory=list)
    oracles: list[OracleResult] = field(default_factory=list)
    trace: RunTrace | None = field(default=None, repr=False, compare=False)

    @property
    def passed(self) -> bool:
        return self.verdict == "pass"

    def to_dict(self) -> dict[str, Any]:
        data = asdict(replace(self, trace=None))
        del data["trace"]
        for oracle in data["oracles"]:
            del oracle["samples"]
            oracle["values"] = {k: _json_value(v) for k, v in oracle["values"].items()}
        return data

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=2, ensure_ascii=False, allow_nan=False) + "\n"

    def table(self) -> str:
        """A plain-text verdict table: one row per criterion, then the execute subtree and the verdict."""
        rows = [("criterion", "type", "expect", "verdict", "at", "message")]
        for o in self.oracles:
            rows.append((o.id, o.type, o.expect, o.verdict, _time(o.at), o.message))
        failed = [e for e in self.execute if e.status == "failure"]
        pending = [e for e in self.execute if e.status in ("running", "not-started", "stopped")]
        if failed:
            execute = ("execute", "", "every entry succeeds", "fail", _time(failed[0].end), f"{failed[0].id}: {failed[0].message}")
        elif pending:
            execute = ("execute", "", "every entry succeeds", "incomplete", "", f"{len(pending)} entries did not finish")
        else:
            end = max((e.end for e in self.execute if e.end is not None), default=None)
            execute = ("execute", "", "every entry succeeds", "pass", _time(end), "")
        rows.append(execute)
        widths = [max(len(r[i]) for r in rows) for i in range(5)]
        lines = ["  ".join(c.ljust(w) for c, w in zip(r[:5], widths)) + ("  " + r[5] if r[5] else "") for r in rows]
        lines.insert(1, "  ".join("-" * w for w in widths))
        verdict = f"{self.test}: {self.verdict.upper()} after {self.duration:g} s ({self.ticks} ticks)"
        if self.message:
            verdict += f" - {self.message}"
        return "\n".join(line.rstrip() for line in lines) + "\n\n" + verdict + "\n"

    def to_junit(self) -> str:
        """JUnit XML: one testcase per criterion plus one for the execute subtree."""
        suite = ET.Element("testsuite", name=self.test, tests=str(len(self.oracles) + 1), time=f"{self.duration:g}")
        failures = errors = 0

        def case(name: str, verdict: str, message: str, at: float | None) -> None:
            nonlocal failures, errors
            el = ET.SubElement(suite, "testcase", classname=f"btgen.{self.test}", name=name,
                               time=f"{at:g}" if at is not None else "0")  # fmt: skip
            if verdict == "fail":
                failures += 1
                ET.SubElement(el, "failure", message=message or "failed").text = message
            elif verdict in ("inconclusive", "timeout", "error", "incomplete"):
                errors += 1
                ET.SubElement(el, "error", message=message or verdict).text = message or verdict

        failed = next((e for e in self.execute if e.status == "failure"), None)
        if failed is not None:
            case("execute", "fail", f"{failed.id}: {failed.message}", failed.end)
        elif self.verdict in ("timeout", "error", "running"):
            case("execute", self.verdict, self.message, self.duration)
        else:
            case("execute", "pass", "", self.duration)
        for o in self.oracles:
            case(f"{o.id} ({o.type}: {o.expect})", o.verdict, o.message, o.at)
        suite.set("failures", str(failures))
        suite.set("errors", str(errors))
        root = ET.Element("testsuites")
        root.append(suite)
        ET.indent(root)
        # characters XML forbids can only sit in names and messages: escaped, the document stays well-formed
        return xml_safe(ET.tostring(root, encoding="unicode", xml_declaration=True)) + "\n"


def _json_value(value: Any) -> Any:
    """A signal value as JSON can hold it: infinity and NaN (a SUMO vehicle's ``gap`` without a
    leader is ``inf``) as the strings ``"inf"``, ``"-inf"``, ``"nan"``, like the replay page."""
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return value


def _time(t: float | None) -> str:
    return "" if t is None else f"{t:g}"
