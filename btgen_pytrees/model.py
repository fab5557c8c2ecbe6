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

__all__ = ["Entry", "Criterion", "TestCase", "SystemSpec", "label", "DEFAULT_TICK",
           "DEFAULT_TIMEOUT", "DEFAULT_JOIN", "tick_count"]

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
        type: ``record``, ``period`` or ``final``
        expect: the parsed expectation
        start, end: a period's window in run seconds (``from``/``to``); ``None`` = default
        at: a final's evaluation time; ``None`` = when the execute subtree finishes
        action: selects a user oracle leaf registered for ``(type, action)``; ``None``: the built-in
        params, expressions: the user leaf's parameters, and those it declares as expressions, parsed
    """

    id: str
    type: str
    expect: Expression
    name: str
    index: int
    start: float | None = None
    end: float | None = None
    at: float | None = None
    action: str | None = None
    params: Mapping[str, Any] = field(default_factory=lambda: EMPTY)
    expressions: Mapping[str, Expression] = field(default_factory=lambda: EMPTY)

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
    """

    type: str = "simulated"
    config: str | None = None
    options: tuple[str, ...] = ()


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

    @property
    def ticks(self) -> int:
        """The ticks of a run that is not stopped earlier (:func:`tick_count`); the last one is at ``timeout``."""
        return tick_count(self.timeout, self.tick)
