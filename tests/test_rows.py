"""generate() walks the timeline's rows read from the entries (construct.execute.case_rows), not a
networkx graph: they must be exactly the rows of timeline()'s graph, and the tree exactly the one the
walk builds over that graph (execute_subtree)."""

from __future__ import annotations

import dataclasses
from typing import Any

import networkx as nx
import pytest
from helpers import case, entry
from hypothesis import given, settings
from hypothesis import strategies as st

import btgen_pytrees
from btgen_pytrees.construct.execute import case_rows, execute_subtree, rows
from btgen_pytrees.leaves import Environment, default_registry
from btgen_pytrees.timeline import timeline


@st.composite
def timelines(draw: Any) -> dict[str, Any]:
    """Random timelines whose entries may name entries below them (file order need not be an order)."""
    n = draw(st.integers(1, 16))
    rank = draw(st.permutations(range(n)))
    entries = []
    for i in range(n):
        preds = draw(st.lists(st.integers(0, n - 1), max_size=3, unique=True))
        preds = [p for p in preds if rank[p] < rank[i]]
        join = draw(st.sampled_from([None, "any", "all"]))
        entries.append(entry(f"E{i}", [f"E{p}" for p in preds], action="hold", duration=0.1, join=join))
    return case(*entries, timeout=100)


def shape(root: Any) -> list[tuple[str, str, tuple[str, ...]]]:
    out, stack = [], [root]
    while stack:
        node = stack.pop()
        out.append((type(node).__name__, node.name, tuple(getattr(node, "waits_for", ()))))
        stack.extend(reversed(node.children))
    return out


@settings(max_examples=300, deadline=None)
@given(timelines(), st.sampled_from([11, 12, 14, 100]))
def test_case_rows_are_the_graphs_rows_and_build_the_same_tree(data: dict[str, Any], max_depth: int) -> None:
    test = btgen_pytrees.load(data)
    graph = timeline(test)
    found = case_rows(test.entries)
    assert found is not None
    expected = rows(graph._pred, graph._succ)
    assert list(found.pred) == list(expected.pred)
    assert {v: tuple(p) for v, p in found.pred.items()} == {v: tuple(p) for v, p in expected.pred.items()}
    assert found.link == expected.link  # looked up, never iterated: their order does not matter
    assert found.rest == expected.rest  # each entry's successors in file order
    generated = btgen_pytrees.generate(test, namespace="/rows/a", max_depth=max_depth)
    walked = execute_subtree(graph, Environment("/rows/b"), default_registry(), max_depth=max_depth)
    assert shape(generated.children[0].children[0]) == shape(walked)


def _odd(test: Any, **changes: Any) -> Any:
    """*test* with its last entry changed as the loader would never allow (a hand-made TestCase)."""
    *head, last = test.entries
    return dataclasses.replace(test, entries=(*head, dataclasses.replace(last, **changes)))


def test_what_the_loader_rejects_is_walked_over_the_graph() -> None:
    test = btgen_pytrees.load(case(entry("A"), entry("B", ["A"]), entry("C", ["A", "B"])))
    named_twice = _odd(test, after=("A", "B", "A"))
    assert case_rows(named_twice.entries) is None
    assert [n for _, n, _ in shape(btgen_pytrees.generate(named_twice))] == [
        n for _, n, _ in shape(btgen_pytrees.generate(test))]  # fmt: skip
    assert case_rows(_odd(test, after=("A", "X")).entries) is None
    with pytest.raises(KeyError):
        btgen_pytrees.generate(_odd(test, after=("A", "X")))  # the graph adds X without an entry
    assert case_rows(_odd(test, id="B").entries) is None
    with pytest.raises(nx.NetworkXUnfeasible):
        btgen_pytrees.generate(_odd(test, id="B"))


def test_a_cycle_of_single_steps_is_found_without_an_order() -> None:
    test = btgen_pytrees.load(case(entry("A"), entry("B", ["A"]), entry("C", ["B"])))
    looped = dataclasses.replace(test, entries=(test.entries[0], dataclasses.replace(test.entries[1], after=("C",)),
                                                test.entries[2]))  # fmt: skip
    found = case_rows(looped.entries)
    assert found is not None and found.link == {"C": "B", "B": "C"} and found.rest == {}
    with pytest.raises(nx.NetworkXUnfeasible, match="cycle"):
        btgen_pytrees.generate(looped)
