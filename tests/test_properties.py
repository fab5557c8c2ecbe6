"""Property tests over random timelines: structure and run semantics.

Each example is a random DAG of ``hold``/``wait`` entries (predecessors drawn
among earlier entries) with random durations and joins. The generated tree is
checked as data (every entry is a leaf exactly once, every trigger waits for
exactly its entry's predecessors) and by running it (every entry runs exactly
once, starts no earlier than it is enabled and at most one tick later, lasts its
duration, and the run passes).
"""

from __future__ import annotations

from collections import Counter
from typing import Any

import py_trees
from helpers import case, entry
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import btgen_pytrees
from btgen_pytrees.clock import VirtualClock
from btgen_pytrees.construct.execute import MAX_DEPTH
from btgen_pytrees.leaves import default_registry
from btgen_pytrees.leaves.simulated import Hold, Wait
from btgen_pytrees.leaves.wiring import Trigger
from btgen_pytrees.run import run_tree

TICK = 0.1
EPS = 1e-6


@st.composite
def timelines(draw: Any, max_entries: int = 14) -> dict[str, Any]:
    n = draw(st.integers(1, max_entries))
    entries = []
    for i in range(n):
        preds = draw(st.lists(st.integers(0, i - 1), max_size=3, unique=True)) if i else []
        action = draw(st.sampled_from(["hold", "wait"]))
        duration = draw(st.sampled_from([0, 0.1, 0.25, 0.5, 1, 1.3]))
        join = draw(st.sampled_from([None, "any", "all"]))
        entries.append(entry(f"E{i}", [f"E{p}" for p in preds], action=action, duration=duration, join=join))
    return case(*entries, join=draw(st.sampled_from(["any", "all"])), tick=TICK, timeout=100)


def counting_registry(starts: Counter[str]):  # type: ignore[no-untyped-def]
    """Built-in hold/wait, but counting how often each entry is (re)started."""
    registry = default_registry()

    def counted(base: type) -> type:
        class Counted(base):  # type: ignore[misc, valid-type]
            def initialise(self) -> None:
                starts[self.entry.id] += 1
                super().initialise()

        Counted.__name__ = base.__name__
        return Counted

    registry.register("hold", counted(Hold), kind="behavior", params_schema=registry.get("behavior", "hold").params_schema, replace=True)
    registry.register("wait", counted(Wait), kind="constraint", params_schema=registry.get("constraint", "wait").params_schema, replace=True)
    return registry


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(timelines())
def test_structure_every_entry_once_and_triggers_exact(data: dict[str, Any]) -> None:
    loaded = btgen_pytrees.load(data)
    root = btgen_pytrees.generate(loaded)
    leaves = Counter(n.btgen_entry.id for n in root.iterate() if getattr(n, "btgen_entry", None) is not None)
    assert leaves == Counter(e.id for e in loaded.entries)
    triggers = {}
    for node in root.iterate():
        if isinstance(node, Trigger):
            seq = node.parent
            assert isinstance(seq, py_trees.composites.Sequence) and seq.children[0] is node
            first = seq.children[1]
            first = first.decorated if isinstance(first, py_trees.decorators.Decorator) else first
            triggers[first.btgen_entry.id] = (set(node.waits_for), node.join)
    joins = {e.id: (set(e.after), e.join) for e in loaded.entries if len(e.after) > 1}
    assert triggers == joins


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(timelines())
def test_run_every_entry_once_on_time(data: dict[str, Any]) -> None:
    loaded = btgen_pytrees.load(data)
    starts: Counter[str] = Counter()
    clock = VirtualClock()
    root = btgen_pytrees.generate(loaded, registry=counting_registry(starts), clock=clock)
    report = run_tree(root, loaded, clock)
    assert report.verdict == "pass", report.message
    assert starts == Counter(e.id for e in loaded.entries)  # exactly once each
    result = {r.id: r for r in report.execute}
    for e in loaded.entries:
        r = result[e.id]
        assert r.status == "success" and r.start is not None and r.end is not None
        ends = [result[p].end for p in e.after]
        enabled = 0.0 if not ends else (min(ends) if e.join == "any" else max(ends))
        assert enabled - EPS <= r.start <= enabled + TICK + EPS, (e.id, enabled, r.start)
        duration = e.params["duration"]
        assert duration - EPS <= r.end - r.start < duration + TICK - EPS or duration == 0 == r.end - r.start


@settings(max_examples=30, deadline=None)
@given(timelines(max_entries=8), st.integers(min_value=12, max_value=16))
def test_depth_bound_does_not_change_what_runs_when(data: dict[str, Any], max_depth: int) -> None:
    """Hoisting (forced here by a tiny depth bound) keeps the same start and end times."""
    loaded = btgen_pytrees.load(data)
    reports = []
    for bound in (MAX_DEPTH, max_depth):
        clock = VirtualClock()
        root = btgen_pytrees.generate(loaded, clock=clock, max_depth=bound)
        depth = max(d for d, _ in _depths(root))
        assert depth <= bound
        reports.append(run_tree(root, loaded, clock).to_json())
    assert reports[0] == reports[1]


def _depths(root: Any) -> Any:
    stack = [(1, root)]
    while stack:
        d, n = stack.pop()
        yield d, n
        stack.extend((d + 1, c) for c in n.children)
