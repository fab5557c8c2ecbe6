"""Nodes the generator adds around the user's leaves: the timeline's wiring.

None of these stand for an entry of the test case; they make the timeline's
ordering work without the leaves knowing about it:

* :class:`TreeRoot` - the generated root: a ``Parallel`` that reads the
  clock once per tick, so every node of a tick sees one time.
* :class:`RunStart` - first leaf of the ``begin`` sequence: clears what an
  earlier run left in the tree's namespace, notes t0, writes the initial signals
  that have no value yet (see :meth:`Environment.start_run`).
* :class:`Completion` - a decorator that marks its child's success on the
  blackboard (``<ns>/done/<id>``, or ``<ns>/execute_done`` for the execute
  subtree). Only entries that some trigger waits for are wrapped.
* :class:`Trigger` - the paper's *virtual node*: RUNNING until the entries it
  waits for are marked done (``any``: one of them, ``all``: every one).
* :class:`WakingParallel` - the execute root: a ``Parallel(SuccessOnAll)`` that
  does not tick a child while its trigger waits, and wakes it when a
  predecessor is marked done (so a tick costs what runs, not what waits).
* :class:`OrMember` - wraps each member of an ``||`` oracle group so the group is
  a real OR under py_trees' ``SuccessOnOne`` policy (see its docstring).
* :class:`Cuttable` and :class:`CutTrigger` - in a case whose entries can be
  stopped (``stops``, ``race``): a branch that a stopped entry ends is finished,
  not failed, and a join that can no longer fire gives up (docs/algorithms.md#control-flow).
"""

from __future__ import annotations

import typing
from heapq import heapify, heappop, heappush

import py_trees
from py_trees.blackboard import Blackboard
from py_trees.common import Status

from ..contracts.environment import Environment
from .composites import Parallel, ends_with_itself
from .node import NODE_TICK, STATUSES, Node

__all__ = ["TreeRoot", "RunStart", "Completion", "Trigger", "WakingParallel", "OrMember", "EXECUTE", "Cuttable",
           "CutTrigger"]

_logging = py_trees.logging
_INFO = py_trees.logging.Level.INFO
# the statuses as module constants: ``Status.SUCCESS`` is a look-up on the Enum class (~80 ns), every tick
_SUCCESS, _FAILURE, _RUNNING, _INVALID = Status.SUCCESS, Status.FAILURE, Status.RUNNING, Status.INVALID

EXECUTE = None
"""``Completion(marks=EXECUTE)`` marks the whole execute subtree."""


class TreeRoot(Parallel):
    """The root of a generated tree: a py_trees ``Parallel`` that begins each tick by reading the clock.

    Its tick calls :meth:`Environment.begin_tick <btgen_pytrees.leaves.Environment.begin_tick>`
    (:meth:`begin_tick`, the first step of the generator's :class:`~btgen_pytrees.leaves.composites.Parallel`
    tick) and then ticks exactly as ``Parallel`` does, so every node of one tick (and
    every visitor, and the report) sees one time - also with a clock that moves
    while the tick runs (the default :class:`~btgen_pytrees.clock.WallClock`).
    Views show it as the ``Parallel`` it is.

    Args:
        name, policy, children: as for ``Parallel``
        env: the tree's environment
    """

    def __init__(self, name: str, policy: py_trees.common.ParallelPolicy.Base,
                 children: typing.Sequence[py_trees.behaviour.Behaviour], env: Environment):  # fmt: skip
        super().__init__(name, policy, children)
        self.env = env

    def begin_tick(self) -> None:  # type: ignore[override]
        """Read the clock: the first step of every tick (:attr:`Parallel.begin_tick <btgen_pytrees.leaves.composites.Parallel.begin_tick>`)."""
        self.env.begin_tick()


class RunStart(Node):
    """Reset the tree's blackboard namespace and start the run clock; always succeeds."""

    def __init__(self, env: Environment, name: str = "start"):
        super().__init__(name=name)
        self.env = env
        self.client = env.attach(self, writes=[env.t0_key, *(env.signal_key(n) for n in env.initial_signals)])

    def update(self) -> Status:
        self.env.start_run(self.client)
        signals = self.env.initial_signals
        self.feedback_message = ", ".join(f"{k}={v!r}" for k, v in signals.items()) or "no signals"
        return _SUCCESS


