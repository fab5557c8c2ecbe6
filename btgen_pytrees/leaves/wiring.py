"""Nodes the generator adds around the user's leaves: the timeline's wiring.

None of these stand for an entry of the test case; they make the timeline's
ordering work without the leaves knowing about it:

* :class:`RunStart` - first leaf of the ``begin`` sequence: clears what an
  earlier run left in the tree's namespace, notes t0, writes the initial signals
  that have no value yet (see :meth:`Environment.start_run`).
* :class:`Completion` - a decorator that marks its child's success on the
  blackboard (``<ns>/done/<id>``, or ``<ns>/execute_done`` for the execute
  subtree). Only entries that some trigger waits for are wrapped.
* :class:`Trigger` - the paper's *virtual node*: RUNNING until the entries it
  waits for are marked done (``any``: one of them, ``all``: every one).
* :class:`OrMember` - wraps each member of an ``||`` oracle group so the group is
  a real OR under py_trees' ``SuccessOnOne`` policy (see its docstring).
"""

from __future__ import annotations

import typing

import py_trees
from py_trees.common import Status

from .environment import Environment

__all__ = ["RunStart", "Completion", "Trigger", "OrMember", "EXECUTE"]

EXECUTE = None
"""``Completion(marks=EXECUTE)`` marks the whole execute subtree."""


class RunStart(py_trees.behaviour.Behaviour):
    """Reset the tree's blackboard namespace and start the run clock; always succeeds."""

    def __init__(self, env: Environment, name: str = "start"):
        super().__init__(name=name)
        self.env = env

    def update(self) -> Status:
        self.env.start_run()
        signals = self.env.initial_signals
        self.feedback_message = ", ".join(f"{k}={v!r}" for k, v in signals.items()) or "no signals"
        return Status.SUCCESS


class Completion(py_trees.decorators.Decorator):
    """Pass the child's status through; when it succeeds, mark it done on the blackboard.

    Args:
        child: the entry's leaf (or the execute subtree)
        env: the tree's environment
        marks: the entry id, or :data:`EXECUTE` for the execute subtree
    """

    def __init__(self, child: py_trees.behaviour.Behaviour, env: Environment, marks: str | None, name: str = ""):
        super().__init__(name=name or f"{marks or 'execute'} done", child=child)
        self.env = env
        self.marks = marks

    def update(self) -> Status:
        status = self.decorated.status
        if status == Status.SUCCESS:
            if self.marks is None:
                self.env.mark_execute_done()
            else:
                self.env.mark_done(self.marks)
        return status


class Trigger(py_trees.behaviour.Behaviour):
    """The virtual trigger node: wait until predecessors have finished.

    Args:
        env: the tree's environment
        waits_for: the predecessors' ids
        join: ``any`` (one finished is enough) or ``all``
    """

    def __init__(self, env: Environment, waits_for: typing.Sequence[str], join: str, name: str = ""):
        if join not in ("any", "all"):
            raise ValueError(f"join must be 'any' or 'all', not {join!r}")
        if not name:
            shown = ", ".join(waits_for) if len(waits_for) <= 4 else f"{len(waits_for)} entries"
            name = f"after {shown}" if len(waits_for) == 1 else f"after {join}({shown})"
        super().__init__(name=name)
        self.env = env
        self.waits_for = tuple(waits_for)
        self.join = join
        self.cursor = 0

    def initialise(self) -> None:
        self.cursor = 0  # `all`: the predecessors before it are known to be done
        shown = ", ".join(self.waits_for[:4]) + (f" (+{len(self.waits_for) - 4})" if len(self.waits_for) > 4 else "")
        self.feedback_message = f"waiting for {self.join} of {shown}"

    def update(self) -> Status:
        is_done = self.env.is_done
        if self.join == "any":
            fired = any(is_done(p) for p in self.waits_for)
        else:
            # done flags stay set for the rest of a run, so resume where the last tick stopped:
            # a join over n predecessors costs O(n) per run, not per tick
            waits_for, cursor = self.waits_for, self.cursor
            while cursor < len(waits_for) and is_done(waits_for[cursor]):
                cursor += 1
            self.cursor = cursor
            fired = cursor == len(waits_for)
        if fired:
            self.feedback_message = "fired"
            return Status.SUCCESS
        return Status.RUNNING


class OrMember(py_trees.decorators.Decorator):
    """Make an ``||`` group behave as a real OR under ``SuccessOnOne``.

    py_trees' :class:`~py_trees.common.ParallelPolicy.SuccessOnOne` fails as soon
    as one child fails. An OR of criteria must instead fail only once *every*
    member has failed. Each member is therefore wrapped: when its criterion
    fails, the wrapper latches the failure (``<ns>/failed/<id>``), stops ticking
    the criterion and reports RUNNING - unless every member of the group has
    failed, in which case it reports FAILURE and the group fails at that tick.
    A success passes straight through, so the group succeeds on the first one.

    Args:
        child: the criterion's leaf
        env: the tree's environment
        member: this criterion's id
        group: the ids of every member of the group (including this one)
    """

    def __init__(self, child: py_trees.behaviour.Behaviour, env: Environment, member: str, group: typing.Sequence[str]):
        super().__init__(name=f"or {member}", child=child)
        self.env = env
        self.member = member
        self.group = tuple(group)
        self.latched = False

    def initialise(self) -> None:
        self.latched = False

    def tick(self) -> typing.Iterator[py_trees.behaviour.Behaviour]:
        if self.status != Status.RUNNING:
            self.initialise()
        if not self.latched:
            yield from self.decorated.tick()
            if self.decorated.status == Status.FAILURE:
                self.latched = True
                self.env.mark_failed(self.member)
        new_status = self.update()
        if new_status != Status.RUNNING:
            self.stop(new_status)
        self.status = new_status
        yield self

    def update(self) -> Status:
        if not self.latched:
            return self.decorated.status
        if all(self.env.is_failed(m) for m in self.group):
            self.feedback_message = "every member of the group failed"
            return Status.FAILURE
        self.feedback_message = "failed; the group may still pass"
        return Status.RUNNING
