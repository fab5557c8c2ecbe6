"""A concrete OpenSCENARIO file as a test-case document of this project (one case model).

The file's parts (ASAM OpenSCENARIO 1.2, clause 7; 1.0: clause 8):

* ``FileHeader`` - revision 1.0 to 1.3; ``description`` is the case's description.
* ``ParameterDeclarations`` (:mod:`.parameters`), ``VariableDeclarations`` (signals),
  ``CatalogLocations`` (:mod:`.catalogs`).
* ``RoadNetwork/LogicFile`` - the OpenDRIVE file, the SUMO system's ``road`` (converted by
  netconvert, cached by content: docs/opendrive.md). ``SceneGraphFile`` is a picture only (used,
  no effect).
* ``Entities`` - each ``ScenarioObject`` an entity of the SUMO system (``system.entities``: its
  BoundingBox, category, performance), its name the vehicle's id and the prefix of its signals.
* ``Storyboard/Init`` - ``TeleportAction`` s and step ``SpeedAction`` s give each entity's place and
  speed at time 0; other init actions are entries that start at time 0.
* ``Storyboard`` - the timeline (:mod:`.storyboard`) and the top-level ``stop``.

The default pass criteria (docs/openscenario.md "Pass criteria"): no collision involving the ego,
every event that started has completed. A sidecar oracle adds or replaces them (:mod:`.oracle`).
"""

from __future__ import annotations

import os
import re
from typing import Any, Mapping

from ..expressions import RESERVED
from .catalogs import Catalogs
from .motion import Motion
from .parameters import Scope
from .storyboard import Timeline
from .xmltree import Node, XmlProblem

__all__ = ["convert_scenario", "signal_names", "REVISIONS", "EGO_NAMES", "DEFAULT_TIMEOUT", "DEFAULT_TICK", "Options"]

REVISIONS = ((1, 0), (1, 1), (1, 2), (1, 3))
EGO_NAMES = ("Ego", "ego", "hero")
DEFAULT_TIMEOUT = 600.0
"""Seconds a converted scenario may run before the verdict is ``timeout`` (its StopTrigger should end it first)."""
DEFAULT_TICK = 0.1


class Options:
    """What the command line (or a sidecar) may set for a conversion."""

    def __init__(self, ego: str | None = None, timeout: float | None = None, controllers: Mapping[str, str] | None = None):
        self.ego, self.timeout, self.controllers = ego, timeout, dict(controllers or {})


def header(root: Node, scope: Scope) -> tuple[int, int, str]:
    head = root.need_child("FileHeader")
    try:
        revision = (int(head.need("revMajor")), int(head.need("revMinor")))
    except ValueError:
        raise XmlProblem(head, "revMajor and revMinor must be integers") from None
    if revision not in REVISIONS:
        raise XmlProblem(head, f"OpenSCENARIO {revision[0]}.{revision[1]} is not supported (1.0 to 1.3 are)")
    description = head.attrs.get("description", "")
    head.use_all()  # date, author, License, Properties: for people
    return revision[0], revision[1], description


