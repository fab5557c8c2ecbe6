"""Finding user leaves: installed entry points and ``--plugin`` modules.

A plugin is any callable ``register(registry)`` that adds leaf types to the
:class:`~btgen_pytrees.leaves.registry.Registry` it is given. It reaches the
generator in one of three ways:

* from Python: call it yourself, or ``registry.register(...)`` directly;
* installed: a distribution declares an entry point in the group
  ``btgen_pytrees.leaves`` (``[project.entry-points."btgen_pytrees.leaves"]``,
  ``my_robot = "my_robot.leaves:register"``); every registry made by
  :func:`btgen_pytrees.leaves.default_registry` includes it;
* on the command line: ``--plugin my_robot.leaves`` imports that module and calls
  its ``register``.
"""

from __future__ import annotations

import importlib
from functools import lru_cache
from importlib.metadata import entry_points
from typing import Callable, Iterable

from ..errors import is_interrupt
from .registry import Registry

__all__ = ["ENTRY_POINT_GROUP", "PluginError", "installed_plugins", "load_module_plugin"]

ENTRY_POINT_GROUP = "btgen_pytrees.leaves"
Register = Callable[[Registry], object]


class PluginError(RuntimeError):
    """A plugin could not be imported or did not register cleanly."""


@lru_cache(maxsize=1)
def installed_plugins() -> tuple[tuple[str, Register], ...]:
    """The ``register`` callables of installed entry points, sorted by name (loaded once per process)."""
    found = []
    for ep in sorted(entry_points(group=ENTRY_POINT_GROUP), key=lambda ep: (ep.name, ep.value)):
        try:
            func = ep.load()
        except BaseException as exc:  # noqa: BLE001 - any failure of a third-party plugin, SystemExit too
            if is_interrupt(exc):
                raise
            raise PluginError(f"entry point {ep.name!r} ({ep.value}): {type(exc).__name__}: {exc}") from exc
        if not callable(func):
            raise PluginError(f"entry point {ep.name!r} ({ep.value}) is not callable")
        found.append((f"entry point {ep.name!r}", func))
    return tuple(found)


def load_module_plugin(module: str) -> tuple[str, Register]:
    """Import *module* and return its ``register`` function."""
    try:
        mod = importlib.import_module(module)
    except BaseException as exc:  # noqa: BLE001 - SystemExit/KeyboardInterrupt at import are the plugin's error
        if is_interrupt(exc):
            raise
        raise PluginError(f"plugin {module!r}: cannot import: {type(exc).__name__}: {exc}") from exc
    func = getattr(mod, "register", None)
    if not callable(func):
        raise PluginError(f"plugin {module!r} has no register(registry) function")
    return f"plugin {module!r}", func


def apply(registry: Registry, plugins: Iterable[tuple[str, Register]]) -> Registry:
    """Call each plugin's ``register(registry)``; wrap its errors in :class:`PluginError`."""
    for label, func in plugins:
        try:
            func(registry)
        except BaseException as exc:  # noqa: BLE001 - SystemExit too: the plugin's error, never the CLI's exit
            if is_interrupt(exc):
                raise
            raise PluginError(f"{label}: register() failed: {type(exc).__name__}: {exc}") from exc
    return registry
