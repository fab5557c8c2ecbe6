"""The pre-order index the run's visitors share, and the numbers it leaves on the nodes.

A node's ``btgen_index`` is only a hint: these tests make it wrong (another
index over part of the tree, a moved node, a node that cannot take attributes)
and check that every visitor still finds every node, by ticking real trees.
"""

from __future__ import annotations

from typing import Any

import py_trees
from helpers import case, crit, entry
from hypothesis import HealthCheck, example, given, settings
from py_trees.common import Status
from test_trace import scenarios, tick_like_the_runner, ticked_with_snapshots

import btgen_pytrees
from btgen_pytrees.clock import VirtualClock
from btgen_pytrees.render.nodes import walk
from btgen_pytrees.run import Collector, run
from btgen_pytrees.run.index import TreeIndex


class Slotted(py_trees.behaviour.Behaviour):
    """A leaf that takes no new attributes (as one with ``__slots__`` only would): it cannot carry its number."""

    def __setattr__(self, name: str, value: Any) -> None:
        if name == "btgen_index":
            raise AttributeError(name)
        super().__setattr__(name, value)

    def update(self) -> Status:
        return Status.SUCCESS


def test_numbers_are_pre_order_with_subtree_ends(fig1_path: str) -> None:
    root = btgen_pytrees.generate(btgen_pytrees.load(fig1_path))
    index = TreeIndex(root)
    walked = [(depth, node) for depth, node in walk(root)]
    assert index.nodes == [node for _, node in walked]
    for i, (depth, node) in enumerate(walked):
        assert index.number(node) == i == node.btgen_index
        inside = [d for d, _ in walked[i + 1:index.ends[i]]]
        assert all(d > depth for d in inside)  # its subtree is below it
        assert index.ends[i] == len(walked) or walked[index.ends[i]][0] <= depth  # and ends where it ends
    assert [i for i, node in enumerate(index.nodes) if node.children] == index.composites
    # what the tagged nodes carry, read once for every visitor: each node's own entry and criterion
    assert index.entries == {i: node.btgen_entry for i, node in enumerate(index.nodes)
                             if getattr(node, "btgen_entry", None) is not None}  # fmt: skip
    assert index.criteria == {i: node.btgen_criterion for i, node in enumerate(index.nodes)
                              if getattr(node, "btgen_criterion", None) is not None}  # fmt: skip
    assert index.entries and index.criteria and sorted({*index.entries, *index.criteria}) == index.tagged
    assert all(getattr(index.nodes[i], "btgen_entry", None) or getattr(index.nodes[i], "btgen_criterion", None)
               for i in index.tagged)  # fmt: skip


def test_a_number_that_is_not_this_trees_is_not_believed() -> None:
    a, b = py_trees.behaviours.Success("a"), Slotted("b")
    root = py_trees.composites.Sequence("root", memory=True, children=[a, b])
    index = TreeIndex(root)
    assert index.number(b) == 2 and not hasattr(b, "btgen_index")
    TreeIndex(a)  # a indexed alone: it now carries 0
    assert a.btgen_index == 0 and index.number(a) == 1 and index.number(root) == 0
    assert index.number(py_trees.behaviours.Success("elsewhere")) is None


def test_a_run_is_the_same_when_another_index_renumbered_its_nodes(fig1_path: str) -> None:
    """Renumber the nodes under the execute part between the collector's set-up and the run."""
    loaded = btgen_pytrees.load(fig1_path)
    expected = run(loaded)
    clock = VirtualClock()
    root = btgen_pytrees.generate(loaded, clock=clock)
    collector = Collector(root, record=True)
    TreeIndex(root.children[0])  # every node of the timeline now carries a number one too small
    tree = py_trees.trees.BehaviourTree(root)
    tree.add_visitor(collector)
    tree.setup()
    for k in range(100):
        clock.set(round(k * loaded.tick, 9))
        tree.tick()
        if root.status != Status.RUNNING:
            break
    report = collector.report()
    assert report.to_json() == expected.to_json()
    assert list(report.trace.transitions()) == list(expected.trace.transitions())


