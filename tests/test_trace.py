"""The run trace records every node status change and every signal change, tick by tick.

Checked against brute force: the same tree ticked the same way while a second
observer copies *every* node's status and *every* blackboard signal after each
tick; replaying the trace must give exactly those snapshots, over random
timelines with ramps, sets, ``until`` waits and failing criteria (so nodes are
halted mid-run). Memory: only changes are kept, and the cap holds.
"""

from __future__ import annotations

import json
from typing import Any, Callable

import py_trees
from helpers import case, crit, entry
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from py_trees.blackboard import Blackboard

import btgen_pytrees
from btgen_pytrees.clock import VirtualClock
from btgen_pytrees.leaves import default_registry
from btgen_pytrees.leaves.composites import Sequence
from btgen_pytrees.render.nodes import walk
from btgen_pytrees.run import run
from btgen_pytrees.run.trace import STATUSES, TraceRecorder

CODES = {py_trees.common.Status.INVALID: "invalid", py_trees.common.Status.RUNNING: "running",
         py_trees.common.Status.SUCCESS: "success", py_trees.common.Status.FAILURE: "failure"}  # fmt: skip


@st.composite
def scenarios(draw: Any) -> dict[str, Any]:
    n = draw(st.integers(1, 8))
    entries = []
    for i in range(n):
        after = [f"E{p}" for p in draw(st.lists(st.integers(0, i - 1), max_size=2, unique=True))] if i else []
        action = draw(st.sampled_from(["hold", "set", "ramp", "until", "wait"]))
        signal = draw(st.sampled_from(["a", "b"]))
        params: dict[str, Any] = {}
        if action == "set":
            params = {"signal": signal, "value": draw(st.integers(-3, 3)), "duration": draw(st.sampled_from([0, 0.2]))}
        elif action == "ramp":
            params = {"signal": signal, "to": draw(st.integers(-5, 5)), "duration": draw(st.sampled_from([0.1, 0.5, 1]))}
        elif action == "until":
            params = {"expect": f"{signal} > {draw(st.integers(-2, 2))} or c > 0", "timeout": draw(st.sampled_from([0.3, 2]))}
        else:
            params = {"duration": draw(st.sampled_from([0, 0.3, 1]))}
        entries.append(entry(f"E{i}", after, action=action, **params))
    criteria = [crit("R1", "record", f"a <= {draw(st.integers(-1, 4))}"),
                crit("F1", "final", f"b != {draw(st.integers(-1, 1))}")]  # fmt: skip
    if draw(st.booleans()):
        criteria.append(crit("P1", "period", "a > -4", **{"from": 0.2, "to": 1}))
    return case(*entries, criteria=criteria, signals={"a": 0, "b": 0, "c": 0}, tick=0.1, timeout=3)


def tick_like_the_runner(loaded: Any, root: Any, clock: VirtualClock, visitor: Any,
                         after_tick: Callable[[], None] = lambda: None) -> None:  # fmt: skip
    """Tick *root* as the runner does, *visitor* driven as a BehaviourTree drives its visitors."""
    root.setup_with_descendants()
    for k in range(int(loaded.timeout / loaded.tick) + 1):
        clock.set(round(k * loaded.tick, 9))
        visitor.initialise()
        for node in root.tick():
            visitor.run(node)
        visitor.finalise()
        after_tick()
        if root.status != py_trees.common.Status.RUNNING:
            break


def ticked_with_snapshots(data: dict[str, Any]) -> tuple[Any, list[list[str]], list[dict[str, Any]]]:
    """Tick like the runner, with the recorder attached; snapshot every node and signal after each tick."""
    loaded = btgen_pytrees.load(data)
    clock = VirtualClock()
    root = btgen_pytrees.generate(loaded, registry=default_registry(), clock=clock)
    prefix = root.btgen_env.namespace + "/signals/"
    nodes = [node for _, node in walk(root)]
    recorder = TraceRecorder(root)
    statuses, signals = [], []

    def snapshot() -> None:
        statuses.append([CODES[n.status] for n in nodes])
        signals.append({key[len(prefix):]: v for key, v in Blackboard.storage.items() if key.startswith(prefix)})

    tick_like_the_runner(loaded, root, clock, recorder, snapshot)
    return recorder.trace, statuses, signals


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scenarios())
def test_replaying_the_trace_gives_every_snapshot(data: dict[str, Any]) -> None:
    trace, statuses, signals = ticked_with_snapshots(data)
    assert len(trace.times) == len(statuses)
    for k, expected in enumerate(statuses):
        assert trace.statuses_at(k) == expected, k
    for k, expected in enumerate(signals):
        assert {name: trace.value_at(name, k) for name in trace.signals} == expected, k
    # changes only: no transition repeats a node's previous status, no sample repeats a value
    last: dict[int, str] = {}
    for _, i, status in trace.transitions():
        assert last.get(i, "invalid") != status
        last[i] = status
    for ticks, values in trace.signals.values():
        assert list(ticks) == sorted(set(ticks))
        assert all((type(a), a) != (type(b), b) for a, b in zip(values, values[1:]))


