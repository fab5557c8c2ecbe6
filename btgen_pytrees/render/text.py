"""Text views of a generated tree: py_trees' symbols, plus what review needs.

py_trees' own :func:`py_trees.display.unicode_tree` shows names and statuses but
not a Parallel's policy, its selected children or what a trigger waits for.
These views draw the same symbols (``/_/`` parallel, ``{-}`` sequence with
memory, ``-^-`` decorator, ``-->`` leaf) and add that detail after each name.
"""

from __future__ import annotations

from typing import Iterator

import py_trees

from ..errors import plural
from .nodes import annotation, symbol, walk
from .stream import chunked

__all__ = ["text_tree", "iter_text_tree"]


def iter_text_tree(root: py_trees.behaviour.Behaviour, *, unicode: bool = True, max_depth: int | None = None) -> Iterator[str]:
    """Render *root* as indented text, as chunks of whole lines (see :mod:`.stream`).

    The first chunk is out after about :data:`~.stream.CHUNK_CHARS` characters'
    worth of nodes, before the rest of the tree is walked; ``"".join`` of the
    chunks is :func:`text_tree`.

    Args:
        unicode: use unicode punctuation (``·``, ``…``); ASCII only when False
        max_depth: show nodes down to this depth (root = 0); deeper ones are
            summarised as ``... N more nodes``
    """
    return chunked(_lines(root, unicode, max_depth))


def text_tree(root: py_trees.behaviour.Behaviour, *, unicode: bool = True, max_depth: int | None = None) -> str:
    """The whole of :func:`iter_text_tree` as one string."""
    return "".join(iter_text_tree(root, unicode=unicode, max_depth=max_depth))


def _lines(root: py_trees.behaviour.Behaviour, unicode: bool, max_depth: int | None) -> Iterator[str]:
    """Each line of the view, with its ``\\n``."""
    sep = " · " if unicode else " - "
    ellipsis = "…" if unicode else "..."
    hidden = 0
    for depth, node in walk(root):
        if max_depth is not None and depth > max_depth:
            hidden += 1
            continue
        if hidden:
            yield f"{'    ' * ((max_depth or 0) + 1)}{ellipsis} {plural(hidden, 'more node')}\n"
            hidden = 0
        note = annotation(node)
        line = f"{'    ' * depth}{symbol(node)} {node.name}" + (f"{sep}{note}" if note else "") + "\n"
        yield line if unicode else line.encode("ascii", "replace").decode("ascii")
    if hidden:
        yield f"{'    ' * ((max_depth or 0) + 1)}{ellipsis} {plural(hidden, 'more node')}\n"
