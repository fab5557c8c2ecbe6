"""What happened in a run, collected while the tree ticks: one object for the runner and for hosts.

A :class:`Collector` is a py_trees visitor (not ``full``: it sees only the nodes
a tick passes through). The runner feeds it every node its tick yields; a host
application that ticks a generated tree inside its own
:class:`py_trees.trees.BehaviourTree` attaches the same object with
``tree.add_visitor(collector)``. Either way :meth:`Collector.report` returns
the :class:`~btgen_pytrees.run.Report` of the run so far - the same object,
table, JSON and JUnit that ``run`` produces, because ``run`` uses this very
class.

What it notes, and when:

* an execute entry's start (the first tick its leaf is visited) and end (the
  tick it succeeded or failed), read from the tree's environment clock, i.e.
  seconds since the run's first tick;
* each tick of the generated root (the root is the last node its tick yields):
  the tick count, the time and the root's status - ``pass``/``fail`` once it has
  finished, ``running`` while it goes on;
* the tree's ``start`` leaf begins a new run: a tree re-run after ``stop()``
  starts a new report.

Oracle verdicts are not copied during the run: :meth:`Collector.report` reads
them from the oracle leaves, which keep their own outcome.
"""

from __future__ import annotations

from typing import Callable

import py_trees
from py_trees.common import Status

from ..leaves.oracles import Outcome, Record
from ..leaves.wiring import RunStart
from ..systems.base import SystemFailure
from .explain import explain, status_tree
from .report import EntryResult, OracleResult, Report

__all__ = ["Collector", "Trace", "trace_line"]

Trace = Callable[[str], None]
_SUCCESS, _FAILURE = Status.SUCCESS, Status.FAILURE
_NO_TAGS: dict[str, object] = {}


def trace_line(now: float, event: str, what: str, message: str = "") -> str:
    """One ``--trace`` line: the run time (to the nanosecond, trailing zeros cut), the event, the id.

    >>> trace_line(0.1, "start", "B3")
    '         0.1  start    B3'
    >>> trace_line(2, "failure", "U", "x > 1 still false after 0.5 s (x=0)")
    '           2  failure  U  x > 1 still false after 0.5 s (x=0)'
    """
    stamp = f"{now:.9f}".rstrip("0").rstrip(".") or "0"
    return f"{stamp:>12}  {event:<8} {what}" + (f"  {message}" if message else "")