def test_signals_only_until_reads_and_after_a_failure_are_recorded() -> None:
    """`gap` is written by nobody the oracles read and read only by `until`; `speed` goes on
    changing after R1 has failed (the run ends at R1's failure, but B2 wrote until then)."""
    data = case(
        entry("B1", action="ramp", signal="gap", to=10, duration=1),
        entry("C1", action="until", expect="gap >= 5", timeout=2),
        entry("B2", action="ramp", signal="speed", to=30, duration=3),
        criteria=[crit("R1", "record", "speed <= 100"), crit("F1", "final", "speed >= 30")],
        signals={"gap": 0, "speed": 0},
    )
    report = btgen_pytrees.run.run(btgen_pytrees.load(data))
    trace = report.trace
    assert report.verdict == "pass"
    assert trace.series("gap")[-1] == (1.0, 10) and len(trace.series("gap")) == 11
    assert trace.series("speed")[-1] == (3.0, 30)
    c1 = trace.node_index("C1")
    assert [(trace.times[k], s) for k, i, s in trace.transitions() if i == c1] == [(0.0, "running"), (0.5, "success")]


def test_trace_is_not_in_the_json_report(fig1_path: str) -> None:
    report = run(btgen_pytrees.load(fig1_path))
    assert report.trace is not None and "trace" not in report.to_dict()
    json.loads(report.to_json())


def test_node_numbering_is_pre_order_with_subtree_ends(fig1_path: str) -> None:
    root = btgen_pytrees.generate(btgen_pytrees.load(fig1_path))
    trace = TraceRecorder(root).trace
    walked = [node for _, node in walk(root)]
    assert [n.name for n in trace.nodes] == [b.name for b in walked]
    for i, node in enumerate(trace.nodes):
        inside = [j for j in range(len(walked)) if any(a is walked[i] for a in _ancestors(walked[j]))]
        assert list(range(i + 1, node.end)) == inside
        assert node.parent == (-1 if i == 0 else next(j for j, b in enumerate(walked) if b is walked[i].parent))


def _ancestors(node: Any) -> list[Any]:
    out = []
    while node.parent is not None:
        node = node.parent
        out.append(node)
    return out


def test_the_cap_bounds_memory_and_says_where_it_cut() -> None:
    data = case(*[entry(f"E{i}", action="ramp", signal=f"s{i}", to=100, duration=5) for i in range(20)], timeout=6)
    loaded = btgen_pytrees.load(data)
    full = run(loaded).trace
    assert full.truncated is None and full.changes() > 1000
    clock = VirtualClock()
    root = btgen_pytrees.generate(loaded, clock=clock)
    recorder = TraceRecorder(root, limit=300)
    root.setup_with_descendants()
    for k in range(40):
        clock.set(k * 0.1)
        recorder.initialise()
        for node in root.tick():
            recorder.run(node)
        recorder.finalise()
    trace = recorder.trace
    assert trace.changes() == 300 and trace.truncated is not None
    assert len(trace.times) == 40  # the clock of every tick is still known
    # what was kept is exactly the start of the full record
    assert list(trace.statuses) == list(full.statuses[: len(trace.statuses)])


def test_statuses_are_btcpp_codes() -> None:
    assert STATUSES == ("invalid", "running", "success", "failure")  # IDLE, RUNNING, SUCCESS, FAILURE


