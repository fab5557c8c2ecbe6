"""The nodes of the control-flow keys (docs/format.md#control-flow, docs/algorithms.md#control-flow).

An entry with control keys is built, outermost first, as::

    Controlled(entry)                     tagged with the entry: its status is the entry's
      Repetitions(repeat)                 py_trees' Repeat        (repeat > 1)
        Gate(when, edge, delay)           the trigger: holds the action until due (when / delay)
          Attempts(attempts)              py_trees' Retry         (attempts > 1)
            VirtualTimeout(timeout)       py_trees' Timeout       (timeout)
              leaf                        the entry's action, as without the keys

Each node is there only when its key is. The decorators are py_trees' own classes, changed where the
timing rules of docs/semantics.md need it: they read the run's clock (the environment's, never the wall
clock unless the case runs on one), and a retried attempt or a new repetition starts on the tick the
previous one ended - ticked again in the same tick, as a Sequence ticks the next child on the tick the
one before it succeeded.

The case's ``stop`` is a :class:`StopGuard` around the execute subtree. ``stops`` and ``race`` go through
the blackboard: a starting entry (or a race's winner) writes a stop request under ``<ns>/stop/<id>``; the
stopped entry's :class:`Controlled` reads it on its next tick. A stop issued on tick *k* stops the entries
that were running on tick *k*, on tick *k + 1*, before their action ticks again - whatever their order in
the tree, so the outcome never depends on which branch ticks first. A stopped entry fails its branch
without a done mark (its successors do not start from it); the branch's
:class:`~btgen_pytrees.leaves.wiring.Cuttable` ends the branch as finished.
"""

from __future__ import annotations

import typing

import py_trees
from py_trees.blackboard import Blackboard
from py_trees.common import Status

from ..contracts.environment import Environment
from ..expressions import Expression, ExpressionError
from ..model import Control, Entry, StopCondition, state_signal
from .composites import ends_with_itself
from .node import NODE_TICK, Node
from .simulated import reached

__all__ = ["Condition", "Gate", "VirtualTimeout", "Attempts", "Repetitions", "Controlled", "StopGuard", "controlled"]

_SUCCESS, _FAILURE, _RUNNING, _INVALID = Status.SUCCESS, Status.FAILURE, Status.RUNNING, Status.INVALID


def _decorate(node: Node, name: str, child: py_trees.behaviour.Behaviour) -> None:
    """What ``py_trees.decorators.Decorator.__init__(node, name=name, child=child)`` does to a node of this module: the
    child checked, :class:`~btgen_pytrees.leaves.node.Node`'s ``__init__``, the child held (``children``,
    ``decorated``) and its parent set - without the chain of ``super().__init__`` calls with keywords through
    py_trees' decorator classes, a third of what building one costs (a 100,000-entry case may have tens of
    thousands). Each class here then sets what its py_trees base's ``__init__`` sets; ``tests/test_control.py``
    compares the attributes with those py_trees' own ``__init__`` chain gives, in order."""
    if not isinstance(child, py_trees.behaviour.Behaviour):
        raise TypeError("A decorator's child must be an instance of py_trees.behaviours.Behaviour")
    Node.__init__(node, name)
    node.children.append(child)
    node.decorated = child
    child.parent = node


def _tick(node: py_trees.behaviour.Behaviour) -> typing.Iterator[py_trees.behaviour.Behaviour]:
    """Tick *node* once, yielding what its tick yields (a leaf of the package without a generator)."""
    if type(node).tick is NODE_TICK:
        node.tick_now()
        yield node
    else:
        yield from node.tick()


class Condition:
    """A ``when`` with its ``edge`` and ``delay``: fires on the first tick the expression holds (or changes, with
    an edge), then is due on the first tick with ``now >= fired + delay``.

    Not a node: the :class:`Gate` of an entry and the :class:`StopGuard` of the case's ``stop`` each hold one.
    A signal without a value makes the expression false (as for ``until``). The first evaluation after
    :meth:`reset` is never an edge.
    """

    __slots__ = ("when", "edge", "delay", "names", "last", "fired")

    def __init__(self, when: Expression | None, edge: str = "none", delay: float = 0.0):
        self.when = when
        self.edge = edge
        self.delay = delay
        self.names = when.ordered_names if when is not None else ()
        self.last: bool | None = None
        self.fired: float | None = None

    def reset(self) -> None:
        self.last = None
        self.fired = None

    def holds(self, env: Environment, client: typing.Any = None) -> bool:
        """The expression now (false when it cannot be evaluated)."""
        if self.when is None:
            return True
        try:
            return bool(self.when.evaluate(env.values(self.names, client)))
        except (ExpressionError, TypeError, ZeroDivisionError, ValueError):
            return False

    def due(self, env: Environment, now: float, client: typing.Any = None) -> bool:
        """Evaluate (until it has fired) and say whether the start is due now."""
        if self.fired is None:
            value = self.holds(env, client)
            edge, last = self.edge, self.last
            self.last = value
            if edge == "none":
                fired = value
            elif last is None:
                fired = False
            elif edge == "rising":
                fired = value and not last
            elif edge == "falling":
                fired = last and not value
            else:
                fired = value != last
            if not fired:
                return False
            self.fired = now
        return not self.delay or reached(now - self.fired, self.delay)

    def describe(self) -> str:
        parts = []
        if self.when is not None:
            parts.append(f"when {self.when.source}" + (f" ({self.edge})" if self.edge != "none" else ""))
        if self.delay:
            parts.append(f"delay {self.delay:g} s")
        return ", ".join(parts)


