"""The generator's nodes tick as py_trees' own classes do, minus py_trees' per-tick waste.

``leaves.composites.Parallel`` (every Parallel the generator builds, the tree's root too; its ``tick``
and ``stop``), ``leaves.composites.Sequence`` (every Sequence it builds; its ``tick`` and ``stop``:
a leaf of the package's ticked without a generator, a child whose tick ends with its own node ticked
with ``yield from``, any other child with py_trees' loop), ``leaves.node.Node`` (every leaf of the package: ``tick`` and ``stop``) and
``leaves.wiring.Completion.tick`` are py_trees' ``Parallel``, ``Behaviour`` and ``Decorator`` methods
without what those spend on every tick for nothing. Each test ticks two trees side by side: the one
as built, and its twin whose nodes run py_trees' own methods (the class swapped for the stock one, or
for a subclass with the stock ``tick`` and ``stop``). After every tick both must have yielded the same nodes in the same order, and every node
must have the same status, feedback and ``current_child``; the reports must be the same; with
py_trees' debug logging on, both must print the same lines.
"""

from __future__ import annotations

import itertools
from functools import lru_cache
from typing import Any, Iterator

import py_trees
import pytest
from helpers import case, crit, entry
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from py_trees.common import ParallelPolicy, Status

import btgen_pytrees
from btgen_pytrees.clock import VirtualClock
from btgen_pytrees.leaves.composites import Parallel, Sequence
from btgen_pytrees.leaves.node import Node
from btgen_pytrees.leaves.wiring import Completion, TreeRoot, WakingParallel
from btgen_pytrees.run import run_tree

_DONE = (Status.SUCCESS, Status.FAILURE)


class _StockRoot(TreeRoot):
    """The tree's root ticked by py_trees' own ``Parallel.tick`` (after reading the clock, as TreeRoot does)."""

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        self.env.begin_tick()
        yield from py_trees.composites.Parallel.tick(self)

    stop = py_trees.composites.Parallel.stop


@lru_cache(maxsize=None)
def _stock(cls: type) -> type:
    """*cls* with py_trees' own ``tick`` and ``stop`` where it has the lean ones."""
    methods: dict[str, Any] = {"__module__": cls.__module__}
    if cls.tick is Node.tick:
        methods["tick"] = py_trees.behaviour.Behaviour.tick
    if cls.tick is Completion.tick:
        methods["tick"] = py_trees.decorators.Decorator.tick
    if cls.stop is Node.stop:
        methods["stop"] = py_trees.behaviour.Behaviour.stop
    if cls.stop is Parallel.stop:
        methods["stop"] = py_trees.composites.Parallel.stop
    return type(cls.__name__, (cls,), methods)


def stock_twin(root: py_trees.behaviour.Behaviour) -> py_trees.behaviour.Behaviour:
    """Make every node of *root* that runs one of the lean methods run py_trees' own instead."""
    for node in root.iterate():
        cls = type(node)
        if cls is Parallel:
            node.__class__ = py_trees.composites.Parallel
        elif cls is Sequence:
            node.__class__ = py_trees.composites.Sequence
        elif cls is TreeRoot:
            node.__class__ = _StockRoot
        elif cls.tick in (Node.tick, Completion.tick) or cls.stop in (Node.stop, Parallel.stop):
            node.__class__ = _stock(cls)
    return root


def _lean_ticks(root: py_trees.behaviour.Behaviour) -> set[str]:
    """Which of the lean methods the tree runs (a test that meets none proves nothing)."""
    found = set()
    for node in root.iterate():
        cls = type(node)
        if isinstance(node, TreeRoot):
            found.add("TreeRoot")
        elif cls.tick is Parallel.tick:
            found.add(f"Parallel {type(node.policy).__name__}")
        elif cls.tick is Sequence.tick:
            found.add("Sequence")
        elif cls.tick is Completion.tick:
            found.add("Completion")
        elif cls.tick is Node.tick:
            found.add("Node")
        if cls.stop in (Node.stop, Parallel.stop, Sequence.stop):
            found.add("stop")
    return found


def _state(root: py_trees.behaviour.Behaviour) -> list[tuple[Any, ...]]:
    return [(n.name, n.status, n.feedback_message, getattr(getattr(n, "current_child", None), "name", None))
            for n in root.iterate()]  # fmt: skip


def _tick(root: py_trees.behaviour.Behaviour) -> list[str]:
    return [node.name for node in root.tick()]


