"""A compact record of one run: every node's status changes and every signal's changes, per tick.

The report says *what* was decided; the trace says *how the run got there*, so
the run picture (``--plot``), the replay page (``--replay``) and the
BehaviorTree.CPP log (``--btlog``) can all be drawn from one source instead of
from whatever an oracle happened to read.

What is recorded, tick by tick (tick *k* is the *k*-th tick of the run, at run
time ``times[k]``):

* **node statuses** - each time a node's status changes: when a ticked node
  returns a new status, and when a node is stopped without being ticked (a
  Parallel that finishes halts its running children; a stopped composite resets
  its whole subtree). Nodes are numbered in pre-order (root = 0), the order of
  :func:`~btgen_pytrees.render.nodes.walk`, so index *i* is graph node ``n<i>``
  of the uncollapsed Graphviz view. Within a tick the changes keep their order;
  a leaf that starts and is halted on the same tick shows both. Every node is
  ``invalid`` before tick 0.
* **signals** - every key under the tree's ``<ns>/signals/`` on the blackboard,
  whoever wrote it (an action, ``until`` only reads, a system's published
  signals), sampled *after* each tick, recorded only when its value changed
  (``1`` and ``1.0`` and ``True`` count as different values). New keys are
  found when the blackboard grows (a dict keeps insertion order, so they are
  at its end); after a signal key went away every key is looked at again.
  **A signal that stops existing ends**: when its key is gone from the
  blackboard after a tick (SUMO's ``V.speed`` once ``V`` has left the
  network), the change recorded is :data:`ENDED` - no value from that tick
  on, as the oracles see it, never the last value held on - until it has a
  value again.

What is not recorded: the halt the runner sends after the last tick of a run
that timed out or erred (the trace shows the tree as it was on its last tick).

**Memory.** Changes only: a status change costs 9 bytes (three packed arrays),
a signal change one list slot and its value. A run is capped at ``limit``
changes (default 2,000,000, a few tens of MB at most); past it recording stops,
``truncated`` is the first tick not fully recorded, and every view says so.

>>> from btgen_pytrees import load
>>> from btgen_pytrees.run import run
>>> trace = run(load("examples/fig1.json")).trace
>>> trace.series("speed")[:3]
[(0.0, 0.0), (0.1, 1.0), (0.2, 2.0)]
>>> trace.status_at(trace.node_index("B4"), 14), trace.status_at(trace.node_index("B4"), 15)
('invalid', 'success')
"""

from __future__ import annotations

import copy
import itertools
import math
from array import array
from dataclasses import dataclass, field
from collections.abc import Sequence
from typing import Any, Callable, Iterator, NamedTuple

import py_trees
from py_trees.blackboard import Blackboard
from py_trees.common import Status

from ..leaves.composites import Parallel
from ..leaves.composites import Sequence as LeanSequence
from ..leaves.wiring import Completion, WakingParallel
from ..render.nodes import role_of
from .index import TreeIndex

__all__ = ["RunTrace", "TraceNode", "TraceRecorder", "STATUSES", "DEFAULT_LIMIT", "ENDED"]

STATUSES = ("invalid", "running", "success", "failure")
"""Status names by code; the codes are BehaviorTree.CPP's (IDLE, RUNNING, SUCCESS, FAILURE)."""

_RUNNING, _SUCCESS, _FAILURE = Status.RUNNING, Status.SUCCESS, Status.FAILURE


def _code(status: Status) -> int:
    """The status code, by identity (hashing an Enum member runs Python code: too slow per node per tick)."""
    return 1 if status is _RUNNING else 2 if status is _SUCCESS else 3 if status is _FAILURE else 0

_PLAIN, _COMPOSITE, _REACTIVE = 0, 1, 2
_KEEPS_CHILDREN = (py_trees.composites.Parallel.tick, Parallel.tick, WakingParallel.tick, py_trees.decorators.Decorator.tick,
                   Completion.tick)  # (TreeRoot's tick is Parallel.tick)
_SEQUENCE_TICKS = (py_trees.composites.Sequence.tick, LeanSequence.tick)  # py_trees' and the generator's


