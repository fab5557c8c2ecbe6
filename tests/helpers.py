"""Shared helpers: build test-case dicts tersely, generate and run them."""

from __future__ import annotations

from typing import Any, Iterable

import btgen_pytrees
from btgen_pytrees.run import run


def entry(id: str, after: Iterable[str] = (), *, action: str = "hold", kind: str | None = None,
          join: str | None = None, **params: Any) -> dict[str, Any]:  # fmt: skip
    """An execute entry; ``hold``/``wait`` default to a one-second duration."""
    if action in ("hold", "wait") and "duration" not in params:
        params["duration"] = 1
    if kind is None:
        kind = "constraint" if action in ("wait", "until") else "behavior"
    e: dict[str, Any] = {"id": id, "kind": kind, "action": action, "params": params}
    if after:
        e["after"] = list(after)
    if join:
        e["join"] = join
    return e


def case(*entries: dict[str, Any], criteria: list[dict[str, Any]] | None = None, relation: Any = None,
         **top: Any) -> dict[str, Any]:  # fmt: skip
    data: dict[str, Any] = {"name": top.pop("name", "t"), "execute": list(entries), **top}
    if criteria is not None:
        data["oracle"] = {"criteria": criteria}
        if relation is not None:
            data["oracle"]["relation"] = relation
    return data


def crit(id: str, type: str, expect: str, **extra: Any) -> dict[str, Any]:
    return {"id": id, "type": type, "expect": expect, **extra}


def chain(n: int, duration: float = 0.1) -> dict[str, Any]:
    return case(*[entry(f"S{i}", [f"S{i - 1}"] if i else [], duration=duration) for i in range(n)])


def generate(data: dict[str, Any], **kw: Any):  # type: ignore[no-untyped-def]
    return btgen_pytrees.generate(btgen_pytrees.load(data), **kw)


def run_case(data: dict[str, Any], **kw: Any):  # type: ignore[no-untyped-def]
    return run(btgen_pytrees.load(data), **kw)


def broken_registry() -> Any:
    """The default registry plus ``broken``, a leaf whose update() raises ``RuntimeError("motor driver offline")``."""
    import py_trees

    from btgen_pytrees.leaves import default_registry

    class Broken(py_trees.behaviour.Behaviour):
        def __init__(self, e: Any, env: Any) -> None:
            super().__init__(name=e.name)

        def update(self) -> py_trees.common.Status:
            raise RuntimeError("motor driver offline")

    registry = default_registry()
    registry.register("broken", Broken)
    return registry


DYING_PLUGIN = '''
import os
import py_trees
from py_trees.common import Status


class Leaf(py_trees.behaviour.Behaviour):
    def __init__(self, entry, env):
        super().__init__(name=entry.name)
        self.when = entry.params.get("when")

    def update(self):
        if self.when == 3 or self.when > 190:
            os._exit(0)  # kills the worker process, as a crashing simulator would
        if self.when == 5:
            raise SystemExit(0)
        return Status.SUCCESS


def register(registry):
    registry.register("maybe_die", lambda entry, env: Leaf(entry, env), kind="behavior")
'''
"""A ``--plugin`` file whose ``maybe_die`` leaf (param ``when``) kills its process at 3 and above 190, and raises
SystemExit at 5: what a crashing simulator or a misbehaving leaf does to the worker that runs it."""
