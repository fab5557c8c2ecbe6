"""Load-time warnings: entries that may write the same signal at the same time.

Within one tick the tree ticks entries in a fixed order (roots in file order; see
"Order within a tick" in ``docs/semantics.md``), so when two entries write one
signal on the same tick the one ticked later wins. That is deterministic, but rarely what the author meant: two roots that
both ``set`` the same signal at t = 0, or a ``ramp`` still running while another
entry ``set``\\ s its signal. The loader therefore *warns* (never refuses) when
two entries that the timeline does not order write the same signal.

**Ordered** means one entry cannot start before the other has finished, whatever
the durations: *A* is ordered before *B* when *A* is in *B*'s *must-finish set*:

* a root's set is empty;
* with one predecessor *p*, or join ``all``: the union over the predecessors of
  ``{p} ∪ must(p)``;
* with join ``any``: the *intersection* over the predecessors of ``{p} ∪ must(p)``
  - the entry starts once one of them has finished, so only what every one of
  them guarantees is guaranteed.

The relation is transitive, so whether all writers of one signal are ordered is
decided by checking consecutive writers in topological order. When they are not,
each writer is compared with the writers before it in the file (the nearest
:data:`NEAREST`) and warned about with the nearest one it is not ordered with: one
warning per writer, at its signal parameter. Which parameters write a signal is what
each action declares as ``signals`` when it is registered (``set.signal`` and
``ramp.signal`` among the built-ins).

>>> from btgen_pytrees import load
>>> case = load({"name": "t", "execute": [
...     {"id": "A", "kind": "behavior", "action": "set", "params": {"signal": "x", "value": 1}},
...     {"id": "B", "kind": "behavior", "action": "set", "params": {"signal": "x", "value": 2}}]})
>>> [(w.pointer, w.message) for w in case.warnings]  # doctest: +NORMALIZE_WHITESPACE
[('/execute/1/params/signal', "signal 'x' is also written by A (/execute/0) and the timeline does not
  order the two: on a tick both write it, the one ticked later wins")]
"""

from __future__ import annotations

from typing import Sequence

from ..errors import MAX_LINE, MAX_PROBLEMS, Problem, plural, printable
from ..leaves import Registry
from ..model import Entry, TestCase
from ..order import positions

__all__ = ["overlapping_writes", "warning_lines", "NEAREST"]

NEAREST = 32
"""How many earlier writers of a signal each writer is compared with (keeps the check linear)."""

BUDGET_PER_ENTRY, BUDGET_BASE = 10, 10_000
"""Nodes the ordering searches may visit (per entry of the case, plus a base) before the check gives up.

A case with thousands of unordered writers of one signal would otherwise cost
a search per pair; past the budget, one more warning says the rest was not checked.
"""


class _OutOfBudget(Exception):
    pass


def warning_lines(case: TestCase, limit: int = MAX_PROBLEMS) -> list[str]:
    """The case's warnings as the CLI prints them on stderr: ``FILE: /pointer: warning: message``; the
    first *limit*, then ``FILE: … and N more warnings`` (every command prints the same lines)."""
    lines = [Problem(w.path, f"warning: {w.message}", w.cause).render(case.source) for w in case.warnings[:limit]]
    if len(case.warnings) > limit:
        lines.append(printable(f"{case.source}: … and {plural(len(case.warnings) - limit, 'more warning')}", limit=MAX_LINE))
    return lines


def overlapping_writes(entries: Sequence[Entry], registry: Registry) -> list[Problem]:
    """One warning (a :class:`Problem` with cause ``overlap``) per pair of unordered writers of a signal."""
    writers: dict[str, list[tuple[Entry, str]]] = {}
    written: dict[tuple[str, str], tuple[str, ...]] = {}  # (kind, action) -> the params naming a written signal
    for entry in entries:
        key = (entry.kind, entry.action)
        params = written.get(key)
        if params is None:
            leaf = registry.get(*key)
            params = written[key] = leaf.signals if leaf is not None else ()
        for param in params:
            signal = entry.params.get(param)
            if isinstance(signal, str):
                writers.setdefault(signal, []).append((entry, param))
    shared = {s: w for s, w in writers.items() if len({e.id for e, _ in w}) > 1}
    if not shared:
        return []
    by_id = {e.id: e for e in entries}
    position = positions({e.id: e.after for e in entries})
    assert position is not None  # a valid case has no cycle
    warnings = []
    budget = [BUDGET_PER_ENTRY * len(by_id) + BUDGET_BASE]  # nodes the searches may still visit

    def ordered(x: Entry, y: Entry) -> bool:
        a, b = (x, y) if position[x.id] < position[y.id] else (y, x)
        return _must_finish(a.id, b.id, by_id, position, budget)

    for signal, written in shared.items():
        pairs = []
        try:
            by_time = sorted(written, key=lambda pair: (position[pair[0].id], pair[0].index))
            if all(x is y or ordered(x, y) for (x, _), (y, _) in zip(by_time, by_time[1:])):
                continue  # the writers form a chain: the common case, in linear time
            for k, (later, param) in enumerate(written):  # file order; the nearest earlier unordered writer
                for earlier, _ in reversed(written[max(0, k - NEAREST):k]):
                    if earlier is not later and not ordered(earlier, later):
                        pairs.append((earlier, later, param))
                        break
        except _OutOfBudget:
            entry, param = written[0]
            warnings.append(Problem((*entry.path, "params", param), f"signal {signal!r} is written by {len(written)} "
                                    "entries; too many to check which of them may write it at the same time", "overlap"))  # fmt: skip
        for earlier, later, param in pairs:
            warnings.append(Problem(
                (*later.path, "params", param),
                f"signal {signal!r} is also written by {earlier.label} (/execute/{earlier.index}) and the timeline "
                f"does not order the two: on a tick both write it, the one ticked later wins",
                "overlap",
            ))  # fmt: skip
    warnings.sort(key=lambda w: (w.path[1], w.message))
    return warnings


def _must_finish(a: str, b: str, by_id: dict[str, Entry], position: dict[str, int], budget: list[int]) -> bool:
    """Whether *a* is in *b*'s must-finish set (``a`` is topologically before ``b``)."""
    floor = position[a]
    memo: dict[str, bool] = {}
    # iterative post-order over b's predecessors, pruned below a's position
    stack: list[tuple[str, bool]] = [(b, False)]
    while stack:
        budget[0] -= 1
        if budget[0] < 0:
            raise _OutOfBudget
        v, expanded = stack.pop()
        if v in memo:
            continue
        preds = [p for p in by_id[v].after]
        if not expanded:
            stack.append((v, True))
            stack.extend((p, False) for p in preds if p != a and p not in memo and position[p] > floor)
            continue
        covers = [p == a or (position[p] > floor and memo.get(p, False)) for p in preds]
        if not preds:
            memo[v] = False
        elif by_id[v].join == "any" and len(preds) > 1:
            memo[v] = all(covers)
        else:
            memo[v] = any(covers)
    return memo[b]