def _entity(obj: Node, scope: Scope, catalogs: Catalogs) -> dict[str, Any]:
    """A ScenarioObject's physical description for the SUMO system."""
    body = None
    inner = scope
    for child in obj.children:
        if child.tag in ("Vehicle", "Pedestrian", "MiscObject"):
            body = child.use()
        elif child.tag == "CatalogReference":
            child.use()
            catalog = scope.text(child, "catalogName") or ""
            for kind in ("VehicleCatalog", "PedestrianCatalog", "MiscObjectCatalog"):
                if kind in catalogs.dirs and catalog in catalogs.load(kind, child):
                    body, inner = catalogs.resolve(kind, child, scope)
                    break
            else:
                raise XmlProblem(child, f"catalog {catalog!r} is in no Vehicle, Pedestrian or MiscObject catalog directory")
        elif child.tag in ("ExternalObjectReference", "EntitySelection"):
            raise XmlProblem(child, f"{child.tag} is not supported")
    if body is None:
        raise XmlProblem(obj, "a ScenarioObject needs a Vehicle, Pedestrian, MiscObject or CatalogReference")
    declarations = body.child("ParameterDeclarations")
    if declarations is not None and inner is scope:
        inner = Scope(scope)
        inner.declare(declarations)
    spec: dict[str, Any] = {}
    box = body.need_child("BoundingBox")
    center, dims = box.need_child("Center"), box.need_child("Dimensions")
    spec["length"] = inner.number(dims, "length")
    spec["width"] = inner.number(dims, "width")
    spec["height"] = inner.number(dims, "height")
    spec["center"] = [inner.number(center, "x"), inner.number(center, "y"), inner.number(center, "z")]
    if body.tag == "Vehicle":
        spec["category"] = inner.text(body, "vehicleCategory") or "car"
        perf = body.child("Performance")
        if perf is not None:
            spec["max_speed"] = inner.number(perf, "maxSpeed")
            spec["max_accel"] = inner.number(perf, "maxAcceleration")
            spec["max_decel"] = inner.number(perf, "maxDeceleration")
            for attr in ("maxAccelerationRate", "maxDecelerationRate"):  # 1.2: jerk limits, not modelled
                inner.text(perf, attr)
    elif body.tag == "Pedestrian":
        spec["category"] = "pedestrian"
        inner.text(body, "pedestrianCategory")
        for attr in ("model", "modelName"):
            inner.text(body, attr)
    else:
        spec["category"] = "misc"
        inner.text(body, "miscObjectCategory")
        inner.text(body, "model3d")
    for attr in ("name", "mass", "role", "model3d"):
        inner.text(body, attr)
    for child in body.children:
        if child.tag in ("Axles", "Properties"):  # wheel geometry and free properties: no effect on SUMO's motion
            child.use_all()
        elif child.tag in ("TrailerHitch", "TrailerCoupler"):  # 1.3: where a trailer would couple; nothing is towed
            inner.number(child, "dx")
            child.use()
        elif child.tag == "Trailer":
            _no_trailer(child, inner)
    return spec


def _no_trailer(trailer: Node, scope: Scope) -> None:
    """A 1.3 ``Trailer`` that tows nothing - its reference empty, as esmini's catalog writes a car that may
    tow one (``<EntityRef entityRef="$TrailerRef"/>``, ``TrailerRef`` "" by default) - is read; a towed
    trailer is refused: SUMO drives no coupled vehicles."""
    ref = trailer.use().only()
    if ref.tag == "EntityRef":
        named = scope.text(ref, "entityRef")
    elif ref.tag == "CatalogReference":
        named = scope.text(ref, "entryName")
        scope.text(ref, "catalogName")
        ref.use_all()
    else:
        named = ref.tag
    if named:
        raise XmlProblem(trailer, f"a towed Trailer ({named!r}) is not supported")


def _placement_order(entities: dict[str, dict[str, Any]], init: Node) -> dict[str, dict[str, Any]]:
    """The entities in the file's order, except that one placed (or given its speed) relative to another
    comes after that one: the Init's actions all apply at time 0 (7.6.1), whatever the order of the
    ``Private`` s - ASAM's SlowPrecedingVehicle places its Ego 200 m behind A1, declared after it - while
    the SUMO system places its entities one after the other (docs/opendrive.md)."""

    def refs(name: str) -> set[str]:
        spec = entities[name]
        found = {p.get("entityRef") for p in spec["position"].values() if isinstance(p, dict)}
        if isinstance(spec.get("speed"), dict):
            found.add(spec["speed"].get("entityRef"))
        return {r for r in found if r in entities and r != name}

    ordered: dict[str, dict[str, Any]] = {}
    pending = list(entities)
    while pending:
        ready = next((n for n in pending if refs(n) <= ordered.keys()), None)
        if ready is None:
            raise XmlProblem(init, f"entities {', '.join(map(repr, pending))} are placed relative to each other in a circle")
        ordered[ready] = entities[ready]
        pending.remove(ready)
    return ordered


_SIGNAL_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
_NOT_IN_NAME = re.compile(r"[^A-Za-z0-9_]")


def signal_names(names: list[str]) -> dict[str, str]:
    """Each ScenarioObject name -> the name its signals (``NAME.speed``) and its SUMO vehicle carry.

    A name the expression language can read (an ASCII letter, then letters, digits, ``_``; not a word of
    the language, not ``sim``) is kept. Any other - ASAM's ``Vehicle 1`` - is mapped: every other character
    becomes ``_``, a name not starting with a letter gets ``E_`` before it, a reserved word ``_`` after it,
    and ``_2``, ``_3`` ... until it is no other entity's name. References in the file (``entityRef``)
    use the scenario's names; the case, its signals and its views the mapped ones."""
    kept = {n for n in names if _SIGNAL_NAME.fullmatch(n) and n not in RESERVED and n != "sim"}
    taken = {n.casefold() for n in kept}
    result: dict[str, str] = {}
    for name in names:
        if name in kept:
            result[name] = name
            continue
        base = _NOT_IN_NAME.sub("_", name)
        base = base if base[:1].isalpha() else "E_" + base
        base = base + "_" if base in RESERVED or base == "sim" else base
        found, n = base, 2
        while found.casefold() in taken:
            found, n = f"{base}_{n}", n + 1
        taken.add(found.casefold())
        result[name] = found
    return result