class Gate(py_trees.decorators.Decorator, Node):
    """The trigger before an entry's action: its child is not ticked until the :class:`Condition` is due (RUNNING
    until then), then on that very tick and on every one after, passing the child's status through - as
    BehaviorTree.CPP's ``Delay`` holds its child, with the ``when`` and ``edge`` before the delay. A new start
    (a repetition) waits again.

    Args:
        child: what starts: the entry's action, with its attempts and timeout
        owner: the entry's :class:`Controlled` (told when the action starts)
        condition: the entry's ``when``, ``edge`` and ``delay``
        env: the tree's environment
    """

    def __init__(self, child: py_trees.behaviour.Behaviour, owner: "Controlled", condition: Condition, env: Environment):
        _decorate(self, condition.describe(), child)
        self.owner = owner
        self.condition = condition
        self.env = env
        self.open = False  # the condition was due: the child runs
        self.client = env.attach_signals(self, condition.names)

    def initialise(self) -> None:
        self.condition.reset()
        self.open = False
        self.feedback_message = "waiting"

    def update(self) -> Status:
        """(Its :meth:`tick` decides; py_trees' ``Decorator`` asks every decorator for one.)"""
        return self.decorated.status if self.open else _RUNNING

    @ends_with_itself
    def tick(self) -> typing.Iterator[py_trees.behaviour.Behaviour]:
        if self.status != _RUNNING:
            self.initialise()
        if not self.open:
            condition, now = self.condition, self.env.now()
            if condition.due(self.env, now, self.client):
                self.open = True
                self.feedback_message = "fired" if condition.fired == now else f"fired at {condition.fired:.6g} s"
                self.owner.begin(now)
            elif condition.fired is not None:
                self.feedback_message = f"fired at {condition.fired:.6g} s, waiting {condition.delay:g} s"
        if self.open:
            yield from _tick(self.decorated)
            new_status = self.decorated.status
        else:
            new_status = _RUNNING
        if new_status != _RUNNING:
            self.stop(new_status)
        self.status = new_status
        yield self


class VirtualTimeout(py_trees.decorators.Timeout, Node):
    """py_trees' ``Timeout`` on the run's clock: an attempt that has not finished ``duration`` seconds after it
    started fails on the first tick with ``now >= start + duration`` (the child is ticked first: one that finishes
    on that tick keeps its status)."""

    def __init__(self, child: py_trees.behaviour.Behaviour, duration: float, env: Environment, owner: "Controlled"):
        _decorate(self, f"timeout {duration:g} s", child)
        self.duration = duration  # (py_trees' Timeout.__init__)
        self.finish_time = 0.0
        self.env = env
        self.owner = owner
        self.started = 0.0

    def initialise(self) -> None:
        self.started = self.env.now()
        self.finish_time = self.started + self.duration
        self.feedback_message = ""

    def update(self) -> Status:
        status = self.decorated.status
        if status == _RUNNING and reached(self.env.now() - self.started, self.duration):
            self.feedback_message = f"timed out after {self.duration:g} s"
            self.owner.timed_out = True
            self.decorated.stop(_INVALID)
            return _FAILURE
        self.feedback_message = ""
        return status


