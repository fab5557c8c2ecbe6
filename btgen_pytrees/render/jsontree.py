"""The JSON view, written node by node.

``json.dumps(tree_data(root))`` would first build a dict per node (more memory
than the text it becomes) and then one string of the whole tree. This view
encodes each node's :func:`~.nodes.node_info` on its own and writes the
``children`` brackets around them while it walks the tree, so what it holds is
the path from the root to the current node, and its output is byte for byte
what ``json.dumps`` gives for :func:`tree_data` with the same options (a test
checks that on random trees). Each node's own fields still go through
``json.dumps``: strings are escaped exactly as the standard encoder does.
"""

from __future__ import annotations

import itertools
import json
from typing import Any, Iterator

import py_trees

from .nodes import node_info, walk
from .stream import chunked

__all__ = ["iter_json_tree", "tree_data", "JSON_INDENT_LIMIT", "auto_indent"]

JSON_INDENT_LIMIT = 2_000
"""Largest tree (in nodes) whose JSON view is indented by default.

Indentation grows with depth (each tree level nests an object in a
``children`` list: four more spaces), so an indented 10,000-entry comb, 100
levels deep, is 48 MB of mostly spaces (2.4 MB compact). Larger trees are written compact
(no spaces, one line); ``indent=`` chooses either way.
"""


def tree_data(root: py_trees.behaviour.Behaviour) -> dict[str, Any]:
    """The tree as nested data: :func:`~.nodes.node_info` plus ``children`` (built without recursion)."""
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


def auto_indent(root: py_trees.behaviour.Behaviour) -> int | None:
    """The default indentation: 2 up to :data:`JSON_INDENT_LIMIT` nodes, else None (compact).

    Counts at most one node past the limit, so a large tree's view does not wait for a full walk.
    """
    return 2 if sum(1 for _ in itertools.islice(walk(root), JSON_INDENT_LIMIT + 1)) <= JSON_INDENT_LIMIT else None


def iter_json_tree(root: py_trees.behaviour.Behaviour, indent: int | None | str = "auto") -> Iterator[str]:
    """:func:`tree_data` of *root* as JSON text in chunks (see :mod:`.stream`), ending in a newline.

    Args:
        indent: spaces per level (0: one key per line, no spaces), None for
            compact JSON (no spaces, one line), or ``"auto"``: :func:`auto_indent`
    """
    return chunked(_pieces(root, indent))




def _pieces(root: py_trees.behaviour.Behaviour, indent: int | None | str) -> Iterator[str]:
    if indent == "auto":
        indent = auto_indent(root)
    if indent is None:
        yield from _walk(root, _Compact())
    elif isinstance(indent, int) and not isinstance(indent, bool) and indent >= 0:
        yield from _walk(root, _Indented(indent))
    else:
        raise ValueError(f"indent must be a whole number >= 0, None or 'auto', not {indent!r}")
    yield "\n"


class _Compact:
    """The pieces of ``json.dumps(..., separators=(",", ":"))``."""

    def __init__(self) -> None:
        self.encode = json.JSONEncoder(separators=(",", ":"), ensure_ascii=False, allow_nan=False).encode

    def head(self, node: py_trees.behaviour.Behaviour, depth: int) -> str:
        return self.encode(node_info(node))[:-1]  # without its '}': the children follow

    def opened(self, depth: int) -> str:
        return ',"children":['

    def empty(self, depth: int) -> str:
        return ',"children":[]}'

    def between(self, depth: int) -> str:
        return ","

    def closed(self, depth: int) -> str:
        return "]}"


class _Indented:
    """The pieces of ``json.dumps(..., indent=indent)``.

    A node at tree depth d is an object at nesting level 2d (its ``children``
    list at 2d+1, the children's objects at 2d+2), and every line of it is
    indented by that level.
    """

    def __init__(self, indent: int) -> None:
        self.encode = json.JSONEncoder(indent=indent, ensure_ascii=False, allow_nan=False).encode
        self.pad = " " * indent

    def nl(self, level: int) -> str:
        return "\n" + self.pad * level

    def head(self, node: py_trees.behaviour.Behaviour, depth: int) -> str:
        text = self.encode(node_info(node))  # at level 0, ending NL '}'; JSON strings hold no raw newline
        end = self.nl(2 * depth)
        if depth:
            text = text.replace("\n", end)
        return text[: -len(end) - 1]  # without its last line, '}': the children follow

    def opened(self, depth: int) -> str:
        return "," + self.nl(2 * depth + 1) + '"children": [' + self.nl(2 * depth + 2)

    def empty(self, depth: int) -> str:
        return "," + self.nl(2 * depth + 1) + '"children": []' + self.nl(2 * depth) + "}"

    def between(self, depth: int) -> str:
        return "," + self.nl(2 * depth)

    def closed(self, depth: int) -> str:
        return self.nl(2 * depth + 1) + "]" + self.nl(2 * depth) + "}"


def _walk(root: py_trees.behaviour.Behaviour, style: _Compact | _Indented) -> Iterator[str]:
    """Pre-order pieces: each node's head, then its children between ``opened`` and ``closed``, or ``empty``."""
    yield style.head(root, 0)
    if not root.children:
        yield style.empty(0)
        return
    yield style.opened(0)
    stack: list[tuple[int, Iterator[py_trees.behaviour.Behaviour]]] = [(0, iter(root.children))]
    first = True
    while stack:
        depth, children = stack[-1]
        child = next(children, None)
        if child is None:
            stack.pop()
            yield style.closed(depth)
            first = False
            continue
        if not first:
            yield style.between(depth + 1)
        yield style.head(child, depth + 1)
        if child.children:
            yield style.opened(depth + 1)
            stack.append((depth + 1, iter(child.children)))
            first = True
        else:
            yield style.empty(depth + 1)
            first = False