def _lockstep(data: dict[str, Any], ticks: int = 600) -> set[str]:
    """Tick the generated tree and its stock twin until they finish; assert the same yields and state after
    every tick and the same report. Returns the lean ticks the tree ran."""
    loaded = btgen_pytrees.load(data)
    clocks = [VirtualClock(), VirtualClock()]
    lean = btgen_pytrees.generate(loaded, clock=clocks[0])
    stock = stock_twin(btgen_pytrees.generate(loaded, clock=clocks[1]))
    used = _lean_ticks(lean)
    assert not _lean_ticks(stock) - {"TreeRoot"}
    for k in range(ticks):
        for clock in clocks:
            clock.set(round(k * loaded.tick, 9))
        assert _tick(lean) == _tick(stock), f"tick {k}"
        assert _state(lean) == _state(stock), f"tick {k}"
        if lean.status in _DONE:
            break
    else:
        raise AssertionError("did not finish")
    reports = [run_tree(btgen_pytrees.generate(loaded), loaded),
               run_tree(stock_twin(btgen_pytrees.generate(loaded)), loaded)]  # fmt: skip
    assert reports[0].to_json() == reports[1].to_json()
    return used


@st.composite
def cases(draw: Any, max_entries: int = 8) -> dict[str, Any]:
    """Timelines of every built-in leaf (an ``until`` may time out and fail) with every kind of criterion,
    joined by ``&&`` or ``||`` (its members wrapped, its group a ``SuccessOnOne`` Parallel)."""
    n = draw(st.integers(1, max_entries))
    entries = []
    for i in range(n):
        preds = draw(st.lists(st.integers(0, i - 1), max_size=2, unique=True)) if i else []
        after = [f"E{p}" for p in preds]
        action = draw(st.sampled_from(["hold", "wait", "set", "ramp", "until"]))
        join = draw(st.sampled_from([None, "any", "all"]))
        if action in ("hold", "wait"):
            params: dict[str, Any] = {"duration": draw(st.sampled_from([0, 0.1, 0.3, 1]))}
        elif action == "set":
            params = {"signal": "x", "value": draw(st.integers(0, 6))}
        elif action == "ramp":
            params = {"signal": "x", "to": draw(st.integers(0, 6)), "duration": draw(st.sampled_from([0.2, 1]))}
        else:
            params = {"expect": f"x >= {draw(st.integers(0, 6))}", "timeout": draw(st.sampled_from([0.3, 1]))}
        entries.append(entry(f"E{i}", after, action=action, join=join, **params))
    criteria = []
    for j in range(draw(st.integers(0, 4))):
        kind = draw(st.sampled_from(["record", "period", "final"]))
        extra = {"from": 0.2} if kind == "period" and draw(st.booleans()) else {}
        criteria.append(crit(f"R{j}", kind, f"x <= {draw(st.integers(2, 7))}", **extra))
    relation = draw(st.sampled_from(["&&", "||", {"record": "||", "others": "&&"}]))
    return case(*entries, criteria=criteria or None, relation=relation if criteria else None, signals={"x": 0},
                tick=0.1, timeout=draw(st.sampled_from([2, 30])))  # fmt: skip


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(cases())
def test_generated_trees_tick_as_with_py_trees_own_ticks(data: dict[str, Any]) -> None:
    _lockstep(data)


def test_the_examples_run_every_lean_tick() -> None:
    data = case(entry("A", action="set", signal="x", value=1), entry("B", ["A"], action="ramp", signal="x", to=4, duration=1),
                entry("C", ["A"], action="until", expect="x >= 3", timeout=2), entry("D", ["B", "C"], join="all", duration=0.3),
                criteria=[crit("R", "record", "x <= 5"), crit("S", "record", "x <= 0"), crit("P", "period", "x >= 0"),
                          crit("F", "final", "x >= 4")],
                relation={"record": "||", "others": "&&"}, signals={"x": 0}, tick=0.1, timeout=10)  # fmt: skip
    used = _lockstep(data)
    assert used == {"TreeRoot", "Completion", "Node", "Parallel SuccessOnAll", "Parallel SuccessOnOne", "stop",
                    "Parallel SuccessOnSelected", "Sequence"}  # the oracle root: the non-record group decides
    failing = case(entry("A", action="until", expect="x >= 9", timeout=0.5), entry("B", ["A"]),
                   criteria=[crit("R", "record", "x <= 5")], signals={"x": 0}, tick=0.1, timeout=10)  # fmt: skip
    _lockstep(failing)  # the execute subtree fails: FAILURE up through the Sequences and Parallels


