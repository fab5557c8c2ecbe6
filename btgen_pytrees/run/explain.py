"""Why a run failed or timed out, in words: margins of failed expectations, what was still waiting, the tree.

"It failed" is not enough to act on. This module turns the state a run ended in
into the lines every report shows (table, JSON ``explanation``/``tree``, the
JUnit ``<failure>``/``<error>`` bodies):

* a **failed criterion**: its expression, the values it read, the time, and the
  *margin* - how far the expectation was from holding - per comparison that was
  false (:func:`why_false`), e.g. ``speed <= 30 false by 2.4 at 3.1 s (speed=32.4)``;
* a **timeout**: the triggers still waiting and for which predecessors, the
  entries still running and for how long, the criteria still undecided;
* the **tree at the end** (:func:`status_tree`), each node with the last status
  it returned, in py_trees' unicode symbols.

The "false by" rule (also in ``docs/semantics.md``): for a comparison ``a OP b``
that is false, the margin shown is ``|a - b|``, the distance between the two sides
(for ``<``/``>`` it is the distance to the boundary, so ``x < 5`` with ``x = 5``
is "false by 0"; for ``!=`` it is 0: the sides are equal) - the magnitude of the
comparison's signed margin in the reports
(:meth:`~btgen_pytrees.expressions.Expression.judge`). A chain ``a < b < c``
is explained by its first false link; ``and`` by each false operand; ``or`` by
every operand (all are false); anything else (``not``, a bare signal, a
function's result) is "false" without a margin. Booleans count as 0 and 1.

>>> from btgen_pytrees.expressions import parse
>>> why_false(parse("speed <= 30"), {"speed": 32.4})
'speed <= 30 false by 2.4'
>>> why_false(parse("0 <= x < 5 && brake == 0"), {"x": 7, "brake": 0})
'x < 5 false by 2'
>>> why_false(parse("a > 1 || b"), {"a": 0, "b": False})
'a > 1 false by 1; b false'
"""

from __future__ import annotations

from typing import Any, Mapping

import py_trees
from py_trees.common import Status
from py_trees.decorators import Decorator

from ..errors import plural
from ..expressions import why_false
from ..render.nodes import symbol, walk

__all__ = ["why_false", "explain", "status_tree", "TREE_LINES", "LINES_PER_KIND"]

TREE_LINES = 300
"""Longest annotated tree kept in a report; finished or untouched subtrees are folded first."""

_SYMBOL = {Status.SUCCESS: "✓", Status.FAILURE: "✕", Status.RUNNING: "*", Status.INVALID: "-"}
# -- the tree at the end ---------------------------------------------------------------------------


def status_tree(root: py_trees.behaviour.Behaviour, last: Mapping[int, Status], *, limit: int = TREE_LINES) -> str:
    """*root* as py_trees' unicode tree, each node with the last status it returned in the run.

    ``last`` maps ``id(node)`` to the status the node had after its last tick
    (nodes never ticked show ``-``); a node's feedback message follows ``--`` as
    in :func:`py_trees.display.unicode_tree`. A composite whose whole subtree
    succeeded, or was never ticked, is folded into one line (``… 12 nodes``)
    when the tree is longer than *limit* lines, and the text is cut at *limit*.
    """
    nodes = list(walk(root))
    fold = len(nodes) > limit
    sizes: dict[int, int] = {}
    settled: dict[int, bool] = {}  # the whole subtree succeeded, or none of it was ticked
    for depth, node in reversed(nodes):
        children = node.children if not isinstance(node, Decorator) else [node.decorated]
        sizes[id(node)] = 1 + sum(sizes[id(c)] for c in children)
        status = last.get(id(node))
        same = all(settled[id(c)] and last.get(id(c)) == status for c in children)
        settled[id(node)] = status in (None, Status.SUCCESS) and same
    lines: list[str] = []
    skip_below: int | None = None
    for depth, node in nodes:
        if skip_below is not None:
            if depth > skip_below:
                continue
            skip_below = None
        status = last.get(id(node), Status.INVALID)
        line = f"{'    ' * depth}{symbol(node)} {node.name} [{_SYMBOL[status]}]"
        if node.feedback_message and status in (Status.RUNNING, Status.FAILURE):  # a success's may be stale
            line += f" -- {node.feedback_message}"
        if fold and sizes[id(node)] > 1 and settled[id(node)]:
            line += f" … {plural(sizes[id(node)] - 1, 'more node')}, {'all succeeded' if status == Status.SUCCESS else 'never ticked'}"
            skip_below = depth
        lines.append(line)
        if len(lines) >= limit:
            lines.append(f"… cut at {limit} lines")
            break
    return "\n".join(lines) + "\n"


# -- what the run ended in ---------------------------------------------------------------------------

LINES_PER_KIND = 20
"""Most lines of one kind (waiting triggers, running entries, ...) in an explanation; the rest are counted."""


def _capped(lines: list[str], one: str, many: str) -> list[str]:
    if len(lines) <= LINES_PER_KIND:
        return lines
    return lines[:LINES_PER_KIND] + [f"  … and {plural(len(lines) - LINES_PER_KIND, 'more ' + one, 'more ' + many)}"]


