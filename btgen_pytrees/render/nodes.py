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

from ..leaves.control import Attempts, Controlled, Gate, Repetitions, StopGuard, VirtualTimeout
from ..leaves.wiring import Completion, Cuttable, OrMember, RunStart, TreeRoot, Trigger, WakingParallel

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
    return role_of(type(node), getattr(node, "btgen_entry", None) or getattr(node, "btgen_action", None),
                   getattr(node, "btgen_criterion", None))  # fmt: skip


def role_of(cls: type, entry: Any = None, criterion: Any = None) -> str:
    """:func:`role` from what decides it: the node's class and its ``btgen_entry``/``btgen_criterion`` tags.

    >>> role_of(Trigger), role_of(Sequence)
    ('trigger', 'composite')
    """
    if entry is not None:
        return entry.kind  # type: ignore[no-any-return]
    if criterion is not None:
        return "oracle"
    if issubclass(cls, (Trigger, Gate)):
        return "trigger"
    if issubclass(cls, (Completion, OrMember, RunStart, Attempts, Repetitions, VirtualTimeout, Cuttable, StopGuard)):
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
        if entry.control is not None:
            info["control"] = _control(entry.control)
    acts = getattr(node, "btgen_action", None)
    if acts is not None:
        info.update(action_of=acts.id, kind=acts.kind, action=acts.action, params=dict(acts.params))
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
    elif isinstance(node, Gate):
        condition = node.condition
        if condition.when is not None:
            info.update(when=condition.when.source, edge=condition.edge)
        if condition.delay:
            info["delay"] = condition.delay
    elif isinstance(node, VirtualTimeout):
        info["timeout"] = node.duration
    elif isinstance(node, Attempts):
        info["attempts"] = node.num_failures
    elif isinstance(node, Repetitions):
        info["repeat"] = node.num_success
    elif isinstance(node, StopGuard):
        info["stop"] = [{"when": s.when.source, "edge": s.edge, "delay": s.delay} for s in node.stops]
    elif isinstance(node, Cuttable):
        info["cuttable"] = True
    return info


def _control(control: Any) -> dict[str, Any]:
    """An entry's control keys as written (defaults left out)."""
    out: dict[str, Any] = {}
    if control.when is not None:
        out["when"] = control.when.source
    if control.edge != "none":
        out["edge"] = control.edge
    if control.delay:
        out["delay"] = control.delay
    if control.timeout is not None:
        out["timeout"] = control.timeout
    if control.attempts > 1:
        out["attempts"] = control.attempts
    if control.repeat > 1:
        out["repeat"] = control.repeat
    if control.stops:
        out["stops"] = list(control.stops)
    if control.race is not None:
        out["race"] = control.race
    return out


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
    if "action_of" in info:
        params = ", ".join(f"{k}={_value(v)}" for k, v in info["params"].items())
        return f"action of {info['action_of']}: {info['kind']} {info['action']}({params})"
    if "control" in info:
        label = f"{info['id']}: " if info["id"] != info["name"] else ""
        control = node.control if isinstance(node, Controlled) else None
        summary = control.summary if control is not None else ""
        if not summary:
            summary = "its states are read" if control is not None and control.watched else "may be stopped"
        return f"{label}{info['kind']}: {summary}"
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
    if isinstance(node, Gate):
        parts = [f"trigger: starts when {info['when']}" + (f" ({info['edge']} edge)" if info["edge"] != "none" else "")] \
            if "when" in info else []
        if "delay" in info:
            parts.append(f"then waits {info['delay']:g} s" if parts else f"trigger: waits {info['delay']:g} s")
        return ", ".join(parts)
    if "timeout" in info:
        return f"Timeout: fails an attempt still running after {info['timeout']:g} s (run clock)"
    if "attempts" in info:
        return f"Retry: a failed attempt starts again, {info['attempts']} attempts in all"
    if "repeat" in info:
        return f"Repeat: runs {info['repeat']} times in a row"
    if "stop" in info:
        return "ends the run when " + " or ".join(_stop_text(s) for s in info["stop"])
    if "cuttable" in info:
        return "a stopped entry ends this branch as finished"
    return ""


def _stop_text(stop: dict[str, Any]) -> str:
    return stop["when"] + (f" ({stop['edge']} edge)" if stop["edge"] != "none" else "") + (
        f" + {stop['delay']:g} s" if stop["delay"] else "")  # fmt: skip


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
