"""Actions: an OpenSCENARIO ``PrivateAction`` (or ``GlobalAction``) as the action and params of a case entry.

ASAM OpenSCENARIO 1.2, clause 7.3 "Actions" (1.0: 8.3). Each supported private action becomes one
of the SUMO leaves (``sumo.speed``, ``sumo.lane_change``, ``sumo.lane_offset``, ``sumo.teleport``,
``sumo.follow``, ``sumo.controller``, ``sumo.trajectory``: docs/opendrive.md has their motion), the
attributes evaluated (parameters and ``${...}`` expressions) and renamed to the leaves' params; a
variable's set action becomes the built-in ``set`` of the variable's signal. Positions are passed
as the position objects of the road system (one key, the OSC element name; attributes evaluated).
"""

from __future__ import annotations

from typing import Any, Callable, Mapping

from .parameters import Scope
from .xmltree import Node, XmlProblem

__all__ = ["ActionWriter", "SHAPES", "DIMENSIONS", "POSITIONS", "ENVIRONMENT_PARTS"]

SHAPES = ("linear", "cubic", "sinusoidal", "step")
DIMENSIONS = {"time": "duration", "rate": "rate", "distance": "distance"}
POSITIONS = ("LanePosition", "RelativeLanePosition", "RoadPosition", "RelativeRoadPosition", "WorldPosition",
             "RelativeWorldPosition", "RelativeObjectPosition")  # fmt: skip
_STRINGS = {"roadId", "entityRef", "type"}
# what an Environment may hold (1.0-1.3): light, weather and the road's surface - read, none of it moves an entity
ENVIRONMENT_PARTS = frozenset({"TimeOfDay", "Weather", "Sun", "Fog", "Precipitation", "Wind", "DomeImage", "DomeFile",
                               "BoundingBox", "Center", "Dimensions", "RoadCondition", "Properties", "Property", "File"})  # fmt: skip
_INTEGERS = {"laneId", "dLane"}


