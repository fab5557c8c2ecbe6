"""The storyboard as the case's timeline: one entry per element, the triggers as control-flow keys.

ASAM OpenSCENARIO 1.2, clause 7.6 "Storyboard" (1.0: 8.6) and its state machine of storyboard
elements (7.6.1: standby, running, complete; start/end/stop transitions):

* **Story, Act, ManeuverGroup, Maneuver, Event** each become an entry (a ``wait`` of 0 s, so no
  tick is lost), named ``Story S``, ``Act A``, ... in every view. A child comes ``after`` its
  parent: it can start only while the parent runs. An Act's and an Event's ``StartTrigger``
  become their entry's ``when``/``edge``/``delay`` (:mod:`.conditions`).
* **Actions** of an Event become entries ``after`` the Event's entry, one per actor of the
  ManeuverGroup, so they start on the tick the Event starts (7.6.4: all actions of an event start
  together).
* **State** (7.6.1): an element some ``StoryboardElementStateCondition`` names, and every Event,
  gets a state signal (``0`` standby, ``1`` running, ``2`` complete) set by ``set`` entries on the
  ticks it starts and completes (an element completes when all its children have: join ``all``).
* **Event priority** (7.6.4): ``override`` (1.0's ``overwrite``) stops the other events of the
  maneuver that are running (the entry's ``stops``); ``parallel`` runs beside them; ``skip`` waits
  until no other event of the maneuver runs (documented: the standard skips it instead).
* **maximumExecutionCount** of an Event: N copies of its entries, each after the one before has
  completed, each waiting for the StartTrigger again (an event counts as complete after its N
  executions). A ManeuverGroup's larger than 1 is refused.
* **The Storyboard's StopTrigger** (7.6.2) is the case's top-level ``stop``: the run ends when it fires.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any, Callable

from ..systems.sumo.opendrive import OpenDriveError, read_opendrive
from ..systems.sumo.roads import resolve
from .actions import ActionWriter
from .conditions import Condition, ConditionWriter
from .parameters import Scope
from .xmltree import Node, XmlProblem

__all__ = ["Timeline", "ELEMENT_TYPES", "STATES", "identifier", "MAX_EXECUTIONS"]

ELEMENT_TYPES = ("story", "act", "maneuverGroup", "maneuver", "event", "action")
STATES = ("startTransition", "endTransition", "stopTransition", "skipTransition", "completeState", "runningState",
          "standbyState")  # fmt: skip
MAX_EXECUTIONS = 100
"""Largest ``maximumExecutionCount`` of an Event (each execution is a copy of its entries)."""
_SUPPORTED_STATES = {"startTransition": ">= 1", "runningState": "== 1", "endTransition": "== 2", "completeState": "== 2"}

_BAD = re.compile(r"[^A-Za-z0-9_-]")


def identifier(name: str, taken: set[str], limit: int = 64) -> str:
    """An entry id for *name* (the id pattern of docs/format.md), unique among *taken*."""
    base = _BAD.sub("_", name) or "x"
    if not (base[0].isalpha() or base[0] == "_"):
        base = "_" + base
    base = base[:limit]
    found, n = base, 2
    while found.casefold() in taken:
        suffix = f"_{n}"
        found = base[: limit - len(suffix)] + suffix
        n += 1
    taken.add(found.casefold())
    return found


@dataclass
class Element:
    kind: str
    name: str
    id: str
    node: Node
    parent: "Element | None"
    children: list["Element"] = field(default_factory=list)
    actions: list[str] = field(default_factory=list)  # entry ids of an action element / an event's actions
    state: str | None = None  # the state signal, when one is needed
    markers: list[str] = field(default_factory=list)  # an event's entry per execution


class Timeline:
    """The entries, signals and stop conditions of one storyboard."""

    def __init__(self, scope: Scope, entities: list[str], catalogs: Any,
                 controller: Callable[[str], str | None] = lambda name: None,
                 road: str | None = None):  # fmt: skip
        self.scope = scope
        self.entities = entities
        self.catalogs = catalogs
        self.entries: list[dict[str, Any]] = []
        self.signals: dict[str, Any] = {}
        self.stop: list[dict[str, Any]] = []
        self.ids: set[str] = set()
        self.signal_names: set[str] = set()
        self.elements: list[Element] = []
        self.variables: dict[str, str] = {}
        self.pending: list[tuple[Element, str, Node, list[Condition]]] = []  # state references resolved at the end
        self.road = road
        self._network: Any = None
        self.conditions = ConditionWriter(scope, entities, self._state_expression, self._variable, self.world, clock=self.clock)
        self.motion: Any = None  # what an action needs beyond itself for its leaf (.motion), set once the Init is read
        self.actions = ActionWriter(scope, entities, self._variable, controller)
        self.events: list[Element] = []
        self.state_refs: list[tuple[str, str, Node, str]] = []  # (type, name, node, placeholder)

    # -- signals ---------------------------------------------------------------------------------
    def signal(self, name: str, value: Any) -> str:
        base = re.sub(r"[^A-Za-z0-9_]", "_", name)
        if not base[0].isalpha():
            base = "s_" + base
        found, n = base[:60], 2
        while found in self.signal_names:
            found = f"{base[:56]}_{n}"
            n += 1
        self.signal_names.add(found)
        self.signals[found] = value
        return found

    def declare_variables(self, node: Node | None) -> None:
        """``VariableDeclarations`` (1.2+): number and boolean variables as signals with their initial values."""
        if node is None:
            return
        for decl in node.all("VariableDeclaration"):
            name = self.scope.text(decl, "name") or ""
            kind = self.scope.choice(decl, "variableType", ("int", "double", "boolean", "unsignedInt", "unsignedShort", "string", "dateTime"))
            raw = self.scope.value(decl, decl.need("value"))
            if kind == "boolean":
                value: Any = raw if isinstance(raw, bool) else raw == "true"
            elif kind in ("string", "dateTime"):
                raise XmlProblem(decl, f"variable {name!r}: {kind} variables are not supported (numbers and booleans are)")
            else:
                try:
                    value = float(raw)
                except (TypeError, ValueError):
                    raise XmlProblem(decl, f"variable {name!r}: {raw!r} is not a number") from None
                value = int(value) if kind != "double" and value.is_integer() else value
            self.variables[name] = self.signal(f"var_{name}", value)

    def _variable(self, name: str, node: Node) -> str:
        if name in self.variables:
            return self.variables[name]
        values = self.scope.all_values()
        if node.tag in ("ParameterAction", "ParameterCondition") and name in values:  # 1.0: parameters set at run time
            raw = values[name]
            value = raw if isinstance(raw, (bool, int, float)) else float(raw)
            self.variables[name] = self.signal(f"par_{name}", value)
            return self.variables[name]
        known = ", ".join(sorted(self.variables)) or "none declared"
        raise XmlProblem(node, f"unknown variable {name!r} ({known})")

    def world(self, node: Node) -> tuple[float, float]:
        """The world point of an absolute ``Position`` (ReachPosition, Distance): the road system's mapping."""
        position = self.actions.position(node)
        kind = next(iter(position))
        if "entityRef" in position[kind]:
            raise XmlProblem(node, f"a {kind} in a condition is not supported (a position of its own is)")
        if self._network is None:
            if self.road is None:
                raise XmlProblem(node, "a position in a condition needs the scenario's road")
            try:
                self._network = read_opendrive(self.road)
            except OpenDriveError as exc:
                raise XmlProblem(node, f"the road: {exc}") from None
        try:
            pose = resolve(self._network, position, {}, "")
        except OpenDriveError as exc:
            raise XmlProblem(node, str(exc).lstrip(": ")) from None
        return float(pose.x), float(pose.y)

    def clock(self) -> str:
        """The signal of the run's time (SimulationTimeCondition): the road system's ``sim.time``."""
        return "sim.time"

    def lowered(self, node: Node, actor: str, kind: str, params: dict[str, Any], name: str, label: str,
                after: list[str]) -> dict[str, Any]:  # fmt: skip
        """The entries of one action for one actor (:mod:`.motion`); the last one is the action's (its completion)."""
        steps = self.motion.lower(node, actor, kind, params) if self.motion is not None else [(kind, params, 0.0)]
        last: dict[str, Any] = {}
        for leaf, p, wait in steps:
            if wait > 0:
                move = self.entry(f"{name}-motion", f"{label} (motion)", "behavior", leaf, p, after)
                last = self.entry(name, f"{label} (its dynamics, {wait:g} s)", "constraint", "wait", {"duration": wait}, [move["id"]])
            else:
                last = self.entry(name, label, "behavior", leaf, p, after)
            after = [last["id"]]
        return last

    # -- entries ---------------------------------------------------------------------------------
    def entry(self, name: str, label: str, kind: str, action: str, params: dict[str, Any], after: list[str],
              **keys: Any) -> dict[str, Any]:  # fmt: skip
        e: dict[str, Any] = {"id": identifier(name, self.ids), "kind": kind, "action": action, "params": params}
        if after:
            e["after"] = after
        e["name"] = label[:200]
        e.update({k: v for k, v in keys.items() if v is not None})
        self.entries.append(e)
        return e

    def marker(self, element_kind: str, name: str, after: list[str], **keys: Any) -> dict[str, Any]:
        return self.entry(name, f"{element_kind} {name}", "constraint", "wait", {"duration": 0}, after, **keys)

    def trigger(self, node: Node | None, after: list[str], owner: str) -> dict[str, Any]:
        """The keys (``when``, ``edge``, ``delay``) of a StartTrigger; helper latch entries added for the rest."""
        if node is None:
            return {}
        groups = []
        for g in node.all("ConditionGroup"):
            conds = [self.conditions.condition(c) for c in g.all("Condition")]
            if not conds:
                raise XmlProblem(g, "a ConditionGroup needs at least one Condition")
            groups.append(conds)
        if not groups:
            return {}  # an empty trigger (1.1+): the element starts with its parent
        if len(groups) == 1 and len(groups[0]) == 1:
            c = groups[0][0]
            return _keys(c.expect, c.edge, c.delay)
        terms = []
        for conds in groups:
            parts = []
            for c in conds:
                if c.edge == "none" and c.delay == 0:
                    parts.append(f"({c.expect})")
                    continue
                latch = self.signal(f"cond_{owner}_{c.name}", False)
                self.entry(f"{owner}-{c.name}", f"Condition {c.name}", "behavior", "set", {"signal": latch, "value": True},
                           after, **_keys(c.expect, c.edge, c.delay))  # fmt: skip
                parts.append(latch)
            terms.append(f"({' && '.join(parts)})" if len(parts) > 1 and len(groups) > 1 else " && ".join(parts))
        return _keys(" || ".join(terms), "none", 0)

    # -- the storyboard --------------------------------------------------------------------------
    def storyboard(self, board: Node, init_after: list[str]) -> None:
        # the storyboard runs until its StopTrigger (7.6.2), not until its stories are done: an entry that
        # never succeeds keeps the timeline running (the stop stops it; without a StopTrigger the run times out)
        self.entry("Storyboard", "Storyboard (until its StopTrigger)", "constraint", "until", {"expect": "false"}, [])
        for story in board.all("Story"):
            self.story(story, init_after)
        stop = board.child("StopTrigger")
        if stop is not None:
            for g in stop.all("ConditionGroup"):
                conds = [self.conditions.condition(c) for c in g.all("Condition")]
                if len(conds) == 1:
                    c = conds[0]
                    self.stop.append(_keys(c.expect, c.edge, c.delay))
                    continue
                parts = []
                for c in conds:
                    if c.edge == "none" and c.delay == 0:
                        parts.append(f"({c.expect})")
                    else:
                        latch = self.signal(f"stop_{c.name}", False)
                        self.entry(f"stop-{c.name}", f"Condition {c.name}", "behavior", "set",
                                   {"signal": latch, "value": True}, [], **_keys(c.expect, c.edge, c.delay))  # fmt: skip
                        parts.append(latch)
                self.stop.append({"when": " && ".join(parts)})
        for child in board.children:
            if child.tag not in ("Init", "Story", "StopTrigger"):
                raise XmlProblem(child, f"{child.tag} in the Storyboard is not supported")

    def story(self, node: Node, after: list[str]) -> None:
        name = self.scope.text(node, "name") or "story"
        declarations = node.child("ParameterDeclarations")
        scope_before = self.scope
        if declarations is not None:  # 1.0/1.1: a Story may declare parameters of its own
            inner = Scope(self.scope)
            inner.declare(declarations)
            self._rescope(inner)
        story = Element("story", name, "", node, None)
        e = self.marker("Story", name, after)
        story.id = e["id"]
        self.elements.append(story)
        for act in node.all("Act"):
            self.act(act, story)
        self._rescope(scope_before)

    def _rescope(self, scope: Scope) -> None:
        self.scope = self.conditions.scope = self.actions.scope = scope

    def act(self, node: Node, story: Element) -> None:
        name = self.scope.text(node, "name") or "act"
        act = Element("act", name, "", node, story)
        story.children.append(act)
        e = self.marker("Act", name, [story.id])
        e.update(self.trigger(node.child("StartTrigger"), [story.id], e["id"]))
        act.id = e["id"]
        self.elements.append(act)
        first = len(self.entries)
        for group in node.all("ManeuverGroup"):
            self.group(group, act)
        stop = node.child("StopTrigger")
        if stop is not None:  # 7.6.2: when it fires, the act's running children stop (the entry's 'stops')
            inside = [x["id"] for x in self.entries[first:]]
            keys = self.trigger(stop, [act.id], f"{act.id}-stop")
            if not keys:
                raise XmlProblem(stop, "an Act's StopTrigger needs a condition")
            self.entry(f"{act.id}-stop", f"StopTrigger of Act {name}", "constraint", "wait", {"duration": 0}, [act.id],
                       stops=inside, **keys)  # fmt: skip

    def group(self, node: Node, act: Element) -> None:
        name = self.scope.text(node, "name") or "group"
        count = self.scope.integer(node, "maximumExecutionCount", 1)
        if count != 1:
            raise XmlProblem(node, f"maximumExecutionCount {count} is not supported (1 is)")
        group = Element("maneuverGroup", name, "", node, act)
        act.children.append(group)
        actors = node.need_child("Actors")
        if self.scope.boolean(actors, "selectTriggeringEntities", False):
            raise XmlProblem(actors, "selectTriggeringEntities=true is not supported")
        names = []
        for ref in actors.all("EntityRef"):
            actor = self.scope.text(ref, "entityRef") or ""
            if actor not in self.entities:
                raise XmlProblem(ref, f"entityRef={actor!r} names no entity (entities: {', '.join(self.entities)})")
            names.append(actor)
        e = self.marker("ManeuverGroup", name, [act.id])
        group.id = e["id"]
        self.elements.append(group)
        for child in node.children:
            if child.tag == "Maneuver":
                child.use()
                self.maneuver(child, group, names, self.scope)
            elif child.tag == "CatalogReference":
                child.use()
                entry, inner = self.catalogs.resolve("ManeuverCatalog", child, self.scope)
                if entry.tag != "Maneuver":
                    raise XmlProblem(child, f"{entry.tag} is not a Maneuver")
                self.maneuver(entry, group, names, inner)

    def maneuver(self, node: Node, group: Element, actors: list[str], scope: Scope) -> None:
        before = self.scope
        if scope is not before:
            self._rescope(scope)
        declarations = node.child("ParameterDeclarations")
        if declarations is not None and scope is before:
            inner = Scope(self.scope)
            inner.declare(declarations)
            self._rescope(inner)
        name = self.scope.text(node, "name") or "maneuver"
        maneuver = Element("maneuver", name, "", node, group)
        group.children.append(maneuver)
        e = self.marker("Maneuver", name, [group.id])
        maneuver.id = e["id"]
        self.elements.append(maneuver)
        events = [(self.event(ev, maneuver, actors), ev) for ev in node.all("Event")]
        for element, ev in events:
            priority = self.scope.choice(ev, "priority", ("override", "overwrite", "skip", "parallel"), "parallel")
            others = [o for o, _ in events if o is not element]
            for marker in (x for x in self.entries if x["id"] in element.markers):  # every execution's
                if priority in ("override", "overwrite") and others:
                    marker["stops"] = [a for o in others for a in o.actions]
                elif priority == "skip" and others:
                    quiet = " && ".join(f"{self.state_of(o)} != 1" for o in others)
                    marker["when"] = f"({marker['when']}) && {quiet}" if "when" in marker else quiet
        self._rescope(before)

    def event(self, node: Node, maneuver: Element, actors: list[str]) -> Element:
        """An Event, its actions, once per execution: ``maximumExecutionCount`` N gives N copies, each
        after the one before has completed, each waiting for the StartTrigger again (7.6.4)."""
        name = self.scope.text(node, "name") or "event"
        count = self.scope.integer(node, "maximumExecutionCount", 1)
        if not 1 <= count <= MAX_EXECUTIONS:
            raise XmlProblem(node, f"maximumExecutionCount {count} must be between 1 and {MAX_EXECUTIONS}")
        event = Element("event", name, "", node, maneuver)
        maneuver.children.append(event)
        self.elements.append(event)
        self.events.append(event)
        elements: dict[int, Element] = {}
        after, join = [maneuver.id], None
        for run in range(count):
            label = name if count == 1 else f"{name} ({run + 1} of {count})"
            e = self.marker("Event", label, after, join=join)
            e.update(self.trigger(node.child("StartTrigger"), after, e["id"]))
            if run == 0:
                event.id = e["id"]
            event.markers.append(e["id"])
            these: list[str] = []
            for k, action in enumerate(node.all("Action")):
                aname = self.scope.text(action, "name") or "action"
                if k not in elements:
                    elements[k] = Element("action", aname, "", action, event)
                    event.children.append(elements[k])
                element = elements[k]
                body = action.only()
                if body.tag == "PrivateAction":
                    if not actors:
                        raise XmlProblem(body, "a private action needs an actor: the ManeuverGroup's Actors name none")
                    for actor in actors:
                        kind, params = self.actions.private(body, actor)
                        text = f"Action {aname}" + (f" ({actor})" if len(actors) > 1 else "")
                        a = self.lowered(body, actor, kind, params, aname if len(actors) == 1 else f"{aname}-{actor}", text, [e["id"]])
                        element.actions.append(a["id"])
                        these.append(a["id"])
                elif body.tag == "GlobalAction":
                    inner = body.only()
                    if inner.tag in ("VariableAction", "ParameterAction"):
                        kind, params = self.actions.variable_action(inner)
                    else:
                        raise XmlProblem(inner, f"{inner.tag} is not supported (VariableAction, ParameterAction are)")
                    a = self.entry(aname, f"Action {aname}", "behavior", kind, params, [e["id"]])
                    element.actions.append(a["id"])
                    these.append(a["id"])
                else:
                    raise XmlProblem(body, f"{body.tag} is not supported (PrivateAction, GlobalAction are)")
            if not these:
                raise XmlProblem(node, "an Event needs at least one Action")
            after, join = these, "all" if len(these) > 1 else None
        for element in elements.values():
            element.id = element.actions[0]
            event.actions.extend(element.actions)
            self.elements.append(element)
        return event

    # -- states ----------------------------------------------------------------------------------
    def state_of(self, element: Element) -> str:
        """The state signal of *element* (0 standby, 1 running, 2 complete), its set entries added once."""
        if element.state is None:
            element.state = self.signal(f"state_{element.kind}_{element.name}", 0)
            start = [element.id] if element.kind != "action" else [element.parent.id]  # type: ignore[union-attr]
            started = self.entry(f"{element.id}-started", f"{element.kind} {element.name} running", "behavior", "set",
                                 {"signal": element.state, "value": 1}, start)  # fmt: skip
            # after its start's too: an element that completes on the tick it starts is running, then complete
            self.entry(f"{element.id}-complete", f"{element.kind} {element.name} complete", "behavior", "set",
                       {"signal": element.state, "value": 2}, [*self._leaves(element), started["id"]], join="all")  # fmt: skip
        return element.state

    def _leaves(self, element: Element) -> list[str]:
        if element.kind in ("action", "event"):
            return list(element.actions)
        return [a for c in element.children for a in self._leaves(c)] or [element.id]

    def _state_expression(self, kind: str, name: str, state: str, node: Node) -> str:
        if kind not in ELEMENT_TYPES:
            raise XmlProblem(node, f"storyboardElementType {kind!r} is not one of {', '.join(ELEMENT_TYPES)}")
        if state not in STATES:
            raise XmlProblem(node, f"state {state!r} is not one of {', '.join(STATES)}")
        if state not in _SUPPORTED_STATES:
            raise XmlProblem(node, f"state {state} is not supported ({', '.join(_SUPPORTED_STATES)} are)")
        placeholder = f"@@state{len(self.state_refs)}@@"
        self.state_refs.append((kind, name, node, placeholder))
        return f"{placeholder} {_SUPPORTED_STATES[state]}"

    def resolve_states(self) -> None:
        """Replace the placeholders of state conditions by the named elements' state signals (the
        elements may be written after the conditions that name them)."""
        for kind, name, node, placeholder in self.state_refs:
            found = [el for el in self.elements if el.kind == kind and el.name == name]
            if not found:
                names = sorted({el.name for el in self.elements if el.kind == kind})
                raise XmlProblem(node, f"no {kind} named {name!r}" + (f" ({', '.join(names)})" if names else ""))
            if len(found) > 1:
                raise XmlProblem(node, f"{len(found)} {kind}s are named {name!r}: the reference is ambiguous")
            signal = self.state_of(found[0])
            for holder in [*self.entries, *self.stop]:
                if "when" in holder and placeholder in holder["when"]:
                    holder["when"] = holder["when"].replace(placeholder, signal)


def _keys(expect: str, edge: str, delay: float) -> dict[str, Any]:
    keys: dict[str, Any] = {"when": expect}
    if edge != "none":
        keys["edge"] = edge
    if delay:
        keys["delay"] = delay
    return keys
