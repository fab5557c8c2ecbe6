"""Text views of a generated tree: py_trees' symbols, plus what review needs.

py_trees' own :func:`py_trees.display.unicode_tree` shows names and statuses but
not a Parallel's policy, its selected children or what a trigger waits for.
These views draw the same symbols (``/_/`` parallel, ``{-}`` sequence with
memory, ``-^-`` decorator, ``-->`` leaf) and add that detail after each name.
"""

from __future__ import annotations

import py_trees

from .info import annotation, symbol, walk

__all__ = ["text_tree"]


def text_tree(root: py_trees.behaviour.Behaviour, *, unicode: bool = True, max_depth: int | None = None) -> str:
    """Render *root* as indented text.

    Args:
        unicode: use unicode punctuation (``·``, ``…``); ASCII only when False
        max_depth: show nodes down to this depth (root = 0); deeper ones are
            summarised as ``... N more nodes``
    """
    sep = " · " if unicode else " - "
    ellipsis = "…" if unicode else "..."
    lines = []
    hidden = 0
    for depth, node in walk(root):
        if max_depth is not None and depth > max_depth:
            hidden += 1
            continue
        if hidden:
            lines.append(f"{'    ' * ((max_depth or 0) + 1)}{ellipsis} {hidden} more nodes")
            hidden = 0
        note = annotation(node)
        line = f"{'    ' * depth}{symbol(node)} {node.name}" + (f"{sep}{note}" if note else "")
        lines.append(line if unicode else line.encode("ascii", "replace").decode("ascii"))
    if hidden:
        lines.append(f"{'    ' * ((max_depth or 0) + 1)}{ellipsis} {hidden} more nodes")
    return "\n".join(lines) + "\n"
