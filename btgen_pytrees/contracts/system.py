"""The system under test: what a generated tree drives and judges.

A :class:`System` is the other side of a run. The tree's leaves act on it (its
actions are leaf factories in the :class:`~btgen_pytrees.contracts.registry.Registry`,
named ``<system>.<action>``, e.g. ``sumo.speed``), and the oracles judge the
signals it publishes. One run drives one system instance through this life
cycle, and the runner (or a host application) guarantees the order::

    system = system_type.create(spec, case)      # nothing started yet
    system.start(env)                             # time 0; may launch a process
    while the run goes on:
        system.publish(env)                       # owned signals -> blackboard
        root.tick()                               # the tree reads and acts
        system.tick()                             # advance one step (case.tick)
    system.close()                                # always: pass, fail, timeout,
                                                  # a leaf that raised, Ctrl-C

*The system's time is the run's clock*: :meth:`System.now` is what leaves and
oracles read (through the tree's :class:`~btgen_pytrees.contracts.environment.Environment`),
so a simulator that steps faster than real time makes the whole test faster
than real time, and a run is as reproducible as the system is.

Signals a system *owns* are read-only for the test: the loader rejects a
built-in ``set``/``ramp`` on them, and the case's initial ``signals`` never
overwrite them. The built-in simulated signals are the first implementation
(:mod:`btgen_pytrees.systems.simulated`): it owns no signals, and its clock is
the virtual clock that moves by ``tick`` per tree tick.

A back end is added like a leaf plugin: ``registry.register_system(SystemType)``
in a ``register(registry)`` function reached through the ``btgen_pytrees.leaves``
entry points or ``--plugin``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Collection, Mapping, Protocol, runtime_checkable

from ..model import SystemSpec  # case data, defined with the case (re-exported here and in systems)
from .environment import Environment

if TYPE_CHECKING:  # pragma: no cover
    from ..errors import Problem
    from ..model import TestCase

__all__ = ["System", "SystemType", "SystemSpec", "SystemInfo", "SystemFailure"]


@dataclass(frozen=True)
class SystemInfo:
    """What the loader needs to know about a configured system, before any run.

    Attributes:
        signals: names of the signals the system owns (read-only for the test);
            expressions may read them, ``set``/``ramp`` may not write them
        problems: what is wrong with the configuration, as
            :class:`~btgen_pytrees.errors.Problem` s (JSON path into the case)
        extra: anything else the type wants to pass on
        writers: see below
    """

    signals: Collection[str] = ()
    problems: tuple["Problem", ...] = ()
    extra: Mapping[str, Any] = field(default_factory=dict)
    writers: Mapping[str, str] = field(default_factory=dict)
    """Optional: owned signal -> the action that changes it (``{"ego.speed": "sumo.speed"}``),
    named by the loader when a ``set``/``ramp`` tries to write that signal."""


class SystemFailure(RuntimeError):
    """The system failed while a run used it (it ended early, refused a command, ...).

    The runner ends the run with verdict ``error`` and this message; it is never
    shown as a traceback.
    """


@runtime_checkable
class System(Protocol):
    """One started-or-startable instance of a system under test, for one run."""

    def start(self, env: "Environment") -> None:
        """Start for a run at time 0 (launch the simulator, load the scenario)."""

    def now(self) -> float:
        """The system's time in seconds: the run's clock."""

    def publish(self, env: "Environment") -> None:
        """Write the current value of every owned signal to *env* (before each tree tick); where
        ``env.wanted`` is a set of names (a run that records no trace), those are enough."""

    def tick(self) -> None:
        """Advance by one step (``case.tick`` seconds), after each tree tick."""

    def close(self) -> None:
        """Release everything (processes, ports, files); safe to call twice or before start."""


class SystemType(Protocol):
    """A kind of system, as registered: its name, its checks and its factory."""

    name: str
    """``simulated``, ``sumo``, ...; also the prefix of its actions (``sumo.speed``)."""

    options: Collection[str]
    """The allow-list of simulator options a case may pass (documented in docs/format.md)."""

    def describe(self, spec: SystemSpec, case_data: Mapping[str, Any]) -> SystemInfo:
        """Check *spec* (and the case's raw data) without starting anything; list owned signals."""

    def create(self, spec: SystemSpec, case: "TestCase") -> System:
        """A new, not yet started, instance for one run of *case*."""
