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

import math
from typing import Callable, Iterable

import py_trees
from py_trees.common import Status

from ..leaves.control import Controlled
from ..leaves.oracles import Outcome, Record
from ..leaves.temporal import Temporal
from ..leaves.wiring import RunStart
from ..contracts.system import SystemFailure
from .explain import explain, status_tree
from .index import TreeIndex
from .report import EntryResult, OracleResult, Report, counts
from .trace import TraceRecorder

__all__ = ["Collector", "Trace", "trace_line"]

Trace = Callable[[str], None]
_RUNNING, _SUCCESS, _FAILURE = Status.RUNNING, Status.SUCCESS, Status.FAILURE
_STATUSES = (Status.INVALID, _RUNNING, _SUCCESS, _FAILURE)  # by status code (run.trace.STATUSES)
_ENTRY, _ROOT, _START, _CONTROLLED = 1, 2, 3, 4


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
        record: also record the run's :class:`~btgen_pytrees.run.trace.RunTrace`
            (every status and signal change, for ``--plot``, ``--replay`` and
            ``--btlog``); a report made once the run has ended (and ticked at
            least once) carries it as ``report.trace``. The runner records; a
            host may too.

    **Cost.** The collector keeps what it knows about each node in flat arrays
    indexed by the node's pre-order number (:class:`~btgen_pytrees.run.index.TreeIndex`):
    a visited node costs a look at its number and its status, and only the
    nodes of execute entries, the root and the start leaf cost more. When it
    records, it hands the recorder the number and status it has just read, so
    a node is looked up once per tick, not once per visitor.
    """

    def __init__(self, root: py_trees.behaviour.Behaviour, *, trace: Trace | None = None, record: bool = False):
        super().__init__(full=False)
        self.root = root
        self.case = root.btgen_case  # type: ignore[attr-defined]
        self.env = root.btgen_env  # type: ignore[attr-defined]
        self.trace = trace
        self.index = index = TreeIndex(root)
        self.recorder: TraceRecorder | None = None
        self._record = record
        nodes = index.nodes
        self._nodes = nodes
        entries, criteria = index.entries, index.criteria  # what the index read from the tagged nodes
        at: dict[int, int] = {}  # entry index -> node number (no tuple per entry: 100k of them cost a full collection)
        for i, entry in entries.items():
            at[entry.index] = i
        self._criteria = [nodes[i] for i in criteria if i not in entries]  # tree order (the index's), an entry's first
        self._entries = [at[k] for k in sorted(at)]  # the numbers of the entries' nodes, in entry order
        # what each node is to the collector: 1 an entry, 2 the root, 3 the start leaf (0: nothing)
        self._watch = bytearray(len(nodes))
        for i in self._entries:
            self._watch[i] = _CONTROLLED if isinstance(nodes[i], Controlled) else _ENTRY
        self._watch[0] = _ROOT
        start = next((i for i, node in enumerate(nodes) if isinstance(node, RunStart)), None)
        if start is not None and not self._watch[start]:
            self._watch[start] = _START
        self.reset()

    def reset(self) -> None:
        """Forget everything: a new run begins."""
        self._slots: dict[int, EntryResult] = {}  # node number -> its entry's result
        self.ordered: list[EntryResult] = []
        nodes = self._nodes
        for i in self._entries:
            entry = nodes[i].btgen_entry  # type: ignore[attr-defined]
            result = EntryResult(entry.id, entry.kind, "not-started", None, None, "", entry.name)  # positional: faster
            self._slots[i] = result
            self.ordered.append(result)
        self._returned = bytearray(len(nodes))  # per node: 1 + the code of the status its last tick returned (0: none)
        self.ticks = 0
        self.duration = 0.0
        self.ending: tuple[str, str] | None = None  # (verdict, message) set by end()/raised()
        self._now: float | None = None  # the clock, read once per tick (time stands still during a tick)
        self._fresh = True  # no watched node (root, start leaf, entry) seen since the last reset
        if self._record:
            self.recorder = TraceRecorder(self.root, index=self.index)

    @property
    def results(self) -> dict[int, EntryResult]:
        """``id(node) -> EntryResult`` of every entry's node."""
        return {id(self._nodes[i]): result for i, result in self._slots.items()}

    @property
    def last(self) -> dict[int, Status]:
        """``id(node) -> Status`` its last tick returned, for every node ticked since the run began."""
        nodes = self._nodes
        return {id(nodes[i]): _STATUSES[code - 1] for i, code in enumerate(self._returned) if code}

    # -- the visitor ---------------------------------------------------------------
    def initialise(self) -> None:
        """A tick begins (the recorder's hook)."""
        if self.recorder is not None:
            self.recorder.initialise()

    def finalise(self) -> None:
        """A tick ended (the recorder looks for halted nodes and samples the signals)."""
        if self.recorder is not None:
            self.recorder.finalise()

    def run(self, behaviour: py_trees.behaviour.Behaviour) -> None:
        """Note what *behaviour* (just ticked) means for the run; called for every visited node."""
        try:  # the number the node carries, if it is this tree's (see TreeIndex)
            i = behaviour.btgen_index  # type: ignore[attr-defined]
            if self._nodes[i] is not behaviour:
                raise LookupError
        except (AttributeError, LookupError, TypeError):
            i = self.index.number(behaviour)
            if i is None:  # not in the generated tree (a host's own node)
                return
        status = behaviour.status
        code = 1 if status is _RUNNING else 2 if status is _SUCCESS else 3 if status is _FAILURE else 0  # trace._code, inline
        self._returned[i] = code + 1
        watch = self._watch[i]
        if watch:
            self._saw(i, watch, code, behaviour)
        if self.recorder is not None:
            self.recorder.seen(i, code)

    def visit(self, behaviours: Iterable[py_trees.behaviour.Behaviour]) -> None:
        """:meth:`run` for each of *behaviours* in turn (a tick's yields: the runner hands it ``root.tick()``).

        The same steps as :meth:`run`, inline in one loop over what it reads: a visit is a few
        attribute reads and stores, so a method call and its look-ups per node were most of what the
        collector added to a tick (on a 20,000-node tick, a third of the run)."""
        nodes, watch, number, trace = self._nodes, self._watch, self.index.number, self.trace
        returned, recorder, slots = self._returned, self.recorder, self._slots
        record = recorder.seen if recorder is not None else None  # the recorder's look at the same number and code
        for behaviour in behaviours:
            try:  # the number the node carries, if it is this tree's (see TreeIndex)
                i = behaviour.btgen_index  # type: ignore[attr-defined]
                if nodes[i] is not behaviour:
                    raise LookupError
            except (AttributeError, LookupError, TypeError):
                i = number(behaviour)
                if i is None:  # not in the generated tree (a host's own node)
                    continue
            status = behaviour.status
            code = 1 if status is _RUNNING else 2 if status is _SUCCESS else 3 if status is _FAILURE else 0
            returned[i] = code + 1
            seen = watch[i]
            if seen == _ENTRY:  # _saw's entry branch, inline: half the nodes of a fan-out's tick are entries'
                self._fresh = False
                result = slots[i]
                if result.end is None:
                    now = self._now
                    if now is None:
                        now = self._now = self.env.now()
                    if result.start is None:
                        result.start, result.status = now, "running"
                        if trace:
                            trace(trace_line(now, "start", result.id))
                    if code >= 2:
                        result.end = now
                        result.status = "success" if code == 2 else "failure"
                        result.message = behaviour.feedback_message if code == 3 else ""
                        if trace:
                            trace(trace_line(now, result.status, result.id, result.message))
            elif seen:
                self._saw(i, seen, code, behaviour)
                returned, recorder, slots = self._returned, self.recorder, self._slots  # the start leaf again: a new run
                record = recorder.seen if recorder is not None else None
            if record is not None:
                record(i, code)

    def _saw(self, i: int, watch: int, code: int, behaviour: py_trees.behaviour.Behaviour) -> None:
        """Node *i* is the root, the start leaf or an entry's: what its tick means."""
        if watch == _CONTROLLED:
            self._controlled(i, code, behaviour)  # type: ignore[arg-type]
            return
        if watch != _ENTRY:
            if watch == _ROOT:
                self.ticks += 1
                self.duration = self.env.now()
                self._now = None  # the tick ends: the next one reads the clock again
            elif not self._fresh:  # the start leaf again: the tree runs anew, and so does its trace
                self.reset()
                self._returned[i] = code + 1
                if self.recorder is not None:
                    self.recorder.initialise()  # the start leaf is the first node a tick of the tree yields
            self._fresh = False
            return
        self._fresh = False
        result = self._slots[i]
        if result.end is not None:
            return
        now = self._now
        if now is None:
            now = self._now = self.env.now()
        if result.start is None:
            result.start, result.status = now, "running"
            if self.trace:
                self.trace(trace_line(now, "start", result.id))
        if code >= 2:
            result.end = now
            result.status = "success" if code == 2 else "failure"
            result.message = behaviour.feedback_message if code == 3 else ""
            if self.trace:
                self.trace(trace_line(now, result.status, result.id, result.message))

    def _controlled(self, i: int, code: int, node: Controlled) -> None:
        """An entry with control keys: it starts when its action does (not while it waits for its ``when``), its
        attempts and repetitions are traced, and a stop request ends it ``stopped``."""
        self._fresh = False
        result = self._slots[i]
        if result.end is not None:
            return
        now = self._now
        if now is None:
            now = self._now = self.env.now()
        trace = self.trace
        events = node.events
        if events:
            for at, event, text in events:
                if event == "start":
                    if result.start is None:
                        result.start, result.status = at, "running"
                elif event == "stopped":
                    continue  # traced as the entry's end, below
                if trace:
                    trace(trace_line(at, event, result.id, text))
            events.clear()
        if code >= 2:
            result.end = now
            result.status = "stopped" if node.cut else "success" if code == 2 else "failure"
            result.message = node.why if code == 3 else ""
            if trace:
                trace(trace_line(now, result.status, result.id, result.message))

    # -- endings the tree's status cannot tell -------------------------------------
    def raised(self, exc: BaseException) -> EntryResult | None:
        """A tick of the tree raised *exc*: end the run with verdict ``error``.

        The entry whose leaf raised (found on the traceback) gets status ``error``
        (traced as an ``error`` event) and is returned; the interrupted tick counts
        as a tick. A
        :class:`~btgen_pytrees.systems.SystemFailure` (a system action found the
        system broken) is reported by its message, any other exception with its type.
        """
        culprit = None
        tb = exc.__traceback__
        while tb is not None:
            culprit = self._result_of(tb.tb_frame.f_locals.get("self")) or culprit
            tb = tb.tb_next
        now = self.env.now()
        self._now = None
        self.ticks += 1
        self.duration = now
        if isinstance(exc, SystemFailure):
            message = str(exc)
        else:  # an exception without a message (``raise KeyboardInterrupt``) is named alone, with no ": " after it
            message = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
        if culprit is not None:
            culprit.start = now if culprit.start is None else culprit.start
            culprit.end, culprit.status, culprit.message = now, "error", message
            if self.trace:
                self.trace(trace_line(now, "error", culprit.id, message))
            message = f"{culprit.id}: {message}" if isinstance(exc, SystemFailure) else f"{culprit.id} raised {message}"
        self.end("error", message)
        return culprit

    def _result_of(self, node: object) -> EntryResult | None:
        i = self.index.number(node) if isinstance(node, py_trees.behaviour.Behaviour) else None  # type: ignore[arg-type]
        return self._slots.get(i) if i is not None else None

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
        if verdict == "running":  # asked for mid-run: copies, which the rest of the run leaves alone
            execute = [result.copy() for result in self.ordered]
        else:  # the run is over: no tick changes its results any more (a re-run makes new ones)
            stop = verdict != "timeout"
            execute = [result.copy("stopped") if stop and result.status == "running" else result for result in self.ordered]
            if self._watch.count(_CONTROLLED) or self.env.stopped() is not None:
                execute = self._ended(execute, verdict)
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
                name=criterion.name, group=group, relation=self.case.relation.get(group, "&&"),
                margin=_margin(getattr(outcome, "margin", None)), decided=getattr(outcome, "decided", None),
                terms=node.terms() if isinstance(node, Temporal) else [], violation=getattr(outcome, "violation", None),
                window=node.window() if isinstance(node, Temporal) else None)))  # fmt: skip
        oracles.sort(key=lambda pair: pair[0])
        if verdict == "fail" and not message:
            message = _why_failed(execute, [o for _, o in oracles])
        report = Report(self.case.name, verdict, now, self.ticks, message, execute, [o for _, o in oracles],
                        source=self.case.source)  # fmt: skip
        if require_complete:
            report = report.require_complete()
        if self.recorder is not None and verdict != "running" and self.recorder.trace.times:
            report.trace = self.recorder.trace  # a run that never ticked has no trace
        if report.verdict not in ("pass", "running"):
            report.explanation = report.explanation or explain(report, self.root, self.env, criteria, self.last)
            report.tree = status_tree(self.root, self.last)
        return report


    def _ended(self, execute: list[EntryResult], verdict: str) -> list[EntryResult]:
        """What the end of the run says of the entries it caught: ``stopped by stop[0] at 2 s``, ``repetition 2 of 3
        running at the timeout``."""
        fired = self.env.stopped()
        nodes = {result.id: self._nodes[i] for i, result in self._slots.items()}
        out = []
        for result in execute:
            if result.status in ("running", "stopped", "not-started") and result.end is None:
                node = nodes.get(result.id)
                where = "" if not isinstance(node, Controlled) else node.progress() if node.status == _RUNNING else node.why
                message = result.message
                if fired is not None and result.status == "stopped":
                    message = f"stopped by {fired[0]} at {fired[1]:g} s" + (f" ({where})" if where else "")
                elif where and verdict == "timeout" and result.status != "not-started":
                    message = f"{where} at the timeout"
                elif where and result.status == "not-started" and fired is None:
                    message = where
                if message != result.message:
                    result = result.copy(result.status)
                    result.message = message
            out.append(result)
        return out


def _margin(value: object) -> float | None:
    """A margin as a float (a plugin's oracle may keep an int, or none at all)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    try:
        margin = float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf
    return None if margin != margin else margin + 0.0


def _why_failed(execute: list[EntryResult], oracles: list[OracleResult]) -> str:
    failed = [f"{e.id} failed" + (f" ({e.message})" if e.message else "") for e in execute if e.status == "failure"]
    failed += [f"{o.id} failed" for o in oracles if o.verdict == "fail" and counts(o, oracles)]  # as why and JUnit say
    return "; ".join(failed)
