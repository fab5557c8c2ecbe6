"""The execute timeline as a networkx graph.

Nodes are execute ids in file order, each carrying its
:class:`~btgen_pytrees.model.Entry` as the ``entry`` attribute; an edge
``p -> s`` says *s* comes after *p*. The paper's adjacency matrix is this graph's
matrix with rows and columns in file order: row *i* lists the successors of
entry *i*, column *j* the predecessors of entry *j*. Algorithm 1 walks those
rows and columns through the graph's sparse adjacency (``graph.succ`` /
``graph.pred``), never through a dense matrix; :func:`adjacency_matrix` exists
for display only.

>>> from btgen_pytrees import load
>>> case = load({"name": "t", "execute": [
...     {"id": "A", "kind": "behavior", "action": "hold", "params": {"duration": 1}},
...     {"id": "B", "kind": "behavior", "action": "hold", "params": {"duration": 1}, "after": ["A"]}]})
>>> g = timeline(case)
>>> list(g.edges)
[('A', 'B')]
>>> adjacency_matrix(g)
[[0, 1], [0, 0]]
"""

from __future__ import annotations

from typing import Iterator

import networkx as nx

from .model import TestCase
from .order import order, positions

__all__ = ["timeline", "adjacency_matrix", "topological_order", "topological_positions", "matrix_text", "matrix_lines",
           "DENSE_LIMIT"]


def timeline(case: TestCase, attributes: bool = True) -> nx.DiGraph:
    """The DiGraph of *case*'s execute entries (edges pred → succ, in file order), each node's entry
    in its ``entry`` attribute; without *attributes*, each node's attribute dict is empty.

    :func:`~btgen_pytrees.construct.generate` walks a graph of its own and takes the
    entries from the case: an empty dict is one object the garbage collector does not
    track, ``{"entry": e}`` one it tracks - on a 100,000-entry timeline, 100,000 fewer
    objects for each of its full collections to walk while the tree is built.
    """
    graph = nx.DiGraph(name=case.name)
    # What add_nodes_from/add_edges_from build (the same dicts, in the same order), written straight
    # into the graph's adjacency dicts: per node, networkx's generic path raises and catches a
    # TypeError (an (id, attributes) pair is unhashable) and copies the attributes twice; per edge it
    # looks the edge up and updates two dicts. On a 100,000-entry chain that was most of this function.
    entries = case.entries
    nodes, succ, pred = graph._node, graph._succ, graph._pred
    nodes.update({e.id: {"entry": e} for e in entries} if attributes else {e.id: {} for e in entries})
    succ.update({e.id: {} for e in entries})
    pred.update({e.id: {} for e in entries})
    for e in entries:
        if e.after:
            v = e.id
            into = pred[v]
            for p in e.after:
                if p not in succ:  # not an entry of the case (a hand-made TestCase): a bare node, as networkx adds
                    nodes[p], succ[p], pred[p] = {}, {}, {}
                into[p] = succ[p][v] = {}  # one (empty) attribute dict per edge, shared by both directions
    return graph


def topological_order(graph: nx.DiGraph) -> list[str]:
    """A topological order that breaks ties by file order (so it is deterministic).

    The order of ``nx.lexicographical_topological_sort(graph, key=file index)``
    - Kahn's algorithm always taking the earliest entry (in file order) whose
    predecessors are all placed - computed over the graph's adjacency dicts
    rather than its views. When every edge goes forward in file order (an entry
    names only entries above it: the usual case) that order is the file order
    itself, found in one linear pass; otherwise a heap of file indices gives it
    in O((n + e) log n).

    Raises:
        networkx.NetworkXUnfeasible: the graph has a cycle
    """
    found = order(graph._pred, graph._succ)  # the adjacency dicts networkx's views wrap: no view objects
    if found is None:
        raise nx.NetworkXUnfeasible("the timeline has a cycle")
    return found


def topological_positions(graph: nx.DiGraph) -> dict[str, int]:
    """Each node's place in :func:`topological_order` (the file index when that is the file order).

    Raises:
        networkx.NetworkXUnfeasible: the graph has a cycle
    """
    found = positions(graph._pred, graph._succ)
    if found is None:
        raise nx.NetworkXUnfeasible("the timeline has a cycle")
    return found


def adjacency_matrix(graph: nx.DiGraph) -> list[list[int]]:
    """The dense 0/1 matrix, rows and columns in file order. O(n²): for display only."""
    return list(_rows(graph))


def _rows(graph: nx.DiGraph) -> Iterator[list[int]]:
    nodes = list(graph)
    for v in nodes:
        succ = graph.succ[v]
        yield [1 if w in succ else 0 for w in nodes]


DENSE_LIMIT = 200
"""Largest timeline whose matrix is printed as a dense table; larger ones print sparse rows."""


def matrix_text(graph: nx.DiGraph, dense_limit: int = DENSE_LIMIT) -> str:
    """The paper's figure-2 table: a header row of ids, then one row per entry.

    Beyond *dense_limit* entries the n×n table would be unreadable (and, at
    10,000 entries, gigabytes), so each row is printed sparsely instead: the
    entry, then the columns holding a 1 (``B1: C1 B2``).
    """
    return "".join(matrix_lines(graph, dense_limit))


def matrix_lines(graph: nx.DiGraph, dense_limit: int = DENSE_LIMIT) -> Iterator[str]:
    """:func:`matrix_text` one line at a time (each with its ``\\n``), for writing it as it is made."""
    nodes = list(graph)
    if len(nodes) > dense_limit:
        yield f"# adjacency matrix of {len(nodes)} entries, sparse rows: ENTRY: successors (columns holding 1)\n"
        for v in nodes:
            yield f"{v}: {' '.join(graph.succ[v])}".rstrip() + "\n"
        return
    width = max([len(v) for v in nodes] + [1])
    yield " " * width + " " + " ".join(v.rjust(width) for v in nodes) + "\n"
    for v, row in zip(nodes, _rows(graph)):
        yield v.ljust(width) + " " + " ".join(str(x).rjust(width) for x in row) + "\n"