# -- trees of py_trees' own composites and scripted leaves, every policy ---------------------------


class _Scripted(Node):
    """A leaf that returns the statuses of its script in turn (the last one for ever)."""

    def __init__(self, name: str, script: tuple[Any, ...]):
        super().__init__(name)
        self.script = script
        self.calls = 0
        self.initialised = 0
        self.terminated: list[Status] = []

    def initialise(self) -> None:
        self.initialised += 1
        self.feedback_message = f"initialised {self.initialised}"

    def terminate(self, new_status: Status) -> None:
        self.terminated.append(new_status)

    def update(self) -> Any:
        status = self.script[min(self.calls, len(self.script) - 1)]
        self.calls += 1
        return status


class _Twice(py_trees.behaviour.Behaviour):
    """A user's leaf whose ``tick`` yields itself twice (py_trees' own ``tick`` run twice: two updates): a
    Sequence must look at it after its first yield, as py_trees' loop does, and stop there when it did not
    succeed - the second update never runs. Not one of the package's nodes: the Sequence keeps py_trees' loop."""

    def __init__(self, name: str, script: tuple[Any, ...]):
        super().__init__(name)
        self.script = script
        self.calls = 0

    def update(self) -> Any:
        status = self.script[min(self.calls, len(self.script) - 1)]
        self.calls += 1
        return status

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        yield from py_trees.behaviour.Behaviour.tick(self)
        yield from py_trees.behaviour.Behaviour.tick(self)


_STATUS = st.sampled_from([Status.SUCCESS, Status.FAILURE, Status.RUNNING, Status.RUNNING])


@st.composite
def trees(draw: Any, depth: int = 0) -> Any:
    """A recipe: ("leaf" or "twice", script) or (kind, policy, synchronise, children)."""
    if depth >= 3 or draw(st.integers(0, 3)) == 0:
        return (draw(st.sampled_from(["leaf", "leaf", "twice"])), tuple(draw(st.lists(_STATUS, min_size=1, max_size=5))))
    kind = draw(st.sampled_from(["parallel", "parallel", "sequence"]))
    children = draw(st.lists(trees(depth + 1), min_size=0 if kind == "parallel" else 1, max_size=4))
    return (kind, draw(st.sampled_from(["all", "one", "selected"])), draw(st.booleans()), children)


def _build(recipe: Any, lean: bool, names: Iterator[int]) -> py_trees.behaviour.Behaviour:
    name = f"n{next(names)}"
    if recipe[0] == "leaf":
        node = _Scripted(name, recipe[1])
        if not lean:
            node.__class__ = _stock(_Scripted)
        return node
    if recipe[0] == "twice":
        return _Twice(name, recipe[1])
    kind, policy_name, synchronise, children = recipe
    built = [_build(child, lean, names) for child in children]
    if kind == "sequence":
        return (Sequence if lean else py_trees.composites.Sequence)(name, memory=synchronise, children=built)
    if policy_name == "all":
        policy: ParallelPolicy.Base = ParallelPolicy.SuccessOnAll(synchronise=synchronise)
    elif policy_name == "one":
        policy = ParallelPolicy.SuccessOnOne()
    else:
        policy = ParallelPolicy.SuccessOnSelected(built[::2], synchronise=synchronise)
    cls = Parallel if lean else py_trees.composites.Parallel
    return cls(name, policy, built)


def _ticked(root: py_trees.behaviour.Behaviour) -> list[Any]:
    try:
        return [node.name for node in root.tick()]
    except RuntimeError as exc:  # an empty SuccessOnSelected: both raise the same
        return [f"raised {exc}"]


@settings(max_examples=300, deadline=None)
@given(trees())
def test_random_trees_tick_as_py_trees_own(recipe: Any) -> None:
    lean, stock = _build(recipe, True, itertools.count()), _build(recipe, False, itertools.count())
    for k in range(8):
        assert _ticked(lean) == _ticked(stock), f"tick {k}"
        assert _state(lean) == _state(stock), f"tick {k}"
        assert [(getattr(n, "initialised", None), getattr(n, "terminated", None), getattr(n, "calls", None))
                for n in lean.iterate()] == [
            (getattr(n, "initialised", None), getattr(n, "terminated", None), getattr(n, "calls", None))
            for n in stock.iterate()]  # fmt: skip
    lean.stop(Status.INVALID)
    stock.stop(Status.INVALID)
    assert _state(lean) == _state(stock)


