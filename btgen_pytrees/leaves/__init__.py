"""Leaves: the behaviours at the tips of a generated tree.

* :mod:`.builtin` - the built-in simulated leaves, registered like any plugin
* :mod:`.plugins` - user leaves from entry points and ``--plugin`` modules
* :mod:`.simulated`, :mod:`.oracles` - the built-in implementations
* :mod:`.wiring` - triggers and completion marks the generator adds

The contracts they implement - the :class:`Registry` (which behaviour stands for which
action or criterion type), the :class:`Environment` (blackboard namespace and clock
shared by one tree) - live in :mod:`btgen_pytrees.contracts` and are re-exported here.
"""

from __future__ import annotations

from typing import Iterable

from ..contracts.environment import Environment, unique_namespace
from ..contracts.registry import Factory, FactoryError, LeafType, Registry
from . import plugins as _plugins
from .builtin import register_builtins
from .plugins import PluginError, loads_user_code

__all__ = [
    "Environment", "Factory", "FactoryError", "LeafType", "PluginError", "Registry",
    "builtin_registry", "default_registry", "loads_user_code", "unique_namespace",
]  # fmt: skip


def builtin_registry() -> Registry:
    """A new registry holding only the built-in leaves."""
    return register_builtins(Registry())


def default_registry(plugins: Iterable[str] = ()) -> Registry:
    """A new registry: the built-ins, installed entry-point plugins, then *plugins* (module names).

    Raises:
        PluginError: a plugin failed to import or to register.
    """
    registry = builtin_registry()
    _plugins.apply(registry, _plugins.installed_plugins())
    return _plugins.apply(registry, [_plugins.load_module_plugin(m) for m in plugins])
