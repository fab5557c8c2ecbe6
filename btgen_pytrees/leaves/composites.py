"""The generator's Parallels and Sequences: py_trees' own classes, ticked without their per-tick overheads.

:class:`Parallel` *is* a ``py_trees.composites.Parallel`` (same ``__init__``, ``setup``,
``stop``, policy, children, ``current_child``; views, visitors and py_trees' display see
the class name ``Parallel``); only :meth:`Parallel.tick` is written again, with the same steps
in the same order - the same children ticked, the same ``stop``/``initialise`` calls, the same
nodes yielded, the same status and ``current_child`` - minus what py_trees 2.x spends on every
tick of every Parallel for nothing:

* the debug lines are formatted only when py_trees' logging level would print them
  (``Logger.debug`` drops them otherwise, after the f-string is built);
* ``validate_policy_configuration()`` is called where it finds something wrong: for a
  ``SuccessOnSelected`` policy that selects no child or a node that is not a child (for the other
  policies it is an ``isinstance`` test that passes; for a valid selection a list built for nothing);
* the new status is read in one pass over the children instead of a generator expression
  for the first failure and another for ``all(...)``;
* :meth:`Parallel.stop` formats its debug line (two Enum members) only when it is printed;
* a child that is one of the package's leaves (its class ticks with
  :data:`~btgen_pytrees.leaves.node.NODE_TICK`) is ticked by its ``tick_now()`` and yielded here,
  without a generator made and resumed for it.

The generator's Sequences are :class:`Sequence`: py_trees' own with a leaner ``tick`` likewise.

A small run ticks a handful of Parallels on every tick (the tree's root, the ``roots`` of the
timeline, the oracle and its groups): the ``cut_in_3d`` SUMO case of ``benchmarks/falsify.py``
ticks four per tick, about 90 ticks per run (docs/performance-history.md). ``tests/test_composites.py``
ticks trees made of these and of py_trees' own classes side by side and compares every node's
status, ``current_child`` and the nodes yielded, on every tick.
"""

from __future__ import annotations

import typing
from itertools import islice

import py_trees
from py_trees.common import ParallelPolicy, Status

from .node import NODE_TICK

__all__ = ["Parallel", "Sequence", "ends_with_itself"]

_RUNNING, _SUCCESS, _FAILURE, _INVALID = Status.RUNNING, Status.SUCCESS, Status.FAILURE, Status.INVALID
_ALL, _ONE, _SELECTED = ParallelPolicy.SuccessOnAll, ParallelPolicy.SuccessOnOne, ParallelPolicy.SuccessOnSelected
_logging = py_trees.logging
_INFO = py_trees.logging.Level.INFO


class Parallel(py_trees.composites.Parallel):
    """``py_trees.composites.Parallel`` whose :meth:`tick` skips the work py_trees' does for nothing (see the module)."""

    begin_tick: typing.Callable[[], typing.Any] | None = None
    """Called first thing in every tick, if a subclass sets it (the tree's root reads the clock): a hook,
    not a ``tick`` that wraps this one, so the nodes the tick yields pass through one generator less."""

    def tick(self) -> typing.Iterator[py_trees.behaviour.Behaviour]:
        """One tick: :attr:`begin_tick`, then the steps of ``py_trees.composites.Parallel.tick`` in its
        order (see the module).

        Yields:
            every node ticked below this one, then this Parallel

        Raises:
            RuntimeError: the policy is not one of py_trees' three, or a ``SuccessOnSelected`` names a
            node that is not a child
        """
        if self.begin_tick is not None:
            self.begin_tick()
        debug = _logging.level < _INFO
        if debug:
            self.logger.debug(f"{self.__class__.__name__}.tick()")
        policy = self.policy
        children = self.children
        if isinstance(policy, _SELECTED):  # py_trees' check, called where it would raise (it logs, then raises)
            selected = policy.children
            if not selected:
                self.validate_policy_configuration()
            for child in selected:
                if child not in children:
                    self.validate_policy_configuration()
        if self.status != _RUNNING:  # a new start: every child begins from INVALID
            if debug:
                self.logger.debug(f"{self.__class__.__name__}.tick(): re-initialising")
            for child in children:  # a child's final status from last time would count as done below
                if child.status != _INVALID:
                    child.stop(_INVALID)
            self.current_child = None
            self.initialise()
        if not children:  # succeeds at once
            self.current_child = None
            self.stop(_SUCCESS)
            yield self
            return
        synchronise = policy.synchronise
        for child in children:  # tick every child (a synchronised one that succeeded waits)
            if synchronise and child.status == _SUCCESS:
                continue
            if type(child).tick is NODE_TICK:  # a leaf of ours: its tick's steps, then the leaf yielded here
                child.tick_now()
                yield child
            else:
                yield from child.tick()
        # the status: FAILURE from the first child that failed, else what the policy says
        new_status = _RUNNING
        self.current_child = children[-1]
        failed = None
        succeeded = 0
        for child in children:
            status = child.status
            if status == _FAILURE:
                failed = child
                break
            if status == _SUCCESS:
                succeeded += 1
        if failed is not None:
            self.current_child = failed
            new_status = _FAILURE
        elif isinstance(policy, _ALL):
            if succeeded == len(children):
                new_status = _SUCCESS
                self.current_child = children[-1]
        elif isinstance(policy, _ONE):
            for child in reversed(children):
                if child.status == _SUCCESS:
                    new_status = _SUCCESS
                    self.current_child = child
                    break
        elif isinstance(policy, _SELECTED):
            selected = policy.children
            for child in selected:  # py_trees' all([...]) without the list (reading a status changes nothing)
                if child.status != _SUCCESS:
                    break
            else:
                new_status = _SUCCESS
                self.current_child = selected[-1]
        else:
            raise RuntimeError(f"this parallel has been configured with an unrecognised policy [{type(policy)}]") from None
        if new_status != _RUNNING:  # finished: children still RUNNING are stopped with it
            self.stop(new_status)
        self.status = new_status
        yield self

    def stop(self, new_status: Status = _INVALID) -> None:
        """``Parallel.stop``: stop the running children, then the composite's own stop (its debug line
        formatted only when py_trees' level prints it)."""
        if _logging.level < _INFO:
            self.logger.debug(f"{self.__class__.__name__}.stop()[{self.status}->{new_status}]")
        for child in self.children:  # a child left RUNNING would go on alone: it is stopped (to INVALID)
            if child.status == _RUNNING:
                child.stop(_INVALID)
        py_trees.composites.Composite.stop(self, new_status)