def _kind(node: py_trees.behaviour.Behaviour) -> int:
    """``_COMPOSITE`` (halts its children only when it finishes) or ``_REACTIVE`` (may halt them any time).

    Judged by the ``tick`` the node's class runs (and, for a Sequence, its
    ``memory``): py_trees' Parallel (and the generator's: :class:`~btgen_pytrees.leaves.composites.Parallel`,
    the tree's :class:`~btgen_pytrees.leaves.wiring.TreeRoot` and the execute root's :class:`WakingParallel`) and a plain decorator
    (and the generator's :class:`Completion`) stop their running children
    only when they themselves finish, and so does a Sequence with memory; a
    Selector (priority interrupts), a Sequence without memory or any composite
    whose ``tick`` is its own may halt a child while it runs on. Only nodes
    with children have a kind; the recorder treats the others as ``_PLAIN``.
    """
    tick = type(node).tick
    if tick in _KEEPS_CHILDREN or (tick in _SEQUENCE_TICKS and getattr(node, "memory", False)):
        return _COMPOSITE
    return _REACTIVE


DEFAULT_LIMIT = 2_000_000
"""Changes (status and signal) a trace keeps before it stops recording."""


class _Ended:
    """The type of :data:`ENDED` (one instance; copies and pickles are that instance)."""

    _one: "_Ended | None" = None

    def __new__(cls) -> "_Ended":
        if cls._one is None:
            cls._one = super().__new__(cls)
        return cls._one

    def __repr__(self) -> str:
        return "ENDED"

    def __reduce__(self) -> str:
        return "ENDED"  # pickled by name: this module's ENDED


ENDED = _Ended()
"""The value a signal's change has when the signal stopped existing (its key left the blackboard):
from that tick on it has no value (:meth:`RunTrace.value_at` gives ``None``), until it gets one again."""

_SCALARS = (bool, int, float, str, type(None))


class TraceNode(NamedTuple):
    """One node of the traced tree (a named tuple: a 100k-entry tree has 400k of them).

    Attributes:
        name: the behaviour's name
        role: ``behavior``, ``constraint``, ``oracle``, ``trigger``, ``wiring`` or ``composite``
        id: the entry or criterion id ("" for other nodes)
        parent: index of the parent (-1 for the root)
        depth: root = 0
        end: one past the index of the last node of its subtree (pre-order)
    """

    name: str
    role: str
    id: str
    parent: int
    depth: int
    end: int


class _NodeTable(Sequence):  # type: ignore[type-arg]
    """:attr:`RunTrace.nodes`, made into :class:`TraceNode` rows only when somebody reads them.

    Most runs never draw their trace (no ``--plot``, ``--replay`` or
    ``--btlog``), so the recorder keeps just what the rows are made of - each
    node's name and class, the tagged nodes' entries and criteria, and the
    pre-order subtree ends, not the nodes
    themselves (a report must not keep its tree alive) - and the rows, parents
    and depths are worked out on first use. Its length is known at once.
    """

    def __init__(self, index: TreeIndex):
        behaviours = index.nodes
        self._names = [node.name for node in behaviours]
        self._classes = [type(node) for node in behaviours]
        # node number -> its entry, its criterion: the tagged nodes only (and no tuple per node, which
        # the garbage collector would have to look at)
        self._entries: dict[int, Any] = index.entries  # read, never changed (dropped by rebinding once used)
        self._criteria: dict[int, Any] = index.criteria
        self._ends = index.ends
        self._rows: list[TraceNode] | None = None

    def _made(self) -> list[TraceNode]:
        if self._rows is None:
            rows: list[TraceNode] = []
            ends, open_ = self._ends, []  # the subtrees the node at i lies in
            roles: dict[type, str] = {}
            entries, criteria = self._entries, self._criteria
            for i, (name, cls) in enumerate(zip(self._names, self._classes)):
                while open_ and ends[open_[-1]] <= i:
                    open_.pop()
                entry, criterion = entries.get(i), criteria.get(i)
                if entry is None and criterion is None:
                    role = roles.get(cls) or roles.setdefault(cls, role_of(cls))
                else:
                    role = role_of(cls, entry, criterion)
                item = entry if entry is not None else criterion
                rows.append(TraceNode(name, role, item.id if item is not None else "",
                                      open_[-1] if open_ else -1, len(open_), ends[i]))  # fmt: skip
                open_.append(i)
            self._rows = rows
            self._names = self._classes = []  # type: ignore[assignment]
            self._entries, self._criteria = {}, {}
        return self._rows

    def __len__(self) -> int:
        return len(self._ends)

    def __getitem__(self, i: Any) -> Any:
        return self._made()[i]

    def __iter__(self) -> Iterator[TraceNode]:
        return iter(self._made())

    def __eq__(self, other: object) -> bool:
        return list(self) == list(other) if isinstance(other, Sequence) else NotImplemented

    def __repr__(self) -> str:
        return repr(self._made())

    def __reduce__(self) -> tuple[Any, ...]:
        return (list, (self._made(),))  # pickled (or copied) as the plain list of rows


