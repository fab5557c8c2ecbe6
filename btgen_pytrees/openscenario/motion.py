"""Actions onto the SUMO leaves that exist today (``sumo.speed``, ``sumo.lane``, ``sumo.release``).

The road system's own motion leaves (a speed action with its dynamics shapes, a lane change with its
lateral motion, lane offsets, trajectories: docs/opendrive.md, not yet in) would take an action as
OpenSCENARIO states it. Until they are in, an action is *lowered* here onto the leaves SUMO cases
have, exactly where that is possible and as the documented approximation where it is not
(docs/openscenario.md "Motion"):

* ``SpeedAction`` -> ``sumo.speed {to, duration}``: a linear ramp from the speed the entity has to the
  target. The duration is the dynamics': ``step`` 0, ``time`` its value, ``rate`` the speed change
  over the rate, ``distance`` ``2 d / (v0 + v1)`` (the distance a linear ramp covers). The speed the
  entity has, and a relative target's reference speed, are the last targets the scenario gave them
  (the Init's speeds, then the actions in the file's order) - exact for storyboard-exact entities whose
  speed only the scenario changes. ``cubic`` and ``sinusoidal`` shapes take the same time, linearly.
* ``LaneChangeAction`` -> ``sumo.lane {lane, safe: false}`` (the SUMO lane of the OpenDRIVE target lane,
  as the road system maps it) followed by a wait: the entity is on the target lane from the next step,
  and the action completes when the dynamics end (time: its value; rate: the lateral distance over the
  rate - ``pi/2`` times that for ``sinusoidal``, ``3/2`` for ``cubic``; distance: over the speed).
* ``ActivateControllerAction`` -> ``sumo.release``: SUMO's driver model takes the entity over.
* An Init ``LongitudinalDistanceAction`` places the entity: its ``ds`` from the referenced entity is the
  distance (``timeGap`` times the referenced entity's speed), plus the bounding boxes' extents with
  ``freespace``, on the side its Init position put it.

Everything else (``LaneOffsetAction``, ``FollowTrajectoryAction``, a run-time ``TeleportAction`` or
``LongitudinalDistanceAction``) is refused at its element, never dropped.
"""

from __future__ import annotations

import math
import os
from typing import Any, Mapping

from ..systems.sumo.roads import resolve, road_case, shift_lane
from .xmltree import Node, XmlProblem

__all__ = ["Motion", "LATERAL_FACTOR"]

LATERAL_FACTOR = {"linear": 1.0, "cubic": 1.5, "sinusoidal": math.pi / 2, "step": 0.0}
"""Time of a lateral move of width w at the peak rate r is ``factor * w / r`` (the shapes' peak over mean)."""