class Completion(py_trees.decorators.Decorator, Node):
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

    @ends_with_itself
    def tick(self) -> typing.Iterator[py_trees.behaviour.Behaviour]:
        """``Decorator.tick``: initialise when not running, tick the child, update, stop on a final status,
        yield the node - without building ``list(Status)`` or a debug line nobody prints (as :class:`Node`),
        nor a generator for a child that is one of the package's leaves (its ``tick_now``, then the child
        yielded here: :class:`~btgen_pytrees.leaves.composites.Sequence`)."""
        if _logging.level < _INFO:
            self.logger.debug(f"{self.__class__.__name__}.tick()")
        if self.status != _RUNNING:
            self.initialise()
        decorated = self.decorated
        if type(decorated).tick is NODE_TICK:
            decorated.tick_now()
            yield decorated
        else:
            yield from decorated.tick()
        new_status = self.update()
        if new_status not in STATUSES:
            self.logger.error(f"A behaviour returned an invalid status, setting to INVALID [{new_status}][{self.name}]")
            new_status = _INVALID
        if new_status != _RUNNING:
            self.stop(new_status)
        self.status = new_status
        yield self

    def update(self) -> Status:
        status = self.decorated.status
        if status == _SUCCESS:
            if self.marks is None:
                self.env.mark_execute_done()
            else:
                self.env.mark_done(self.marks)
        return status


class Trigger(Node):
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
            return _SUCCESS
        return _RUNNING


