"""Views of a generated tree for review: text, JSON, the adjacency matrix, Graphviz, BT.CPP XML.

:func:`render` is the single entry point the CLI uses; each format lives in its
own module. ``svg`` and ``png`` need Graphviz's ``dot`` program
(:class:`~.dot.GraphvizMissing` otherwise); ``png`` is the only format that
returns bytes. :func:`render_chunks` gives the same output as a stream of
chunks: the text views (``unicode``, ``ascii``, ``json``, ``matrix``) are drawn
while they are written (see :mod:`.stream`), the others come as one chunk.
"""

from __future__ import annotations

from typing import Any, Callable, Iterator

import networkx as nx
import py_trees

from ..timeline import matrix_lines
from .btcpp import format_btcpp
from .dot import GraphvizMissing, format_dot, format_png, format_svg
from .nodes import node_info
from .jsontree import JSON_INDENT_LIMIT, iter_json_tree, tree_data
from .stream import chunked
from .text import iter_text_tree, text_tree

__all__ = ["render", "render_chunks", "tree_data", "FORMATS", "STREAMED", "JSON_INDENT_LIMIT", "text_tree",
           "iter_text_tree", "iter_json_tree", "node_info", "GraphvizMissing"]  # fmt: skip


def _json(root: py_trees.behaviour.Behaviour, graph: nx.DiGraph, indent: int | None | str = "auto", **_: Any) -> Iterator[str]:
    return iter_json_tree(root, indent)


def _matrix(root: py_trees.behaviour.Behaviour, graph: nx.DiGraph, **_: Any) -> Iterator[str]:
    return chunked(matrix_lines(graph))


def _unicode(root: py_trees.behaviour.Behaviour, graph: nx.DiGraph, max_depth: int | None = None, **_: Any) -> Iterator[str]:
    return iter_text_tree(root, unicode=True, max_depth=max_depth)


def _ascii(root: py_trees.behaviour.Behaviour, graph: nx.DiGraph, max_depth: int | None = None, **_: Any) -> Iterator[str]:
    return iter_text_tree(root, unicode=False, max_depth=max_depth)


STREAMED: dict[str, Callable[..., Iterator[str]]] = {"unicode": _unicode, "ascii": _ascii, "json": _json, "matrix": _matrix}
"""The formats drawn as a stream of chunks, each a function ``(root, graph, **options) -> chunks``."""


def _joined(view: Callable[..., Iterator[str]]) -> Callable[..., str]:
    def whole(root: py_trees.behaviour.Behaviour, graph: nx.DiGraph, **options: Any) -> str:
        return "".join(view(root, graph, **options))

    whole.__name__ = whole.__qualname__ = view.__name__
    whole.__doc__ = view.__doc__
    return whole


FORMATS: dict[str, Callable[..., str | bytes]] = {
    **{fmt: _joined(view) for fmt, view in STREAMED.items()},
    "dot": format_dot, "svg": format_svg, "png": format_png, "btcpp": format_btcpp,
}  # fmt: skip
"""Every format, each a function ``(root, graph, **options) -> str | bytes`` giving the whole output."""


def render(root: py_trees.behaviour.Behaviour, graph: nx.DiGraph, fmt: str, **options: Any) -> str | bytes:
    """Render *root* (generated from the timeline *graph*) in format *fmt* (a key of :data:`FORMATS`)."""
    return FORMATS[fmt](root, graph, **options)


def render_chunks(root: py_trees.behaviour.Behaviour, graph: nx.DiGraph, fmt: str, **options: Any) -> Iterator[str | bytes]:
    """:func:`render` as chunks whose concatenation is its result.

    A streamed format (:data:`STREAMED`) draws its chunks as they are taken,
    so a writer can put each out before the next is made; any other format is
    rendered here, whole (a missing Graphviz raises now, not while writing),
    and comes as one chunk.
    """
    if fmt in STREAMED:
        return STREAMED[fmt](root, graph, **options)
    return iter([FORMATS[fmt](root, graph, **options)])
