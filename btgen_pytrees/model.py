"""The validated test case, as plain immutable data.

The loader turns JSON into these objects once; everything after it (the
timeline graph, the construction, the leaves, the views) reads them and never
the raw JSON again.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Mapping

from .expressions import Expression
from .formulas import Formula

__all__ = ["Entry", "Control", "StopCondition", "Criterion", "TestCase", "SystemSpec", "label", "DEFAULT_TICK",
           "DEFAULT_TIMEOUT", "DEFAULT_JOIN", "tick_count", "EDGES", "STATES", "state_signal"]

EMPTY: Mapping[str, Any] = MappingProxyType({})

DEFAULT_TICK = 0.1
"""Virtual seconds per tick when a case gives no ``tick``."""

DEFAULT_TIMEOUT = 60.0
"""Virtual seconds before a run is stopped when a case gives no ``timeout``."""

DEFAULT_JOIN = "any"
"""The join of an entry with several predecessors when neither it nor the case gives one."""


def tick_count(timeout: float, tick: float) -> int:
    """How many ticks a run that is not stopped earlier takes: at t = 0, tick, 2 tick, ... up to *timeout*.

    (``1e-9`` absorbs the rounding of ``timeout / tick``: 0.3 / 0.1 is 2.9999999999999996.)

    >>> tick_count(60.0, 0.1), tick_count(0.3, 0.1), tick_count(0.0, 0.1)
    (601, 4, 1)
    """
    return int(timeout / tick + 1e-9) + 1


def label(id: str, name: str) -> str:
    """``id``, or ``id (name)`` when a ``name`` other than the id was given.

    >>> label("B3", "B3"), label("B3", "accelerate")
    ('B3', 'B3 (accelerate)')
    """
    return id if not name or name == id else f"{id} ({name})"


EDGES = ("none", "rising", "falling", "any")
"""The values of ``edge``: what a ``when`` must do to fire (``none``: hold)."""

STATES = ("started", "running", "ended", "succeeded", "failed", "stopped")
"""An entry's states that a ``when`` (or a ``stop``) may read as the boolean signal ``<id>.<state>``."""


def state_signal(entry_id: str, state: str) -> str:
    """The signal name of an entry's state, ``<id>.<state>`` (see docs/format.md#control-flow).

    >>> state_signal("A1", "ended")
    'A1.ended'
    """
    return f"{entry_id}.{state}"


@dataclass(frozen=True, eq=False, slots=True)
class Control:
    """An entry's control-flow keys (docs/format.md#control-flow); ``None`` on an entry without any.

    Attributes:
        when: the start condition, parsed (``None``: start as soon as the predecessors are done)
        edge: ``none``, ``rising``, ``falling`` or ``any`` (see :data:`EDGES`)
        delay: seconds from the trigger to the start
        timeout: seconds an attempt may run before it fails (``None``: no limit)
        attempts: tries in all (a failed attempt starts again, up to this many)
        repeat: runs in a row (each waits for ``when``/``delay`` again)
        stops: ids of the entries stopped when this one starts
        race: the race group's name (``None``: no race)
        watched: another entry's ``when`` or a ``stop`` reads this entry's states (``<id>.<state>``)
    """

    when: Expression | None = None
    edge: str = "none"
    delay: float = 0.0
    timeout: float | None = None
    attempts: int = 1
    repeat: int = 1
    stops: tuple[str, ...] = ()
    race: str | None = None
    watched: bool = False

    @property
    def summary(self) -> str:
        """The keys in a few words, for views: ``when gap < 20 (rising), delay 1 s, 3 attempts``."""
        parts = []
        if self.when is not None:
            parts.append(f"when {self.when.source}" + (f" ({self.edge})" if self.edge != "none" else ""))
        if self.delay:
            parts.append(f"delay {self.delay:g} s")
        if self.timeout is not None:
            parts.append(f"timeout {self.timeout:g} s")
        if self.attempts > 1:
            parts.append(f"{self.attempts} attempts")
        if self.repeat > 1:
            parts.append(f"repeat {self.repeat}")
        if self.stops:
            parts.append("stops " + ", ".join(self.stops))
        if self.race is not None:
            parts.append(f"race {self.race}")
        return ", ".join(parts)


@dataclass(frozen=True, eq=False, slots=True)
class StopCondition:
    """One item of the case's top-level ``stop``: the run ends when ``when`` fires (after ``delay``).

    Attributes:
        when, edge, delay: as for :class:`Control`
        index: position in the ``stop`` array
    """

    when: Expression
    edge: str = "none"
    delay: float = 0.0
    index: int = 0

    @property
    def path(self) -> tuple[str | int, ...]:
        return ("stop", self.index)

    @property
    def label(self) -> str:
        """How reports name it: ``stop[0]``."""
        return f"stop[{self.index}]"


