"""The storyboard as the case's timeline: one entry per element, the triggers as control-flow keys.

ASAM OpenSCENARIO XML 1.3, clauses 8.3 "Execution" and 8.4 "Storyboard element execution" (1.2: 7.6,
1.0: 8.6), the state machine of storyboard elements (standby, running, complete; start, end, stop and
skip transitions):

* **Story, Act, ManeuverGroup, Maneuver, Event** each become an entry (a ``wait`` of 0 s, so no
  tick is lost), named ``Story S``, ``Act A``, ... in every view. A child comes ``after`` its
  parent: it can start only while the parent runs. An Act's and an Event's ``StartTrigger``
  become their entry's ``when``/``edge``/``delay`` (:mod:`.conditions`).
* **Actions** of an Event become entries ``after`` the Event's entry, one per actor of the
  ManeuverGroup, so they start on the tick the Event starts (8.4.1).
* **Executions** (8.3.2, 8.4.2.1): an Event's ``maximumExecutionCount`` N gives N copies of its entries,
  each after the one before is over, each waiting for the StartTrigger again; a ManeuverGroup's M gives M
  copies of its maneuvers in a row (it has no trigger). Between two executions the element is in standby.
* **State** (8.4): every Event, and an element a ``StoryboardElementStateCondition`` names, gets a state
  signal (``0`` standby, ``1`` running, ``2`` complete; ``-1`` before its parent starts when a condition
  reads its standbyState) set by ``set`` entries on the ticks it starts and ends - standby again when
  executions are left, complete after the last (an element ends when all its children have: join
  ``all``). A transition a condition reads (start, end, skip) is a boolean signal that turns true on its
  first occurrence.
* **Event priority** (8.4.2.2): ``override`` (1.0's ``overwrite``) stops the other events of the
  maneuver that are running (the entry's ``stops``; their states complete: a stopTransition, as for
  what an Act's StopTrigger stops); ``parallel`` runs beside them; ``skip``: an event
  triggered while another event of its maneuver runs does not start - two racing entries after its
  trigger, one for "none running", one for "skipped" - and the skip counts as an execution.
* **The Storyboard's StopTrigger** is the case's top-level ``stop``: the run ends on the tick it fires.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping

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
_QUIET = "@@quiet@@"  # no other event of the maneuver running: filled in once the maneuver's events are known

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
    executions: list["Execution"] = field(default_factory=list)
    transitions: dict[str, str] = field(default_factory=dict)  # start/end/skip -> its signal, when one is needed
    entry_points: list[dict[str, Any]] = field(default_factory=list)  # its first entry in each execution of its parent
    standby: bool = False  # a condition reads its standbyState
    stops: list[str] = field(default_factory=list)  # its stop signals: true once a stopper stopped it (complete)


@dataclass
class Execution:
    """One execution of an element: it runs from the start of the entry ``start`` and is over when every entry
    of ``over`` has succeeded. ``last``: its end is completeState (else standbyState: executions are left).
    An event's execution has its ``marker`` (the entry with the StartTrigger), ``done`` (its actions ended)
    and, with priority skip, ``skip`` (the entry that skips it) and the two ``branches`` racing."""

    start: str
    over: list[str]
    last: bool = True
    skip: str | None = None
    done: dict[str, Any] | None = None
    marker: dict[str, Any] = field(default_factory=dict)
    branches: list[dict[str, Any]] = field(default_factory=list)
    next: dict[str, Any] | None = None  # the first entry of the next execution (it comes after this one's end)
    seal: dict[str, Any] | None = None  # the entry that ends the parent's execution (it comes after this one's end)
    written: bool = False  # its state's set entries are written


class Timeline:
    """The entries, signals and stop conditions of one storyboard."""

    def __init__(self, scope: Scope, entities: Mapping[str, str], catalogs: Any,
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
        self.state_refs: list[tuple[str, str, Node, str, str]] = []  # (type, name, node, placeholder, state)
        self.copy = ""  # the execution of the maneuver groups around, in the names of the entries ("(G 2 of 3)")
        self.repeating = False  # building the trigger of an element executed more than once
        self.written = False  # the states' set entries are written (write_states)
        self.stoppers: list[tuple[str, list[Element], bool]] = []  # (entry, elements it stops, only running ones)
        self.stopped: list[tuple[str, list[Element], bool, list[str]]] = []  # the same with each element's stop signal
        self.quiet: list[tuple[list[dict[str, Any]], list[Element]]] = []  # a skip event's racing entries, the others

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
        mine = next((x for x in self.entries if x["id"] == owner), None)
        if mine is not None and self.entries[-1] is not mine:  # after its latches: it reads them on the tick they are set
            self.entries.remove(mine)
            self.entries.append(mine)
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
        name = self.scope.name(node, default="story")
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
        story.executions.append(Execution(story.id, [x for a in story.children for x in a.executions[-1].over] or [story.id]))
        story.entry_points.append(e)
        self._rescope(scope_before)

    def _rescope(self, scope: Scope) -> None:
        self.scope = self.conditions.scope = self.actions.scope = scope

    def act(self, node: Node, story: Element) -> None:
        name = self.scope.name(node, default="act")
        act = Element("act", name, "", node, story)
        story.children.append(act)
        e = self.marker("Act", name, [story.id])
        e.update(self.trigger(node.child("StartTrigger"), [story.id], e["id"]))
        act.id = e["id"]
        act.entry_points.append(e)
        self.elements.append(act)
        first = len(self.entries)
        for group in node.all("ManeuverGroup"):
            self.group(group, act)
        act.executions.append(Execution(act.id, [x for g in act.children for x in g.executions[-1].over] or [act.id]))
        stop = node.child("StopTrigger")
        if stop is not None:  # 7.6.2: when it fires, the act's running children stop (the entry's 'stops')
            inside = [x["id"] for x in self.entries[first:]]
            keys = self.trigger(stop, [act.id], f"{act.id}-stop")
            if not keys:
                raise XmlProblem(stop, "an Act's StopTrigger needs a condition")
            entry = self.entry(f"{act.id}-stop", f"StopTrigger of Act {name}", "constraint", "wait", {"duration": 0},
                               [act.id], stops=inside, **keys)  # fmt: skip
            self.stoppers.append((entry["id"], list(_within(act)), False))  # 8.4.2: stopTransition to complete

    def group(self, node: Node, act: Element) -> None:
        """A ManeuverGroup, executed ``maximumExecutionCount`` times in a row (8.3.2: each execution starts when
        the one before is over; it has no StartTrigger): one copy of its maneuvers per execution."""
        name = self.scope.name(node, default="group")
        count = self.scope.integer(node, "maximumExecutionCount", 1)
        if not 1 <= count <= MAX_EXECUTIONS:
            raise XmlProblem(node, f"maximumExecutionCount {count} must be between 1 and {MAX_EXECUTIONS}")
        group = Element("maneuverGroup", name, "", node, act)
        act.children.append(group)
        actors = node.need_child("Actors")
        if self.scope.boolean(actors, "selectTriggeringEntities", False):
            raise XmlProblem(actors, "selectTriggeringEntities=true is not supported")
        names = []
        for ref in actors.all("EntityRef"):
            names.append(self.actions.entity(ref))
        self.elements.append(group)
        after, outer = [act.id], self.copy
        repeating = self.repeating
        for run in range(count):
            self.copy = outer if count == 1 else f"{outer}{' ' if outer else ''}({name} {run + 1} of {count})"
            self.repeating = repeating or count > 1
            label = name if count == 1 else f"{name} ({run + 1} of {count})"
            e = self.entry(name, f"ManeuverGroup {label}", "constraint", "wait", {"duration": 0}, after)
            if group.executions:
                group.executions[-1].next = e
            if run == 0:
                group.id = e["id"]
                group.entry_points.append(e)
            k = 0
            for child in node.children:
                if child.tag == "Maneuver":
                    child.use()
                    self.maneuver(child, group, names, self.scope, k, e["id"])
                    k += 1
                elif child.tag == "CatalogReference":
                    child.use()
                    entry, inner = self.catalogs.resolve("ManeuverCatalog", child, self.scope)
                    if entry.tag != "Maneuver":
                        raise XmlProblem(child, f"{entry.tag} is not a Maneuver")
                    self.maneuver(entry, group, names, inner, k, e["id"])
                    k += 1
            these = [x for m in group.children for x in m.executions[-1].over] or [e["id"]]
            over = self.entry(f"{name}-over", f"ManeuverGroup {label} over", "constraint", "wait", {"duration": 0}, these, join="all" if len(these) > 1 else None)
            for m in group.children:
                m.executions[-1].seal = over
            group.executions.append(Execution(e["id"], [over["id"]], last=run == count - 1))
            after = [over["id"]]
        self.copy, self.repeating = outer, repeating

    def maneuver(self, node: Node, group: Element, actors: list[str], scope: Scope, index: int, start: str) -> None:
        before = self.scope
        if scope is not before:
            self._rescope(scope)
        declarations = node.child("ParameterDeclarations")
        if declarations is not None and scope is before:
            inner = Scope(self.scope)
            inner.declare(declarations)
            self._rescope(inner)
        name = self.scope.name(node, default="maneuver")
        if index < len(group.children):  # a further execution of the maneuver group: the same element
            maneuver = group.children[index]
        else:
            maneuver = Element("maneuver", name, "", node, group)
            group.children.append(maneuver)
            self.elements.append(maneuver)
        e = self.entry(name, f"Maneuver {name}" + (f" {self.copy}" if self.copy else ""), "constraint", "wait", {"duration": 0}, [start])
        if not maneuver.id:
            maneuver.id = e["id"]
        maneuver.entry_points.append(e)
        nodes = node.all("Event")
        executions = []
        for k, ev in enumerate(nodes):
            existing = maneuver.children[k] if k < len(maneuver.children) else None
            executions.append(self.event(ev, maneuver, actors, e["id"], existing, skippable=len(nodes) > 1))
        over = [x for these in executions for x in these[-1].over] or [e["id"]]
        maneuver.executions.append(Execution(e["id"], over))
        for k, ev in enumerate(nodes):
            element = maneuver.children[k]
            priority = self.scope.choice(ev, "priority", ("override", "overwrite", "skip", "parallel"), "parallel")
            others = [o for o in maneuver.children if o is not element]
            for execution in executions[k]:
                if priority in ("override", "overwrite") and others:
                    execution.marker["stops"] = [a for o in others for a in o.actions]
                    self.stoppers.append((execution.start, others, True))  # the running ones: stopTransition
            self.quiet.extend((execution.branches, others) for execution in executions[k] if execution.branches)
        self._rescope(before)

    def event(self, node: Node, maneuver: Element, actors: list[str], start: str, event: "Element | None",
              skippable: bool) -> list["Execution"]:  # fmt: skip
        """An Event, its actions, once per execution: ``maximumExecutionCount`` N gives N copies, each after the
        one before is over, each waiting for the StartTrigger again (8.4.2.1). Returns this copy's executions."""
        name = self.scope.name(node, default="event")
        count = self.scope.integer(node, "maximumExecutionCount", 1)
        if not 1 <= count <= MAX_EXECUTIONS:
            raise XmlProblem(node, f"maximumExecutionCount {count} must be between 1 and {MAX_EXECUTIONS}")
        priority = self.scope.choice(node, "priority", ("override", "overwrite", "skip", "parallel"), "parallel")
        skips = priority == "skip" and skippable
        if event is None:
            event = Element("event", name, "", node, maneuver)
            maneuver.children.append(event)
            self.elements.append(event)
            self.events.append(event)
            self.state_of(event)  # every event has a state: the default criterion reads it
        elements = {k: a for k, a in enumerate(event.children)}
        after: list[str] = [start]
        executions: list[Execution] = []
        repeating = self.repeating
        self.repeating = repeating or count > 1
        for run in range(count):
            label = name if count == 1 else f"{name} ({run + 1} of {count})"
            label += f" {self.copy}" if self.copy else ""
            e = self.entry(name, f"Event {label}", "constraint", "wait", {"duration": 0}, after)
            e.update(self.trigger(node.child("StartTrigger"), after, e["id"]))
            if not event.id:
                event.id = e["id"]
            if run == 0:
                event.entry_points.append(e)
            begin, skip, branches = e["id"], None, []
            if skips:  # 8.4.2.2: triggered while another event of the maneuver runs, it is skipped (not started)
                race = identifier(f"{e['id']}-priority", self.ids)
                go = self.entry(f"{e['id']}-go", f"Event {label} starts (no other event of its maneuver running)", "constraint",
                                "wait", {"duration": 0}, [e["id"]], when=_QUIET, race=race)  # fmt: skip
                skipped = self.entry(f"{e['id']}-skip", f"Event {label} skipped (another event of its maneuver running)",
                                     "constraint", "wait", {"duration": 0}, [e["id"]], when=f"not ({_QUIET})", race=race)  # fmt: skip
                begin, skip, branches = go["id"], skipped["id"], [go, skipped]
            these: list[str] = []
            for k, action in enumerate(node.all("Action")):
                aname = self.scope.name(action, default="action")
                if k not in elements:
                    elements[k] = Element("action", aname, "", action, event)
                    event.children.append(elements[k])
                    self.elements.append(elements[k])
                element = elements[k]
                mine: list[str] = []
                body = action.only()
                if body.tag == "PrivateAction":
                    if not actors:
                        raise XmlProblem(body, "a private action needs an actor: the ManeuverGroup's Actors name none")
                    for actor in actors:
                        kind, params = self.actions.private(body, actor)
                        text = f"Action {aname}" + (f" ({actor})" if len(actors) > 1 else "")
                        a = self.lowered(body, actor, kind, params, aname if len(actors) == 1 else f"{aname}-{actor}", text, [begin])
                        mine.append(a["id"])
                elif body.tag == "GlobalAction":
                    inner = body.only()
                    if inner.tag in ("VariableAction", "ParameterAction"):
                        kind, params = self.actions.variable_action(inner)
                        a = self.entry(aname, f"Action {aname}", "behavior", kind, params, [begin])
                    elif inner.tag == "EnvironmentAction":  # read, no effect on a SUMO run: ends on the tick it starts
                        env = self.actions.environment(inner, self.catalogs)
                        a = self.entry(aname, f"Action {aname} (Environment {env}: read, no effect on a SUMO run)",
                                       "constraint", "wait", {"duration": 0}, [begin])  # fmt: skip
                    else:
                        raise XmlProblem(inner, f"{inner.tag} is not supported (VariableAction, ParameterAction, EnvironmentAction are)")
                    mine.append(a["id"])
                else:
                    raise XmlProblem(body, f"{body.tag} is not supported (PrivateAction, GlobalAction are)")
                if not element.id:
                    element.id = mine[0]
                element.actions.extend(mine)
                event.actions.extend(mine)
                element.executions.append(Execution(begin, mine))
                these.extend(mine)
            if not these:
                raise XmlProblem(node, "an Event needs at least one Action")
            done = self.entry(f"{e['id']}-done", f"Event {label} ended", "constraint", "wait", {"duration": 0}, these, join="all")
            over = done
            if skip is not None:
                over = self.entry(f"{e['id']}-over", f"Event {label} over", "constraint", "wait", {"duration": 0},
                                  [done["id"], skip], join="any")  # fmt: skip
            execution = Execution(begin, [over["id"]], last=run == count - 1, skip=skip, done=done, marker=e, branches=branches)
            for element in elements.values():
                element.executions[-1].seal = done  # the event ends after its actions' states
            ended = self._state_sets(event, execution, e["id"], f"event {label}")
            execution.over = [ended["id"]]  # what follows the execution follows its state
            event.executions.append(execution)
            executions.append(execution)
            after = [ended["id"]]
        self.repeating = repeating
        return executions

    # -- states ----------------------------------------------------------------------------------
    def state_of(self, element: Element) -> str:
        """The state signal of *element* (0 standby, 1 running, 2 complete; -1 before it is first in standby,
        when a condition reads its standbyState); its ``set`` entries are written by :meth:`write_states`."""
        if element.state is None:
            if self.written:
                raise RuntimeError(f"the state of {element.kind} {element.name} is asked for after the states were written")
            element.state = self.signal(f"state_{element.kind}_{element.name}", 0)
        return element.state

    def transition_of(self, element: Element, transition: str) -> str:
        """A boolean signal that turns true on the first ``transition`` (start, end, skip) of *element*."""
        if transition not in element.transitions:
            element.transitions[transition] = self.signal(f"{transition}_{element.kind}_{element.name}", False)
        return element.transitions[transition]

    def _state_sets(self, element: Element, ex: "Execution", tag: str, text: str) -> dict[str, Any]:
        """The ``set`` entries of *element*'s state for one execution: running on its start, standby or complete
        when it is over; what comes after the execution (its ``next``, its ``seal``) comes after that."""
        assert element.state is not None
        started = self.entry(f"{tag}-running", f"{text} running", "behavior", "set", {"signal": element.state, "value": 1}, [ex.start])
        value, word = (2, "complete") if ex.last else (0, "standby")
        if ex.done is not None and ex.skip is not None:  # it ends after its start's set, or is skipped
            ex.done["after"].append(started["id"])
            after, join = list(ex.over), None
        else:  # after its start's set too: one that ends on the tick it starts is running, then over
            after, join = [*ex.over, started["id"]], "all"
        ended = self.entry(f"{tag}-{word}", f"{text} {word}", "behavior", "set", {"signal": element.state, "value": value},
                           after, join=join)  # fmt: skip
        if ex.next is not None:  # the next execution after this one's state: running after standby
            ex.next["after"] = [ended["id"]]
            ex.next.pop("join", None)
        if ex.seal is not None:  # what closes the parent's execution comes after this state too
            ex.seal["after"].append(ended["id"])
            ex.seal["join"] = "all"
        ex.written = True
        return ended

    def write_states(self) -> None:
        """The ``set`` entries of every state and transition signal asked for, now that every execution is known."""
        self.written = True
        for element in self.elements:
            many = len(element.executions) > 1
            for k, ex in enumerate(element.executions):
                tag = f"{element.id}-{k + 1}" if many else element.id
                text = f"{element.kind} {element.name}" + (f" (execution {k + 1})" if many else "")
                if element.state is not None and not ex.written:
                    self._state_sets(element, ex, tag, text)
                for transition, signal in element.transitions.items():
                    if transition == "start":
                        after = [ex.start]
                    elif transition == "end":
                        after = [ex.done["id"]] if ex.done is not None else list(ex.over)
                    elif ex.skip is not None:
                        after = [ex.skip]
                    else:
                        continue
                    self.entry(f"{tag}-{transition}", f"{text} {transition}Transition", "behavior", "set",
                               {"signal": signal, "value": True}, after, join="all" if len(after) > 1 else None)  # fmt: skip
            if element.state is not None:  # 8.3: standby from its parent's start (again in each of its executions)
                if element.standby:
                    self.signals[element.state] = -1  # not yet in standby: its parent has not started
                for point in element.entry_points[0 if element.standby else 1:]:
                    wait = self.entry(f"{point['id']}-standby", f"{element.kind} {element.name} standby", "behavior", "set",
                                      {"signal": element.state, "value": 0}, point.get("after", []), join=point.get("join"))  # fmt: skip
                    point["after"] = [wait["id"]]
                    point.pop("join", None)
        for stopper, targets, running, latches in self.stopped:
            for element, latch in zip(targets, latches):
                # 8.4.2: an overridden event that runs, or an element of a stopped act not yet complete, moves to
                # completeState with a stopTransition. Its own latch (one writer: no two entries write one signal
                # unordered); "if" as a race of the set (with its condition) and a no-op
                race = identifier(f"{stopper}-{element.id}-stop", self.ids)
                test = self.expression(element, "runningState" if running else "notComplete", skip_latch=latch)
                self.entry(f"{stopper}-stops-{element.id}", f"{element.kind} {element.name} stopped", "behavior", "set",
                           {"signal": latch, "value": True}, [stopper], when=test, race=race)  # fmt: skip
                self.entry(f"{stopper}-spares-{element.id}", f"{element.kind} {element.name} not stopped", "constraint", "wait",
                           {"duration": 0}, [stopper], race=race)  # fmt: skip

    def expression(self, element: Element, state: str, skip_latch: str | None = None) -> str:
        """The expression of *element*'s *state* (``standbyState``, ``runningState``, ``completeState``,
        ``notComplete``) on its state signal and its stop signals (a stopped element is complete)."""
        signal = self.state_of(element)
        stopped = " || ".join(x for x in element.stops if x != skip_latch)
        if state == "completeState":
            return f"({signal} == 2 || {stopped})" if stopped else f"{signal} == 2"
        if state == "notComplete":
            return f"{signal} != 2 && !({stopped})" if stopped else f"{signal} != 2"
        value = {"standbyState": 0, "runningState": 1}[state]
        return f"{signal} == {value} && !({stopped})" if stopped else f"{signal} == {value}"

    def _state_expression(self, kind: str, name: str, state: str, node: Node) -> str:
        if kind not in ELEMENT_TYPES:
            raise XmlProblem(node, f"storyboardElementType {kind!r} is not one of {', '.join(ELEMENT_TYPES)}")
        if state not in STATES:
            raise XmlProblem(node, f"state {state!r} is not one of {', '.join(STATES)}")
        if state.endswith("Transition") and self.repeating:
            raise XmlProblem(node, f"a {state} in the trigger of an element executed more than once is not supported "
                                   "(a transition is read as 'has happened': it would start every further execution at once)")  # fmt: skip
        if state == "standbyState" and kind == "action":
            raise XmlProblem(node, "standbyState of an action is not supported (of an event, maneuver, group, act or story it is)")
        placeholder = f"@@state{len(self.state_refs)}@@"
        self.state_refs.append((kind, name, node, placeholder, state))
        return f"{placeholder}"

    def resolve_states(self) -> None:
        """Replace the placeholders of state conditions by the named elements' state and transition signals (the
        elements may be written after the conditions that name them), then write the signals' ``set`` entries."""
        texts: list[tuple[str, Any, str | None]] = []
        for kind, name, node, placeholder, state in self.state_refs:
            found = [el for el in self.elements if el.kind == kind and el.name == name]
            if not found:
                names = sorted({el.name for el in self.elements if el.kind == kind})
                raise XmlProblem(node, f"no {kind} named {name!r}" + (f" ({', '.join(names)})" if names else ""))
            if len(found) > 1:
                raise XmlProblem(node, f"{len(found)} {kind}s are named {name!r}: the reference is ambiguous")
            element = found[0]
            if state.endswith("Transition"):
                transition = state[: -len("Transition")]
                if transition == "stop":
                    self.state_of(element)  # a stop is seen in the state: running (or standby) to complete
                    texts.append((placeholder, element, "stopTransition"))
                    continue
                if transition == "skip" and not any(ex.skip for ex in element.executions):
                    text = "false"  # 8.4.2.2: only an event of priority skip in a maneuver of several events is ever skipped
                else:
                    text = self.transition_of(element, transition)
                texts.append((placeholder, text, None))
            else:
                if state == "standbyState":
                    element.standby = True
                self.state_of(element)
                texts.append((placeholder, element, state))
        for element in self.events:
            self.state_of(element)
        for stopper, targets, running in self.stoppers:  # a stop signal per stopper and element with a state
            targets = [el for el in targets if el.state is not None]
            latches = [self.signal(f"stopped_{el.kind}_{el.name}", False) for el in targets]
            for element, latch in zip(targets, latches):
                element.stops.append(latch)
            self.stopped.append((stopper, targets, running, latches))
        for placeholder, what, state in texts:
            if isinstance(what, Element):
                text = (" || ".join(what.stops) or "false") if state == "stopTransition" else self.expression(what, state)
                text = f"({text})" if "||" in text or "&&" in text else text
            else:
                text = what
            for holder in [*self.entries, *self.stop]:
                if "when" in holder and placeholder in holder["when"]:
                    holder["when"] = holder["when"].replace(placeholder, text)
        for branches, others in self.quiet:  # priority skip: none of the others running
            quiet = " && ".join(f"!({self.expression(o, 'runningState')})" for o in others) or "true"
            for branch in branches:
                branch["when"] = branch["when"].replace(_QUIET, quiet)
        self.write_states()


def _within(element: Element) -> Any:
    """*element* and every element below it."""
    yield element
    for child in element.children:
        yield from _within(child)


def _keys(expect: str, edge: str, delay: float) -> dict[str, Any]:
    keys: dict[str, Any] = {"when": expect}
    if edge != "none":
        keys["edge"] = edge
    if delay:
        keys["delay"] = delay
    return keys