class Attempts(py_trees.decorators.Retry, Node):
    """py_trees' ``Retry``: a failed attempt starts again, up to ``num_failures`` tries in all - on the tick it
    failed (the child is ticked again in the same tick)."""

    def __init__(self, child: py_trees.behaviour.Behaviour, attempts: int, owner: "Controlled"):
        _decorate(self, f"{attempts} attempts", child)
        self.failures = 0  # (py_trees' Retry.__init__)
        self.num_failures = attempts
        self.owner = owner

    def initialise(self) -> None:
        super().initialise()
        self.owner.attempt = 1

    @ends_with_itself
    def tick(self) -> typing.Iterator[py_trees.behaviour.Behaviour]:
        if self.status != _RUNNING:
            self.initialise()
        decorated = self.decorated
        while True:
            yield from _tick(decorated)
            if decorated.status != _FAILURE or self.failures + 1 >= self.num_failures:
                break
            self.failures += 1
            self.owner.retry(self.failures + 1, self.num_failures, _message(decorated))
        new_status = self.update()
        if new_status != _RUNNING:
            self.stop(new_status)
        self.status = new_status
        yield self


class Repetitions(py_trees.decorators.Repeat, Node):
    """py_trees' ``Repeat``: the entry runs ``num_success`` times in a row, a new repetition starting on the tick
    the one before it succeeded (each waits for its ``when``/``delay`` again); the first failure fails it."""

    def __init__(self, child: py_trees.behaviour.Behaviour, repeat: int, owner: "Controlled", starts: bool):
        _decorate(self, f"repeat {repeat}", child)
        self.success = 0  # (py_trees' Repeat.__init__)
        self.num_success = repeat
        self.owner = owner
        self.starts = starts  # no Gate below: a repetition's start is the action's

    def initialise(self) -> None:
        super().initialise()
        self.owner.repetition = 1

    @ends_with_itself
    def tick(self) -> typing.Iterator[py_trees.behaviour.Behaviour]:
        if self.status != _RUNNING:
            self.initialise()
        decorated = self.decorated
        owner = self.owner
        while True:
            if self.starts and decorated.status != _RUNNING:
                owner.begin(owner.env.now())
            yield from _tick(decorated)
            if decorated.status != _SUCCESS or self.success + 1 >= self.num_success:
                break
            self.success += 1
            owner.repeated(self.success + 1, self.num_success)
        new_status = self.update()
        if new_status != _RUNNING:
            self.stop(new_status)
        self.status = new_status
        yield self


def _message(node: py_trees.behaviour.Behaviour) -> str:
    """The deepest feedback message of a finished subtree (the action's, or a timeout's)."""
    found = ""
    while True:
        if node.feedback_message:
            found = node.feedback_message
        if isinstance(node, py_trees.decorators.Decorator):
            node = node.decorated
        elif node.children:
            current = getattr(node, "current_child", None)
            node = current if current is not None else node.children[-1]
        else:
            return found