@dataclass
class RunTrace:
    """What happened on every tick of one run (see the module notes).

    Attributes:
        nodes: the tree, in pre-order
        times: run time of each tick
        ticks, nodes_changed, statuses: the status changes, as three parallel
            arrays (tick, node index, status code; see :data:`STATUSES`)
        signals: per signal, the ticks at which its value changed and the values
            (:data:`ENDED` where it stopped having one)
        truncated: the first tick from which changes were dropped (``None``: complete)
        limit: the cap on changes
        scene: where every vehicle was on every tick (:class:`~.scene.Scene`), when the
            system offers a scene (the runner records it; ``None`` otherwise)
    """

    nodes: Sequence[TraceNode]
    times: list[float] = field(default_factory=list)
    ticks: array = field(default_factory=lambda: array("L"))
    nodes_changed: array = field(default_factory=lambda: array("L"))
    statuses: array = field(default_factory=lambda: array("B"))
    signals: dict[str, tuple[array, list[Any]]] = field(default_factory=dict)
    truncated: int | None = None
    limit: int = DEFAULT_LIMIT
    scene: Any = None

    # -- reading ------------------------------------------------------------------------------------

    def transitions(self) -> Iterator[tuple[int, int, str]]:
        """Every status change, in order: ``(tick, node index, status name)``."""
        for k, i, s in zip(self.ticks, self.nodes_changed, self.statuses):
            yield k, i, STATUSES[s]

    def node_index(self, ident: str) -> int:
        """The index of the node of entry or criterion *ident* (:class:`KeyError` if none)."""
        for i, node in enumerate(self.nodes):
            if node.id == ident:
                return i
        raise KeyError(ident)

    def statuses_at(self, tick: int) -> list[str]:
        """Every node's status at the end of *tick*."""
        codes = bytearray(len(self.nodes))
        for k, i, s in zip(self.ticks, self.nodes_changed, self.statuses):
            if k > tick:
                break
            codes[i] = s
        return [STATUSES[c] for c in codes]

    def status_at(self, node: int, tick: int) -> str:
        """Node *node*'s status at the end of *tick*."""
        return self.statuses_at(tick)[node]

    def value_at(self, signal: str, tick: int) -> Any:
        """The value of *signal* at the end of *tick* (``None`` while it has none: before its first, after it ended)."""
        ticks, values = self.signals[signal]
        value = None
        for k, v in zip(ticks, values):
            if k > tick:
                break
            value = v
        return None if value is ENDED else value

    def series(self, signal: str) -> list[tuple[float, Any]]:
        """``(time, value)`` each time *signal* changed; the value is :data:`ENDED` where it stopped existing."""
        ticks, values = self.signals[signal]
        return [(self.times[k], v) for k, v in zip(ticks, values)]

    def changes(self) -> int:
        return len(self.statuses) + sum(len(t) for t, _ in self.signals.values())

    def to_data(self) -> dict[str, Any]:
        """The trace as compact JSON-ready data (the replay page's input).

        ``transitions`` is one flat list ``[tick, node, code, tick, node, code, ...]``;
        ``signals`` maps each name (sorted) to ``[[tick, value], ...]``, with ``[tick]`` (no
        value) where the signal ended.
        """
        flat: list[int] = []
        for k, i, s in zip(self.ticks, self.nodes_changed, self.statuses):
            flat += (k, i, s)
        return {
            "times": self.times,
            "nodes": [[n.name, n.role, n.id, n.parent, n.depth] for n in self.nodes],
            "statuses": list(STATUSES),
            "transitions": flat,
            "signals": {name: [[k] if v is ENDED else [k, v] for k, v in zip(*self.signals[name])]
                        for name in sorted(self.signals)},
            "truncated": self.truncated,
        }