class Collector(py_trees.visitors.VisitorBase):
    """Collect one generated tree's run into a :class:`Report`.

    Args:
        root: the root returned by :func:`btgen_pytrees.generate` (it carries
            the case and the environment whose clock times are read from)
        trace: called with one line per entry start and end, if given
    """

    def __init__(self, root: py_trees.behaviour.Behaviour, *, trace: Trace | None = None):
        super().__init__(full=False)
        self.root = root
        self.case = root.btgen_case  # type: ignore[attr-defined]
        self.env = root.btgen_env  # type: ignore[attr-defined]
        self.trace = trace
        self._nodes: list[tuple[int, py_trees.behaviour.Behaviour]] = []
        self._criteria: list[py_trees.behaviour.Behaviour] = []  # oracle leaves, in tree order
        self._start: py_trees.behaviour.Behaviour | None = None
        stack = [root]
        while stack:  # pre-order, without recursion
            node = stack.pop()
            stack.extend(reversed(node.children))
            tags = getattr(node, "__dict__", _NO_TAGS)
            entry = tags.get("btgen_entry")
            if entry is not None:
                self._nodes.append((entry.index, node))
            elif tags.get("btgen_criterion") is not None:
                self._criteria.append(node)
            elif self._start is None and isinstance(node, RunStart):
                self._start = node
        self._nodes.sort(key=lambda pair: pair[0])
        self.reset()

    def reset(self) -> None:
        """Forget everything: a new run begins."""
        self.results: dict[int, EntryResult] = {}
        self.ordered: list[EntryResult] = []
        for _, node in self._nodes:
            entry = node.btgen_entry  # type: ignore[attr-defined]
            result = EntryResult(entry.id, entry.kind, name=entry.name)
            self.results[id(node)] = result
            self.ordered.append(result)
        self.last: dict[int, Status] = {}  # id(node) -> the status its last tick returned
        self.ticks = 0
        self.duration = 0.0
        self.ending: tuple[str, str] | None = None  # (verdict, message) set by end()/raised()
        self._now: float | None = None  # the clock, read once per tick (time stands still during a tick)
        self._fresh = True  # nothing noted since the last reset

    # -- the visitor ---------------------------------------------------------------
    def run(self, behaviour: py_trees.behaviour.Behaviour) -> None:
        """Note what *behaviour* (just ticked) means for the run; called for every visited node."""
        key = id(behaviour)
        result = self.results.get(key)
        if result is None:
            if behaviour is self.root:
                self.ticks += 1
                self.duration = self.env.now()
                self._now = None  # the tick ends: the next one reads the clock again
            elif behaviour is self._start and not self._fresh:
                self.reset()
            self._fresh = False
            self.last[key] = behaviour.status
            return
        self._fresh = False
        status = self.last[key] = behaviour.status
        if result.end is not None:
            return
        now = self._now
        if now is None:
            now = self._now = self.env.now()
        if result.start is None:
            result.start, result.status = now, "running"
            if self.trace:
                self.trace(trace_line(now, "start", result.id))
        if status is _SUCCESS or status is _FAILURE:
            result.end = now
            result.status = "success" if status is _SUCCESS else "failure"
            result.message = behaviour.feedback_message if status is _FAILURE else ""
            if self.trace:
                self.trace(trace_line(now, result.status, result.id, result.message))

    # -- endings the tree's status cannot tell -------------------------------------
    def raised(self, exc: BaseException) -> EntryResult | None:
        """A tick of the tree raised *exc*: end the run with verdict ``error``.

        The entry whose leaf raised (found on the traceback) is marked failed and
        returned; the interrupted tick counts as a tick. A
        :class:`~btgen_pytrees.systems.SystemFailure` (a system action found the
        system broken) is reported by its message, any other exception with its type.
        """
        culprit = None
        tb = exc.__traceback__
        while tb is not None:
            result = self.results.get(id(tb.tb_frame.f_locals.get("self")))
            culprit = result if result is not None else culprit
            tb = tb.tb_next
        now = self.env.now()
        self._now = None
        self.ticks += 1
        self.duration = now
        message = str(exc) if isinstance(exc, SystemFailure) else f"{type(exc).__name__}: {exc}"
        if culprit is not None:
            culprit.start = now if culprit.start is None else culprit.start
            culprit.end, culprit.status, culprit.message = now, "failure", message
            message = f"{culprit.id}: {message}" if isinstance(exc, SystemFailure) else f"{culprit.id} raised {message}"
        self.end("error", message)
        return culprit

    def trace_end(self) -> None:
        """Trace what the end of the run did to the entries still running: ``stopped``, or ``running`` at a timeout."""
        if not self.trace:
            return
        verdict, _ = self.verdict()
        for result in self.ordered:
            if result.status == "running":
                self.trace(trace_line(self.duration, "running" if verdict == "timeout" else "stopped", result.id))
        self.trace(trace_line(self.duration, "end", verdict))

    def end(self, verdict: str, message: str) -> None:
        """End the run with *verdict* (``timeout`` or ``error``) whatever the tree's status says."""
        self.ending = (verdict, message)

    # -- the result ----------------------------------------------------------------
    def verdict(self) -> tuple[str, str]:
        """``(verdict, message)`` so far: ``pass``/``fail`` once the root finished, else ``running``."""
        if self.ending is not None:
            return self.ending
        status = self.root.status
        if self.ticks and status == Status.SUCCESS:
            return "pass", ""
        if self.ticks and status == Status.FAILURE:
            return "fail", ""
        return "running", f"still running after {self.duration:g} s" if self.ticks else "not ticked yet"

    def report(self, *, require_complete: bool = False) -> Report:
        """The :class:`Report` of the run so far (may be asked for at any time, any number of times).

        With *require_complete* a pass with an incomplete timeline is a failure
        (:meth:`Report.require_complete`). A report that is not a pass (nor
        ``running``) carries its explanation and the tree with each node's last
        status (:mod:`btgen_pytrees.run.explain`).
        """
        verdict, message = self.verdict()
        now = self.duration
        execute = [result.copy() for result in self.ordered]  # a report asked for mid-run does not change afterwards
        if verdict not in ("timeout", "running"):
            for result in execute:
                if result.status == "running":
                    result.status = "stopped"
        oracles = []
        criteria = {}
        for node in self._criteria:
            criterion = node.btgen_criterion  # type: ignore[attr-defined]
            if isinstance(node, Record) and verdict in ("pass", "fail", "timeout"):
                node.conclude(now)
            outcome: Outcome = getattr(node, "outcome", None) or Outcome()
            criteria[criterion.id] = criterion
            group = "record" if criterion.type == "record" else "others"
            oracles.append((criterion.index, OracleResult(
                criterion.id, criterion.type, criterion.expect.source, outcome.verdict, outcome.at,
                outcome.message, dict(outcome.values), list(getattr(node, "samples", [])),
                name=criterion.name, group=group, relation=self.case.relation.get(group, "&&"))))  # fmt: skip
        oracles.sort(key=lambda pair: pair[0])
        if verdict == "fail" and not message:
            message = _why_failed(execute, [o for _, o in oracles])
        report = Report(self.case.name, verdict, now, self.ticks, message, execute, [o for _, o in oracles],
                        source=self.case.source)  # fmt: skip
        if require_complete:
            report = report.require_complete()
        if report.verdict not in ("pass", "running"):
            report.explanation = report.explanation or explain(report, self.root, self.env, criteria, self.last)
            report.tree = status_tree(self.root, self.last)
        return report


def _why_failed(execute: list[EntryResult], oracles: list[OracleResult]) -> str:
    failed = [f"{e.id} failed" + (f" ({e.message})" if e.message else "") for e in execute if e.status == "failure"]
    failed += [f"{o.id} failed" for o in oracles if o.verdict == "fail"]
    return "; ".join(failed)
