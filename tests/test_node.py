"""leaves.node.Node: the generator's own nodes start as py_trees' Behaviour.__init__ starts them, but
draw their id without a system call. If a py_trees release changes what Behaviour.__init__ sets,
these tests say so."""

from __future__ import annotations

import gc
import os
import types
import uuid

import py_trees
import pytest
from helpers import case, chain, crit, entry
from py_trees.common import Status

import btgen_pytrees
from btgen_pytrees.clock import VirtualClock
from btgen_pytrees.leaves.node import Node, new_id
from btgen_pytrees.run import run_tree


class _Stock(py_trees.behaviour.Behaviour):
    def update(self) -> Status:
        return Status.SUCCESS


class _Ours(Node):
    def update(self) -> Status:
        return Status.SUCCESS


LAZY = {"_id": "id", "_logger": "logger", "_iterator": "iterator", "_blackboards": "blackboards"}
"""Attributes made when first read, behind properties."""


def test_a_node_has_what_a_stock_behaviour_has_in_the_same_order() -> None:
    stock, ours = _Stock("a name"), _Ours("a name")
    assert [LAZY.get(k, k) for k in vars(ours)] == list(vars(stock))
    assert ours._iterator is None and ours._blackboards is None and ours._id is None and ours._logger is None
    for key, expected in vars(stock).items():
        got = getattr(ours, key)
        assert type(got) is type(expected), key
        if key == "id":
            assert got != expected and got.version == 4 and got.variant == uuid.RFC_4122
            assert ours.id is got  # made once
        elif key == "iterator":
            assert isinstance(got, types.GeneratorType) and got.gi_code is Node.tick.__code__  # its own tick (below)
            assert expected.gi_code is py_trees.behaviour.Behaviour.tick.__code__
            assert ours.iterator is got  # made once
        elif key == "logger":
            assert vars(got) == vars(expected)
            assert ours.logger is got  # made once
        elif key == "qualified_name":
            assert got == "_Ours/a name" and expected == "_Stock/a name"
        else:
            assert got == expected, key
    assert [LAZY.get(k, k) for k in vars(ours)] == list(vars(stock))  # reading them added no attribute
    other = _Ours("b")
    assert ours.children is not other.children and ours.blackboards is not other.blackboards
    with pytest.raises(TypeError, match="name should be a string"):
        _Ours(3)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="name should be a string"):
        _Stock(3)  # type: ignore[arg-type]


def test_a_client_attaches_as_to_a_stock_behaviour() -> None:
    ours, stock = _Ours("leaf"), _Stock("leaf")
    for node in (ours, stock):
        client = node.attach_blackboard_client()
        assert node.blackboards == [client] and client.name == "leaf"
        client.unregister()
    ours.blackboards = []
    assert ours.blackboards == [] and ours._blackboards == []


def test_decorators_reach_it_through_decorator_init() -> None:
    class Pass(py_trees.decorators.Decorator, Node):
        def update(self) -> Status:
            return self.decorated.status

    child = _Ours("child")
    wrapped = Pass(name="wrap", child=child)
    stock = py_trees.decorators.PassThrough(name="wrap", child=_Stock("child"))
    assert [LAZY.get(k, k) for k in vars(wrapped)] == list(vars(stock))
    assert wrapped.children == [child] and child.parent is wrapped and wrapped.decorated is child
    assert wrapped.qualified_name.endswith(".Pass/wrap")


def test_stop_makes_a_new_iterator_as_py_trees_does() -> None:
    ours = _Ours("x")
    ours.tick_once()
    first = ours.iterator
    ours.stop(Status.INVALID)
    assert isinstance(ours.iterator, types.GeneratorType) and ours.iterator is not first
    assert [LAZY.get(k, k) for k in vars(ours)] == list(vars(_Stock("x")))  # no attribute added by stop()


def test_ids_are_version_4_and_distinct() -> None:
    ids = [new_id() for _ in range(20_000)]
    assert len(set(ids)) == len(ids)
    assert {(i.version, i.variant) for i in ids} == {(4, uuid.RFC_4122)}
    assert len({str(i)[14] for i in ids}) == 1  # the version digit; the rest varies
    assert len({str(i)[19] for i in ids}) == 4  # variant digit 8, 9, a or b


@pytest.mark.skipif(not hasattr(os, "fork"), reason="POSIX fork only")
def test_a_forked_child_draws_other_ids() -> None:
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the child
        try:
            os.write(write, new_id().bytes)
        finally:
            os._exit(0)
    os.close(write)
    child = os.read(read, 16)
    os.close(read)
    os.waitpid(pid, 0)
    assert len(child) == 16 and child != new_id().bytes


def test_every_node_the_generator_makes_of_its_own_is_one() -> None:
    data = case(entry("A", action="set", signal="x", value=1), entry("B", ["A"]), entry("C", ["A"]),
                entry("D", ["B", "C"], action="until", expect="x >= 0", timeout=1),
                criteria=[crit("R", "record", "x <= 5"), crit("P", "period", "x >= 0"), crit("F", "final", "x >= 0")],
                relation={"record": "||"}, signals={"x": 0})  # fmt: skip
    root = btgen_pytrees.generate(btgen_pytrees.load(data))
    nodes = list(root.iterate())
    ours = {type(n).__name__ for n in nodes if isinstance(n, Node)}
    assert ours == {"RunStart", "Set", "Hold", "Until", "Trigger", "Completion", "Record", "Period", "Final", "OrMember"}
    stock = {type(n).__name__ for n in nodes if not isinstance(n, Node)}
    assert stock == {"TreeRoot", "WakingParallel", "Sequence", "Parallel"}  # composites: py_trees' own __init__
    assert len({n.id for n in nodes}) == len(nodes)


def _dicts() -> int:
    gc.collect()
    return sum(1 for o in gc.get_objects() if type(o) is dict)


def test_a_run_gives_no_node_a_dict_of_its_own() -> None:
    """Every attribute a node will have is set in __init__: one first set later (by stop()) makes
    CPython give each node its own dict - 2,000 more objects here for the collector to walk."""
    test = btgen_pytrees.load({**chain(2_000, duration=0.1), "timeout": 1_000})
    clock = VirtualClock()
    root = btgen_pytrees.generate(test, clock=clock)
    before = _dicts()
    assert run_tree(root, test, clock).verdict == "pass"
    assert _dicts() - before < 100