class WakingParallel(Parallel):
    """``Parallel(SuccessOnAll(synchronise=True))`` that skips the ticks of children waiting on a trigger.

    The execute root holds one ``Sequence(trigger, ...)`` per join and per
    hoisted fork. py_trees' Parallel ticks every unfinished child on every
    tick, so each waiting trigger is polled each tick: a no-op (it answers
    RUNNING and nothing changes) whose cost grows with the number of waiting
    heads - a 100,000-entry comb (about 1,000 heads, 50,000 ticks) spent 150 s
    polling. This composite ticks the same children in the same order, minus
    exactly those no-op ticks:

    * its first tick (a fresh run, or the first after :meth:`stop`) ticks every
      child, as py_trees does, so every trigger starts waiting as before;
    * afterwards a child whose first node is a :class:`Trigger` that is still
      RUNNING *sleeps*: it is not ticked again until woken;
    * a trigger can only change its answer when one of its predecessors is
      marked done, which only :class:`Completion` does, through
      :meth:`Environment.mark_done <btgen_pytrees.leaves.Environment.mark_done>`;
      that call notifies this composite, which wakes every child waiting for
      that entry. A child later in the tick order than the one being ticked is
      ticked in the same pass (a trigger still fires on the tick its
      predecessor finishes); an earlier one on the next tick, which is when a
      polling Parallel would first have seen the mark too;
    * every other child is ticked on every tick until it has succeeded; the
      status follows py_trees' rules (FAILURE once a child failed, SUCCESS once
      all succeeded), kept as counts instead of a scan of all children.

    A tick therefore costs O(active children · log) instead of O(children).
    Skipped ticks yield nothing, so visitors (and the runner's recorder) see
    only the nodes that were ticked. Views show this node as the Parallel it
    behaves as.

    Args:
        name: the composite's name
        env: the tree's environment (its done marks wake the children)
        children: the children, in tick order
    """

    def __init__(self, name: str, env: Environment, children: typing.Sequence[py_trees.behaviour.Behaviour] | None = None):
        super().__init__(name, py_trees.common.ParallelPolicy.SuccessOnAll(synchronise=True), children)
        self.env = env
        self._waiters: dict[str, list[int]] = {}  # entry id -> children whose trigger waits for it
        self._sleeper: list[Trigger | None] = []  # per child: the trigger that may put it to sleep
        self._queued = bytearray()  # per child: 1 while it is in _heap or _next
        self._heap: list[int] = []  # children to tick in the current pass (a heap: tick order)
        self._next: list[int] = []  # children to tick in the next pass
        self._at = 0  # index of the child being ticked; wakes of later children join this pass
        self._succeeded = 0
        self._passing = False
        env.listen_done(self._marked)
        env.listen_cut(self._cut)

    def _prepare(self, everything: bool) -> None:
        """Queue the children for a full pass; with *everything*, also rebuild who waits for what."""
        children = self.children
        if everything:
            sleeper: list[Trigger | None] = []
            waiters: dict[str, list[int]] = {}
            for i, child in enumerate(children):
                if isinstance(child, Cuttable):
                    child = child.decorated
                first = child.children[0] if isinstance(child, py_trees.composites.Sequence) and child.children else None
                trigger = first if isinstance(first, Trigger) and first.env is self.env else None
                sleeper.append(trigger)
                if trigger is not None:
                    for p in trigger.waits_for:
                        waiters.setdefault(p, []).append(i)
            self._sleeper, self._waiters = sleeper, waiters
        pending = [i for i, child in enumerate(children) if child.status != _SUCCESS]
        self._succeeded = len(children) - len(pending)
        self._queued = bytearray(len(children))
        for i in pending:
            self._queued[i] = 1
        self._heap, self._next = pending, []

    def _marked(self, entry_id: str) -> None:
        """:meth:`Environment.mark_done` was called: wake the children waiting for *entry_id*."""
        queued = self._queued
        for i in self._waiters.get(entry_id, ()):
            if not queued[i]:
                queued[i] = 1
                if i > self._at:
                    heappush(self._heap, i)
                else:
                    self._next.append(i)

    def _cut(self, entry_id: str) -> None:
        """:meth:`Environment.mark_cut` was called: the children waiting for *entry_id* look at their join in this
        pass, even those before the child being ticked - a join that can no longer fire gives up on the tick
        its last hope went, whatever the order (their trigger cannot fire from a cut: only give up or wait)."""
        queued = self._queued
        for i in self._waiters.get(entry_id, ()):
            if not queued[i]:
                queued[i] = 1
                if self._passing:
                    heappush(self._heap, i)
                else:
                    self._next.append(i)

    @ends_with_itself
    def tick(self) -> typing.Iterator[py_trees.behaviour.Behaviour]:
        children = self.children
        if self.status != _RUNNING:
            for child in children:
                if child.status != _INVALID:
                    child.stop(_INVALID)
            self.current_child = None
            self.initialise()
            self._prepare(everything=True)
        elif self._passing:  # the last pass was abandoned half-way (an exception): tick everyone once
            self._prepare(everything=False)
        if not children:
            self.current_child = None
            self.stop(_SUCCESS)
            yield self
            return
        heap, queued, sleeper = self._heap, self._queued, self._sleeper
        if self._next:
            heap.extend(self._next)
            self._next = []
        heapify(heap)
        failed = -1
        self._at = -1
        self._passing = True
        while heap:
            i = heappop(heap)
            queued[i] = 0
            if i > self._at:  # (a join given up on may come back to an earlier child: see _cut)
                self._at = i
            child = children[i]
            if child.status == _SUCCESS:
                continue
            if type(child).tick is NODE_TICK:  # a leaf of ours (see Parallel.tick)
                child.tick_now()
                yield child
            else:
                yield from child.tick()
            status = child.status
            if status == _SUCCESS:
                self._succeeded += 1
            elif status == _FAILURE:
                if failed < 0:
                    failed = i
            elif not queued[i]:
                trigger = sleeper[i]
                if trigger is None or trigger.status != _RUNNING:
                    queued[i] = 1
                    self._next.append(i)
        self._passing = False
        self._at = len(children)
        self._heap, self._next = self._next, heap  # heap is empty: it collects wakes until the next pass
        new_status = _RUNNING
        self.current_child = children[-1]
        if failed >= 0:
            new_status = _FAILURE
            self.current_child = children[failed]
        elif self._succeeded == len(children):
            new_status = _SUCCESS
        if new_status != _RUNNING:
            self.stop(new_status)
        self.status = new_status
        yield self


