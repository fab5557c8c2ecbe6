"""The result of a run, as data, and its renderings (table, JSON, JUnit XML).

The JSON form is described by ``schemas/report.schema.json``.
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from dataclasses import asdict, dataclass, field, replace
from typing import TYPE_CHECKING, Any, Sequence

from ..errors import plural, xml_safe
from ..expressions import conjunction, disjunction
from ..model import label

if TYPE_CHECKING:  # pragma: no cover
    from .trace import RunTrace

__all__ = ["EntryResult", "OracleResult", "Report", "counts", "oracle_margin", "margin_text"]

_UNFINISHED = {
    "running": ("entry still running", "entries still running"),
    "stopped": ("entry stopped", "entries stopped"),
    "not-started": ("entry did not run", "entries did not run"),
}


@dataclass
class EntryResult:
    """What happened to one execute entry.

    ``status`` is ``success``, ``failure``, ``error`` (its leaf raised: the run's
    verdict is ``error``), ``running`` (still running when the run timed out),
    ``stopped`` (interrupted when the run ended) or ``not-started``.
    """

    id: str
    kind: str
    status: str = "not-started"
    start: float | None = None
    end: float | None = None
    message: str = ""
    name: str = ""

    @property
    def label(self) -> str:
        return label(self.id, self.name)

    def copy(self, status: str | None = None) -> EntryResult:
        """A shallow copy (with *status*, if given), as ``dataclasses.replace`` gives, in a seventh of its time.

        Field by field: reading ``__dict__`` would give every result a dict of its own.
        """
        return EntryResult(self.id, self.kind, status or self.status, self.start, self.end, self.message, self.name)


@dataclass
class OracleResult:
    """The verdict of one criterion: ``pass``, ``fail`` or ``inconclusive``.

    ``group`` is ``record`` or ``others`` (Algorithm 2's groups) and ``relation``
    the group's ``&&``/``||``: a member of an ``||`` group may fail while its group,
    and the run, pass.

    ``margin`` is the criterion's robustness (signal temporal logic's quantitative
    semantics, ``docs/semantics.md``): > 0 held with room to spare, < 0 violated by
    that much, 0 on the boundary; over the ticks it judged (``record``, ``period``:
    the minimum; ``final``: its one tick). None when it judged no tick, or when a
    signal it reads had no value.
    """

    id: str
    type: str
    expect: str
    verdict: str = "inconclusive"
    at: float | None = None
    message: str = ""
    values: dict[str, Any] = field(default_factory=dict)
    samples: list[tuple[float, dict[str, Any]]] = field(default_factory=list, repr=False)
    name: str = ""
    group: str = ""
    relation: str = "&&"
    margin: float | None = None
    decided: float | None = None
    """A temporal criterion's: the run time of the tick after which its verdict was certain (JSON: temporal only)."""
    terms: list[tuple[str, list[float]]] = field(default_factory=list, repr=False)
    """A temporal criterion's sub-formulas and their robustness on each tick (the replay page draws them; not in JSON)."""
    window: tuple[float, float | None] | None = field(default=None, repr=False)
    """A temporal criterion's anchor and horizon, run times (horizon None: the end of the run), once its anchor
    was known: the window ``--plot`` and the replay page draw (not in JSON)."""
    violation: tuple[float, dict[str, Any]] | None = field(default=None, repr=False)
    """A failed temporal criterion's: the run time of the tick its explanation names and the values read there
    (``--plot`` marks the violation there; not in JSON: ``at``/``values`` are the verdict's)."""

    @property
    def label(self) -> str:
        return label(self.id, self.name)


def counts(oracle: OracleResult, oracles: Sequence[OracleResult]) -> bool:
    """Whether *oracle*'s verdict counts for a run whose criteria are *oracles*.

    Every member of an ``&&`` group counts. A member of an ``||`` group counts
    unless another member of its group passed: the group passed without it.
    """
    if oracle.relation != "||":
        return True
    return not any(o.verdict == "pass" for o in oracles if o.group == oracle.group and o is not oracle)


