"""Algorithm 1: the execute subtree, from the timeline graph.

The paper walks the adjacency matrix twice. Here both walks go through the
graph's sparse adjacency, so the cost is linear in entries + edges:

* **columns** (predecessors): an entry with several predecessors is a *join*.
  It gets a virtual :class:`~btgen_pytrees.leaves.wiring.Trigger` and starts a
  ``Sequence(trigger, entry, ...)`` directly under the execute root Parallel.
  Its predecessors are wrapped in a
  :class:`~btgen_pytrees.leaves.wiring.Completion` that marks them done on the
  blackboard, which is what the trigger waits for.
* **rows** (successors): an entry's successors that have no other predecessor
  continue its Sequence. One such successor is appended to the same Sequence
  (the paper: "add it to the parent, because the parent is a Sequence"); several
  go under a ``Parallel(SuccessOnAll)`` whose children are their Sequences.
* entries without predecessors start together under the ``roots`` Parallel of
  the ``begin`` Sequence, after the :class:`~btgen_pytrees.leaves.wiring.RunStart`
  leaf.

Depth is bounded: where nesting one more fork would make the tree deeper than
:data:`MAX_DEPTH`, the fork is *hoisted* to the execute root behind a
single-predecessor trigger instead. What runs when does not change (a trigger
placed after its predecessor in tick order fires on the same tick), but
py_trees' recursive tick stays far from Python's recursion limit.

Sequences have ``memory=True`` so a finished leaf is never ticked again;
Parallels are ``SuccessOnAll(synchronise=True)`` so a finished branch is skipped
while its siblings run. Children of the execute root are ordered topologically
by their first entry, so every trigger is ticked after its predecessors. The
execute root is a :class:`~btgen_pytrees.leaves.wiring.WakingParallel`: it ticks
a head only once one of its trigger's predecessors is marked done, so a tick
costs what is active, not what waits.
"""

from __future__ import annotations

import heapq
from functools import cached_property
from typing import Any, Mapping

import networkx as nx
import py_trees

from ..leaves import Environment, Registry
from ..leaves.composites import Parallel, Sequence
from ..leaves.control import controlled
from ..leaves.wiring import Completion, Cuttable, CutTrigger, RunStart, Trigger, WakingParallel
from ..model import Entry
from ..timeline import topological_positions

__all__ = ["execute_subtree", "walk_consuming", "MAX_DEPTH", "EXECUTE_DEPTH"]

MAX_DEPTH = 100
"""Deepest level any generated node may sit at (the generated root is level 1)."""

CHUNK = 256
"""Most children of one Sequence; longer chains are split into parts (see :class:`_ChainWriter`)."""

EXECUTE_DEPTH = 3
"""Level of the execute Parallel: root Parallel → Completion(execute) → execute."""


def _all() -> py_trees.common.ParallelPolicy.Base:
    return py_trees.common.ParallelPolicy.SuccessOnAll(synchronise=True)


class _ChainWriter:
    """Appends a chain's nodes to its Sequence, in parts of :data:`CHUNK` once it grows long.

    py_trees' memory Sequence finds its running child with ``list.index`` on every
    tick, so one Sequence of 100,000 leaves costs 50,000 comparisons a tick. A long
    chain is therefore split: its Sequence holds part Sequences of at most
    :data:`CHUNK` nodes each, one level deeper. Order and memory semantics are the
    same; only chains longer than :data:`CHUNK` change shape.
    """

    def __init__(self, seq: Sequence, level: int):
        self.top = seq
        self.part: Sequence | None = None
        self.parts = 0
        self.top_level = level

    @property
    def level(self) -> int:
        """Level of the Sequence the next node goes into."""
        full = self.part is None and len(self.top.children) >= CHUNK
        return self.top_level + (0 if self.part is None and not full else 1)

    def add(self, node: py_trees.behaviour.Behaviour) -> int:
        """Append *node*; return the level of the Sequence it went into."""
        if self.part is None and len(self.top.children) < CHUNK:
            self.top.append_child(node)
            return self.top_level
        if self.part is None:  # first overflow: move what is there into part 1
            moved = list(self.top.children)
            self.top.remove_all_children()
            self.part = self._new_part()
            for moved_node in moved:
                self.part.append_child(moved_node)
        if len(self.part.children) >= CHUNK:
            self.part = self._new_part()
        self.part.append_child(node)
        return self.top_level + 1

    def _new_part(self) -> Sequence:
        self.parts += 1
        part = Sequence(f"{self.top.name} part {self.parts}", memory=True)
        self.top.add_child(part)
        return part