def explain(report: Any, root: py_trees.behaviour.Behaviour, env: Any, criteria: Mapping[str, Any],
            last: Mapping[int, Status]) -> list[str]:  # fmt: skip
    """The lines that say why *report* (not a pass) ended as it did.

    * ``fail``: each failed entry and each failed criterion that counts, with its
      message (a criterion's has the margin, the time and the values), and an
      incomplete timeline when the case requires a complete one;
    * ``timeout``: each trigger still waiting (the entry it gates, its join, the
      predecessors not done and their state), each entry still running (since
      when, for how long, its feedback), each criterion still undecided (and what
      it waits for);
    * ``error``: the message.
    """
    lines: list[str] = []
    if report.verdict == "error":
        return [report.message]
    if report.verdict == "fail":
        for e in report.execute:
            if e.status == "failure":
                lines.append(f"entry {e.label} failed at {e.end:g} s: {e.message}")
        for o in report.oracles:
            if o.verdict == "fail" and report.decisive(o):
                lines.append(f"criterion {o.label} ({o.type}) failed: {o.message}")
        if not lines and report.incomplete:
            lines.append(report.message)
            lines += _capped([f"  entry {e.label}: {e.status}" for e in report.execute if e.status != "success"], "entry", "entries")
        return lines
    # timeout
    now = report.duration
    lines.append(report.message or f"no verdict after {now:g} s")
    results = {e.id: e for e in report.execute}
    leaves = {node.btgen_entry.id: node for node in root.iterate() if getattr(node, "btgen_entry", None) is not None}

    def state(entry_id: str) -> str:
        e = results.get(entry_id)
        if e is None or e.status == "not-started":
            return "not started"
        if e.status == "running":
            return f"running since {e.start:g} s"
        return e.status

    waiting = []
    for node in root.iterate():
        if getattr(node, "waits_for", None) is None or last.get(id(node)) != Status.RUNNING:
            continue
        missing = [p for p in node.waits_for if not env.is_done(p)]
        gated = _gated(node)
        shown = ", ".join(f"{p} ({state(p)})" for p in missing[:5]) + (f" and {len(missing) - 5} more" if len(missing) > 5 else "")
        preds = ", ".join(node.waits_for[:5]) + (f" (+{len(node.waits_for) - 5})" if len(node.waits_for) > 5 else "")
        join = f"{node.join} of " if len(node.waits_for) > 1 else ""
        waiting.append(f"  trigger before {gated} waits for {join}{preds}; not done: {shown}")
    if waiting:
        lines.append("triggers still waiting:")
        lines += _capped(waiting, "trigger", "triggers")
    running = []
    for e in report.execute:
        if e.status == "running":
            leaf = leaves.get(e.id)
            feedback = getattr(leaf, "feedback_message", "")
            expect = getattr(leaf, "entry", None) and leaf.entry.expressions.get("expect")  # type: ignore[union-attr]
            if expect is not None:  # an until: how far its condition is from holding
                feedback = why_false(expect, env.values(expect.ordered_names)) or feedback
            feedback = e.message or feedback  # an entry with control keys: "repetition 2 of 3 running at the timeout"
            running.append(f"  {e.label} running since {e.start:g} s ({now - e.start:g} s)" + (f": {feedback}" if feedback else ""))
    if running:
        lines.append("entries still running:")
        lines += _capped(running, "entry", "entries")
    gates = [f"  {e.label} {e.message}" for e in report.execute if e.status == "not-started" and e.message.startswith("waiting")]
    if gates:
        lines.append("entries waiting for their start condition:")
        lines += _capped(gates, "entry", "entries")
    undecided = [f"  {o.label} ({o.type}: {o.expect}) {_awaits(criteria.get(o.id))}" for o in report.oracles if o.verdict == "inconclusive"]
    if undecided:
        lines.append("criteria still undecided:")
        lines += _capped(undecided, "criterion", "criteria")
    return lines


def _gated(trigger: py_trees.behaviour.Behaviour) -> str:
    """The entry (or hoisted fork) a trigger starts: the first entry after it in its Sequence."""
    parent = trigger.parent
    if parent is None:
        return "?"
    after = parent.children[parent.children.index(trigger) + 1 :]
    for child in after:
        for node in child.iterate():
            entry = getattr(node, "btgen_entry", None)
            if entry is not None:
                return entry.label if parent.name.startswith("join ") else f"{entry.label} (in {parent.name})"
    return parent.name


def _awaits(criterion: Any) -> str:
    if criterion is None:
        return "undecided"
    if criterion.type == "final":
        return f"due at {criterion.at:g} s" if criterion.at is not None else "waits for the execute subtree to finish"
    if criterion.type == "period":
        start = criterion.start or 0
        if criterion.end is not None:
            return f"window [{start:g}, {criterion.end:g}] s had not closed"
        return f"window from {start:g} s closes when the execute subtree finishes"
    if criterion.type == "temporal":
        span = criterion.expect.span
        reach = "to the end of the run" if span == float("inf") else f"{span:g} s past its anchor"
        return f"its horizon ({reach}) had not passed"
    return "undecided"