class TraceRecorder(py_trees.visitors.VisitorBase):
    """A py_trees visitor that records a :class:`RunTrace` while a tree is ticked.

    Drive it as :class:`py_trees.trees.BehaviourTree` drives its visitors:
    :meth:`initialise` before each tick, :meth:`run` for every node the tick
    yields, :meth:`finalise` after the tick (also after a tick that raised).

    **Cost.** A tick costs the recorder what the tick itself visits, not the
    size of the tree: :meth:`run` is one lookup and one comparison per visited
    node, and the nodes that change without being visited (halted ones) are
    looked for only below the composites that can have halted them on this
    tick (see :meth:`finalise`), so the thousands of running-but-sleeping heads
    of a large execute root are never looked at.

    Args:
        root: the tree (generated trees carry their environment, whose
            namespace says where the signals are)
        now: run time of the current tick (default: the environment's ``now``)
        limit: the cap on recorded changes
    """

    def __init__(self, root: py_trees.behaviour.Behaviour, *, now: Callable[[], float] | None = None,
                 limit: int = DEFAULT_LIMIT, index: TreeIndex | None = None):  # fmt: skip
        index = index if index is not None else TreeIndex(root)
        super().__init__(full=False)
        behaviours, ends = index.nodes, index.ends
        kinds = bytearray(len(behaviours))
        known: dict[type, int] = {}  # by class, for the classes whose kind is not a Sequence's (by its memory)
        for i in index.composites:
            node = behaviours[i]
            cls = type(node)
            kind = known.get(cls)
            if kind is None:
                kind = _kind(node) if cls.tick in _SEQUENCE_TICKS else known.setdefault(cls, _kind(node))
            kinds[i] = kind
        self.trace = RunTrace(_NodeTable(index), limit=limit)
        self._index = index
        self._behaviours = behaviours
        self._ends = ends
        self._kinds = kinds
        self._last = bytearray(len(behaviours))
        self._halts: list[int] = []  # composites visited this tick that may have halted nodes below them
        self._walks: list[int] = []  # subtrees whose every node must be looked at (they were reset)
        env = getattr(root, "btgen_env", None)
        self._now = now if now is not None else (env.now if env is not None else (lambda: 0.0))
        self._prefix = env.namespace + "/signals/" if env is not None else None
        self._keys: dict[str, str] = {}  # blackboard key -> signal name
        self._storage_size = -1
        self._values: dict[str, Any] = {}
        self._tick = -1
        self._left = limit  # changes still to be recorded
        self._append = (self.trace.ticks.append, self.trace.nodes_changed.append, self.trace.statuses.append)

    # -- the visitor protocol -----------------------------------------------------------------------

    def initialise(self) -> None:
        """A tick begins."""
        self._tick += 1
        self._walks.clear()
        self._halts.clear()
        if self._last[0] == 1 and self._behaviours[0].status is not _RUNNING:
            self._walks.append(0)  # stopped between two ticks (a host's stop()): look at every node after this tick

    def run(self, behaviour: py_trees.behaviour.Behaviour) -> None:
        """*behaviour* was ticked: note its status as it returned it."""
        i = self._index.number(behaviour)
        if i is not None:  # else a node added after the recorder was made: not traced
            self.seen(i, _code(behaviour.status))

    def seen(self, i: int, code: int) -> None:
        """Node number *i* was ticked and returned the status of *code* (the :class:`Collector` calls this).

        :meth:`_note` is inline here: a call fewer per changed node (on a 10k-entry fan-in, most of a
        tick's 20,000 nodes change)."""
        last = self._last[i]
        kind = self._kinds[i]
        if kind:
            if last >= 2:  # a finished composite runs again: its children were reset
                self._walks.append(i)
            if code != 1 or kind == _REACTIVE:  # it finished (halting its running children) or may halt any time
                self._halts.append(i)
        if code != last:
            self._last[i] = code  # _note, inline
            if self._left:
                self._left -= 1
                ticks, nodes, statuses = self._append
                ticks(self._tick)
                nodes(i)
                statuses(code)
            else:
                self._room()  # marks the trace truncated from this tick

    def finalise(self) -> None:
        """A tick ended: catch the nodes halted without a tick, then sample the signals.

        A node changes without being ticked only when something stops it: a
        composite that finishes halts its running children (and a halted
        composite resets its whole subtree); a reactive one (a ``Selector``, a
        ``Sequence`` without memory, any composite or decorator whose ``tick``
        is not one of py_trees' parallel, memory sequence or plain decorator
        ticks) may halt them while it keeps running. Every such composite was
        ticked itself on this tick, so only the nodes below the composites this
        tick visited and that finished (or are reactive) are looked at, and of
        those only the ones recorded as running - found by a byte search of the
        recorded codes, not one look per node. A tree halted from outside (a
        host's ``stop()`` on the generated root between ticks, or a host's own
        composite halting it during one) is caught too: the root's own status
        is compared before and after every tick.
        """
        self.trace.times.append(self._now())
        ends, last, behaviours = self._ends, self._last, self._behaviours
        halts, walks = self._halts, self._walks
        outside = last[0] == 1 and behaviours[0].status is not _RUNNING  # the root was stopped, not ticked
        if outside:
            halts.append(0)
        if halts:
            reach = -1
            for i in sorted(halts):
                lo, hi = i + 1 if i >= reach else reach, ends[i]  # max(i + 1, reach), without a call per halt
                j = last.find(1, lo, hi) if lo < hi else -1
                while j >= 0:
                    node = behaviours[j]
                    code = _code(node.status)
                    if code != 1:
                        self._note(j, code)
                        if code == 0 and ends[j] > j + 1:
                            walks.append(j)
                    j = last.find(1, j + 1, hi)
                if hi > reach:
                    reach = hi
        if outside:
            code = _code(behaviours[0].status)
            self._note(0, code)
            if code == 0:
                walks.append(0)
        if walks:
            reach = -1
            for i in sorted(walks):
                for j in range(max(i, reach), ends[i]):
                    code = _code(behaviours[j].status)
                    if code != last[j]:
                        self._note(j, code)
                reach = max(reach, ends[i])
        self._sample_signals()

    # -- recording ----------------------------------------------------------------------------------

    def _room(self) -> bool:
        if self._left:
            self._left -= 1
            return True
        if self.trace.truncated is None:
            self.trace.truncated = self._tick
        return False

    def _note(self, i: int, code: int) -> None:
        self._last[i] = code
        if self._room():
            ticks, nodes, statuses = self._append
            ticks(self._tick)
            nodes(i)
            statuses(code)

    def _discover(self, storage: dict[str, Any]) -> None:
        """Find the signal keys: all of them on the first look or when keys went away, else
        only the newest (a dict iterates in insertion order, so new keys are at its end)."""
        prefix = self._prefix
        assert prefix is not None
        size = len(storage)
        if self._storage_size < 0 or size < self._storage_size:
            fresh = [k for k in storage if k.startswith(prefix)]
        else:
            fresh = [k for k in itertools.islice(reversed(storage), size - self._storage_size) if k.startswith(prefix)]
        for key in sorted(fresh):
            self._keys.setdefault(key, key[len(prefix):])
        self._storage_size = size

    def _sample_signals(self) -> None:
        if self._prefix is None:
            return
        storage = Blackboard.storage
        if not self._keys.keys() <= storage.keys():  # a key went away (a host reset the namespace); a set test in C
            self._storage_size = -1
        if len(storage) != self._storage_size:
            self._discover(storage)
        missing = object()
        for key, name in self._keys.items():
            value = storage.get(key, missing)
            last = self._values.get(name, missing)
            if value is missing:
                if last is missing or last is ENDED:
                    continue
                value = ENDED  # it had a value and has none now: it ended (not: it kept its last value)
            elif last is not missing and _same(value, last):
                continue
            if not self._room():
                return
            if not isinstance(value, _SCALARS) and value is not ENDED:
                value = copy.deepcopy(value)  # a list changed in place later must not change the record
            self._values[name] = value
            ticks, values = self.trace.signals.setdefault(name, (array("L"), []))
            ticks.append(self._tick)
            values.append(value)


def _same(a: Any, b: Any) -> bool:
    if a is b:
        return True
    if type(a) is not type(b):
        return False
    if isinstance(a, float) and math.isnan(a) and math.isnan(b):
        return True
    try:
        return bool(a == b)
    except Exception:  # noqa: BLE001 - an odd value that cannot compare counts as changed
        return False