def oracle_margin(oracles: Sequence[OracleResult]) -> float | None:
    """The margin of the whole oracle: each group's members combined by its relation
    (``&&`` the minimum, ``||`` the maximum), then the groups by ``&&``.

    An unknown margin (None) is left out where the known ones decide (a minimum below
    0, a maximum above 0) and makes the result unknown otherwise. None without criteria.
    """
    groups: dict[str, list[OracleResult]] = {}
    for o in oracles:
        groups.setdefault(o.group, []).append(o)
    margins = []
    for members in groups.values():
        combine = disjunction if members[0].relation == "||" else conjunction
        margins.append(combine([o.margin for o in members]))
    return conjunction(margins)


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
    source: str = "<dict>"
    explanation: list[str] = field(default_factory=list)
    tree: str = ""

    @property
    def passed(self) -> bool:
        return self.verdict == "pass"

    @property
    def margin(self) -> float | None:
        """The oracle's robustness: its criteria's margins combined by its ``&&``/``||`` tree
        as min/max (:func:`oracle_margin`); < 0 when the oracle failed. None without criteria
        or when unknown. The timeline is not part of it: a run whose entry failed fails
        whatever its oracle's margin."""
        return oracle_margin(self.oracles)

    @property
    def complete(self) -> bool:
        """Whether every entry of the timeline ran to success."""
        return all(e.status == "success" for e in self.execute)

    @property
    def incomplete(self) -> str:
        """Why the timeline is incomplete, e.g. ``1 entry stopped, 2 entries did not run``; "" when complete.

        Failed entries are not counted here: they fail the run and say so themselves.
        """
        counts: dict[str, int] = {}
        for e in self.execute:
            if e.status in _UNFINISHED:
                counts[e.status] = counts.get(e.status, 0) + 1
        parts = []
        for status, (one, many) in _UNFINISHED.items():
            n = counts.get(status, 0)
            if n:
                parts.append(f"{n} {one if n == 1 else many}")
        return ", ".join(parts)

    def require_complete(self) -> Report:
        """This report, failed if it passed with an incomplete timeline (``--require-complete``)."""
        if self.verdict != "pass" or not self.incomplete:
            return self
        why = f"timeline incomplete: {self.incomplete} (the case requires a complete timeline)"
        unfinished = [f"  entry {e.label}: {e.status}" for e in self.execute if e.status != "success"]
        shown = unfinished[:20] + ([f"  … and {plural(len(unfinished) - 20, 'more entry', 'more entries')}"] if len(unfinished) > 20 else [])
        return replace(self, verdict="fail", message=why, explanation=[why, *shown])

    def decisive(self, oracle: OracleResult) -> bool:
        """Whether *oracle*'s verdict counts for the run (:func:`counts`)."""
        return counts(oracle, self.oracles)

    def to_dict(self) -> dict[str, Any]:
        data = asdict(replace(self, trace=None))
        del data["trace"]
        for oracle in data["oracles"]:
            del oracle["samples"]
            del oracle["terms"]
            del oracle["violation"]
            del oracle["window"]
            oracle["values"] = {k: _json_value(v) for k, v in oracle["values"].items()}
            oracle["margin"] = _json_value(oracle["margin"])
            if oracle["type"] != "temporal":
                del oracle["decided"]
        ordered = {k: data[k] for k in ("test", "source", "verdict")}
        ordered["margin"] = _json_value(self.margin)
        ordered.update((k, data[k]) for k in ("duration", "ticks", "message"))
        ordered["timeline"] = {"complete": self.complete, "message": self.incomplete}
        ordered["explanation"] = list(self.explanation)
        ordered["execute"] = [_name_second(e) for e in data["execute"]]
        ordered["oracles"] = [_name_second(o) for o in data["oracles"]]
        ordered["tree"] = self.tree
        return ordered

    def why(self) -> str:
        """The explanation and the tree at the end, as one text (the JUnit failure body)."""
        text = "\n".join(self.explanation)
        if self.tree:
            text += ("\n\n" if text else "") + "tree at the end (last status of each node):\n" + self.tree
        return text

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=2, ensure_ascii=False, allow_nan=False) + "\n"

    def table(self) -> str:
        """A plain-text verdict table: one row per criterion, then the execute subtree and the verdict."""
        rows = [("criterion", "type", "expect", "verdict", "at", "message")]
        for o in self.oracles:
            message = o.message
            if o.verdict != "pass" and not self.decisive(o):
                message = f"{message} (not counted: its || group passed)" if message else "not counted: its || group passed"
            rows.append((o.label, o.type, o.expect, o.verdict, _time(o.at), message))
        failed = [e for e in self.execute if e.status == "failure"]
        if self.verdict == "error":  # a leaf raised, or the system failed: not a verdict on the timeline
            erred = next((e for e in self.execute if e.status == "error"), None)
            execute = ("execute", "", "every entry succeeds", "error", _time(self.duration), self.message)
            if erred is not None:
                execute = ("execute", "", "every entry succeeds", "error", _time(erred.end), f"{erred.label}: {erred.message}")
        elif failed:
            execute = ("execute", "", "every entry succeeds", "fail", _time(failed[0].end), f"{failed[0].label}: {failed[0].message}")
        elif self.incomplete:
            execute = ("execute", "", "every entry succeeds", "incomplete", "", self.incomplete)
        else:
            end = max((e.end for e in self.execute if e.end is not None), default=None)
            execute = ("execute", "", "every entry succeeds", "pass", _time(end), "")
        rows.append(execute)
        widths = [max(len(r[i]) for r in rows) for i in range(5)]
        lines = ["  ".join(c.ljust(w) for c, w in zip(r[:5], widths)) + ("  " + r[5] if r[5] else "") for r in rows]
        lines.insert(1, "  ".join("-" * w for w in widths) + "  " + "-" * len(rows[0][5]))
        verdict = f"{self.test}: {self.verdict.upper()}"
        if self.verdict == "pass" and self.incomplete:
            verdict += f" (timeline incomplete: {self.incomplete})"
        verdict += f" after {self.duration:g} s ({plural(self.ticks, 'tick')})"
        if self.message:
            verdict += f" - {self.message}"
        why = "".join(f"  {line}\n" for line in self.explanation) if self.explanation else ""
        if why:
            why = "why:\n" + why
        return "\n".join(line.rstrip() for line in lines) + "\n\n" + verdict + "\n" + why

    def junit_suite(self) -> ET.Element:
        """This run as one JUnit ``<testsuite>``: a testcase for the execute subtree and one per criterion.

        The counts agree with the verdict: ``failures + errors == 0`` exactly when
        the run passed. A member of an ``||`` group that failed while its group
        passed is not a failure: it is reported in the testcase's ``system-out``.
        A criterion still undecided when the run ended is ``skipped``; so is the
        execute testcase of a run that passed with an incomplete timeline.
        """
        suite = ET.Element("testsuite", name=self.test, tests=str(len(self.oracles) + 1), time=f"{self.duration:g}")
        counts = {"failure": 0, "error": 0, "skipped": 0}
        if self.margin is not None:
            _properties(suite, margin=self.margin)

        why = self.why()

        def case(name: str, outcome: str, message: str, at: float | None, out: str = "", margin: float | None = None,
                 decided: float | None = None) -> None:  # fmt: skip
            el = ET.SubElement(suite, "testcase", classname=f"btgen.{self.test}", name=name,
                               time=f"{at:g}" if at is not None else "0")  # fmt: skip
            if margin is not None or decided is not None:  # decided: temporal criteria only
                _properties(el, **{k: v for k, v in (("margin", margin), ("decided", decided)) if v is not None})
            if outcome in counts:
                counts[outcome] += 1
                body = message or outcome
                if outcome in ("failure", "error") and why:
                    body += "\n\n" + why
                ET.SubElement(el, outcome, message=(message or outcome).split("\n")[0]).text = body
            if out:
                ET.SubElement(el, "system-out").text = out

        failed = next((e for e in self.execute if e.status == "failure"), None)
        erred = next((e for e in self.execute if e.status == "error"), None)
        if self.verdict == "error":  # an error is an <error>, which CI servers count apart from failures
            case("execute", "error", f"{erred.label}: {erred.message}" if erred else self.message or "error",
                 erred.end if erred else self.duration)  # fmt: skip
        elif failed is not None:
            case("execute", "failure", f"{failed.label}: {failed.message}", failed.end)
        elif self.verdict in ("timeout", "running"):
            case("execute", "error", self.message or self.verdict, self.duration)
        elif self.verdict == "fail" and not any(o.verdict == "fail" and self.decisive(o) for o in self.oracles):
            case("execute", "failure", self.message or "failed", self.duration)  # e.g. --require-complete
        elif self.incomplete:
            case("execute", "skipped", f"timeline incomplete: {self.incomplete}", self.duration)
        else:
            case("execute", "pass", "", self.duration)
        for o in self.oracles:
            name = f"{o.label} ({o.type}: {o.expect})"
            if not self.decisive(o):
                note = f"{o.verdict}" + (f" at {o.at:g} s" if o.at is not None else "") + (f": {o.message}" if o.message else "")
                case(name, "pass", "", o.at, f"{note}; not counted: its || group passed", o.margin, o.decided)
            elif o.verdict == "fail":
                case(name, "failure", o.message or "failed", o.at, margin=o.margin, decided=o.decided)
            elif o.verdict == "inconclusive":
                case(name, "skipped", o.message or "undecided when the run ended", o.at, margin=o.margin, decided=o.decided)
            else:
                case(name, "pass", "", o.at, margin=o.margin, decided=o.decided)
        if self.verdict != "pass" and counts["failure"] + counts["error"] == 0:  # never green on a red run
            counts["error"] += 1
            el = suite.find("testcase")
            assert el is not None
            ET.SubElement(el, "error", message=self.verdict).text = (self.message or self.verdict) + ("\n\n" + why if why else "")
        suite.set("failures", str(counts["failure"]))
        suite.set("errors", str(counts["error"]))
        suite.set("skipped", str(counts["skipped"]))
        for element in suite.iter():  # names and messages come from the case: keep the XML well-formed
            for key, value in element.attrib.items():
                element.set(key, xml_safe(value))
            if element.text:
                element.text = xml_safe(element.text)
        return suite

    def to_junit(self) -> str:
        """JUnit XML (:meth:`junit_suite` in a ``<testsuites>``)."""
        root = ET.Element("testsuites")
        root.append(self.junit_suite())
        ET.indent(root)
        # characters XML forbids can only sit in names and messages: escaped, the document stays well-formed
        return xml_safe(ET.tostring(root, encoding="unicode", xml_declaration=True)) + "\n"


