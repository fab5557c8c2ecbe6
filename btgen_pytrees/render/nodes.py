"""What a reviewer needs to know about each node, as data.

Every view (text, JSON, dot, BT.CPP XML) is drawn from :func:`node_info`, so
they cannot disagree about a policy, a selected child or a trigger's
predecessors.
"""

from __future__ import annotations

from collections import Counter
from typing import Any, Iterator

import py_trees
from py_trees.composites import Parallel, Selector, Sequence
from py_trees.decorators import Decorator

from ..leaves.wiring import Completion, OrMember, RunStart, TreeRoot, Trigger, WakingParallel

__all__ = ["node_info", "walk", "depth_for", "symbol", "policy_name", "annotation", "role", "role_of", "selected", "is_selected", "type_name"]


def walk(root: py_trees.behaviour.Behaviour) -> Iterator[tuple[int, py_trees.behaviour.Behaviour]]:
    """Pre-order ``(depth, node)`` pairs, root at depth 0, without recursion."""
    stack = [(0, root)]
    while stack:
        depth, node = stack.pop()
        yield depth, node
        stack.extend((depth + 1, child) for child in reversed(node.children))


def depth_for(root: py_trees.behaviour.Behaviour, max_nodes: int) -> int | None:
    """The deepest ``max_depth`` that shows at most *max_nodes* nodes (``None``: the whole tree fits).

    >>> from btgen_pytrees import generate, load
    >>> root = generate(load("examples/fig1.json"))  # 27 nodes; 1, 2, 3 and 5 at depths 0 to 3
    >>> depth_for(root, 100), depth_for(root, 10)
    (None, 2)
    """
    depths = Counter(depth for depth, _ in walk(root))
    if sum(depths.values()) <= max_nodes:
        return None
    total, depth = 0, 0
    for d in sorted(depths):
        total += depths[d]
        if total > max_nodes:
            break
        depth = d
    return depth


def selected(node: py_trees.behaviour.Behaviour) -> list[py_trees.behaviour.Behaviour] | None:
    """The children a ``SuccessOnSelected`` Parallel waits for (its exit condition), else None."""
    policy = getattr(node, "policy", None)
    if isinstance(policy, py_trees.common.ParallelPolicy.SuccessOnSelected):
        return list(policy.children)
    return None


def is_selected(parent: py_trees.behaviour.Behaviour, child: py_trees.behaviour.Behaviour) -> bool:
    return any(c is child for c in selected(parent) or ())


def policy_name(node: Parallel) -> str:
    return type(node.policy).__name__


def role(node: py_trees.behaviour.Behaviour) -> str:
    """``behavior``, ``constraint``, ``oracle``, ``trigger``, ``wiring`` or ``composite``."""
    return role_of(type(node), getattr(node, "btgen_entry", None), getattr(node, "btgen_criterion", None))


def role_of(cls: type, entry: Any = None, criterion: Any = None) -> str:
    """:func:`role` from what decides it: the node's class and its ``btgen_entry``/``btgen_criterion`` tags.

    >>> role_of(Trigger), role_of(Sequence)
    ('trigger', 'composite')
    """
    if entry is not None:
        return entry.kind  # type: ignore[no-any-return]
    if criterion is not None:
        return "oracle"
    if issubclass(cls, Trigger):
        return "trigger"
    if issubclass(cls, (Completion, OrMember, RunStart)):
        return "wiring"
    return "composite"


def type_name(node: py_trees.behaviour.Behaviour) -> str:
    """The node's class name; ``Parallel`` for the execute root's :class:`WakingParallel` and the tree's :class:`TreeRoot`.

    The first ticks exactly as a ``Parallel(SuccessOnAll(synchronise=True))``
    (it only skips ticks that would change nothing), the second exactly as a
    ``Parallel`` (it reads the clock first), so reviewers see them as such.
    """
    return "Parallel" if isinstance(node, (WakingParallel, TreeRoot)) else type(node).__name__


def node_info(node: py_trees.behaviour.Behaviour) -> dict[str, Any]:
    """A node as JSON-ready data (without its children)."""
    info: dict[str, Any] = {"name": node.name, "type": type_name(node)}
    if isinstance(node, Parallel):
        info["policy"] = policy_name(node)
        info["synchronise"] = node.policy.synchronise
        chosen = selected(node)
        if chosen is not None:
            info["selected"] = [child.name for child in chosen]
    elif isinstance(node, Sequence):
        info["memory"] = node.memory
    entry = getattr(node, "btgen_entry", None)
    if entry is not None:
        info.update(id=entry.id, kind=entry.kind, action=entry.action, params=dict(entry.params))
    criterion = getattr(node, "btgen_criterion", None)
    if criterion is not None:
        info.update(id=criterion.id, criterion=criterion.type, expect=criterion.expect.source)
        if criterion.action is not None:
            info.update(action=criterion.action, params=dict(criterion.params))
        for key, value in (("from", criterion.start), ("to", criterion.end), ("at", criterion.at)):
            if value is not None:
                info[key] = value
    if isinstance(node, Trigger):
        info.update(waits_for=list(node.waits_for), join=node.join)
    elif isinstance(node, Completion):
        info["marks"] = node.marks if node.marks is not None else "execute"
    elif isinstance(node, OrMember):
        info.update(member=node.member, group=list(node.group))
    return info


def _value(v: Any) -> str:
    return str(v).lower() if isinstance(v, bool) else str(v)


def annotation(node: py_trees.behaviour.Behaviour) -> str:
    """One line of review detail for the text views ("" when the name says it all)."""
    info = node_info(node)
    if "policy" in info:
        text = info["policy"]
        if "selected" in info:
            text += "(" + ", ".join(info["selected"]) + ")"
        return text + (", synchronised" if info["synchronise"] else "")
    if "memory" in info:
        return "memory" if info["memory"] else "no memory"
    if "action" in info and "kind" in info:
        params = ", ".join(f"{k}={_value(v)}" for k, v in info["params"].items())
        label = f"{info['id']}: " if info["id"] != info["name"] else ""
        return f"{label}{info['kind']} {info['action']}({params})"
    if "criterion" in info:
        window = "".join(f", {k}={info[k]}" for k in ("from", "to", "at") if k in info)
        label = f"{info['id']}: " if info["id"] != info["name"] else ""
        leaf = ""
        if "action" in info:
            leaf = f" [{info['action']}({', '.join(f'{k}={_value(v)}' for k, v in info['params'].items())})]"
        return f"{label}{info['criterion']}{leaf}: {info['expect']}{window}"
    if "waits_for" in info:
        return f"trigger: waits for {info['join']} of {', '.join(info['waits_for'])}"
    if "marks" in info:
        return f"marks {info['marks']} done on the blackboard"
    if "member" in info:
        return f"|| member; fails only when all of {', '.join(info['group'])} failed"
    if isinstance(node, RunStart):
        return "resets the blackboard namespace, starts the clock, sets initial signals"
    return ""


def symbol(node: py_trees.behaviour.Behaviour) -> str:
    """py_trees' own symbol for *node*'s type (``/_/`` Parallel, ``{-}`` Sequence with memory, ``-->`` leaf, ...),
    shared by the text views and the status tree of a report."""
    if isinstance(node, Parallel):
        return "/_/"
    if isinstance(node, Decorator):
        return "-^-"
    if isinstance(node, Sequence):
        return "{-}" if node.memory else "[-]"
    if isinstance(node, Selector):
        return "{o}" if node.memory else "[o]"
    return "-->"
