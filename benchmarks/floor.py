"""The construction floor: the same tree built from plain py_trees classes.

A generator cannot be cheaper than instantiating the nodes it emits, so the
benchmark divides each generation time by the time py_trees itself needs to
build a tree of the same size and shape. :func:`capture` records the generated
tree as a post-order list of ``(kind, name, number of children)``;
:func:`build` replays it with the cheapest stock class of each kind:

======================  ======================================================
generated node          floor node
======================  ======================================================
``Sequence``            ``Sequence(name, memory=True)``
``Parallel``            ``Parallel(name, SuccessOnAll(synchronise=True))``
other composites        ``Selector(name, memory=False)``
any ``Decorator``       ``decorators.PassThrough``
any other behaviour     ``behaviours.Success``
======================  ======================================================

Names are kept (pre-made strings, so the floor pays for none of the
generator's formatting) because py_trees builds a logger and a qualified name
from each. Both walks are iterative: the benchmark must report a deep tree, not
die on the recursion limit while measuring it.
"""

from __future__ import annotations

from collections import Counter
from typing import NamedTuple

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.composites import Composite, Parallel, Selector, Sequence

__all__ = ["KINDS", "Shape", "capture", "build", "count", "depth"]

KINDS = ("sequence", "parallel", "composite", "decorator", "leaf")
"""Node kinds, in the order the benchmark reports their counts."""


class Shape(NamedTuple):
    """A tree's nodes in post-order: ``(kind, name, child count)``, root last."""

    nodes: list[tuple[str, str, int]]

    def counts(self) -> dict[str, int]:
        """How many nodes of each kind (every kind of :data:`KINDS` present, possibly 0)."""
        found = Counter(kind for kind, _, _ in self.nodes)
        return {kind: found.get(kind, 0) for kind in KINDS}

    def __len__(self) -> int:
        return len(self.nodes)


def _kind(node: Behaviour) -> str:
    if isinstance(node, Sequence):
        return "sequence"
    if isinstance(node, Parallel):
        return "parallel"
    if isinstance(node, Composite):
        return "composite"
    if isinstance(node, py_trees.decorators.Decorator):
        return "decorator"
    return "leaf"


def capture(root: Behaviour) -> Shape:
    """Record *root*'s tree as a :class:`Shape` (iteratively, any depth)."""
    out: list[tuple[str, str, int]] = []
    stack: list[tuple[Behaviour, bool]] = [(root, False)]
    while stack:
        node, expanded = stack.pop()
        if expanded:
            out.append((_kind(node), node.name, len(node.children)))
            continue
        stack.append((node, True))
        stack.extend((child, False) for child in reversed(node.children))
    return Shape(out)


def build(shape: Shape) -> Behaviour:
    """Instantiate *shape* with stock py_trees classes; return the root."""
    built: list[Behaviour] = []
    all_policy = py_trees.common.ParallelPolicy.SuccessOnAll
    for kind, name, n_children in shape.nodes:
        if n_children:
            children = built[-n_children:]
            del built[-n_children:]
        else:
            children = []
        node: Behaviour
        if kind == "leaf":
            node = py_trees.behaviours.Success(name)
        elif kind == "decorator":
            node = py_trees.decorators.PassThrough(name=name, child=children[0])
        elif kind == "sequence":
            node = Sequence(name, memory=True, children=children)
        elif kind == "parallel":
            node = Parallel(name, all_policy(synchronise=True), children)
        else:
            node = Selector(name, memory=False, children=children)
        built.append(node)
    if len(built) != 1:
        raise ValueError(f"shape does not describe one tree ({len(built)} roots left)")
    return built[0]


def count(root: Behaviour) -> int:
    """Number of nodes under *root*, inclusive (iteratively)."""
    total, stack = 0, [root]
    while stack:
        node = stack.pop()
        total += 1
        stack.extend(node.children)
    return total


def depth(root: Behaviour) -> int:
    """Levels of *root*'s tree (the root alone is 1)."""
    deepest, stack = 0, [(root, 1)]
    while stack:
        node, level = stack.pop()
        deepest = max(deepest, level)
        stack.extend((child, level + 1) for child in node.children)
    return deepest