class Odometer:
    """A system that owns ``odo`` (its step count) and ``lap`` (which changes every third step)."""

    def __init__(self, tick: float):
        self.k, self.step = 0, tick

    def start(self, env: Any) -> None:
        pass

    def now(self) -> float:
        return round(self.k * self.step, 9)

    def publish(self, env: Any) -> None:
        env.publish("odo", self.k)
        env.publish("lap", self.k // 3)

    def tick(self) -> None:
        self.k += 1

    def close(self) -> None:
        pass


class OdometerType:
    name = "odometer"
    options = ()

    def describe(self, spec: Any, case_data: Any) -> Any:
        from btgen_pytrees.systems import SystemInfo

        return SystemInfo(signals=("odo", "lap"))

    def create(self, spec: Any, case: Any) -> Odometer:
        return Odometer(case.tick)


def test_a_systems_own_signals_are_recorded_every_tick_they_change() -> None:
    registry = default_registry()
    registry.register_system(OdometerType())
    data = case(entry("C1", action="until", expect="odo >= 7"), system={"type": "odometer"}, tick=0.5)
    report = run(btgen_pytrees.load(data, registry=registry), registry=registry)
    assert report.verdict == "pass" and report.duration == 3.5
    trace = report.trace
    assert trace.series("odo") == [(k * 0.5, k) for k in range(8)]  # read by until only, written by the system
    assert trace.series("lap") == [(0.0, 0), (1.5, 1), (3.0, 2)]  # read by nobody: recorded when it changed


def test_a_host_attaches_the_recorder_to_its_own_tree(fig1_path: str) -> None:
    """The recorder is a py_trees visitor: under a host's BehaviourTree it records what run() records."""
    loaded = btgen_pytrees.load(fig1_path)
    clock = VirtualClock()
    ours = btgen_pytrees.generate(loaded, clock=clock)
    host = py_trees.composites.Sequence("host", memory=False, children=[py_trees.behaviours.Success("warm-up"), ours])
    tree = py_trees.trees.BehaviourTree(host)
    recorder = TraceRecorder(ours)
    tree.add_visitor(recorder)
    tree.setup()
    for k in range(40):
        clock.set(round(k * loaded.tick, 9))
        tree.tick()
        if ours.status != py_trees.common.Status.RUNNING:
            break
    expected = run(loaded).trace
    assert recorder.trace.times == expected.times
    assert list(recorder.trace.transitions()) == list(expected.transitions())
    assert {n: recorder.trace.series(n) for n in recorder.trace.signals} == {n: expected.series(n) for n in expected.signals}


def test_a_signal_replacing_a_deleted_one_is_found_on_its_tick(fig1_path: str) -> None:
    """The blackboard keeps its size when one key goes and another comes: the new signal is still found."""
    loaded = btgen_pytrees.load(fig1_path)
    clock = VirtualClock()
    root = btgen_pytrees.generate(loaded, clock=clock)
    prefix = root.btgen_env.namespace + "/signals/"
    recorder = TraceRecorder(root)
    root.setup_with_descendants()
    for k in range(6):
        clock.set(round(k * 0.1, 9))
        recorder.initialise()
        for node in root.tick():
            recorder.run(node)
        if k == 4:  # a host swaps one key for another between two looks
            del Blackboard.storage[prefix + "mode"]
            Blackboard.storage[prefix + "extra"] = 7
        recorder.finalise()
    assert recorder.trace.series("extra") == [(0.4, 7)]


def _ticked_stock_tree(root: py_trees.behaviour.Behaviour, ticks: int, between: Any = None) -> tuple[Any, list[list[str]]]:
    """Tick a stock py_trees tree with the recorder attached; snapshot every node after each tick."""
    nodes = [node for _, node in walk(root)]
    recorder = TraceRecorder(root)
    root.setup_with_descendants()
    statuses = []
    for k in range(ticks):
        if between is not None:
            between(k)
        recorder.initialise()
        for node in root.tick():
            recorder.run(node)
        recorder.finalise()
        statuses.append([CODES[n.status] for n in nodes])
    return recorder.trace, statuses


def test_a_selector_halting_a_lower_priority_child_while_it_runs_on_is_recorded() -> None:
    """A Selector is reactive: it stays RUNNING while it halts the child a higher-priority one
    overtook. The recorder looks below composites that finished, and below reactive ones always."""
    Status = py_trees.common.Status
    high = py_trees.behaviours.StatusQueue("high", queue=[Status.FAILURE, Status.FAILURE], eventually=Status.RUNNING)
    low = py_trees.composites.Sequence("low", memory=True, children=[py_trees.behaviours.Running("low leaf")])
    selector = py_trees.composites.Selector("selector", memory=False, children=[high, low])
    root = py_trees.composites.Parallel("root", py_trees.common.ParallelPolicy.SuccessOnAll(),
                                        children=[selector, py_trees.behaviours.Running("beside")])  # fmt: skip
    trace, statuses = _ticked_stock_tree(root, 4)
    for k, expected in enumerate(statuses):
        assert trace.statuses_at(k) == expected, k
    leaf = [n.name for n in trace.nodes].index("low leaf")
    assert [(k, s) for k, i, s in trace.transitions() if i == leaf] == [(0, "running"), (2, "invalid")]


def test_a_sequence_without_memory_is_reactive_beside_one_with_memory() -> None:
    """The recorder's kind of a Sequence is its own memory's, not its class's: a Sequence without memory,
    below one with memory, stays RUNNING while it halts a later child an earlier one overtook."""
    Status = py_trees.common.Status
    first = py_trees.behaviours.StatusQueue("first", queue=[Status.SUCCESS], eventually=Status.RUNNING)
    reactive = py_trees.composites.Sequence("reactive", memory=False,
                                            children=[first, py_trees.behaviours.Running("later")])  # fmt: skip
    root = py_trees.composites.Sequence("root", memory=True, children=[reactive])
    trace, statuses = _ticked_stock_tree(root, 3)
    for k, expected in enumerate(statuses):
        assert trace.statuses_at(k) == expected, k
    later = [n.name for n in trace.nodes].index("later")
    assert [(k, s) for k, i, s in trace.transitions() if i == later] == [(0, "running"), (1, "invalid")]


def test_a_tree_stopped_by_its_host_between_ticks_is_recorded(fig1_path: str) -> None:
    """A host may stop() the generated root between two ticks and tick it again: the recorder
    notices on the next tick (nodes that were running and are not running again say so)."""
    loaded = btgen_pytrees.load(fig1_path)
    clock = VirtualClock()
    root = btgen_pytrees.generate(loaded, clock=clock)

    def between(k: int) -> None:
        clock.set(round((k % 12) * loaded.tick, 9))
        if k == 12:
            root.stop(py_trees.common.Status.INVALID)

    trace, statuses = _ticked_stock_tree(root, 16, between)
    for k, expected in enumerate(statuses):
        assert trace.statuses_at(k) == expected, k
    assert any(k == 12 and s == "invalid" for k, _, s in trace.transitions())


def test_a_tree_halted_by_a_host_composite_during_a_tick_is_recorded() -> None:
    """The host's own Selector (not traced) halts the generated tree mid-run: every running node
    of it is recorded as halted on that tick, though none of them was ticked."""
    Status = py_trees.common.Status
    ours = py_trees.composites.Sequence("ours", memory=True, children=[
        py_trees.composites.Parallel("pair", py_trees.common.ParallelPolicy.SuccessOnAll(),
                                     children=[py_trees.behaviours.Running("a"), py_trees.behaviours.Running("b")])])  # fmt: skip
    urgent = py_trees.behaviours.StatusQueue("urgent", queue=[Status.FAILURE, Status.FAILURE], eventually=Status.SUCCESS)
    host = py_trees.composites.Selector("host", memory=False, children=[urgent, ours])
    nodes = [node for _, node in walk(ours)]
    recorder = TraceRecorder(ours)
    tree = py_trees.trees.BehaviourTree(host)
    tree.add_visitor(recorder)
    tree.setup()
    statuses = []
    for _ in range(4):
        tree.tick()
        statuses.append([CODES[n.status] for n in nodes])
    assert statuses[1] == ["running"] * 4 and statuses[2] == ["invalid"] * 4
    for k, expected in enumerate(statuses):
        assert recorder.trace.statuses_at(k) == expected, k


class Passing:
    """A system owning ``car.speed``: the car is there on ticks 2-4 and 7-8 (speed = tick) and gone otherwise,
    as a vehicle that enters, leaves and comes back: while it is gone the signal has no value."""

    def __init__(self, tick: float):
        self.k, self.step = 0, tick

    def start(self, env: Any) -> None:
        self.key = env.namespace + "/signals/car.speed"

    def now(self) -> float:
        return round(self.k * self.step, 9)

    def publish(self, env: Any) -> None:
        if 2 <= self.k <= 4 or 7 <= self.k <= 8:
            env.publish("car.speed", float(self.k))
        else:
            Blackboard.storage.pop(self.key, None)

    def tick(self) -> None:
        self.k += 1

    def close(self) -> None:
        pass


class PassingType:
    name = "passing"
    options = ()

    def describe(self, spec: Any, case_data: Any) -> Any:
        from btgen_pytrees.systems import SystemInfo

        return SystemInfo(signals=("car.speed",))

    def create(self, spec: Any, case: Any) -> Passing:
        return Passing(case.tick)


def test_a_signal_that_stops_existing_ends_in_the_trace_and_in_every_view() -> None:
    """Not the last value held on (what the trace did): no value, as the oracles see it, until it comes back."""
    import math

    from btgen_pytrees.run.plot import _signal_series
    from btgen_pytrees.run.replay import replay_html

    registry = default_registry()
    registry.register_system(PassingType())
    data = case(entry("W", action="wait", duration=1), criteria=[crit("F", "final", "car.speed >= 0", at=1)],
                system={"type": "passing"}, tick=0.1, timeout=2)  # fmt: skip
    report = run(btgen_pytrees.load(data, registry=registry), registry=registry)
    trace = report.trace
    assert report.oracles[0].message == "signal 'car.speed' has no value at 1 s"  # the oracle: no value ...
    assert [trace.value_at("car.speed", k) for k in range(11)] == [None, None, 2.0, 3.0, 4.0, None, None, 7.0, 8.0,
                                                                    None, None]  # fmt: skip  ... and the trace
    from btgen_pytrees.run.trace import ENDED

    assert trace.series("car.speed") == [(0.2, 2.0), (0.3, 3.0), (0.4, 4.0), (0.5, ENDED), (0.7, 7.0), (0.8, 8.0),
                                         (0.9, ENDED)]  # fmt: skip
    assert trace.to_data()["signals"]["car.speed"] == [[2, 2.0], [3, 3.0], [4, 4.0], [5], [7, 7.0], [8, 8.0], [9]]
    loaded = btgen_pytrees.load(data, registry=registry)
    html = replay_html(report, loaded, btgen_pytrees.generate(loaded, registry=registry)).decode()
    page = json.loads(html.split('<script type="application/json" id="run-data">')[1].split("</script>")[0])
    assert page["signals"]["car.speed"] == [[2, 2.0], [3, 3.0], [4, 4.0], [5], [7, 7.0], [8, 8.0], [9]]
    from btgen_pytrees.run.export import signal_table

    columns, rows = signal_table(report, loaded)
    assert [row[columns.index("car.speed")] for row in rows] == [None, None, 2.0, 3.0, 4.0, None, None, 7.0, 8.0,
                                                                  None, None]  # fmt: skip
    drawn = _signal_series(report)["car.speed"]
    assert [(t, v) for t, v in drawn if not math.isnan(v)] == [(0.2, 2.0), (0.3, 3.0), (0.4, 4.0), (0.7, 7.0), (0.8, 8.0)]
    assert [t for t, v in drawn if math.isnan(v)] == [0.5, 0.9]  # the line stops there
    import copy
    import pickle

    assert pickle.loads(pickle.dumps(trace)).series("car.speed") == trace.series("car.speed")  # ENDED stays ENDED
    assert copy.deepcopy(ENDED) is ENDED


def test_the_generators_sequences_are_recorded_as_py_trees_memory_sequences(fig1_path: str) -> None:
    """The generator's Sequences (``leaves.composites.Sequence``, a leaner ``tick``) halt their children only
    when they finish, as py_trees' Sequence with memory does: the recorder gives them that kind, not the
    kind of a composite whose tick is unknown (which it would look below on every tick)."""
    root = btgen_pytrees.generate(btgen_pytrees.load(fig1_path))
    ours = TraceRecorder(root)._kinds
    sequences = [n for n in root.iterate() if type(n) is Sequence]
    assert sequences
    for node in sequences:
        node.__class__ = py_trees.composites.Sequence
    assert TraceRecorder(root)._kinds == ours