@dataclass(frozen=True, eq=False, slots=True)
class Entry:
    """One execute entry: a behaviour or a constraint on the timeline.

    Attributes:
        id: unique identifier
        kind: ``behavior`` or ``constraint``
        action: the leaf type (``set``, ``ramp``, ... or a user action)
        params: the action's parameters, as written
        after: ids of the predecessors, in the order written
        join: ``any`` or ``all`` for entries with several predecessors
        name: display label (the id when none was given)
        index: position in the file's ``execute`` list
        expressions: parameters that the action declares as expressions, parsed
        control: the control-flow keys (:class:`Control`), ``None`` when it has none
    """

    id: str
    kind: str
    action: str
    params: Mapping[str, Any]
    after: tuple[str, ...]
    join: str
    name: str
    index: int
    expressions: Mapping[str, Expression] = field(default_factory=lambda: EMPTY)
    control: Control | None = None

    @property
    def path(self) -> tuple[str | int, ...]:
        return ("execute", self.index)

    @property
    def label(self) -> str:
        """How reports name the entry: its id, and its ``name`` in parentheses when it has one."""
        return label(self.id, self.name)


@dataclass(frozen=True, eq=False, slots=True)
class Criterion:
    """One oracle criterion.

    Attributes:
        id, name, index: as for :class:`Entry`
        type: ``record``, ``period``, ``final`` or ``temporal``
        expect: the parsed expectation (a temporal criterion's: a :class:`~btgen_pytrees.formulas.Formula`)
        start, end: a period's window in run seconds (``from``/``to``); ``None`` = default; a temporal
            criterion's anchor in seconds (``from``)
        anchor: a temporal criterion's anchor at an entry, ``(entry id, "start" | "end")``; ``None``: ``start``
        tick: the case's tick (a temporal criterion's windows count ticks)
        at: a final's evaluation time; ``None`` = when the execute subtree finishes
        action: selects a user oracle leaf registered for ``(type, action)``; ``None``: the built-in
        params, expressions: the user leaf's parameters, and those it declares as expressions, parsed
    """

    id: str
    type: str
    expect: Expression | Formula
    name: str
    index: int
    start: float | None = None
    end: float | None = None
    at: float | None = None
    action: str | None = None
    params: Mapping[str, Any] = field(default_factory=lambda: EMPTY)
    expressions: Mapping[str, Expression] = field(default_factory=lambda: EMPTY)
    anchor: tuple[str, str] | None = None
    tick: float = DEFAULT_TICK

    @property
    def path(self) -> tuple[str | int, ...]:
        return ("oracle", "criteria", self.index)

    @property
    def label(self) -> str:
        """How reports name the criterion (see :attr:`Entry.label`)."""
        return label(self.id, self.name)


@dataclass(frozen=True)
class SystemSpec:
    """What a case (or ``run --system TYPE[:CONFIG]``) says about its system.

    Attributes:
        type: the system type's name (``simulated``, ``sumo``, ...)
        config: the configuration file, resolved relative to the case file
            (``None`` when the type needs none)
        options: simulator options, each checked against the type's allow-list
        road: an OpenDRIVE road network (``.xodr``), resolved relative to the case file, that the
            type builds its scenario on (``sumo``: docs/opendrive.md), or ``None``
        entities: the case's ``entities`` (what stands on that road), as JSON text, or ``None``
    """

    type: str = "simulated"
    config: str | None = None
    options: tuple[str, ...] = ()
    road: str | None = None
    entities: str | None = None


@dataclass(frozen=True, eq=False)
class TestCase:
    """A validated test case.

    Attributes:
        name, description: as written
        signals: initial signal values (empty when the file gives none)
        declares_signals: whether the file had a ``signals`` object (names are then checked)
        tick, timeout: virtual seconds per tick and before a run is stopped
        join: the default join
        entries: execute entries in file order
        criteria: oracle criteria in file order
        relation: ``{"record": "&&"|"||", "others": "&&"|"||"}``
        source: file name, or ``<dict>``
        system: the system under test (``simulated`` unless the case names one)
        require_complete: a run that passes with entries unfinished fails instead
        warnings: problems (:class:`~btgen_pytrees.errors.Problem`) that do not stop a run,
            e.g. two entries that may write one signal at once (:mod:`btgen_pytrees.load.warnings`)
        stop: the top-level ``stop`` conditions (:class:`StopCondition`; empty: none)
    """

    __test__ = False  # not a pytest class, despite the name

    name: str
    entries: tuple[Entry, ...]
    criteria: tuple[Criterion, ...] = ()
    signals: Mapping[str, Any] = field(default_factory=lambda: EMPTY)
    declares_signals: bool = False
    description: str = ""
    tick: float = DEFAULT_TICK
    timeout: float = DEFAULT_TIMEOUT
    join: str = DEFAULT_JOIN
    relation: Mapping[str, str] = field(default_factory=lambda: MappingProxyType({"record": "&&", "others": "&&"}))
    source: str = "<dict>"
    system: SystemSpec = SystemSpec()
    require_complete: bool = False
    warnings: tuple[Any, ...] = ()
    stop: tuple[StopCondition, ...] = ()

    @property
    def controlled(self) -> bool:
        """Whether an entry has control-flow keys or the case has a ``stop`` (the tree then has their nodes)."""
        return bool(self.stop) or any(e.control is not None for e in self.entries)

    @property
    def ticks(self) -> int:
        """The ticks of a run that is not stopped earlier (:func:`tick_count`); the last one is at ``timeout``."""
        return tick_count(self.timeout, self.tick)
