"""Finding user leaves: installed entry points and ``--plugin`` modules.

A plugin is any callable ``register(registry)`` that adds leaf types to the
:class:`~btgen_pytrees.contracts.registry.Registry` it is given. It reaches the
generator in one of three ways:

* from Python: call it yourself, or ``registry.register(...)`` directly;
* installed: a distribution declares an entry point in the group
  ``btgen_pytrees.leaves`` (``[project.entry-points."btgen_pytrees.leaves"]``,
  ``my_robot = "my_robot.leaves:register"``); every registry made by
  :func:`btgen_pytrees.leaves.default_registry` includes it;
* on the command line: ``--plugin my_robot.leaves`` imports that module (the
  current directory is importable while it does) and calls its ``register``;
  ``--plugin path/to/robot.py`` does the same with a file (its directory is
  importable while it runs, so it may import its neighbours).

Systems under test (:mod:`btgen_pytrees.systems`) come the same way: a plugin's
``register`` calls ``registry.register_system(...)`` and registers the system's
actions as leaves named ``<system>.<action>``.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import os
import sys
from contextlib import contextmanager
from functools import lru_cache
from importlib.metadata import EntryPoint, entry_points
from types import ModuleType
from typing import Callable, Iterable, Iterator

from ..contracts.registry import Registry
from ..errors import UserError, is_interrupt
from ..writing import at_home

__all__ = ["ENTRY_POINT_GROUP", "PluginError", "installed_plugins", "load_module_plugin", "loads_user_code"]

ENTRY_POINT_GROUP = "btgen_pytrees.leaves"
Register = Callable[[Registry], object]


class PluginError(UserError, RuntimeError):
    """A plugin could not be imported or did not register cleanly."""


@lru_cache(maxsize=1)
def _entry_points() -> tuple[EntryPoint, ...]:
    """The installed entry points of the group, sorted by name (found once per process, nothing imported)."""
    return tuple(sorted(entry_points(group=ENTRY_POINT_GROUP), key=lambda ep: (ep.name, ep.value)))


def loads_user_code(plugins: Iterable[str] = ()) -> bool:
    """Whether a registry with *plugins* imports code from outside btgen_pytrees (plugins or installed entry points)."""
    return bool(list(plugins)) or bool(_entry_points())


@lru_cache(maxsize=1)
def installed_plugins() -> tuple[tuple[str, Register], ...]:
    """The ``register`` callables of installed entry points, sorted by name (loaded once per process)."""
    found = []
    for ep in _entry_points():
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


def is_path(plugin: str) -> bool:
    """Whether ``--plugin`` names a file (``robot.py``, ``x/robot``) rather than a module (``my_robot.leaves``)."""
    return plugin.endswith(".py") or os.sep in plugin or "/" in plugin


@contextmanager
def _importable(directory: str) -> Iterator[None]:
    """*directory* on ``sys.path`` for the duration (unless it already is); put back exactly."""
    added = directory not in sys.path
    if added:
        sys.path.insert(0, directory)
    try:
        yield
    finally:
        if added and directory in sys.path:
            sys.path.remove(directory)


def _import_file(path: str) -> ModuleType:
    """Import the Python file *path* as a module named after it (reused if that file is already imported)."""
    full = os.path.abspath(path)
    if not os.path.isfile(full):
        raise PluginError(f"plugin {path!r}: no such file")
    stem = os.path.splitext(os.path.basename(full))[0]
    name = stem if stem.isidentifier() else "btgen_plugin"
    loaded = sys.modules.get(name)
    if loaded is not None and os.path.abspath(getattr(loaded, "__file__", None) or "") == full:
        return loaded
    if loaded is not None:  # another module of that name: do not replace it
        name = f"btgen_plugin_{hashlib.sha1(full.encode()).hexdigest()[:12]}"
    spec = importlib.util.spec_from_file_location(name, full)
    if spec is None or spec.loader is None:
        raise PluginError(f"plugin {path!r}: not a Python file")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        with _importable(os.path.dirname(full)):
            spec.loader.exec_module(module)
    except BaseException:
        sys.modules.pop(name, None)
        raise
    return module


def load_module_plugin(module: str) -> tuple[str, Register]:
    """Import *module* (a module name, or the path of a ``.py`` file) and return its ``register`` function."""
    at_home()  # a relative path means what it meant when the command began (user code may have moved since)
    try:
        if is_path(module):
            mod = _import_file(module)
        else:
            with _importable(os.getcwd()):
                mod = importlib.import_module(module)
    except PluginError:
        raise
    except BaseException as exc:  # noqa: BLE001 - SystemExit/KeyboardInterrupt at import are the plugin's error
        if is_interrupt(exc):
            raise
        raise PluginError(f"plugin {module!r}: cannot import: {type(exc).__name__}: {exc}") from exc
    finally:
        at_home()  # the CLI's process: relative paths (inputs, outputs, the next plugin) mean what they meant
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
        finally:
            at_home()
    return registry
