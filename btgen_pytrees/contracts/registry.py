"""Which py_trees behaviour stands for which entry or criterion.

A :class:`Registry` maps ``(kind, action)`` to a :class:`LeafType`: a factory
that builds the leaf, the JSON schema of the action's ``params`` and which of
them are expressions or signal names (so the loader can check them before any
tree exists). The built-in simulated leaves are registered exactly like user
leaves; nothing downstream special-cases them.

It also holds the *system types* (:mod:`btgen_pytrees.systems`) a case may name
in its ``system`` key: ``register_system(system_type)``, ``system(name)``,
``systems()``. A system's actions are ordinary leaves whose action name is
``<system>.<action>`` (``sumo.speed``), registered with :meth:`Registry.register`.

>>> from btgen_pytrees.leaves import default_registry
>>> default_registry().actions("constraint")
['until', 'wait']
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Any, Callable, Iterable, Mapping, Union

import py_trees

from ..errors import UserError, is_interrupt
from ..model import Criterion, Entry
from ..validator import SchemaValidator, shared_validator
from .environment import Environment
from .system import SystemType

__all__ = ["Factory", "FactoryError", "LeafError", "LeafType", "Registry", "KINDS"]

KINDS = ("behavior", "constraint", "record", "period", "final", "temporal")
Factory = Callable[[Union[Entry, Criterion], Environment], py_trees.behaviour.Behaviour]
"""``factory(entry_or_criterion, environment) -> Behaviour``."""


class LeafError(TypeError):
    """A user leaf's ``update()`` returned something that is not a :class:`py_trees.common.Status`.

    py_trees would log an error line on stdout every tick and carry on with
    INVALID; raised instead, it ends the run with verdict ``error`` naming the entry.
    """


def _checked_update(node: py_trees.behaviour.Behaviour) -> Callable[[], py_trees.common.Status]:
    """*node*'s ``update`` that raises :class:`LeafError` for a non-Status result (user leaves only)."""
    update = node.update
    Status = py_trees.common.Status

    def checked() -> py_trees.common.Status:
        self = node  # noqa: F841 - the run's error report finds the entry by the frame's 'self'
        status = update()
        if not isinstance(status, Status):
            shown = repr(status) if len(repr(status)) < 60 else type(status).__name__
            raise LeafError(f"{type(node).__name__}.update() returned {shown}, not a py_trees Status")
        return status

    return checked


class FactoryError(UserError, TypeError):
    """A leaf factory raised (anything, ``SystemExit`` included) or returned something that is not a Behaviour.

    The CLI reports it as one line (exit 2; ``run``: the verdict ``error``).
    """


@dataclass(frozen=True)
class LeafType:
    """How to build and check one kind of leaf.

    Attributes:
        kind: ``behavior``/``constraint`` (execute entries) or a criterion type
        action: the entry's ``action``; ``None`` for criteria
        factory: builds the behaviour
        params_schema: JSON schema for ``params`` (``None``: anything goes)
        expressions: names of params holding expressions (parsed at load time)
        signals: names of params holding a signal name (checked against ``signals``)
        description: one line for ``--help`` style listings
        check: the rules of ``params`` a JSON schema cannot state (``profile``'s increasing times): called
            with params that fit the schema, it yields ``(path inside params, message)`` per problem
    """

    kind: str
    action: str | None
    factory: Factory
    params_schema: Mapping[str, Any] | None = None
    expressions: tuple[str, ...] = ()
    signals: tuple[str, ...] = ()
    description: str = ""
    check: Callable[[Mapping[str, Any]], Iterable[tuple[tuple[str | int, ...], str]]] | None = None

    @cached_property
    def params_validator(self) -> SchemaValidator | None:
        if self.params_schema is None:
            return None
        return shared_validator(self.params_schema)