class Motion:
    """What the scenario says of each entity's speed and lane, as the actions are converted in order."""

    def __init__(self, entities: Mapping[str, dict[str, Any]], road: str, base: str):
        self.entities = entities
        self.road_path = os.path.join(base, road)
        self.speeds: dict[str, float] = {}
        self.controlled: set[str] = {n for n, e in entities.items() if e.get("controller")}
        self.lanes: dict[str, tuple[str, int]] = {}
        self._road: Any = None

    # -- Init ------------------------------------------------------------------------------------
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
            raise XmlProblem(node, "a continuous LongitudinalDistanceAction is not supported yet (docs/openscenario.md)")
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
            front = lambda e: e.get("center", [0, 0, 0])[0] + e.get("length", 5.0) / 2  # noqa: E731
            rear = lambda e: e.get("length", 5.0) / 2 - e.get("center", [0, 0, 0])[0]  # noqa: E731
            gap += front(other) + rear(spec) if ahead else rear(other) + front(spec)
        rel = {k: v for k, v in rel.items() if k != "dsLane"}
        rel["ds"] = gap if ahead else -gap
        position["RelativeLanePosition"] = rel

    # -- actions ---------------------------------------------------------------------------------
    def speed(self, node: Node, actor: str, params: Mapping[str, Any]) -> dict[str, Any]:
        v0 = self.speeds.get(actor, 0.0)
        if "relative" in params:
            rel = params["relative"]
            if rel.get("continuous"):
                raise XmlProblem(node, "a continuous RelativeTargetSpeed is not supported yet (docs/openscenario.md)")
            ref = self.speeds.get(rel["entity"], 0.0)
            target = ref + rel["value"] if rel["type"] == "delta" else ref * rel["value"]
        else:
            target = params["to"]
        if target < 0:
            raise XmlProblem(node, f"target speed {target:g} m/s is negative (a reverse drive is not supported)")
        shape = params["shape"]
        if shape == "step":
            duration = 0.0
        elif "duration" in params:
            duration = params["duration"]
        elif "rate" in params:
            rate = abs(params["rate"])
            if abs(target - v0) < 1e-9:
                duration = 0.0
            elif rate == 0:
                raise XmlProblem(node, f"rate 0 never reaches {target:g} m/s from {v0:g} m/s")
            else:
                duration = abs(target - v0) / rate
        else:
            mean = (v0 + target) / 2
            if mean <= 0:
                raise XmlProblem(node, "a distance dynamics from and to standstill covers no distance")
            duration = params["distance"] / mean
        if duration < 0:
            raise XmlProblem(node, f"the dynamics' duration {duration:g} s is negative")
        self.speeds[actor] = target
        out = {"vehicle": actor, "to": round(target, 9), "duration": round(duration, 9)}
        if actor not in self.controlled:
            out["safe"] = False  # storyboard-exact: SUMO does not brake on its own
        return out

    def road(self, node: Node) -> Any:
        """The road system's case (netconvert's network, the entities placed), made once."""
        if self._road is None:  # only a lane change needs SUMO's network
            try:
                self._road = road_case(self.road_path, dict(self.entities))
            except ValueError as exc:
                raise XmlProblem(node, f"the road system: {exc}") from None
        return self._road

    def lane_of(self, node: Node, name: str) -> tuple[str, int]:
        if name not in self.lanes:
            pose = self.road(node).placed[name].pose
            self.lanes[name] = (str(pose.road), int(pose.lane))
        return self.lanes[name]

    def lane_change(self, node: Node, actor: str, params: Mapping[str, Any]) -> tuple[dict[str, Any], float]:
        """``sumo.lane``'s params and the seconds the dynamics take."""
        road, lane = self.lane_of(node, actor)
        if "relative" in params:
            ref_road, ref_lane = self.lane_of(node, params["relative"]["entity"])
            target = shift_lane(ref_lane, params["relative"]["value"])
        else:
            target = params["lane"]
        if params.get("target_offset"):
            raise XmlProblem(node, "a LaneChangeAction's targetLaneOffset is not supported yet (docs/openscenario.md)")
        case = self.road(node)
        lanes = case.net.by_origin.get(f"{road}_{target}")
        if not lanes:
            raise XmlProblem(node, f"road {road!r} has no driving lane {target} in SUMO's network")
        shape = params["shape"]
        width = abs(target - lane) * 3.5
        placed = case.placed[actor]
        try:
            here = self._t(case, road, lane, placed.pose.s)
            there = self._t(case, road, target, placed.pose.s)
            width = abs(there - here)
        except (ValueError, KeyError):  # the lanes' centres as the road system computes them, else 3.5 m a lane
            pass
        if shape == "step":
            seconds = 0.0
        elif "duration" in params:
            seconds = params["duration"]
        elif "rate" in params:
            if params["rate"] <= 0:
                raise XmlProblem(node, f"lateral rate {params['rate']:g} must be greater than 0")
            seconds = LATERAL_FACTOR[shape] * width / params["rate"]
        else:
            v = self.speeds.get(actor, 0.0)
            if v <= 0:
                raise XmlProblem(node, "a lane change by distance needs the entity to move")
            seconds = params["distance"] / v
        self.lanes[actor] = (road, target)
        out = {"vehicle": actor, "lane": lanes[0].index, "timeout": round(seconds + 2.0, 9)}
        if actor not in self.controlled:
            out["safe"] = False
        return out, round(seconds, 9)

    @staticmethod
    def _t(case: Any, road: str, lane: int, s: float) -> float:
        return float(resolve(case.network, {"LanePosition": {"roadId": road, "laneId": lane, "s": s, "offset": 0}}, {}, "").t)

    def activate(self, actor: str) -> dict[str, Any]:
        self.controlled.add(actor)
        return {"vehicle": actor}

    def lower(self, node: Node, actor: str, kind: str, params: Mapping[str, Any]) -> list[tuple[str, dict[str, Any], float]]:
        """The entries an action becomes: ``(action, params, seconds to wait after it)``."""
        if kind == "sumo.speed":
            return [("sumo.speed", self.speed(node, actor, params), 0.0)]
        if kind == "sumo.lane_change":
            lane, seconds = self.lane_change(node, actor, params)
            return [("sumo.lane", lane, seconds)]
        if kind == "sumo.controller":
            return [("sumo.release", self.activate(actor), 0.0)]
        what = {"sumo.follow": "LongitudinalDistanceAction", "sumo.lane_offset": "LaneOffsetAction",
                "sumo.teleport": "TeleportAction", "sumo.trajectory": "FollowTrajectoryAction"}.get(kind, kind)  # fmt: skip
        raise XmlProblem(node, f"{what} after the Init is not supported yet: the road system has no leaf for its "
                               "motion (docs/openscenario.md \"Motion\")")  # fmt: skip
