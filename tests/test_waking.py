"""The execute root's WakingParallel ticks like py_trees' Parallel, minus the no-op polls.

Each test ticks two identically generated trees side by side: one as generated
(heads sleep until a predecessor is marked done), one whose execute root has
been turned back into a stock ``Parallel`` (every waiting trigger polled on
every tick). After every tick every node must have the same status and
feedback, and the reports must be identical; the waking tree must tick its
triggers far less often.
"""

from __future__ import annotations

from collections import Counter
from typing import Any

import py_trees
import pytest
from helpers import case, entry
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from py_trees.common import Status
from test_properties import timelines

import btgen_pytrees
from btgen_pytrees.clock import VirtualClock
from btgen_pytrees.leaves.wiring import Trigger, WakingParallel
from btgen_pytrees.run import run_tree

_DONE = (Status.SUCCESS, Status.FAILURE)


def _execute_root(root: py_trees.behaviour.Behaviour) -> WakingParallel:
    found = [n for n in root.iterate() if isinstance(n, WakingParallel)]
    assert len(found) == 1
    return found[0]


def _pair(data: dict[str, Any], max_depth: int = 100) -> list[tuple[Any, VirtualClock]]:
    """The tree as generated, and the same tree with a stock Parallel as its execute root."""
    loaded = btgen_pytrees.load(data)
    trees = []
    for stock in (False, True):
        clock = VirtualClock()
        root = btgen_pytrees.generate(loaded, clock=clock, max_depth=max_depth)
        if stock:
            _execute_root(root).__class__ = py_trees.composites.Parallel  # polls every head every tick
        trees.append((root, clock))
    return trees


def _state(root: py_trees.behaviour.Behaviour) -> list[tuple[str, Status, str]]:
    return [(n.name, n.status, n.feedback_message) for n in root.iterate()]


def _count_trigger_ticks(root: py_trees.behaviour.Behaviour) -> Counter[str]:
    counts: Counter[str] = Counter()
    for node in root.iterate():
        if isinstance(node, Trigger):
            original = node.update

            def update(node: Trigger = node, original: Any = original) -> Status:
                counts[node.name] += 1
                return original()  # type: ignore[no-any-return]

            node.update = update  # type: ignore[method-assign]
    return counts


def _lockstep(data: dict[str, Any], max_depth: int = 100, ticks: int = 400) -> tuple[int, list[Counter[str]]]:
    """Tick both trees until they finish; assert equal state after every tick. Returns (ticks, trigger ticks)."""
    (waking, wclock), (stock, sclock) = _pair(data, max_depth)
    counts = [_count_trigger_ticks(waking), _count_trigger_ticks(stock)]
    tick = btgen_pytrees.load(data).tick
    for k in range(ticks):
        for clock in (wclock, sclock):
            clock.set(round(k * tick, 9))
        waking.tick_once()
        stock.tick_once()
        assert _state(waking) == _state(stock), f"tick {k}"
        if waking.status in _DONE:
            return k + 1, counts
    raise AssertionError("did not finish")


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(timelines(), st.sampled_from([12, 14, 100]))
def test_same_state_as_a_polling_parallel_after_every_tick(data: dict[str, Any], max_depth: int) -> None:
    _lockstep(data, max_depth)


def test_a_failure_fails_on_the_same_tick() -> None:
    data = case(entry("A", duration=0.2), entry("B", duration=0.1),
                entry("F", ["A", "B"], action="until", expect="false", timeout=0.3, join="all"),
                entry("G", ["A", "B"], join="any", duration=5), tick=0.1, timeout=20)  # fmt: skip
    ticks, _ = _lockstep(data)
    assert ticks == 6  # F starts at 0.2 and fails at 0.5


def _comb(n: int) -> dict[str, Any]:
    entries = []
    for i in range(n):
        entries.append(entry(f"S{i}", [f"S{i - 1}"] if i else [], duration=0.1))
        entries.append(entry(f"C{i}", [f"S{i}"], action="wait", duration=0.1))
    return case(*entries, tick=0.1, timeout=1000)


def test_waiting_heads_are_not_polled() -> None:
    """A comb hoisted every few levels: each trigger is ticked once to start waiting and once to fire."""
    ticks, (waking, stock) = _lockstep(_comb(60), max_depth=14)
    heads = len(waking)
    assert heads >= 10 and ticks > 60
    assert all(n == 2 for n in waking.values()), waking
    assert sum(stock.values()) > 10 * sum(waking.values())


def test_joins_wake_on_each_predecessor() -> None:
    """An 'all' join over 30 predecessors finishing one per tick is ticked on its first tick and once per mark."""
    preds = [entry(f"P{i}", duration=0.1 * (i + 1)) for i in range(30)]
    data = case(*preds, entry("J", [p["id"] for p in preds], join="all", duration=0.1), tick=0.1, timeout=100)
    ticks, (waking, stock) = _lockstep(data)
    assert waking[next(iter(waking))] == 1 + 30
    assert sum(stock.values()) == 31  # the stock Parallel polls it on every tick until it fires


def test_rerun_after_stop_gives_the_same_report() -> None:
    loaded = btgen_pytrees.load(_comb(30))
    clock = VirtualClock()
    root = btgen_pytrees.generate(loaded, clock=clock, max_depth=14)
    first = run_tree(root, loaded, clock).to_json()
    root.stop(Status.INVALID)
    assert run_tree(root, loaded, clock).to_json() == first
    # and stopped half-way through a run, then run again
    for k in range(7):
        clock.set(round(k * loaded.tick, 9))
        root.tick_once()
    root.stop(Status.INVALID)
    assert run_tree(root, loaded, clock).to_json() == first


def test_an_abandoned_pass_ticks_everyone_next_time() -> None:
    """If a tick is cut short (a leaf raised), the next tick falls back to ticking every unfinished child."""
    (waking, wclock), (stock, sclock) = _pair(_comb(30), max_depth=14)
    for root, clock in ((waking, wclock), (stock, sclock)):
        for k in range(12):
            clock.set(round(k * 0.1, 9))
            ticking = root.tick()
            if k == 5:
                for _ in range(4):  # stop part-way through the tick
                    next(ticking)
                ticking.close()
            else:
                for _ in ticking:
                    pass
    # both continue to the end without losing a head
    for root, clock in ((waking, wclock), (stock, sclock)):
        for k in range(12, 400):
            clock.set(round(k * 0.1, 9))
            root.tick_once()
            if root.status in _DONE:
                break
        assert root.status == Status.SUCCESS


@pytest.mark.parametrize("fmt", ["json", "ascii", "btcpp"])
def test_views_show_a_parallel(fmt: str) -> None:
    from btgen_pytrees.render import render

    loaded = btgen_pytrees.load(_comb(3))
    waking = btgen_pytrees.generate(loaded)
    stock = btgen_pytrees.generate(loaded)
    _execute_root(stock).__class__ = py_trees.composites.Parallel
    graph = btgen_pytrees.timeline(loaded)
    assert render(waking, graph, fmt) == render(stock, graph, fmt)