TIMES_OUT = case(entry("E0", duration=0.3), entry("E1", ["E0"]), entry("E2", ["E1"]), entry("E3", ["E2"]),
                 criteria=[crit("R1", "record", "a <= 0"), crit("F1", "final", "b != 0")], signals={"a": 0, "b": 0, "c": 0},
                 tick=0.1, timeout=3)  # fmt: skip
"""3.3 s of holds in a chain under a 3 s timeout: the tree is still running after its last tick."""


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scenarios())
@example(TIMES_OUT)  # scenarios() draws such runs too, in some runs of the suite only
def test_the_collector_records_the_trace_the_recorder_records(data: dict[str, Any]) -> None:
    """The runner's path (the collector hands each node to the recorder) against the recorder alone."""
    alone, _, _ = ticked_with_snapshots(data)
    loaded = btgen_pytrees.load(data)
    clock = VirtualClock()
    root = btgen_pytrees.generate(loaded, clock=clock)
    collector = Collector(root, record=True)
    tick_like_the_runner(loaded, root, clock, collector)
    if root.status == Status.RUNNING:  # still running at the timeout: the runner ends the run there (a report has a trace
        collector.end("timeout", f"no verdict after {loaded.timeout:g} s")  # once the run is over)
    fed = collector.report().trace
    assert fed.times == alone.times and list(fed.transitions()) == list(alone.transitions())
    assert {n: fed.series(n) for n in fed.signals} == {n: alone.series(n) for n in alone.signals}
    assert fed.to_data() == run(loaded).trace.to_data()


def test_a_host_rerun_starts_a_new_trace(fig1_path: str) -> None:
    loaded = btgen_pytrees.load(fig1_path)
    expected = run(loaded)
    clock = VirtualClock()
    root = btgen_pytrees.generate(loaded, clock=clock)
    tree = py_trees.trees.BehaviourTree(root)
    collector = Collector(root, record=True)
    tree.add_visitor(collector)
    tree.setup()
    reports = []
    for _ in range(2):
        for k in range(100):
            clock.set(round(k * loaded.tick, 9))
            tree.tick()
            if k == 5:
                assert collector.report().trace is None  # a report asked for mid-run has no trace yet
            if root.status != Status.RUNNING:
                break
        reports.append(collector.report())
        root.stop(Status.INVALID)
    first, second = reports
    assert first.trace is not second.trace
    for report in reports:
        assert report.to_json() == expected.to_json()
        assert report.trace.to_data() == expected.trace.to_data()


def test_two_generated_trees_under_one_host_each_collect_their_own_run(fig1_path: str) -> None:
    """Each collector meets the other tree's nodes, which carry numbers of another index: it ignores them."""
    loaded = btgen_pytrees.load(fig1_path)
    expected = run(loaded)
    clock = VirtualClock()
    ours = [btgen_pytrees.generate(loaded, clock=clock, namespace=f"/host/t{k}") for k in range(2)]
    host = py_trees.composites.Parallel("host", policy=py_trees.common.ParallelPolicy.SuccessOnAll(synchronise=True),
                                        children=ours)  # fmt: skip
    tree = py_trees.trees.BehaviourTree(host)
    collectors = [Collector(root, record=True) for root in ours]
    for collector in collectors:
        tree.add_visitor(collector)
    tree.setup()
    for k in range(100):
        clock.set(round(k * loaded.tick, 9))
        tree.tick()
        if host.status != Status.RUNNING:
            break
    for collector in collectors:
        report = collector.report()
        assert report.to_json() == expected.to_json()
        assert report.trace.to_data() == expected.trace.to_data()