class _Walk:
    """One run of Algorithm 1 over a graph.

    The walk reads the graph's adjacency dicts (``graph._succ``, ``graph._pred``,
    ``graph._node``: what ``graph.succ``, ``graph.pred`` and ``graph.nodes`` wrap)
    directly: every view lookup builds an object, and on a 100,000-entry
    timeline those lookups and ``nx.lexicographical_topological_sort`` were
    about a quarter of generation. In-degrees are ``len(pred[v])``; which
    entries a trigger waits for is decided where the row walk reaches them.
    """

    def __init__(self, graph: nx.DiGraph, env: Environment, registry: Registry, depth: int, max_depth: int,
                 consume: bool = False, entries: Mapping[str, Entry] | None = None):  # fmt: skip
        self.consume = consume
        self.succ: dict[str, dict[str, Any]] = graph._succ
        self.pred: dict[str, dict[str, Any]] = graph._pred
        self.nodes: dict[str, dict[str, Any]] = graph._node
        # each node's Entry: from its 'entry' attribute, or given (generate's own graph carries no attributes)
        self.entry_of: Mapping[str, Entry] = entries if entries is not None else {v: a["entry"] for v, a in graph._node.items()}
        self.env = env
        self.registry = registry
        self.depth = depth
        self.max_depth = max_depth
        self.graph = graph
        # the control-flow keys (docs/algorithms.md#control-flow): each controlled entry is built with its nodes
        # (up to five levels above its leaf); with stops or races each branch is Cuttable (one level more)
        self.build_entry = registry.build
        self.cuttable = False
        self.extra = 0
        self.rivals: dict[str, tuple[str, ...]] = {}
        control = [e for e in self.entry_of.values() if e.control is not None]
        if control:
            races: dict[str, list[str]] = {}
            for e in control:
                if e.control.race is not None:  # type: ignore[union-attr]
                    races.setdefault(e.control.race, []).append(e.id)  # type: ignore[union-attr]
            self.rivals = {m: tuple(x for x in members if x != m) for members in races.values() for m in members}
            self.cuttable = bool(races) or any(e.control.stops for e in control)  # type: ignore[union-attr]
            self.build_entry = self.controlled_entry
            self.extra = 5 + self.cuttable
        joins = [(v, p) for v, p in self.pred.items() if len(p) > 1]
        if joins or not consume or any(len(s) > 1 for s in self.succ.values()):
            # the order (and the cycle check) before anything is built; without joins and forks
            # (a chain) no order is ever read, and build() finds a cycle by the entries it did not reach
            self.position  # noqa: B018
        # column walk: (topological position, first entry, predecessors, join, hoisted fork's entry or "")
        entry_of = self.entry_of
        self.heads: list[tuple[int, str, tuple[str, ...], str, str]] = [
            (self.position[v], v, tuple(p), entry_of[v].join, "") for v, p in joins
        ]
        heapq.heapify(self.heads)

    @cached_property
    def position(self) -> dict[str, int]:
        """Each entry's place in the topological order (raises NetworkXUnfeasible on a cycle)."""
        return topological_positions(self.graph)

    def leaf(self, v: str, wrap: bool) -> py_trees.behaviour.Behaviour:
        node = self.build_entry(self.entry_of[v], self.env)
        return Completion(node, self.env, marks=v) if wrap else node

    def controlled_entry(self, entry: Entry, env: Environment) -> py_trees.behaviour.Behaviour:
        """The entry's leaf, inside the nodes of its control keys when it has some."""
        node = self.registry.build(entry, env)
        if entry.control is None:
            return node
        return controlled(node, entry, env, self.rivals.get(entry.id, ()))

    def branch(self, seq: Sequence) -> py_trees.behaviour.Behaviour:
        """A branch's Sequence as its Parallel holds it: inside a :class:`Cuttable` when entries can be stopped."""
        return Cuttable(seq, self.env) if self.cuttable else seq

    def chain(self, seq: Sequence, first: str, level: int, *, fork_of: str | None = None) -> None:
        """Row walk from *first*, filling *seq* (which sits at *level*).

        With *fork_of*, *seq* holds a hoisted fork instead: the branches that
        follow *fork_of* (whose leaf is elsewhere), under one Parallel.
        """
        stack: list[tuple[Sequence, str, int]] = []
        if fork_of is not None:
            self.fork(_ChainWriter(seq, level), fork_of, self.singles(fork_of), stack)
            if self.consume:
                del self.succ[fork_of]
        else:
            stack.append((seq, first, level))
        succ, pred, nodes, entry_of, consume = self.succ, self.pred, self.nodes, self.entry_of, self.consume
        build, env = self.build_entry, self.env
        while stack:
            seq, v, level = stack.pop()
            out = _ChainWriter(seq, level)
            while True:
                successors = succ[v]
                if len(successors) == 1:  # the usual step, without the lists singles() builds
                    (s,) = successors
                    if len(pred[s]) == 1:  # s continues v's Sequence: no fork, no hoist, no Completion
                        out.add(build(entry_of[v], env))
                        if consume:  # what drop() does, inline
                            del nodes[v], succ[v]
                            if len(pred[v]) < 2:
                                del pred[v]
                        v = s
                        continue
                singles = self.singles(v) if successors else []
                # fork Parallel, branch Sequence, part Sequence (a branch longer than CHUNK),
                # Completion, leaf: up to five more levels
                hoist = len(singles) > 1 and out.level + 5 + self.extra > self.max_depth
                # a successor with other predecessors is a join, whose trigger waits for v
                out.add(self.leaf(v, wrap=hoist or len(singles) != len(successors)))
                if consume:  # v's leaf and row are done: drop them from the graph (a hoisted fork reads its row later)
                    self.drop(v)
                    if not hoist:
                        del succ[v]
                if not singles:
                    break
                if hoist:
                    position = min(self.position[s] for s in singles)
                    heapq.heappush(self.heads, (position, singles[0], (v,), "all", v))
                    break
                if len(singles) == 1:
                    v = singles[0]
                    continue
                self.fork(out, v, singles, stack)
                break

    def drop(self, v: str) -> None:
        """Forget *v*'s attributes, and its column unless it is a join's (consume mode, once *v*'s leaf is built).

        Only the predecessors' row walks read a column (``singles``), and they all ran before *v*
        was reached - unless *v* is a join, whose predecessors may be walked later.
        """
        del self.nodes[v]
        if len(self.pred[v]) < 2:
            del self.pred[v]

    def singles(self, v: str) -> list[str]:
        """Successors of *v* that have no other predecessor (they continue *v*'s Sequence)."""
        pred = self.pred
        return [s for s in self.succ[v] if len(pred[s]) == 1]

    def fork(self, out: _ChainWriter, v: str, singles: list[str], stack: list[tuple[Sequence, str, int]]) -> None:
        """Append ``Parallel(fork v)`` with one branch Sequence per successor; queue the branches."""
        fork = Parallel(f"fork {v}", _all())
        level = out.add(fork)
        branches = []
        for s in singles:
            branch = Sequence(f"chain {s}", memory=True)
            fork.add_child(self.branch(branch))
            branches.append((branch, s, level + 2 + self.cuttable))
        stack.extend(reversed(branches))

    def build(self) -> Parallel:
        root = WakingParallel("timeline", self.env)
        roots = Parallel("roots", _all())
        root.add_child(Sequence("begin", memory=True, children=[RunStart(self.env), roots]))
        for v in [v for v, p in self.pred.items() if not p]:  # file order (listed first: the walk may drop columns)
            seq = Sequence(f"chain {v}", memory=True)
            roots.add_child(self.branch(seq))
            self.chain(seq, v, self.depth + 3 + self.cuttable)
        while self.heads:
            _, v, preds, join, fork_of = heapq.heappop(self.heads)
            name = f"after {fork_of}" if fork_of else f"join {v}"
            trigger = (CutTrigger if self.cuttable else Trigger)(self.env, preds, join)
            seq = Sequence(name, memory=True, children=[trigger])
            root.add_child(self.branch(seq))
            self.chain(seq, v, self.depth + 1 + self.cuttable, fork_of=fork_of or None)
        if self.consume and self.nodes:  # entries no walk reached: only a cycle hides them (when no order was taken)
            raise nx.NetworkXUnfeasible("the timeline has a cycle")
        return root


