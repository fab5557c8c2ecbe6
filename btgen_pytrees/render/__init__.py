"""Views of a generated tree for review: text, JSON, the adjacency matrix, Graphviz, BT.CPP XML.

:func:`render` is the single entry point the CLI uses; each format lives in its
own module. ``svg`` and ``png`` need Graphviz's ``dot`` program
(:class:`~.dot.GraphvizMissing` otherwise); ``png`` is the only format that
returns bytes.
"""

from __future__ import annotations

import json
from typing import Any, Callable

import networkx as nx
import py_trees

from ..timeline import matrix_text
from .btcpp import format_btcpp
from .dot import GraphvizMissing, format_dot, format_png, format_svg
from .info import node_info, walk
from .text import text_tree

__all__ = ["render", "tree_data", "FORMATS", "JSON_INDENT_LIMIT", "text_tree", "node_info", "GraphvizMissing"]


def tree_data(root: py_trees.behaviour.Behaviour) -> dict[str, Any]:
    """The tree as nested data: :func:`~.info.node_info` plus ``children`` (built without recursion)."""
    made: dict[int, dict[str, Any]] = {}
    top: dict[str, Any] = {}
    for _, node in walk(root):
        info = node_info(node)
        info["children"] = []
        made[id(node)] = info
        parent = made.get(id(node.parent)) if node is not root else None
        if parent is None:
            top = info
        else:
            parent["children"].append(info)
    return top


JSON_INDENT_LIMIT = 2_000
"""Largest tree (in nodes) whose JSON view is indented by default.

Indentation grows with depth (each tree level nests an object in a
``children`` list: four more spaces), so an indented 10,000-entry comb, 100
levels deep, is 48 MB of mostly spaces (2.4 MB compact). Larger trees are written compact
(no spaces, one line); ``indent=`` chooses either way.
"""


def _json(root: py_trees.behaviour.Behaviour, graph: nx.DiGraph, indent: int | None | str = "auto", **_: Any) -> str:
    data = tree_data(root)
    if indent == "auto":
        indent = 2 if sum(1 for _ in walk(root)) <= JSON_INDENT_LIMIT else None
    if indent is None:
        return json.dumps(data, separators=(",", ":"), ensure_ascii=False, allow_nan=False) + "\n"
    return json.dumps(data, indent=indent, ensure_ascii=False, allow_nan=False) + "\n"


def _matrix(root: py_trees.behaviour.Behaviour, graph: nx.DiGraph, **_: Any) -> str:
    return matrix_text(graph)


def _unicode(root: py_trees.behaviour.Behaviour, graph: nx.DiGraph, max_depth: int | None = None, **_: Any) -> str:
    return text_tree(root, unicode=True, max_depth=max_depth)


def _ascii(root: py_trees.behaviour.Behaviour, graph: nx.DiGraph, max_depth: int | None = None, **_: Any) -> str:
    return text_tree(root, unicode=False, max_depth=max_depth)


FORMATS: dict[str, Callable[..., str | bytes]] = {
    "unicode": _unicode, "ascii": _ascii, "json": _json, "matrix": _matrix,
    "dot": format_dot, "svg": format_svg, "png": format_png, "btcpp": format_btcpp,
}  # fmt: skip


def render(root: py_trees.behaviour.Behaviour, graph: nx.DiGraph, fmt: str, **options: Any) -> str | bytes:
    """Render *root* (generated from the timeline *graph*) in format *fmt* (a key of :data:`FORMATS`)."""
    return FORMATS[fmt](root, graph, **options)
