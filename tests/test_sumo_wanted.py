"""A SUMO run that records no trace (a sweep's, a search's) reads and publishes only the signals its tree reads.

``run_tree(..., record=False)`` sets ``Environment.wanted`` to the signals the tree's blackboard clients
declared, when every node of the tree is this package's; the SUMO system then subscribes each tracked
vehicle to its speed, place and lane and to what the run wants, and publishes only those signals
(docs/sumo.md, "Signals"). Checked here against the same case recorded (every signal, as ``run`` gives)
and against libsumo's own subscription results. These tests run the simulator: they skip without libsumo,
except under CI.
"""

from __future__ import annotations

import importlib.util
import os
import pathlib
from typing import Any

import py_trees
import pytest
from py_trees.blackboard import Blackboard

import btgen_pytrees
from btgen_pytrees import generate
from btgen_pytrees.leaves import default_registry
from btgen_pytrees.run import run_tree

ROOT = pathlib.Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples" / "sumo"
CUT_IN_3D = ROOT / "benchmarks" / "falsify_cases" / "cut_in_3d.json"

pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("libsumo") is None and not os.environ.get("CI"),
    reason="libsumo is not installed (pip install -e '.[sumo]'; CI installs it)",
)

_SPEED, _POSITION, _LANE_INDEX, _LEADER = 0x40, 0x42, 0x52, 0x68


def ticks_of(case: Any, registry: Any, record: bool) -> tuple[Any, list[dict[str, Any]], list[dict[str, frozenset[int]]]]:
    """Run *case*; per tick, its signals on the blackboard and libsumo's subscription results' variables."""
    import libsumo

    system = btgen_pytrees.run.create_system(case, registry)
    root = generate(case, registry=registry, clock=system)
    prefix = root.btgen_env.namespace + "/signals/"
    signals: list[dict[str, Any]] = []
    subscribed: list[dict[str, frozenset[int]]] = []

    def seen(_k: int, _t: float) -> None:
        signals.append({k[len(prefix):]: v for k, v in Blackboard.storage.items() if k.startswith(prefix)})
        subscribed.append({vid: frozenset(r) for vid, r in libsumo.vehicle.getAllSubscriptionResults().items()})

    report = run_tree(root, case, system=system, record=record, progress=seen)
    root.btgen_env.clear()
    return report, signals, subscribed


def outcome(report: Any) -> tuple[Any, ...]:
    return (report.verdict, report.message, [(o.id, o.verdict, o.margin) for o in report.oracles],
            [(e.id, e.status, e.start, e.end) for e in report.execute])  # fmt: skip


@pytest.mark.parametrize("path", [EXAMPLES / "cut_in.json", EXAMPLES / "acc_hard_brake.json", CUT_IN_3D], ids=lambda p: p.stem)
def test_a_run_that_records_nothing_publishes_only_what_its_tree_reads_with_the_same_values(path: pathlib.Path) -> None:
    """The same verdicts, margins and entries; on every tick the signals the tree reads have the recorded
    run's values, and no other signal of the system is on the blackboard; libsumo's subscriptions hold the
    core variables and the leader only where ``gap`` or ``ttc`` is read, where the recorded run's hold all."""
    registry = default_registry()
    case = btgen_pytrees.load(path, registry=registry)
    full, full_signals, full_subscribed = ticks_of(case, registry, record=True)
    lean, lean_signals, lean_subscribed = ticks_of(case, registry, record=False)
    assert outcome(lean) == outcome(full)
    assert len(lean_signals) == len(full_signals) == full.ticks
    read = {name for criterion in case.criteria for name in criterion.expect.ordered_names}
    read |= {name for e in case.entries if e.action == "until" for name in e.expressions["expect"].ordered_names}
    assert read and all("." in name for name in read)
    for lean_tick, full_tick in zip(lean_signals, full_signals):
        assert set(lean_tick) <= read | set(case.signals)
        assert {k: v for k, v in full_tick.items() if k in lean_tick} == lean_tick
        assert {k for k in full_tick if k in read} == {k for k in lean_tick if k in read}
    assert any(f"{vid}.accel" in tick for tick in full_signals for vid in ("ego", "cutter", "lead"))
    for lean_tick, full_tick in zip(lean_subscribed, full_subscribed):
        for vid, variables in lean_tick.items():
            leader = f"{vid}.gap" in read or f"{vid}.ttc" in read
            assert variables == {_SPEED, _POSITION, _LANE_INDEX} | ({_LEADER} if leader else set()), (vid, variables)
            assert len(full_tick[vid]) == 8  # speed, accel, place, lane, lateral offset, distance, heading, leader


def test_a_plugin_node_in_the_tree_gets_every_signal() -> None:
    """A node that is not this package's may read a signal it did not declare: the run publishes them all."""

    class Peek(py_trees.behaviour.Behaviour):
        def update(self) -> py_trees.common.Status:
            return py_trees.common.Status.SUCCESS

    registry = default_registry()
    case = btgen_pytrees.load(EXAMPLES / "cut_in.json", registry=registry)
    system = btgen_pytrees.run.create_system(case, registry)
    root = generate(case, registry=registry, clock=system)
    root.add_child(Peek("peek"))
    prefix = root.btgen_env.namespace + "/signals/"
    seen: list[set[str]] = []
    report = run_tree(root, case, system=system, record=False,
                      progress=lambda _k, _t: seen.append({k[len(prefix):] for k in Blackboard.storage if k.startswith(prefix)}))  # fmt: skip
    root.btgen_env.clear()
    assert report.verdict == "fail"
    assert any({"ego.accel", "cutter.lateral", "sim.vehicles"} <= tick for tick in seen)
