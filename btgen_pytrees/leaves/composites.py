"""The generator's Parallels: py_trees' own ``Parallel``, ticked without its per-tick overheads.

:class:`Parallel` *is* a ``py_trees.composites.Parallel`` (same ``__init__``, ``setup``,
``stop``, policy, children, ``current_child``; views, visitors and py_trees' display see
the class name ``Parallel``); only :meth:`Parallel.tick` is written again, with the same steps
in the same order - the same children ticked, the same ``stop``/``initialise`` calls, the same
nodes yielded, the same status and ``current_child`` - minus what py_trees 2.x spends on every
tick of every Parallel for nothing:

* the debug lines are formatted only when py_trees' logging level would print them
  (``Logger.debug`` drops them otherwise, after the f-string is built);
* ``validate_policy_configuration()`` is called where it checks something: for a
  ``SuccessOnSelected`` policy (for the others it is an ``isinstance`` test that passes);
* the new status is read in one pass over the children instead of a generator expression
  for the first failure and another for ``all(...)``;
* :meth:`Parallel.stop` formats its debug line (two Enum members) only when it is printed.

A small run ticks a handful of Parallels on every tick (the tree's root, the ``roots`` of the
timeline, the oracle and its groups): the ``cut_in_3d`` SUMO case of ``benchmarks/falsify.py``
ticks four per tick, about 90 ticks per run (docs/performance.md). ``tests/test_composites.py``
ticks trees made of these and of py_trees' own classes side by side and compares every node's
status, ``current_child`` and the nodes yielded, on every tick.
"""

from __future__ import annotations

import typing

import py_trees
from py_trees.common import ParallelPolicy, Status

__all__ = ["Parallel"]

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
        if isinstance(policy, _SELECTED):
            self.validate_policy_configuration()
        children = self.children
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
        for child in children:  # tick every child (a synchronised one that succeeded waits)
            if policy.synchronise and child.status == _SUCCESS:
                continue
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
            if all([c.status == _SUCCESS for c in policy.children]):
                new_status = _SUCCESS
                self.current_child = policy.children[-1]
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