def _properties(element: ET.Element, **properties: float) -> None:
    """JUnit ``<properties>`` (the first child, where JUnit readers look), one ``<property>`` each."""
    holder = ET.SubElement(element, "properties")
    for name, value in properties.items():
        ET.SubElement(holder, "property", name=name, value=margin_text(value))


def _json_value(value: Any) -> Any:
    """A signal value as JSON can hold it: infinity and NaN (a SUMO vehicle's ``gap`` without a
    leader is ``inf``) as the strings ``"inf"``, ``"-inf"``, ``"nan"``, like the replay page."""
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return value


def _name_second(item: dict[str, Any]) -> dict[str, Any]:
    """``id`` and ``name`` first; ``margin`` right after ``verdict``."""
    ordered = {"id": item["id"], "name": item["name"]}
    for k, v in item.items():
        if k not in ("id", "name", "margin"):
            ordered[k] = v
            if k == "verdict" and "margin" in item:
                ordered["margin"] = item["margin"]
    return ordered


def margin_text(margin: float) -> str:
    """A margin in text (JUnit properties): the shortest exact decimal, ``inf``, ``-inf``.

    >>> margin_text(-2.4000000000000004), margin_text(0.0), margin_text(float("inf"))
    ('-2.4000000000000004', '0.0', 'inf')
    """
    return repr(float(margin))


def _time(t: float | None) -> str:
    return "" if t is None else f"{t:g}"