def execute_subtree(
    graph: nx.DiGraph,
    env: Environment,
    registry: Registry,
    *,
    depth: int = EXECUTE_DEPTH,
    max_depth: int = MAX_DEPTH,
    consume: bool = False,
) -> Parallel:
    """Build the execute subtree of *graph* (Algorithm 1).

    Args:
        graph: the timeline (see :func:`btgen_pytrees.timeline.timeline`), acyclic
        env: the environment shared by the tree's nodes
        registry: where entry leaves come from
        depth: the level the returned Parallel will sit at in the full tree
        max_depth: deepest level a node may reach (see :data:`MAX_DEPTH`)
        consume: the graph is the caller's to throw away: the walk drops each
            entry's attributes and successors from it once it has used them, so
            the graph shrinks while the tree grows (:func:`~.tree.generate`,
            which builds its own graph, passes True; the graph is left broken)
    """
    if max_depth < depth + 8:
        raise ValueError(f"max_depth must be at least {depth + 8}")
    return _Walk(graph, env, registry, depth, max_depth, consume).build()


def walk_consuming(graph: nx.DiGraph, entries: Mapping[str, Entry], env: Environment, registry: Registry, *,
                   depth: int, max_depth: int) -> Parallel:  # fmt: skip
    """:func:`execute_subtree` with ``consume=True`` over a graph built without node attributes
    (:func:`~.tree.generate`'s own), the entries given by id instead."""
    if max_depth < depth + 8:
        raise ValueError(f"max_depth must be at least {depth + 8}")
    return _Walk(graph, env, registry, depth, max_depth, True, entries).build()