class Registry:
    """A mutable mapping of ``(kind, action)`` to :class:`LeafType`, and of names to system types."""

    def __init__(self, types: Mapping[tuple[str, str | None], LeafType] | None = None,
                 systems: Mapping[str, SystemType] | None = None):  # fmt: skip
        self._types: dict[tuple[str, str | None], LeafType] = dict(types or {})
        self._systems: dict[str, SystemType] = dict(systems or {})
        self._classes: dict[type, bool] = {}  # leaf classes seen by build(): Behaviours, and whether defined in this package

    def register(
        self,
        action: str | None,
        factory: Factory | None = None,
        *,
        kind: str = "behavior",
        params_schema: Mapping[str, Any] | None = None,
        expressions: tuple[str, ...] = (),
        signals: tuple[str, ...] = (),
        description: str = "",
        replace: bool = False,
        check: Callable[[Mapping[str, Any]], Iterable[tuple[tuple[str | int, ...], str]]] | None = None,
    ) -> Any:
        """Register *factory* for ``(kind, action)``; usable as a decorator when *factory* is omitted."""
        if kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, not {kind!r}")

        def add(f: Factory) -> Factory:
            key = (kind, action)
            if key in self._types and not replace:
                raise ValueError(f"{kind} action {action!r} is already registered (pass replace=True)")
            self._types[key] = LeafType(kind, action, f, params_schema, tuple(expressions), tuple(signals), description, check)
            return f

        return add if factory is None else add(factory)

    def get(self, kind: str, action: str | None = None) -> LeafType | None:
        return self._types.get((kind, action))

    def actions(self, kind: str) -> list[str]:
        """Sorted action names registered for *kind*."""
        return sorted(a for (k, a) in self._types if k == kind and a is not None)

    def build(self, item: Entry | Criterion, env: Environment) -> py_trees.behaviour.Behaviour:
        """The leaf for an execute entry or a criterion, made by its registered factory.

        The leaf is tagged with its item (``btgen_entry`` or ``btgen_criterion``),
        which is how views and reports find the entry a leaf stands for.

        Raises:
            LookupError: nothing is registered for the item's (kind, action)
            FactoryError: the factory raised, or did not return a py_trees Behaviour
        """
        is_entry = isinstance(item, Entry)
        kind = item.kind if is_entry else item.type  # type: ignore[union-attr]
        leaf_type = self._types.get((kind, item.action))
        if leaf_type is None:
            raise LookupError(f"no leaf registered for {kind} action {item.action!r}")
        try:
            node = leaf_type.factory(item, env)
        except BaseException as exc:  # noqa: BLE001 - user code: SystemExit too is this leaf's error
            if is_interrupt(exc):
                raise
            detail = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
            raise FactoryError(f"{item.id}: the factory for {kind} {item.action!r} raised {detail}") from exc
        cls = type(node)
        own = self._classes.get(cls)
        if own is None:  # first leaf of this class: is it a Behaviour, is it one of ours? (an ABC check per leaf adds up)
            if not isinstance(node, py_trees.behaviour.Behaviour):
                raise FactoryError(f"{item.id}: the factory for {kind} {item.action!r} returned {cls.__name__}, not a py_trees Behaviour")
            own = self._classes[cls] = cls.__module__.startswith("btgen_pytrees.")
        if is_entry:
            node.btgen_entry = item  # type: ignore[attr-defined]
        else:
            node.btgen_criterion = item  # type: ignore[attr-defined]
        if not own:
            node.update = _checked_update(node)  # type: ignore[method-assign]
        return node

    def copy(self) -> "Registry":
        return Registry(self._types, self._systems)

    # -- systems under test ----------------------------------------------------
    def register_system(self, system_type: SystemType, *, replace: bool = False) -> SystemType:
        """Make *system_type* available to cases as ``"system": {"type": system_type.name}``."""
        name = getattr(system_type, "name", None)
        if not isinstance(name, str) or not name.isidentifier():
            raise ValueError(f"a system type needs a name that is an identifier, not {name!r}")
        if name in self._systems and not replace:
            raise ValueError(f"system {name!r} is already registered (pass replace=True)")
        self._systems[name] = system_type
        return system_type

    def system(self, name: str) -> SystemType | None:
        """The system type registered as *name*, or ``None``."""
        return self._systems.get(name)

    def systems(self) -> list[str]:
        """Sorted names of the registered system types."""
        return sorted(self._systems)

    def __contains__(self, key: tuple[str, str | None]) -> bool:
        return key in self._types
