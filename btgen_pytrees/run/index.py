"""A tree's nodes numbered in pre-order, once per run, for the visitors that follow it.

The two visitors of a run - the :class:`~btgen_pytrees.run.Collector` and the
:class:`~btgen_pytrees.run.trace.TraceRecorder` - keep what they know about
each node in flat arrays indexed by the node's pre-order number (root = 0, the
order of :func:`~btgen_pytrees.render.nodes.walk`), so both need the number of
every node a tick yields. That look-up is on the hot path of every tick: a dict
keyed by ``id()`` works, but with a few hundred thousand nodes its slots are
scattered over tens of megabytes and every look-up misses the processor's
caches (a 100k-entry fan-in ran 1.5 x slower than bare ticking for that alone).
So each indexed node also carries its number as the attribute ``btgen_index``,
read from the node the tick has just touched anyway. The attribute is only a
hint: :meth:`TreeIndex.number` accepts it only if this index's own list has
that very node at that place, so a node moved since, one that carries another
tree's number, or one that cannot take attributes is found through the
``id()`` table instead (built when first needed).

>>> import py_trees
>>> a, b = py_trees.behaviours.Success("a"), py_trees.behaviours.Success("b")
>>> root = py_trees.composites.Sequence("root", memory=True, children=[a, b])
>>> index = TreeIndex(root)
>>> [node.name for node in index.nodes], index.number(b), index.ends, index.tagged
(['root', 'a', 'b'], 2, [3, 2, 3], [])
"""

from __future__ import annotations

from typing import Any

import py_trees

__all__ = ["TreeIndex"]


class TreeIndex:
    """The nodes under *root* in pre-order, with the subtree each one spans.

    Attributes:
        nodes: the behaviours, in pre-order (root = 0)
        ends: for node *i*, one past the number of the last node of its subtree
            (so its subtree is ``range(i, ends[i])``)
        composites: the numbers of the nodes that have children, in pre-order
        tagged: the numbers of the nodes tagged with an execute entry or an
            oracle criterion (``btgen_entry``, ``btgen_criterion``), in pre-order
        entries, criteria: node number -> the ``btgen_entry`` / ``btgen_criterion`` a tagged
            node carries (read once here, for every visitor of the run)
    """

    def __init__(self, root: py_trees.behaviour.Behaviour):
        nodes: list[py_trees.behaviour.Behaviour] = []
        composites: list[int] = []
        tagged: list[int] = []
        entries: dict[int, Any] = {}
        criteria: dict[int, Any] = {}
        numbered = True  # every node took its number so far
        stack = [root]
        while stack:  # pre-order, without recursion (a chain of 100k entries is 100k levels deep)
            node = stack.pop()
            i = len(nodes)
            children = node.children
            if children:
                composites.append(i)
                stack.extend(reversed(children))
            # getattr, not node.__dict__: reading __dict__ makes every node build a dict of its own
            entry, criterion = getattr(node, "btgen_entry", None), getattr(node, "btgen_criterion", None)
            if entry is not None or criterion is not None:
                tagged.append(i)
                if entry is not None:
                    entries[i] = entry
                if criterion is not None:
                    criteria[i] = criterion
            try:
                node.btgen_index = i  # type: ignore[attr-defined]
            except AttributeError:  # a node that takes no attributes: found through the id() table
                numbered = False
            nodes.append(node)
        ends = list(range(1, len(nodes) + 1))
        for i in reversed(composites):  # last to first: a composite's children are done before it
            j = i + 1  # its first child; each next one follows the subtree of the one before
            for _ in range(len(nodes[i].children) - 1):
                j = ends[j]
            ends[i] = ends[j]
        self.nodes = nodes
        self.ends = ends
        self.composites = composites
        self.tagged = tagged
        self.entries = entries
        self.criteria = criteria
        self._ids: dict[int, int] | None = None if numbered else self._table()

    def _table(self) -> dict[int, int]:
        return {id(node): i for i, node in enumerate(self.nodes)}

    def __len__(self) -> int:
        return len(self.nodes)

    def number(self, node: py_trees.behaviour.Behaviour) -> int | None:
        """*node*'s pre-order number, or ``None`` if it is not in the indexed tree."""
        i = getattr(node, "btgen_index", None)
        if type(i) is int and 0 <= i < len(self.nodes) and self.nodes[i] is node:
            return i
        if self._ids is None:
            self._ids = self._table()
        return self._ids.get(id(node))
