"""The simulator: tick a generated tree on a virtual clock and report.

Tick *k* happens at ``t = k * tick`` (t = 0 on the first tick); nothing sleeps,
so a 60 s test runs as fast as its tree ticks, and the same input gives the same
run to the byte. The run ends when the root finishes (its exit condition
succeeded, or something failed) or after the tick at ``timeout``.

The runner ticks the root's generator directly rather than through
:class:`py_trees.trees.BehaviourTree` (which walks the whole tree after every
tick); a light recorder sees each ticked node to note when entries start and
end, and can print a trace line per event.

>>> from btgen_pytrees import load
>>> report = run(load("examples/fig1.json"))
>>> report.verdict, report.duration, report.ticks
('pass', 3.0, 31)
"""

from __future__ import annotations

from typing import Callable

import py_trees
from py_trees.common import Status

from ..clock import VirtualClock
from ..construct import generate
from ..leaves import Registry
from ..leaves.oracles import Outcome, Record
from ..model import TestCase
from .report import EntryResult, OracleResult, Report

__all__ = ["run", "run_tree", "Trace"]

Trace = Callable[[str], None]
_DONE = (Status.SUCCESS, Status.FAILURE)


class _Recorder:
    """Notes start/end times of entry leaves as the tick passes through them."""

    def __init__(self, root: py_trees.behaviour.Behaviour, clock: VirtualClock, trace: Trace | None):
        self.clock = clock
        self.trace = trace
        self.results: dict[int, EntryResult] = {}
        self.ordered: list[tuple[int, EntryResult]] = []
        self.nodes: dict[int, py_trees.behaviour.Behaviour] = {}
        for node in root.iterate():
            entry = getattr(node, "btgen_entry", None)
            if entry is not None:
                result = EntryResult(entry.id, entry.kind)
                self.results[id(node)] = result
                self.ordered.append((entry.index, result))
                self.nodes[id(node)] = node
        self.ordered.sort(key=lambda pair: pair[0])

    def see(self, node: py_trees.behaviour.Behaviour) -> None:
        result = self.results.get(id(node))
        if result is None or result.end is not None:
            return
        now = self.clock.now()
        if result.start is None:
            result.start, result.status = now, "running"
            if self.trace:
                self.trace(f"{now:10.3f}  start   {result.id}")
        if node.status in _DONE:
            result.end = now
            result.status = "success" if node.status == Status.SUCCESS else "failure"
            result.message = node.feedback_message if node.status == Status.FAILURE else ""
            if self.trace:
                self.trace(f"{now:10.3f}  {result.status:8s}{result.id}" + (f"  {result.message}" if result.message else ""))


    def raised(self, exc: BaseException) -> EntryResult | None:
        """Mark the entry whose leaf raised *exc* (found on the traceback) as failed, and return it."""
        culprit = None
        tb = exc.__traceback__
        while tb is not None:
            result = self.results.get(id(tb.tb_frame.f_locals.get("self")))
            culprit = result if result is not None else culprit
            tb = tb.tb_next
        if culprit is not None:
            now = self.clock.now()
            culprit.start = now if culprit.start is None else culprit.start
            culprit.end, culprit.status, culprit.message = now, "failure", f"{type(exc).__name__}: {exc}"
        return culprit


def run_tree(
    root: py_trees.behaviour.Behaviour,
    case: TestCase,
    clock: VirtualClock,
    *,
    trace: Trace | None = None,
) -> Report:
    """Tick *root* (generated from *case* with *clock*) until it finishes or times out."""
    recorder = _Recorder(root, clock, trace)
    see = recorder.see
    root.setup_with_descendants()
    last = int(case.timeout / case.tick + 1e-9)
    verdict, message, ticks, now = "timeout", f"no verdict after {case.timeout:g} s", 0, 0.0
    for k in range(last + 1):
        now = round(k * case.tick, 9)  # 0.30000000000000004 -> 0.3
        clock.set(now)
        ticks = k + 1
        try:
            for node in root.tick():
                see(node)
        except Exception as exc:  # a leaf raised: report it, never a traceback
            verdict, message = "error", f"{type(exc).__name__}: {exc}"
            culprit = recorder.raised(exc)
            if culprit is not None:
                message = f"{culprit.id} raised {message}"
            break
        if root.status in _DONE:
            verdict = "pass" if root.status == Status.SUCCESS else "fail"
            message = ""
            break
    if root.status == Status.RUNNING or verdict == "error":
        root.stop(Status.INVALID)
    return _report(root, case, recorder, verdict, message, now, ticks)


def _report(root, case, recorder, verdict, message, now, ticks) -> Report:  # type: ignore[no-untyped-def]
    execute = []
    for _, result in recorder.ordered:
        if result.status == "running" and verdict != "timeout":
            result.status = "stopped"
        execute.append(result)
    oracles = []
    for node in root.iterate():
        criterion = getattr(node, "btgen_criterion", None)
        if criterion is None:
            continue
        if isinstance(node, Record) and verdict in ("pass", "fail", "timeout"):
            node.conclude(now)
        outcome: Outcome = getattr(node, "outcome", None) or Outcome()
        oracles.append((criterion.index, OracleResult(
            criterion.id, criterion.type, criterion.expect.source, outcome.verdict, outcome.at,
            outcome.message, dict(outcome.values), list(getattr(node, "samples", [])))))  # fmt: skip
    oracles.sort(key=lambda pair: pair[0])
    if verdict == "fail" and not message:
        message = _why_failed(execute, [o for _, o in oracles])
    return Report(case.name, verdict, now, ticks, message, execute, [o for _, o in oracles])


def _why_failed(execute: list[EntryResult], oracles: list[OracleResult]) -> str:
    failed = [f"{e.id} failed" + (f" ({e.message})" if e.message else "") for e in execute if e.status == "failure"]
    failed += [f"{o.id} failed" for o in oracles if o.verdict == "fail"]
    return "; ".join(failed)


def run(case: TestCase, *, registry: Registry | None = None, trace: Trace | None = None) -> Report:
    """Generate *case*'s tree on a virtual clock, run it and return the :class:`Report`."""
    clock = VirtualClock()
    root = generate(case, registry=registry, clock=clock)
    return run_tree(root, case, clock, trace=trace)