class OrMember(py_trees.decorators.Decorator, Node):
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
        # how many members have failed in this run: one shared counter under the tree's namespace
        # (cleared with it at the start of each run), so "has every member failed?" costs O(1), not a
        # scan of the group by each latched member on every tick (O(N^2) per tick for N members)
        self._failed_count = f"{env.namespace}/failed_count/{self.group[0] if self.group else member}"

    def initialise(self) -> None:
        self.latched = False

    @ends_with_itself
    def tick(self) -> typing.Iterator[py_trees.behaviour.Behaviour]:
        if self.status != _RUNNING:
            self.initialise()
        if not self.latched:
            decorated = self.decorated
            if type(decorated).tick is NODE_TICK:  # a leaf of ours (see Completion.tick)
                decorated.tick_now()
                yield decorated
            else:
                yield from decorated.tick()
            if self.decorated.status == _FAILURE:
                self.latched = True
                if not self.env.is_failed(self.member):
                    self.env.mark_failed(self.member)
                    storage = Blackboard.storage
                    storage[self._failed_count] = storage.get(self._failed_count, 0) + 1
        new_status = self.update()
        if new_status != _RUNNING:
            self.stop(new_status)
        self.status = new_status
        yield self

    def update(self) -> Status:
        if not self.latched:
            return self.decorated.status
        if Blackboard.storage.get(self._failed_count, 0) >= len(self.group):
            self.feedback_message = "every member of the group failed"
            return _FAILURE
        self.feedback_message = "failed; the group may still pass"
        return _RUNNING


class Cuttable(py_trees.decorators.Decorator, Node):
    """A branch (a chain's Sequence under a Parallel) that a stopped entry may end: finished, not failed.

    A stopped entry (:class:`~btgen_pytrees.leaves.control.Controlled`) or a join that can no longer fire
    (:class:`CutTrigger`) fails its Sequence and sets the environment's ``cutting``; the failure reaches this
    node first, which takes the flag back, marks every entry of the branch that is not done as *cut*
    (:meth:`Environment.mark_cut`: joins waiting for them may give up in turn) and succeeds. Any other
    failure passes through. Only cases with ``stops`` or ``race`` have these nodes.
    """

    def __init__(self, child: py_trees.behaviour.Behaviour, env: Environment):
        super().__init__(name=child.name, child=child)
        self.env = env
        self.cut = False

    def initialise(self) -> None:
        self.cut = False

    def update(self) -> Status:
        """(Its :meth:`tick` decides; py_trees' ``Decorator`` asks every decorator for one.)"""
        return self.decorated.status

    @ends_with_itself
    def tick(self) -> typing.Iterator[py_trees.behaviour.Behaviour]:
        if self.status != _RUNNING:
            self.initialise()
        decorated = self.decorated
        if type(decorated).tick is NODE_TICK:
            decorated.tick_now()
            yield decorated
        else:
            yield from decorated.tick()
        new_status = decorated.status
        env = self.env
        if new_status == _FAILURE and env.cutting:
            env.cutting = False
            self.cut = True
            self.feedback_message = "ended by a stop"
            for node in decorated.iterate():
                if isinstance(node, Completion) and node.marks is not None and not env.is_done(node.marks):
                    env.mark_cut(node.marks)
            new_status = _SUCCESS
        if new_status != _RUNNING:
            self.stop(new_status)
        self.status = new_status
        yield self


class CutTrigger(Trigger):
    """A :class:`Trigger` that gives up once its join can no longer fire: ``any`` when every predecessor is cut,
    ``all`` when one is (cut entries never succeed). It then fails with the environment's ``cutting`` set, so its
    branch's :class:`Cuttable` ends the branch, unrun, as finished."""

    def update(self) -> Status:
        status = super().update()
        if status != _RUNNING:
            return status
        is_cut, is_done = self.env.is_cut, self.env.is_done
        if self.join == "any":
            dead = all(is_cut(p) for p in self.waits_for)
        else:
            dead = any(is_cut(p) and not is_done(p) for p in self.waits_for)
        if dead:
            self.feedback_message = "never fires: a predecessor was stopped"
            self.env.cutting = True
            return _FAILURE
        return _RUNNING
