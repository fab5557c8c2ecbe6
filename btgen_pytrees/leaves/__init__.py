"""Leaves: the behaviours at the tips of a generated tree.

* :mod:`.registry` - which behaviour stands for which action or criterion type
* :mod:`.builtin` - the built-in simulated leaves, registered like any plugin
* :mod:`.simulated`, :mod:`.oracles` - their implementations
* :mod:`.wiring` - triggers and completion marks the generator adds
* :mod:`.environment` - blackboard namespace and clock shared by one tree
"""

from __future__ import annotations

from .builtin import register_builtins
from .environment import Environment, unique_namespace
from .registry import Factory, LeafType, Registry

__all__ = ["Environment", "Factory", "LeafType", "Registry", "default_registry", "unique_namespace"]


def default_registry() -> Registry:
    """A new registry holding only the built-in leaves (callers may add to it freely)."""
    return register_builtins(Registry())
