"""The base of the generator's own py_trees nodes: :class:`Node`, a ``Behaviour`` that starts cheaper.

``py_trees.behaviour.Behaviour.__init__`` gives every node a ``uuid.uuid4()``: sixteen bytes from
``os.urandom`` (a system call per node) passed through ``UUID``'s checks, about half of what building
a leaf costs - 100,000 system calls for a 100,000-entry chain. :class:`Node` sets the same attributes
to the same values as ``Behaviour.__init__``, with these differences:

* its id is a version-4 UUID made from 128 bits of a random generator of this module's own (seeded
  from ``os.urandom``, and again in a forked child, as :mod:`random` does for its own), given to
  ``uuid.UUID(int=...)``. What py_trees reads an id for - telling nodes apart (``add_child`` returns
  it, ``remove_child_by_id``, ``BehaviourTree.prune_subtree``, the display and snapshot visitors) -
  needs it unique, not unpredictable; the host's :mod:`random` state is never touched;
* its ``id`` and its ``logger`` (py_trees' ``Logger``, read to print a debug line) are made when first
  read, behind properties over ``_id`` and ``_logger``: the generator builds its chains with
  :meth:`~btgen_pytrees.leaves.composites.Sequence.append_child`, which does not read the id
  ``add_child`` returns, and nothing of a run reads either unless py_trees' debug logging is on. A
  UUID and a ``Logger`` are two objects in four of a leaf, which the garbage collector walks at every
  full collection while a large tree is built (docs/performance.md#control-flow: the nodes of the
  control-flow keys made the collector run during the walk of a 100,000-entry chain, and scan every
  node made so far, three times);
* ``iterator``, the ``tick()`` generator ``Behaviour.__init__`` makes and ``stop()`` makes anew,
  and ``blackboards``, the list of the node's blackboard clients, are made when first read: py_trees
  never reads ``iterator`` (it ticks through fresh ``tick()`` calls), and reads ``blackboards`` only
  to attach a client (:meth:`Environment.attach <btgen_pytrees.contracts.environment.Environment.attach>`:
  the leaves that have one) and in views and the snapshot visitor. A generator and a list per node
  are two objects in six that the garbage collector would walk at every full collection while the
  tree is built. Both are properties over ``_iterator`` and ``_blackboards`` (``None`` until made),
  set in ``__init__`` where ``Behaviour.__init__`` sets theirs: a node keeps the attribute layout its
  class's first instance gave it (an attribute first set after ``__init__`` - by ``stop()`` - would
  make CPython give each node a dict of its own);
* its :meth:`~Node.tick` is ``Behaviour.tick``'s steps without what that method spends on every tick
  for nothing: it builds ``list(Status)`` (an iteration of the Enum class, about a microsecond) to
  check the status ``update()`` returned, where a tuple of the same members made once answers the
  same (members compare by identity), and formats its debug line even when py_trees' logging level
  would drop it, where the level is read first. The same ``initialise``/``update``/``stop`` calls in
  the same order, the same status, the same error line and the same one node yielded; its
  :meth:`~Node.stop` likewise formats its debug line (two Enum members, slow to format) only when
  printed, and leaves the fresh ``iterator`` to its first reader.

``tests/test_node.py`` compares a :class:`Node` with a stock ``Behaviour`` attribute by attribute,
so a py_trees release that changes ``Behaviour.__init__`` fails there, not in a user's tree.

Every node class of this package derives from it (the simulated leaves, the oracles, the wiring's
leaves and decorators: ``class Completion(py_trees.decorators.Decorator, Node)`` puts it between the
decorator and ``Behaviour``, so ``Decorator.__init__`` reaches it); the Sequences and Parallels the
generator builds are py_trees' own with a leaner ``tick`` (:mod:`btgen_pytrees.leaves.composites`),
which tick a child whose class ticks with :meth:`Node.tick` by its :meth:`~Node.tick_now`, and every
user leaf is the user's.
"""

from __future__ import annotations

import os
import random
from typing import Iterator
from uuid import UUID

import py_trees
from py_trees.common import BlackBoxLevel, Status

__all__ = ["Node", "new_id", "STATUSES", "NODE_TICK"]

STATUSES = tuple(Status)
"""py_trees' statuses, made once: what ``Behaviour.tick`` builds ``list(Status)`` for on every tick."""
_RUNNING, _INVALID = Status.RUNNING, Status.INVALID
_logging = py_trees.logging
_INFO = py_trees.logging.Level.INFO

_random = random.Random()  # seeded from os.urandom
if hasattr(os, "register_at_fork"):  # pragma: no branch - POSIX
    os.register_at_fork(after_in_child=_random.seed)  # a forked child draws other ids than its parent