class Controlled(py_trees.decorators.Decorator, Node):
    """An entry with control keys: its status is the entry's, and it is what the run's report follows.

    It notes when the action first started (:attr:`started`; the entry waits for its ``when`` before),
    the attempt and repetition under way, why it failed, and whether it was stopped (:attr:`stopped_by`);
    :attr:`events` are the ``--trace`` lines of attempts and repetitions, which the run's collector takes.
    When the entry starts it writes the stop requests of its ``stops``; a race's winner those of the other
    members. With ``watched`` it publishes its states as the signals ``<id>.<state>``.

    Args:
        child: the entry's subtree below it (the decorators, the gate, the leaf)
        entry: the entry
        env: the tree's environment
        rivals: the other members of its race (empty when it runs in none)
    """

    def __init__(self, child: py_trees.behaviour.Behaviour, entry: Entry, env: Environment, rivals: tuple[str, ...] = ()):
        _decorate(self, entry.name, child)
        self.entry = entry
        self.control: Control = entry.control or Control()
        self.env = env
        self.rivals = rivals
        self.stop_key = env.stop_key(entry.id)
        self.starts_itself = True  # no Gate or Repetitions below tells it the action started
        self.reset()

    def reset(self) -> None:
        self.started: float | None = None
        self.attempt = 1
        self.repetition = 1
        self.timed_out = False
        self.cut = False
        self.stopped_by: tuple[str, float, str] | None = None  # (who, when, how: "stops" or "race")
        self.why = ""  # why it failed, or was stopped; where it was when the run ended around it (progress())
        self.events: list[tuple[float, str, str]] | None = None  # made by the first event (see note())
        self.since = 0  # the tick number it became active on

    def initialise(self) -> None:
        self.reset()
        self.since = self.env.ticks
        if self.control.watched:
            self.publish(running=False)

    # -- what the nodes below tell it -------------------------------------------------------------------------
    def begin(self, now: float) -> None:
        """The action starts (its first start, or a new repetition's)."""
        if self.started is None:
            self.started = now
            self.note(now, "start", "")
        env = self.env
        for target in self.control.stops:
            env.request_stop(target, self.entry.id, now, "stops")
        if self.control.watched:
            self.publish(running=True)

    def note(self, now: float, event: str, text: str) -> None:
        """An event for the ``--trace`` (the run's collector takes them after the node's tick)."""
        if self.events is None:
            self.events = []  # (most entries never get one before their start: no list per node for nothing)
        self.events.append((now, event, text))

    def retry(self, attempt: int, attempts: int, message: str) -> None:
        """Attempt *attempt* starts: the last one failed with the action's *message* - or timed out, which says so
        (as :meth:`failure` does for the last: the action's own message is only its progress then)."""
        if self.timed_out:
            message = f"timed out after {self.control.timeout:g} s"
        self.attempt = attempt
        self.timed_out = False
        now = self.env.now()
        self.note(now, "attempt", f"{attempt} of {attempts}" + (f" after: {message}" if message else ""))

    def repeated(self, repetition: int, repeat: int) -> None:
        self.repetition = repetition
        self.attempt = 1
        now = self.env.now()
        self.note(now, "repeat", f"repetition {repetition} of {repeat}")
        if self.control.watched:
            self.publish(running=False)

    def publish(self, *, running: bool, ended: str = "") -> None:
        """Post the entry's states (seen from the next tick on, whatever the tree's order)."""
        post, id_ = self.env.post, self.entry.id
        post(state_signal(id_, "started"), self.started is not None)
        post(state_signal(id_, "running"), running)
        post(state_signal(id_, "ended"), bool(ended))
        for state in ("succeeded", "failed", "stopped"):
            post(state_signal(id_, state), ended == state)

    # -- the tick -------------------------------------------------------------------------------------------
    def update(self) -> Status:
        """(Its :meth:`tick` decides; py_trees' ``Decorator`` asks every decorator for one.)"""
        return self.decorated.status

    @ends_with_itself
    def tick(self) -> typing.Iterator[py_trees.behaviour.Behaviour]:
        if self.status != _RUNNING:
            self.initialise()
            if self.starts_itself:
                self.begin(self.env.now())
        request = Blackboard.storage.get(self.stop_key) if self.stop_key in Blackboard.storage else None
        if request is not None and self.stopped(request):
            if self.decorated.status == _RUNNING:
                self.decorated.stop(_INVALID)
            new_status = _FAILURE
        else:
            yield from _tick(self.decorated)
            new_status = self.decorated.status
            if new_status == _FAILURE:
                self.why = self.failure()
            elif new_status == _SUCCESS and self.rivals:
                now = self.env.now()
                for rival in self.rivals:
                    self.env.request_stop(rival, self.entry.id, now, "race")
        if new_status != _RUNNING:
            if self.control.watched:
                self.publish(running=False, ended="stopped" if self.cut else "succeeded" if new_status == _SUCCESS else "failed")
            if self.cut:
                self.env.cutting = True
            self.stop(new_status)
        self.status = new_status
        yield self

    def terminate(self, new_status: Status) -> None:
        """Halted while it ran (the run ended around it): note where it was, before its children are reset."""
        if new_status == _INVALID and self.status == _RUNNING:
            self.why = self.progress()

    def stopped(self, requests: list[tuple[str, int, float, str]]) -> bool:
        """Whether a stop request applies: written on an earlier tick than this one, on a tick it was running."""
        ticks = self.env.ticks
        for by, tick, when, how in requests:
            if self.since <= tick < ticks:
                self.cut = True
                self.stopped_by = (by, when, how)
                self.why = f"lost the race to {by}" if how == "race" else f"stopped by {by} at {when:g} s"
                self.feedback_message = self.why
                self.note(self.env.now(), "stopped", self.why)
                return True
        return False

    def failure(self) -> str:
        """Why the entry failed, in the words of the report: ``attempt 3 of 3 failed: <the action's reason>``,
        ``repetition 2 of 3 failed: timed out after 1 s``."""
        control = self.control
        reason = f"timed out after {control.timeout:g} s" if self.timed_out else _message(self.decorated)
        where = []
        if control.repeat > 1:
            where.append(f"repetition {self.repetition} of {control.repeat}")
        if control.attempts > 1:
            where.append(f"attempt {self.attempt} of {control.attempts}")
        if not where:
            return reason
        head = ", ".join(where) + " failed"
        return f"{head}: {reason}" if reason else head

    def progress(self) -> str:
        """Where the entry was when the run ended around it: ``repetition 2 of 3 running``, ``attempt 2 of 3
        running``, ``waiting (when x > 3)``; empty when there is nothing to add."""
        control = self.control
        parts = []
        if control.repeat > 1 and self.started is not None:
            parts.append(f"repetition {self.repetition} of {control.repeat}")
        gate = self.waiting()
        if gate is not None:
            return " ".join([*parts, f"waiting ({gate.name})"])
        if control.attempts > 1:
            parts.append(f"attempt {self.attempt} of {control.attempts}")
        return (", ".join(parts) + " running") if parts else ""

    def waiting(self) -> py_trees.behaviour.Behaviour | None:
        """The gate the entry waits at, if it waits at one."""
        node = self.decorated
        while isinstance(node, py_trees.decorators.Decorator):
            if isinstance(node, Gate):
                return node if node.status == _RUNNING and not node.open else None
            node = node.decorated
        return None


