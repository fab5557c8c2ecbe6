"""timeline.topological_order is networkx's lexicographical order by file index, computed without views."""

from __future__ import annotations

import networkx as nx
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from btgen_pytrees.order import is_acyclic, order, positions
from btgen_pytrees.timeline import topological_order, topological_positions


@st.composite
def dags(draw: st.DrawFn) -> nx.DiGraph:
    """Random DAGs whose node order (file order) need not be topological."""
    n = draw(st.integers(1, 25))
    rank = draw(st.permutations(range(n)))  # edges go from lower to higher rank
    graph = nx.DiGraph()
    graph.add_nodes_from(f"E{i}" for i in range(n))
    for a in range(n):
        for b in draw(st.lists(st.integers(0, n - 1), max_size=3)):
            if rank[a] < rank[b]:
                graph.add_edge(f"E{a}", f"E{b}")
    return graph


@settings(max_examples=300, deadline=None)
@given(dags())
def test_same_order_as_networkx(graph: nx.DiGraph) -> None:
    index = {v: i for i, v in enumerate(graph)}
    assert topological_order(graph) == list(nx.lexicographical_topological_sort(graph, key=index.__getitem__))


def test_a_cycle_is_refused() -> None:
    graph = nx.DiGraph([("A", "B"), ("B", "A"), ("C", "A")])
    with pytest.raises(nx.NetworkXUnfeasible):
        topological_order(graph)


@settings(max_examples=300, deadline=None)
@given(dags())
def test_order_over_after_lists_is_the_same(graph: nx.DiGraph) -> None:
    """btgen_pytrees.order over plain after-lists (what the loader and the overlap warnings pass) agrees."""
    after = {v: tuple(graph.predecessors(v)) for v in graph}
    expected = topological_order(graph)
    assert order(after) == expected
    assert positions(after) == {v: i for i, v in enumerate(expected)} == topological_positions(graph)
    assert is_acyclic(after)


def test_a_cycle_has_no_order() -> None:
    after = {"C": (), "A": ("B", "C"), "B": ("A",)}
    assert order(after) is None and positions(after) is None and not is_acyclic(after)
    assert is_acyclic({"A": (), "B": ("A",)}) and positions({"B": ("A",), "A": ()}) == {"A": 0, "B": 1}


def test_timeline_with_and_without_the_entries() -> None:
    from btgen_pytrees import load
    from btgen_pytrees.timeline import timeline

    case = load({"name": "t", "execute": [
        {"id": "A", "kind": "behavior", "action": "set", "params": {"signal": "x", "value": 1}},
        {"id": "B", "kind": "behavior", "action": "set", "params": {"signal": "x", "value": 2}, "after": ["A"]},
    ]})
    full, bare = timeline(case), timeline(case, attributes=False)
    assert list(full.edges) == list(bare.edges) == [("A", "B")]
    assert full.nodes["B"]["entry"] is case.entries[1] and bare.nodes["B"] == {}
