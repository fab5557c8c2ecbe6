"""timeline.topological_order is networkx's lexicographical order by file index, computed without views."""

from __future__ import annotations

import networkx as nx
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from btgen_pytrees.timeline import topological_order


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