class StopGuard(py_trees.decorators.Decorator, Node):
    """The case's ``stop``: around the execute subtree, checked at the start of every tick, before any entry, and
    again after the entries have ticked (a signal an entry wrote on this tick ends the run on this tick).

    When one of its conditions is due, the execute subtree is halted (running entries are ``stopped``) and this
    node succeeds, so the execute subtree is done: ``final`` criteria without ``at`` are evaluated on this tick,
    periods without ``to`` end on it, and the run ends after it with the oracles' verdict. The stop that fired
    is written to the blackboard (``<ns>/stopped``: its label and time).
    """

    def __init__(self, child: py_trees.behaviour.Behaviour, stops: typing.Sequence[StopCondition], env: Environment):
        super().__init__(name="stop when " + " | ".join(Condition(s.when, s.edge, s.delay).describe()[5:] for s in stops), child=child)
        self.env = env
        self.stops = tuple(stops)
        self.conditions = [Condition(s.when, s.edge, s.delay) for s in stops]
        keys = sorted({env.signal_key(n) for c in self.conditions for n in c.names})
        self.client = env.attach(self, reads=keys) if keys else None

    def initialise(self) -> None:
        for condition in self.conditions:
            condition.reset()

    def update(self) -> Status:
        """(Its :meth:`tick` decides; py_trees' ``Decorator`` asks every decorator for one.)"""
        return self.decorated.status

    def _fired(self, now: float) -> StopCondition | None:
        """The first stop due now (every condition evaluated: each keeps its own edge and delay)."""
        fired = None
        for stop, condition in zip(self.stops, self.conditions):
            if condition.due(self.env, now, self.client) and fired is None:
                fired = stop
        return fired

    @ends_with_itself
    def tick(self) -> typing.Iterator[py_trees.behaviour.Behaviour]:
        if self.status != _RUNNING:
            self.initialise()
        env = self.env
        now = env.now()
        fired = self._fired(now)
        if fired is None:
            yield from _tick(self.decorated)
            new_status = self.decorated.status
            if new_status == _RUNNING:  # again after the entries: what they wrote on this tick ends it on this tick
                fired = self._fired(now)
        if fired is not None:
            if self.decorated.status == _RUNNING:
                self.decorated.stop(_INVALID)
            self.feedback_message = f"{fired.label} fired at {now:g} s"
            env.note_stop(fired.label, now)
            new_status = _SUCCESS
        if new_status != _RUNNING:
            self.stop(new_status)
        self.status = new_status
        yield self


def controlled(leaf: py_trees.behaviour.Behaviour, entry: Entry, env: Environment,
               rivals: tuple[str, ...] = ()) -> Controlled:  # fmt: skip
    """The subtree of an entry with control keys around its *leaf* (see the module), tagged with the entry.

    The leaf keeps its own nodes and clients; its ``btgen_entry`` tag moves to the :class:`Controlled`, and the
    leaf is tagged ``btgen_action`` (views still show it as the entry's action).
    """
    control = entry.control or Control()
    owner = Controlled.__new__(Controlled)
    body: py_trees.behaviour.Behaviour = leaf
    if control.timeout is not None:
        body = VirtualTimeout(body, control.timeout, env, owner)
    if control.attempts > 1:
        body = Attempts(body, control.attempts, owner)
    gated = control.when is not None or control.delay > 0
    if gated:
        body = Gate(body, owner, Condition(control.when, control.edge, control.delay), env)
    if control.repeat > 1:
        body = Repetitions(body, control.repeat, owner, starts=not gated)
    Controlled.__init__(owner, body, entry, env, rivals)
    owner.starts_itself = not gated and control.repeat == 1
    if getattr(leaf, "btgen_entry", None) is entry:
        del leaf.btgen_entry  # type: ignore[attr-defined]
    try:
        leaf.btgen_action = entry  # type: ignore[attr-defined]
    except AttributeError:
        pass
    owner.btgen_entry = entry  # type: ignore[attr-defined]
    return owner