_WHOLE: set[typing.Callable[..., typing.Any]] = set()
"""The ``tick`` methods known to yield their node last and to end there (see :func:`ends_with_itself`)."""


def ends_with_itself(tick: typing.Callable[..., typing.Any]) -> typing.Callable[..., typing.Any]:
    """Mark *tick* (a ``tick`` method, as a decorator) as one whose generator yields its own node last and
    ends right there - no code after that yield, no other yield of that node before it. A :class:`Sequence`
    ticks a child whose class's ``tick`` is so marked with ``yield from``: py_trees' loop, which re-yields
    each node and looks at the child's status after the child's own yield, does exactly the same for it
    (a user's ``tick`` may do anything after yielding its node: it keeps py_trees' loop)."""
    _WHOLE.add(tick)
    return tick


ends_with_itself(Parallel.tick)
ends_with_itself(NODE_TICK)


class Sequence(py_trees.composites.Sequence):
    """``py_trees.composites.Sequence`` whose :meth:`tick` skips the work py_trees' does for nothing.

    The steps of ``py_trees.composites.Sequence.tick`` in their order - the same children ticked,
    ``stop``/``initialise`` calls, nodes yielded, status and ``current_child`` - minus: the debug line
    formatted when py_trees' level drops it; a generator made and resumed for a child that is one of
    this package's leaves (:data:`~btgen_pytrees.leaves.node.NODE_TICK`: its :meth:`~btgen_pytrees.leaves.node.Node.tick_now`,
    then the child yielded here); and py_trees' loop that re-yields every node of a child's tick one by one
    and compares each with the child, where the child's ``tick`` is one of this package's that yields
    the child last and ends there (:func:`ends_with_itself`): ``yield from`` it, then the same look at the
    child's status. A user's child keeps py_trees' loop exactly. Its :meth:`stop` formats its debug line
    only when it is printed. The generator's Sequences are these; views, visitors and py_trees' display
    see the class name ``Sequence`` (``tests/test_composites.py`` ticks them beside py_trees' own).
    """

    def append_child(self, child: py_trees.behaviour.Behaviour) -> None:
        """``add_child`` without its return value, the child's ``id``: the package's nodes
        (:class:`~btgen_pytrees.leaves.node.Node`) make their UUID when the id is first read, which
        ``add_child`` would do for nothing where the caller drops it (the generator's chains: one per
        entry). The same checks, in the same order, and the same effect."""
        if not isinstance(child, py_trees.behaviour.Behaviour):
            raise TypeError(f"children must be behaviours, but you passed in {type(child)}")
        self.children.append(child)
        if child.parent is not None:
            raise RuntimeError(f"behaviour '{child.name}' already has parent '{child.parent.name}'")
        child.parent = self

    def tick(self) -> typing.Iterator[py_trees.behaviour.Behaviour]:
        """One tick: the steps of ``py_trees.composites.Sequence.tick`` in its order (see the class).

        Yields:
            every node ticked below this one, then this Sequence
        """
        if _logging.level < _INFO:
            self.logger.debug(f"{self.__class__.__name__}.tick()")
        children = self.children
        index = 0
        if self.status != _RUNNING:
            self.current_child = children[0] if children else None
            for child in children:
                if child.status != _INVALID:
                    child.stop(_INVALID)
            self.initialise()  # user specific initialisation
        elif self.memory and self.current_child is not None:
            index = children.index(self.current_child)
        else:
            self.current_child = children[0] if children else None
        if not children:
            self.current_child = None
            self.stop(_SUCCESS)
            yield self
            return
        for child in islice(children, index, None):
            tick = type(child).tick
            if tick is NODE_TICK:
                child.tick_now()
                yield child
                status = child.status
            elif tick in _WHOLE:
                yield from child.tick()
                status = child.status
            else:  # py_trees' own loop: it looks at the child right after the child is yielded, whatever follows
                status = _SUCCESS
                for node in child.tick():
                    yield node
                    if node is child and node.status != _SUCCESS:
                        status = node.status
                        break
            if status != _SUCCESS:
                if not self.memory:  # invalidate the remainder of the sequence, i.e. kill dangling runners
                    for later in islice(children, index + 1, None):
                        if later.status != _INVALID:
                            later.stop(_INVALID)
                if status != _RUNNING:  # stop the sequence if a terminal (non-success) state was reached
                    self.stop(status)
                else:
                    self.status = status
                yield self
                return
            try:  # advance if there is a next sibling
                self.current_child = children[index + 1]
                index += 1
            except IndexError:
                pass
        self.stop(_SUCCESS)
        yield self

    def stop(self, new_status: Status = _INVALID) -> None:
        """``Sequence.stop``: the composite's own stop, its debug line formatted only when it is printed."""
        if _logging.level < _INFO:
            self.logger.debug(f"{self.__class__.__name__}.stop()[{self.status}->{new_status}]")
        py_trees.composites.Composite.stop(self, new_status)


ends_with_itself(Sequence.tick)