class ActionWriter:
    """Entries' ``(action, params)`` for actions of one entity (the actor).

    Args:
        scope: the parameters
        entities: the ScenarioObject names -> the names their signals carry (:func:`.scenario.signal_names`)
        variable: ``(name, node) -> (signal, kind)`` for variable actions
    """

    def __init__(self, scope: Scope, entities: Mapping[str, str], variable: Callable[[str, Node], str],
                 controller: Callable[[str], str | None] = lambda name: None):  # fmt: skip
        self.scope, self.entities, self.variable, self.controller = scope, entities, variable, controller
        self.object_controllers: dict[str, str | None] = {}  # entity -> the name of its ObjectController (1.3)

    def entity(self, node: Node, attr: str = "entityRef") -> str:
        name = self.scope.text(node, attr) or ""
        if name not in self.entities:
            raise XmlProblem(node, f"{attr}={name!r} names no entity (entities: {', '.join(self.entities)})")
        return self.entities[name]

    def position(self, node: Node) -> dict[str, Any]:
        """A ``Position`` element as the road system's position object."""
        kind = node.only()
        if kind.tag not in POSITIONS:
            raise XmlProblem(kind, f"{kind.tag} is not supported (supported: {', '.join(POSITIONS)})")
        attrs: dict[str, Any] = {}
        for name in kind.attrs:
            if name == "entityRef":
                attrs[name] = self.entity(kind)
            elif name in _STRINGS:
                attrs[name] = self.scope.text(kind, name)
            elif name in _INTEGERS:
                attrs[name] = self.scope.integer(kind, name)
            else:
                attrs[name] = self.scope.number(kind, name)
        result: dict[str, Any] = {kind.tag: attrs}
        orientation = kind.child("Orientation")
        if orientation is not None:
            o: dict[str, Any] = {}
            for name in orientation.attrs:
                o[name] = self.scope.text(orientation, name) if name == "type" else self.scope.number(orientation, name)
            result["Orientation"] = o
        for extra in kind.children:
            if not extra.used:
                raise XmlProblem(extra, f"{extra.tag} in a {kind.tag} is not supported")
        return result

    def dynamics(self, node: Node) -> dict[str, Any]:
        shape = self.scope.choice(node, "dynamicsShape", SHAPES)
        dimension = self.scope.choice(node, "dynamicsDimension", tuple(DIMENSIONS))
        value = self.scope.number(node, "value")
        if shape == "step":
            return {"shape": "step"}
        return {"shape": shape, DIMENSIONS[dimension]: value}

    def private(self, action: Node, actor: str) -> tuple[str, dict[str, Any]]:
        """``(action, params)`` of a ``PrivateAction`` for *actor*."""
        kind = action.only()
        s = self.scope
        if kind.tag == "LongitudinalAction":
            inner = kind.only()
            if inner.tag == "SpeedAction":
                params: dict[str, Any] = {"vehicle": actor, **self.dynamics(inner.need_child("SpeedActionDynamics"))}
                target = inner.need_child("SpeedActionTarget").only()
                if target.tag == "AbsoluteTargetSpeed":
                    params["to"] = s.number(target, "value")
                elif target.tag == "RelativeTargetSpeed":
                    params["relative"] = {"entity": self.entity(target), "value": s.number(target, "value"),
                                          "type": s.choice(target, "speedTargetValueType", ("delta", "factor")),
                                          "continuous": s.boolean(target, "continuous")}  # fmt: skip
                else:
                    raise XmlProblem(target, f"unknown speed target {target.tag}")
                return "sumo.speed", params
            if inner.tag == "LongitudinalDistanceAction":
                params = {"vehicle": actor, "entity": self.entity(inner), "freespace": s.boolean(inner, "freespace"),
                          "continuous": s.boolean(inner, "continuous")}  # fmt: skip
                if "distance" in inner.attrs:
                    params["distance"] = s.number(inner, "distance")
                elif "timeGap" in inner.attrs:
                    params["time_gap"] = s.number(inner, "timeGap")
                else:
                    raise XmlProblem(inner, "LongitudinalDistanceAction needs distance or timeGap")
                s.choice(inner, "coordinateSystem", ("entity", "road", "lane"), "entity")
                params["displacement"] = s.choice(inner, "displacement", ("any", "trailingReferencedEntity", "leadingReferencedEntity"),
                                                  "trailingReferencedEntity")  # fmt: skip
                limits = inner.child("DynamicConstraints")
                if limits is not None:
                    for attr, key in (("maxAcceleration", "max_accel"), ("maxDeceleration", "max_decel"), ("maxSpeed", "max_speed")):
                        if attr in limits.attrs:
                            params[key] = s.number(limits, attr)
                return "sumo.follow", params
            raise XmlProblem(inner, f"{inner.tag} is not supported")
        if kind.tag == "LateralAction":
            inner = kind.only()
            if inner.tag == "LaneChangeAction":
                params = {"vehicle": actor, **self.dynamics(inner.need_child("LaneChangeActionDynamics"))}
                if "targetLaneOffset" in inner.attrs:
                    params["target_offset"] = s.number(inner, "targetLaneOffset")
                target = inner.need_child("LaneChangeTarget").only()
                if target.tag == "AbsoluteTargetLane":
                    params["lane"] = s.integer(target, "value")
                elif target.tag == "RelativeTargetLane":
                    params["relative"] = {"entity": self.entity(target), "value": s.integer(target, "value")}
                else:
                    raise XmlProblem(target, f"unknown lane target {target.tag}")
                return "sumo.lane_change", params
            if inner.tag == "LaneOffsetAction":
                params = {"vehicle": actor, "continuous": s.boolean(inner, "continuous")}
                dyn = inner.need_child("LaneOffsetActionDynamics")
                params["shape"] = s.choice(dyn, "dynamicsShape", SHAPES)
                if "maxLateralAcc" in dyn.attrs:
                    params["max_lateral_acc"] = s.number(dyn, "maxLateralAcc")
                target = inner.need_child("LaneOffsetTarget").only()
                if target.tag == "AbsoluteTargetLaneOffset":
                    params["offset"] = s.number(target, "value")
                elif target.tag == "RelativeTargetLaneOffset":
                    params["relative"] = {"entity": self.entity(target), "value": s.number(target, "value")}
                else:
                    raise XmlProblem(target, f"unknown lane offset target {target.tag}")
                return "sumo.lane_offset", params
            raise XmlProblem(inner, f"{inner.tag} is not supported")
        if kind.tag == "TeleportAction":
            return "sumo.teleport", {"vehicle": actor, "position": self.position(kind.need_child("Position"))}
        if kind.tag in ("ControllerAction", "ActivateControllerAction"):
            inner = kind.only() if kind.tag == "ControllerAction" else kind
            if inner.tag != "ActivateControllerAction":
                raise XmlProblem(inner, f"{inner.tag} is not supported (ActivateControllerAction is)")
            params = {"vehicle": actor, "active": True}
            for attr in ("lateral", "longitudinal"):
                if attr in inner.attrs:
                    params[attr] = s.boolean(inner, attr)
            for attr in ("animation", "lighting"):  # 1.2: no effect on the motion
                s.text(inner, attr)
            ref = s.text(inner, "objectControllerRef")  # 1.3: which of the entity's ObjectControllers (one is supported)
            if ref is not None and (actor not in self.object_controllers or self.object_controllers[actor] != ref):
                raise XmlProblem(inner, f"objectControllerRef={ref!r} names no ObjectController of {actor!r}")
            name = self.controller(actor)
            if name is not None:  # the sidecar's controller: a plugin's leaf, started here (docs/opendrive.md)
                return name, {"vehicle": actor}
            return "sumo.controller", params
        if kind.tag == "RoutingAction":
            inner = kind.only()
            if inner.tag == "FollowTrajectoryAction":
                return "sumo.trajectory", self.trajectory(inner, actor)
            raise XmlProblem(inner, f"{inner.tag} is not supported")
        raise XmlProblem(kind, f"{kind.tag} is not supported")

    def trajectory(self, node: Node, actor: str) -> dict[str, Any]:
        s = self.scope
        holder = node.child("TrajectoryRef") or node
        trajectory = holder.child("Trajectory")
        if trajectory is None:
            raise XmlProblem(holder, "FollowTrajectoryAction needs a Trajectory (a CatalogReference to one is not supported)")
        params: dict[str, Any] = {"vehicle": actor, "closed": s.boolean(trajectory, "closed")}
        s.text(trajectory, "name")
        shape = trajectory.need_child("Shape").only()
        if shape.tag != "Polyline":
            raise XmlProblem(shape, f"{shape.tag} trajectories are not supported (Polyline is)")
        vertices = []
        for v in shape.all("Vertex"):
            vertex: dict[str, Any] = {"position": self.position(v.need_child("Position"))}
            if "time" in v.attrs:
                vertex["time"] = s.number(v, "time")
            vertices.append(vertex)
        if len(vertices) < 2:
            raise XmlProblem(shape, "a Polyline needs at least two vertices")
        params["vertices"] = vertices
        reference = node.need_child("TimeReference").only()
        if reference.tag == "Timing":
            params["absolute"] = s.choice(reference, "domainAbsoluteRelative", ("absolute", "relative")) == "absolute"
            params["time_scale"] = s.number(reference, "scale")
            params["time_offset"] = s.number(reference, "offset")
        elif reference.tag != "None":
            raise XmlProblem(reference, f"unknown time reference {reference.tag}")
        mode = node.need_child("TrajectoryFollowingMode")
        params["following"] = s.choice(mode, "followingMode", ("position", "follow"))
        if "followingMode" in mode.attrs and params["following"] != "position":
            raise XmlProblem(mode, "followingMode 'follow' is not supported ('position' is)")
        if "initialDistanceOffset" in node.attrs and s.number(node, "initialDistanceOffset") != 0:
            raise XmlProblem(node, "an initialDistanceOffset other than 0 is not supported")
        return params

    def environment(self, node: Node, catalogs: Any) -> str:
        """An ``EnvironmentAction`` (7.3.2): read, with no effect on the run; the Environment's name.

        Time of day, sun, fog, clouds, precipitation, wind and road properties change what sensors and
        drivers would see; SUMO models none of them (nor do esmini's physics), so every attribute is
        evaluated (a bad ``$`` reference is still exit 2) and nothing is applied. What would change the
        motion and is not applied - a ``RoadCondition`` ``frictionScaleFactor`` other than 1 - is refused
        at its element. An element not in :data:`ENVIRONMENT_PARTS` stays unused: reported unsupported.
        """
        inner = node.only()
        scope = self.scope
        if inner.tag == "CatalogReference":
            inner, scope = catalogs.resolve("EnvironmentCatalog", inner, scope)
        elif inner.tag != "Environment":
            raise XmlProblem(inner, f"{inner.tag} in an EnvironmentAction is not supported")
        name = scope.text(inner, "name") or "environment"
        todo = [c for c in inner.children if c.tag in ENVIRONMENT_PARTS]
        while todo:
            part = todo.pop(0).use()
            for attr in part.attrs:
                if part.tag == "RoadCondition" and attr == "frictionScaleFactor":
                    friction = scope.number(part, attr)
                    if friction != 1:
                        raise XmlProblem(part, f"frictionScaleFactor {friction:g} is not supported: SUMO's vehicles brake and "
                                               "accelerate as on a dry road (only 1 is, which changes nothing)")  # fmt: skip
                else:
                    scope.text(part, attr)
            todo.extend(c for c in part.children if c.tag in ENVIRONMENT_PARTS)
        return name

    def variable_action(self, node: Node) -> tuple[str, dict[str, Any]]:
        """``VariableAction``/``ParameterAction`` (1.0's ``ParameterSetAction``) -> ``set`` of its signal."""
        s = self.scope
        ref_attr = "variableRef" if node.tag == "VariableAction" else "parameterRef"
        signal = self.variable(s.text(node, ref_attr) or "", node)
        inner = node.only()
        if inner.tag != "SetAction":
            raise XmlProblem(inner, f"{inner.tag} is not supported (SetAction is)")
        raw = s.value(inner, inner.need("value"))
        if isinstance(raw, bool) or raw in ("true", "false"):
            value: Any = raw if isinstance(raw, bool) else raw == "true"
        else:
            try:
                value = float(raw)
            except (TypeError, ValueError):
                raise XmlProblem(inner, f"{raw!r}: only number and boolean variables are supported") from None
            value = int(value) if value.is_integer() else value
        return "set", {"signal": signal, "value": value}
