"""What the scenario says of each entity's speed, and the few adjustments an action needs for its leaf.

The road system's leaves take OpenSCENARIO's actions as the standard states them (docs/opendrive.md):
``sumo.speed`` with its dynamics shapes and relative targets, ``sumo.lane_change``,
``sumo.lane_offset``, ``sumo.teleport``, ``sumo.follow``, ``sumo.controller``. This module keeps
what the conversion must know beyond one action:

* the speed each entity was last given (the Init's, then the actions in the file's order): a
  ``SpeedAction`` by ``rate`` whose target is the speed the entity already has is a step (the leaf
  needs a rate above 0: the corpus's ``CutInVehicle_Acceleration_Rate_mps2`` is 0 by default), and a
  negative rate is its magnitude (the corpus writes a deceleration as a negative rate);
* an Init ``LongitudinalDistanceAction`` places the entity: its ``RelativeLanePosition``'s ``ds`` from
  the referenced entity is the distance (``timeGap`` times the referenced entity's speed), plus the
  bounding boxes' extents with ``freespace``, on the side its Init position put it.

"""

from __future__ import annotations

from typing import Any, Mapping

from .xmltree import Node, XmlProblem

__all__ = ["Motion"]


class Motion:
    """The entities' speeds as the scenario gives them, action after action."""

    def __init__(self, entities: Mapping[str, dict[str, Any]]):
        self.entities = entities
        self.speeds: dict[str, float] = {}

    def init_speeds(self) -> None:
        for name, e in self.entities.items():
            v = e.get("speed", 0.0)
            if isinstance(v, dict):
                ref = self.speeds.get(v["entityRef"], 0.0)
                v = ref + v["value"] if v.get("type", "delta") == "delta" else ref * v["value"]
            self.speeds[name] = float(v)

    def place_at_distance(self, node: Node, actor: str, params: Mapping[str, Any]) -> None:
        """An Init LongitudinalDistanceAction: the actor's position along the referenced entity's lane."""
        if params.get("continuous"):
            raise XmlProblem(node, "a continuous LongitudinalDistanceAction in the Init is not supported (after it, it is)")
        ref = params["entity"]
        spec = self.entities[actor]
        position = spec.get("position", {})
        rel = position.get("RelativeLanePosition")
        if rel is None or rel.get("entityRef") != ref:
            raise XmlProblem(node, f"an Init LongitudinalDistanceAction is supported for an entity placed with a "
                                   f"RelativeLanePosition to {ref!r}")  # fmt: skip
        gap = params["distance"] if "distance" in params else params["time_gap"] * self.speeds.get(ref, 0.0)
        ahead = rel.get("ds", rel.get("dsLane", 0.0)) >= 0
        if params.get("freespace"):
            other = self.entities[ref]

            def front(e: Mapping[str, Any]) -> float:
                return float(e.get("center", [0, 0, 0])[0]) + float(e.get("length", 5.0)) / 2

            def rear(e: Mapping[str, Any]) -> float:
                return float(e.get("length", 5.0)) / 2 - float(e.get("center", [0, 0, 0])[0])

            gap += front(other) + rear(spec) if ahead else rear(other) + front(spec)
        rel = {k: v for k, v in rel.items() if k != "dsLane"}
        rel["ds"] = gap if ahead else -gap
        position["RelativeLanePosition"] = rel

    def lower(self, node: Node, actor: str, kind: str, params: dict[str, Any]) -> list[tuple[str, dict[str, Any], float]]:
        """The entries an action becomes: ``(action, params, seconds to wait after it)`` - one, the leaf's."""
        if kind == "sumo.speed":
            return [(kind, self.speed(node, actor, params), 0.0)]
        if kind in ("sumo.lane_change", "sumo.lane_offset") and params.get("rate", 1) <= 0 and params.get("shape") != "step":
            raise XmlProblem(node, f"rate {params['rate']:g} must be greater than 0")
        if kind == "sumo.lane_offset" and params.get("max_lateral_acc", 1) <= 0:
            raise XmlProblem(node, f"maxLateralAcc {params['max_lateral_acc']:g} must be greater than 0")
        return [(kind, params, 0.0)]

    def speed(self, node: Node, actor: str, params: dict[str, Any]) -> dict[str, Any]:
        v0 = self.speeds.get(actor, 0.0)
        rel = params.get("relative")
        if rel is not None:
            ref = self.speeds.get(rel["entity"], 0.0)
            target = ref + rel["value"] if rel["type"] == "delta" else ref * rel["value"]
        else:
            target = params["to"]
            if target < 0:
                raise XmlProblem(node, f"target speed {target:g} m/s is negative (a reverse drive is not supported)")
        out = dict(params)
        if "rate" in out:
            rate = abs(out["rate"])
            if rate == 0:
                if rel is None and abs(target - v0) > 1e-9:
                    raise XmlProblem(node, f"rate 0 never reaches {target:g} m/s from {v0:g} m/s")
                out.pop("rate")
                out["shape"] = "step"  # the speed it has: nothing to change
            else:
                out["rate"] = rate
        self.speeds[actor] = target
        return out