_bits = _random.getrandbits
_V4_MASK = ~((0xF << 76) | (0x3 << 62)) & ((1 << 128) - 1)  # version (bits 76-79) and variant (62-63) cleared
_V4 = (4 << 76) | (0x2 << 62)  # version 4, variant RFC 4122: what uuid.uuid4() sets


def new_id() -> UUID:
    """A random version-4 UUID, as ``uuid.uuid4()`` gives, without a system call."""
    return UUID(int=_bits(128) & _V4_MASK | _V4)


class Node(py_trees.behaviour.Behaviour):
    """``py_trees.behaviour.Behaviour`` whose ``__init__`` draws its id without a system call and
    leaves ``iterator`` and ``blackboards`` to their first reader (see the module)."""

    def __init__(self, name: str):
        if not isinstance(name, str):
            raise TypeError(f"a behaviour name should be a string, but you passed in {type(name)}")
        self._id: UUID | None = None
        self.name: str = name
        self._blackboards: list[py_trees.blackboard.Client] | None = None
        self.qualified_name = f"{self.__class__.__qualname__}/{name}"
        self.status = Status.INVALID
        self._iterator: Iterator[py_trees.behaviour.Behaviour] | None = None
        self.parent: py_trees.behaviour.Behaviour | None = None
        self.children: list[py_trees.behaviour.Behaviour] = []
        self._logger: py_trees.logging.Logger | None = None
        self.feedback_message = ""
        self.blackbox_level = BlackBoxLevel.NOT_A_BLACKBOX

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        """``Behaviour.tick``: initialise when not running, update, stop on a final status, yield the node
        (see the module for what it does not spend): :meth:`tick_now`, then ``yield self``."""
        self.tick_now()
        yield self

    def tick_now(self) -> None:
        """The steps of :meth:`tick` before its one yield: what the generator's composites call for a child
        whose class ticks with :meth:`tick` (:data:`NODE_TICK`), then yield the child themselves - the same
        steps at the same moment, without a generator made and resumed for each leaf on every tick."""
        if _logging.level < _INFO:
            self.logger.debug(f"{self.__class__.__name__}.tick()")
        if self.status != _RUNNING:
            self.initialise()
        # self.status keeps the old status until stop(): a leaf's terminate() may read it
        new_status = self.update()
        if new_status not in STATUSES:
            self.logger.error(f"A behaviour returned an invalid status, setting to INVALID [{new_status}][{self.name}]")
            new_status = _INVALID
        if new_status != _RUNNING:
            self.stop(new_status)
        self.status = new_status

    def stop(self, new_status: Status) -> None:
        """``Behaviour.stop``: terminate, take the status, a fresh ``tick()`` generator as :attr:`iterator` -
        made when first read (see the module), as is the debug line, only when py_trees' level prints it."""
        if _logging.level < _INFO:
            self.logger.debug("{}.stop({})".format(
                self.__class__.__name__,
                (f"{self.status}->{new_status}" if self.status != new_status else f"{new_status}")))  # fmt: skip
        self.terminate(new_status)
        self.status = new_status
        self._iterator = None

    @property  # type: ignore[override]
    def id(self) -> UUID:
        """The node's unique id (:func:`new_id`, made when first read)."""
        found = self._id
        if found is None:
            found = self._id = new_id()
        return found

    @id.setter
    def id(self, value: UUID) -> None:
        self._id = value

    @property  # type: ignore[override]
    def logger(self) -> py_trees.logging.Logger:
        """py_trees' ``Logger`` named after the node, as ``Behaviour.__init__`` makes it (made when first read)."""
        found = self._logger
        if found is None:
            found = self._logger = py_trees.logging.Logger(self.name)
        return found

    @logger.setter
    def logger(self, value: py_trees.logging.Logger) -> None:
        self._logger = value

    @property  # type: ignore[override]
    def blackboards(self) -> list[py_trees.blackboard.Client]:
        """The py_trees blackboard clients attached to the node (a list made when first read)."""
        found = self._blackboards
        if found is None:
            found = self._blackboards = []
        return found

    @blackboards.setter
    def blackboards(self, clients: list[py_trees.blackboard.Client]) -> None:
        self._blackboards = clients

    @property  # type: ignore[override]
    def iterator(self) -> Iterator[py_trees.behaviour.Behaviour]:
        """A ``tick()`` generator, as ``Behaviour.__init__`` and ``stop()`` keep (made when first read)."""
        found = self._iterator
        if found is None:
            found = self._iterator = self.tick()
        return found

    @iterator.setter
    def iterator(self, value: Iterator[py_trees.behaviour.Behaviour]) -> None:
        self._iterator = value


NODE_TICK = Node.tick
"""``Node.tick``: a composite that finds it as its child's class's ``tick`` calls the child's
:meth:`~Node.tick_now` and yields the child instead of ticking it through a generator."""
