"""Contracts: what the pipeline, the built-in leaves and systems, and every plugin agree on.

* :mod:`.environment` - what the nodes of one tree share: a blackboard namespace, a clock, the system
* :mod:`.system` - the system under test's interface (:class:`System`, :class:`SystemType`,
  :class:`SystemInfo`, :class:`SystemFailure`)
* :mod:`.registry` - which behaviour stands for which entry or criterion, and which system type for
  which name (:class:`Registry`, :class:`LeafType`, :class:`FactoryError`)

They import nothing of the project above the vocabulary modules (``errors``, ``model``, ``clock``,
``validator``, ...): the leaves (:mod:`btgen_pytrees.leaves`) and systems
(:mod:`btgen_pytrees.systems`) that implement them sit above. The public names are re-exported
where they are documented: ``btgen_pytrees.leaves`` (``Environment``, ``Registry``, ...) and
``btgen_pytrees.systems`` (``System``, ``SystemFailure``, ...).
"""

from .environment import Environment, unique_namespace
from .registry import Factory, FactoryError, LeafError, LeafType, Registry
from .system import System, SystemFailure, SystemInfo, SystemSpec, SystemType

__all__ = [
    "Environment", "Factory", "FactoryError", "LeafError", "LeafType", "Registry", "System", "SystemFailure",
    "SystemInfo", "SystemSpec", "SystemType", "unique_namespace",
]  # fmt: skip