def test_a_report_made_before_a_host_rerun_keeps_its_results(fig1_path: str) -> None:
    """A finished report shares the collector's entry results; the re-run must not change them."""
    loaded = btgen_pytrees.load(fig1_path)
    clock = VirtualClock()
    root = btgen_pytrees.generate(loaded, clock=clock)
    tree = py_trees.trees.BehaviourTree(root)
    collector = Collector(root, record=True)
    tree.add_visitor(collector)
    tree.setup()
    for k in range(100):
        clock.set(round(k * loaded.tick, 9))
        tree.tick()
        if root.status != Status.RUNNING:
            break
    first = collector.report()
    before, transitions = first.to_json(), list(first.trace.transitions())
    root.stop(Status.INVALID)
    for k in range(12):  # part of a second run
        clock.set(round(k * loaded.tick, 9))
        tree.tick()
    assert collector.report().verdict == "running"
    assert first.to_json() == before and list(first.trace.transitions()) == transitions


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scenarios())
def test_visit_is_run_node_by_node(data: dict[str, Any]) -> None:
    """Collector.visit (the runner's: a tick's yields in one call) against Collector.run called per node (a
    host's visitor), on the same yields: two runs of the tree (the start leaf again starts a new report and
    trace), with a node of no generated tree and a node carrying another index's number among them."""
    loaded = btgen_pytrees.load(data)
    clock = VirtualClock()
    root = btgen_pytrees.generate(loaded, clock=clock)
    lines: tuple[list[str], list[str]] = ([], [])  # each collector's --trace lines (entries' starts and ends)
    one = Collector(root, record=True, trace=lines[0].append)
    other = Collector(root, record=True, trace=lines[1].append)
    foreign, misnumbered = py_trees.behaviours.Success("foreign"), py_trees.behaviours.Failure("misnumbered")
    TreeIndex(py_trees.composites.Sequence("elsewhere", memory=True, children=[misnumbered]))
    reports = []
    for _ in range(2):
        for k in range(600):
            clock.set(round(k * loaded.tick, 9))
            yielded = [foreign, *root.tick(), misnumbered]
            for collector in (one, other):
                collector.initialise()
            for node in yielded:
                one.run(node)
            other.visit(yielded)
            for collector in (one, other):
                collector.finalise()
            assert one.last == other.last and one.ticks == other.ticks
            if root.status != Status.RUNNING:
                break
        reports.append([(r.to_json(), r.trace.to_data()) for r in (one.report(), other.report())])
        root.stop(Status.INVALID)
    for by_run, by_visit in reports:
        assert by_run == by_visit
    assert reports[0][1][0] == reports[1][1][0]  # the second run started anew
    assert lines[0] == lines[1]


def test_a_visit_that_raises_leaves_the_recorder_what_was_yielded(fig1_path: str) -> None:
    """A tick whose leaf raises part way: Collector.visit hands the recorder every node yielded before
    it (the runner then finalises the tick and reports the error), as Collector.run node by node does."""
    loaded = btgen_pytrees.load(fig1_path)
    clock = VirtualClock()
    root = btgen_pytrees.generate(loaded, clock=clock)
    one, other = Collector(root, record=True), Collector(root, record=True)
    root.setup_with_descendants()
    for k in range(8):
        clock.set(round(k * loaded.tick, 9))
        yielded = list(root.tick())

        def raising() -> Any:
            yield from yielded[:3]
            raise RuntimeError("a leaf raised")

        for collector in (one, other):
            collector.initialise()
        for node in yielded[:3]:
            one.run(node)
        try:
            other.visit(raising())
        except RuntimeError:
            pass
        for collector in (one, other):
            collector.finalise()
    one.end("error", "a leaf raised")
    other.end("error", "a leaf raised")
    first, second = one.report(), other.report()
    assert first.trace is not None and first.trace.changes() > 0
    assert second.to_json() == first.to_json() and second.trace.to_data() == first.trace.to_data()