def convert_scenario(root: Node, path: str, given: Mapping[str, Any] | None = None, options: Options | None = None,
                     check_constraints: bool = True, case_dir: str | None = None) -> tuple[dict[str, Any], Catalogs]:  # fmt: skip
    """The case document of the scenario *root* (read from *path*), its parameters set to *given*;
    its files named relative to *case_dir* (default: the scenario's directory)."""
    options = options or Options()
    root.use()
    scope = Scope()
    _, _, description = header(root, scope)
    declarations = root.child("ParameterDeclarations")
    unknown = sorted(set(given or {}) - {d.attrs.get("name") for d in (declarations.children if declarations else [])})
    if unknown:
        raise XmlProblem(declarations or root, f"no parameter named {', '.join(map(repr, unknown))} is declared")
    scope.declare(declarations, given, check=check_constraints)
    base = os.path.dirname(os.path.abspath(path))
    catalogs = Catalogs(root.child("CatalogLocations"), scope, base)
    road_node = root.need_child("RoadNetwork")
    logic = road_node.need_child("LogicFile")
    road = scope.text(logic, "filepath") or ""
    if not os.path.isfile(os.path.join(base, road)):
        hint = "" if road.lower().endswith(".xodr") else (
            "; LogicFile names an OpenDRIVE .xodr file - a CARLA town (Town04) is a map inside CARLA: give its .xodr")
        raise XmlProblem(logic, f"road network {road!r} not found (looked for {os.path.join(base, road)!r}){hint}")
    for child in road_node.children:
        if child.tag == "SceneGraphFile":  # 3D model for visualisation
            child.use_all()
        elif child.tag == "TrafficSignals":
            raise XmlProblem(child, "TrafficSignals are not supported")
        elif child.tag == "UsedArea":
            child.use_all()
    entities_node = root.need_child("Entities")
    entities: dict[str, dict[str, Any]] = {}
    assigned: dict[str, str | None] = {}
    objects = entities_node.all("ScenarioObject")
    given_names: list[str] = []
    for obj in objects:
        name = scope.name(obj)
        if not name:
            raise XmlProblem(obj, "a ScenarioObject needs a name")
        if name in given_names:
            raise XmlProblem(obj, f"two entities are named {name!r}")
        given_names.append(name)
    aliases = signal_names(given_names)  # "Vehicle 1" -> Vehicle_1: the name of its signals
    original = {safe: name for name, safe in aliases.items()}
    for obj, name in zip(objects, aliases.values()):
        entities[name] = _entity(obj, scope, catalogs)
        entities[name]["controller"] = False
        ctrl = obj.child("ObjectController")
        if ctrl is not None:  # assigned, not active until an ActivateControllerAction (7.3.5)
            assigned[name] = scope.text(ctrl, "name")  # 1.3: the name an ActivateControllerAction may give
            ref = ctrl.only()
            if ref.tag == "CatalogReference":
                entry, _ = catalogs.resolve("ControllerCatalog", ref, scope)
                entry.use_all()
            elif ref.tag == "Controller":
                ref.use_all()
            else:
                raise XmlProblem(ref, f"{ref.tag} is not supported")
    for child in entities_node.children:
        if child.tag == "EntitySelection":
            raise XmlProblem(child, "EntitySelection is not supported")
    names = list(aliases)
    controllers = options.controllers
    timeline = Timeline(scope, aliases, catalogs, lambda safe: controllers.get(original.get(safe, safe), controllers.get(safe)),
                        road=os.path.join(base, road))  # fmt: skip
    timeline.actions.object_controllers = assigned
    timeline.declare_variables(root.child("VariableDeclarations"))
    board = root.need_child("Storyboard")
    init = board.need_child("Init")
    later: list[tuple[Node, str, str, dict[str, Any]]] = []  # Init actions that are entries at time 0
    follow: list[tuple[Node, str, dict[str, Any]]] = []
    actions = init.need_child("Actions")
    for part in actions.children:
        part.use()
        if part.tag == "Private":
            actor = timeline.actions.entity(part)
            for pa in part.all("PrivateAction"):
                kind, params = timeline.actions.private(pa, actor)
                if kind == "sumo.teleport" and "position" not in entities[actor]:
                    entities[actor]["position"] = params["position"]
                elif kind == "sumo.controller":  # active from time 0: SUMO's driver model (or the named controller)
                    entities[actor]["controller"] = params.get("name", True)
                elif kind == "sumo.follow":  # places the entity (.motion)
                    follow.append((pa, actor, params))
                elif kind == "sumo.speed" and params.get("shape") == "step" and "speed" not in entities[actor] and (
                        params.get("relative") is None or params["relative"]["type"] in ("delta", "factor")
                        and not params["relative"].get("continuous")):  # fmt: skip
                    rel = params.get("relative")
                    entities[actor]["speed"] = params["to"] if rel is None else {"entityRef": rel["entity"], "value": rel["value"], "type": rel["type"]}
                else:
                    later.append((pa, actor, kind, params))
        elif part.tag == "GlobalAction":
            inner = part.only()
            if inner.tag in ("VariableAction", "ParameterAction"):
                kind, params = timeline.actions.variable_action(inner)
                timeline.signals[params["signal"]] = params["value"]  # at time 0: the initial value
            elif inner.tag == "EnvironmentAction":  # read, no effect on a SUMO run (docs/openscenario.md)
                timeline.actions.environment(inner, catalogs)
            else:
                raise XmlProblem(inner, f"{inner.tag} is not supported")
        elif part.tag == "UserDefinedAction":
            raise XmlProblem(part, "UserDefinedAction is not supported")
    for name, spec in entities.items():
        if "position" not in spec:
            raise XmlProblem(init, f"entity {name!r} has no TeleportAction in Init: its place at time 0 is unknown")
    entities = _placement_order(entities, init)
    motion = Motion(entities)
    motion.init_speeds()
    for pa, actor, params in follow:
        motion.place_at_distance(pa, actor, params)
    timeline.motion = motion
    for pa, actor, kind, params in later:
        short = kind.split(".")[-1]
        timeline.lowered(pa, actor, kind, params, f"init-{actor}-{short}", f"Init {actor} {short}", [])
    timeline.storyboard(board, [])
    timeline.resolve_states()
    ego = aliases.get(options.ego, options.ego) if options.ego else next((n for n in EGO_NAMES if n in entities), None)
    if options.ego is not None and ego not in entities:
        raise XmlProblem(entities_node, f"--ego {options.ego!r} names no entity (entities: {', '.join(names)})")
    criteria: list[dict[str, Any]] = []
    if ego is not None:
        criteria.append({"id": "no_collision", "type": "record", "expect": f"not {ego}.collided",
                         "name": f"no collision involving the ego ({ego})"})  # fmt: skip
        # SUMO removes a vehicle at the end of its road: the run ends there too, and fails, instead of
        # running on without the ego (an error); the StopTrigger was not reached
        criteria.append({"id": "stop_trigger", "type": "final", "expect": f"not {ego}.end_of_road",
                         "name": f"the StopTrigger ended the run, not the end of the road ({ego})"})  # fmt: skip
        timeline.stop.append({"when": f"{ego}.end_of_road"})
    for event in timeline.events:  # not running at the end: standby (executions left), complete or stopped
        signal = timeline.state_of(event)
        expect = " || ".join([f"{signal} != 1", *event.stops])
        criteria.append({"id": f"completed-{event.id}"[:64], "type": "final", "expect": expect,
                         "name": f"event {event.name} completed if it started"[:200]})  # fmt: skip
    stem = os.path.splitext(os.path.basename(path))[0]
    doc: dict[str, Any] = {"name": stem[:200] or "scenario"}
    if description:
        doc["description"] = description[:100_000]
    if case_dir is not None:
        road = os.path.relpath(os.path.join(base, road), case_dir)
    doc["system"] = {"type": "sumo", "road": road, "entities": entities}
    doc["tick"] = DEFAULT_TICK
    doc["timeout"] = options.timeout if options.timeout is not None else DEFAULT_TIMEOUT
    if timeline.signals:
        doc["signals"] = timeline.signals
    doc["execute"] = timeline.entries
    if timeline.stop:
        doc["stop"] = timeline.stop
    doc["oracle"] = {"relation": "&&", "criteria": criteria}
    return doc, catalogs