def test_an_unknown_policy_raises_as_py_trees_does() -> None:
    class Odd(ParallelPolicy.Base):
        pass

    for cls in (Parallel, py_trees.composites.Parallel):
        with pytest.raises(RuntimeError, match="unrecognised policy"):
            cls("p", Odd(), [_Scripted("a", (Status.RUNNING,))]).tick_once()


def test_a_selection_of_no_child_or_of_a_stranger_raises_as_py_trees_does(capsys: pytest.CaptureFixture[str]) -> None:
    """py_trees' check of a ``SuccessOnSelected`` policy runs where it finds something: the same error, logged."""
    outputs = []
    for cls in (Parallel, py_trees.composites.Parallel):
        stranger = _Scripted("stranger", (Status.RUNNING,))
        child = _Scripted("a", (Status.RUNNING,))
        for selected in ([], [child, stranger]):
            parallel = cls("p", ParallelPolicy.SuccessOnSelected(selected), [child])
            with pytest.raises(RuntimeError) as raised:
                parallel.tick_once()
            child.parent = None
            outputs.append((str(raised.value), capsys.readouterr().out))
    assert outputs[:2] == outputs[2:]
    assert "non-empty selection" in outputs[0][0] and "['stranger']" in outputs[1][0]


def test_the_same_log_lines_as_py_trees(capsys: pytest.CaptureFixture[str]) -> None:
    """Debug on: the same debug lines, in the same order; an update that returns no Status: the same error line."""
    recipe = ("parallel", "all", True, [("sequence", "all", True, [("leaf", (Status.SUCCESS,)), ("leaf", (None, Status.RUNNING))]),
                                        ("parallel", "one", False, [("leaf", (Status.RUNNING, Status.SUCCESS))])])  # fmt: skip
    level = py_trees.logging.level
    outputs = []
    try:
        for lean in (True, False):
            for debug in (True, False):
                py_trees.logging.level = py_trees.logging.Level.DEBUG if debug else py_trees.logging.Level.INFO
                root = _build(recipe, lean, itertools.count())
                for _ in range(3):
                    root.tick_once()
                outputs.append(capsys.readouterr().out)
    finally:
        py_trees.logging.level = level
    assert outputs[0] == outputs[2] and outputs[1] == outputs[3]
    assert "Parallel.tick()" in outputs[0] and "_Scripted.tick()" in outputs[0] and "re-initialising" in outputs[0]
    assert "Sequence.tick()" in outputs[0] and "Sequence.stop()" in outputs[0]
    assert "A behaviour returned an invalid status" in outputs[1] and "tick()" not in outputs[1]


def test_every_parallel_the_generator_builds_is_the_lean_one() -> None:
    data = case(entry("A"), entry("B"), entry("C", ["A", "B"]), entry("D", ["C"]), entry("E", ["C"]),
                criteria=[crit("R", "record", "x <= 5"), crit("S", "record", "x <= 6"), crit("F", "final", "x >= 0")],
                relation={"record": "||", "others": "&&"}, signals={"x": 0})  # fmt: skip
    root = btgen_pytrees.generate(btgen_pytrees.load(data))
    parallels = [n for n in root.iterate() if isinstance(n, py_trees.composites.Parallel)]
    assert {type(n) for n in parallels} == {Parallel, TreeRoot, WakingParallel}
    assert all(isinstance(n, Parallel) for n in parallels)
    assert {type(n).__name__ for n in parallels if type(n) is Parallel} == {"Parallel"}  # what the views show


def test_every_sequence_the_generator_builds_is_the_lean_one() -> None:
    data = case(entry("A"), entry("B", ["A"]), entry("C", ["A"]), entry("D", ["B", "C"], join="any"),
                criteria=[crit("R", "record", "x <= 5")], signals={"x": 0})  # fmt: skip
    root = btgen_pytrees.generate(btgen_pytrees.load(data))
    sequences = [n for n in root.iterate() if isinstance(n, py_trees.composites.Sequence)]
    assert len(sequences) >= 3 and {type(n) for n in sequences} == {Sequence}
    assert {type(n).__name__ for n in sequences} == {"Sequence"}  # what the views show
