"""The SUMO action leaves: ``sumo.speed``, ``sumo.release``, ``sumo.lane``, ``sumo.spawn``, ``sumo.signal``.

:func:`register` adds the ``sumo`` system type (:mod:`btgen_pytrees.systems.sumo`)
and these leaves to a registry, like any plugin. They live with the leaves, above
the system they act on: the system type knows nothing of them.

Each is an ordinary py_trees behaviour built by the registry from an entry; it
reaches the running :class:`~btgen_pytrees.systems.sumo.system.SumoSystem` through its environment
(``env.system``) when it ticks. A command SUMO refuses, or a vehicle that is not
in the network, makes the leaf fail with a message saying so (never an
exception). Timing follows the built-in leaves (see
:func:`btgen_pytrees.leaves.simulated.reached`); a command given at run time
*t* acts in SUMO's step at *t + tick*.
"""

from __future__ import annotations

from typing import Any
from py_trees.common import Status

from ..contracts.registry import Registry
from ..model import Entry
from ..systems.sumo import SUMO
import math
from typing import Callable, Mapping

from ..systems.sumo.opendrive import OpenDriveError, Pose
from ..systems.sumo.roads import POSITION_KINDS, resolve, shift_lane
from ..systems.sumo.system import CommandError, SumoSystem
from .simulated import SimulatedLeaf, reached

__all__ = ["SumoAction", "Speed", "Release", "Lane", "Spawn", "Signal", "Controller", "LaneChange", "LaneOffset",
           "Teleport", "Follow", "Trajectory", "SHAPES", "PARAMS", "TIMEOUT", "register"]

# the statuses as module constants: ``Status.SUCCESS`` is a look-up on the Enum class (~80 ns), every tick
_SUCCESS, _FAILURE, _RUNNING = Status.SUCCESS, Status.FAILURE, Status.RUNNING

_SECONDS = {"type": "number", "minimum": 0, "description": "seconds, >= 0"}
TIMEOUT = 10
"""Seconds ``sumo.lane`` and ``sumo.spawn`` wait when their entry gives no ``timeout``."""
_VEHICLE = {"type": "string", "minLength": 1, "maxLength": 200, "description": "a vehicle id"}


def _params(required: list[str], **properties: Any) -> dict[str, Any]:
    return {"type": "object", "required": required, "additionalProperties": False, "properties": properties}


SHAPES: dict[str, Callable[[float], float]] = {
    "step": lambda tau: 1.0,
    "linear": lambda tau: tau,
    "cubic": lambda tau: tau * tau * (3 - 2 * tau),
    "sinusoidal": lambda tau: (1 - math.cos(math.pi * tau)) / 2,
}
"""OpenSCENARIO's dynamics shapes: the share of the change done at share *tau* of the time (docs/opendrive.md)."""

_SHAPE = {"enum": list(SHAPES), "description": "the dynamics' shape (OpenSCENARIO's DynamicsShape)"}
_DIMENSIONS = ("duration", "rate", "distance")
_POSITIVE = {"type": "number", "exclusiveMinimum": 0}
_ENTITY = {"type": "string", "minLength": 1, "maxLength": 200, "description": "an entity of the case's road"}
_RELATIVE = {"type": "object", "required": ["entity", "value"], "additionalProperties": False,
             "properties": {"entity": _ENTITY, "value": {"type": "number"}, "type": {"enum": ["delta", "factor"]},
                            "continuous": {"type": "boolean"}}}  # fmt: skip
_POSITION = {"type": "object", "minProperties": 1, "maxProperties": 2,
             "propertyNames": {"enum": [*POSITION_KINDS, "Orientation"]},
             "description": "an OpenSCENARIO position object (docs/opendrive.md)"}  # fmt: skip
_VERTEX = {"type": "object", "required": ["time", "position"], "additionalProperties": False,
           "properties": {"time": {"type": "number"}, "position": _POSITION}}  # fmt: skip


PARAMS: dict[str, dict[str, Any]] = {
    "speed": {**_params(["vehicle"], vehicle=_VEHICLE, to={"type": "number", "minimum": 0, "description": "m/s"},
                        relative=_RELATIVE, shape=_SHAPE, duration=_SECONDS, rate=_POSITIVE, distance=_POSITIVE,
                        safe={"type": "boolean"}),
              "oneOf": [{"required": ["to"]}, {"required": ["relative"]}]},  # fmt: skip
    "lane_change": {**_params(["vehicle"], vehicle=_VEHICLE, lane={"type": "integer", "not": {"const": 0}},
                              relative=_RELATIVE, target_offset={"type": "number"}, shape=_SHAPE, duration=_SECONDS,
                              rate=_POSITIVE, distance=_POSITIVE),
                    "oneOf": [{"required": ["lane"]}, {"required": ["relative"]}]},  # fmt: skip
    "lane_offset": {**_params(["vehicle"], vehicle=_VEHICLE, offset={"type": "number"}, relative=_RELATIVE,
                              shape=_SHAPE, duration=_SECONDS, max_lateral_acc=_POSITIVE,
                              continuous={"type": "boolean"}),
                    "oneOf": [{"required": ["offset"]}, {"required": ["relative"]}]},  # fmt: skip
    "teleport": _params(["vehicle", "position"], vehicle=_VEHICLE, position=_POSITION),
    "trajectory": _params(["vehicle", "vertices"], vehicle=_VEHICLE,
                          vertices={"type": "array", "minItems": 1, "maxItems": 10000, "items": _VERTEX},
                          closed={"type": "boolean"}, following={"enum": ["position"]},
                          time_scale=_POSITIVE, time_offset={"type": "number"}, absolute={"type": "boolean"}),
    "follow": {**_params(["vehicle", "entity"], vehicle=_VEHICLE, entity=_ENTITY, distance={"type": "number", "minimum": 0},
                         time_gap={"type": "number", "minimum": 0}, freespace={"type": "boolean"},
                         displacement={"enum": ["trailingReferencedEntity", "leadingReferencedEntity", "any"]},
                         continuous={"type": "boolean"}, max_accel=_POSITIVE, max_decel=_POSITIVE, max_speed=_POSITIVE),
               "oneOf": [{"required": ["distance"]}, {"required": ["time_gap"]}]},  # fmt: skip
    "release": _params(["vehicle"], vehicle=_VEHICLE),
    "lane": _params(["vehicle", "lane"], vehicle=_VEHICLE, lane={"type": "integer", "minimum": 0},
                    duration=_SECONDS, timeout=_SECONDS, safe={"type": "boolean"}),  # fmt: skip
    "spawn": _params(["vehicle", "route"], vehicle=_VEHICLE, route={"type": "string", "minLength": 1},
                     type={"type": "string", "minLength": 1}, lane={"type": "integer", "minimum": 0},
                     position={"type": "number", "minimum": 0}, speed={"type": "number", "minimum": 0},
                     timeout=_SECONDS),  # fmt: skip
    "controller": _params(["vehicle"], vehicle=_VEHICLE, active={"type": "boolean"}, longitudinal={"type": "boolean"},
                          lateral={"type": "boolean"}),  # fmt: skip
    "signal": _params(["tls", "state"], tls={"type": "string", "minLength": 1},
                      state={"type": "string", "pattern": "^[rRyYgGsuoO]+$",
                             "description": "a state string of r, y, g, G, s, u, o, O (one per controlled link)"}),  # fmt: skip
}


class SumoAction(SimulatedLeaf):
    """Base: the entry, its environment and when it started (as every built-in leaf), and the failure it met."""

    def __init__(self, entry: Entry, env: Any):
        super().__init__(entry, env)
        self.failed = ""

    def initialise(self) -> None:
        super().initialise()
        self.failed = ""
        try:
            self.begin(self.system())
        except CommandError as exc:
            self.failed = f"SUMO refused {self.entry.action}: {exc}"

    def update(self) -> Status:
        if self.failed:
            self.feedback_message = self.failed
            return _FAILURE
        try:
            return self.step(self.env.system)
        except CommandError as exc:
            self.feedback_message = f"SUMO refused {self.entry.action}: {exc}"
            return _FAILURE

    def system(self) -> SumoSystem:
        system = getattr(self.env, "system", None)
        if not isinstance(system, SumoSystem):
            raise CommandError(f"{self.entry.action} needs the case's system to be 'sumo'")
        return system

    def need(self, system: SumoSystem, vid: str) -> bool:
        """Whether *vid* is in the network; if not, remember why as the failure."""
        if system.present(vid):
            return True
        self.failed = system.absent_reason(vid)
        return False

    def begin(self, system: SumoSystem) -> None:
        """Give SUMO the command (on the first tick)."""

    def step(self, system: SumoSystem) -> Status:
        return _SUCCESS


class Speed(SumoAction):
    """``sumo.speed {vehicle, to | relative, shape = linear, duration = 0 | rate | distance, safe = true}``: take over
    the speed; change it to the target with the dynamics' shape, then hold it.

    The leaf commands, on each tick, the speed the profile has at the end of SUMO's next step, and
    succeeds when the profile ends: after *duration*, or ``|to - v0| / rate``, or ``2 distance / (v0 + to)``
    (the distance the profile covers: every shape's mean speed is ``(v0 + to) / 2``). Shapes are
    OpenSCENARIO's: ``step`` (at once), ``linear``, ``cubic`` (``3τ² - 2τ³``), ``sinusoidal``
    (``(1 - cos πτ) / 2``). ``relative: {entity, value, type = delta | factor, continuous = false}`` takes the
    target from another entity's speed when the action starts (``continuous``: on every tick, and the leaf
    never ends - OpenSCENARIO's continuous action). The vehicle keeps the target until ``sumo.release``
    or another speed action. ``safe: false`` switches SUMO's speed checks off (speed mode 0: no safe speed,
    no acceleration bounds, no right of way), which is how a test provokes a collision; with ``safe:
    true`` SUMO may drive slower than commanded to stay collision-free (an entity on an OpenDRIVE road that
    is driven storyboard-exactly has speed mode 0 anyway).
    """

    def begin(self, system: SumoSystem) -> None:
        vid = self.params["vehicle"]
        if self.need(system, vid):
            self.origin = system.speed(vid)
            self.target = self._target(system)
            self.span = _span(self.params, self.origin, self.target)

    def _target(self, system: SumoSystem) -> float:
        relative = self.params.get("relative")
        if relative is None:
            return float(self.params["to"])
        ref = relative["entity"]
        if not system.present(ref):
            raise CommandError(system.absent_reason(ref))
        speed = system.speed(ref)
        value = float(relative["value"])
        return max(0.0, speed * value if relative.get("type", "delta") == "factor" else speed + value)

    def step(self, system: SumoSystem) -> Status:
        vid = self.params["vehicle"]
        if not system.present(vid):
            self.feedback_message = system.absent_reason(vid)
            return _FAILURE
        continuous = bool((self.params.get("relative") or {}).get("continuous", False))
        if continuous:
            self.target = self._target(system)
        elapsed = self.elapsed()
        done = reached(elapsed, self.span)
        share = 1.0 if done else min(1.0, (elapsed + system.tick_length) / self.span)
        shape = SHAPES[self.params.get("shape", "linear")]
        system.set_speed(vid, self.origin + (self.target - self.origin) * shape(share), self.params.get("safe", True))
        self.feedback_message = f"{vid} speed {system.speed(vid):.4g} m/s -> {self.target:g}"
        return _SUCCESS if done and not continuous else _RUNNING


def _span(params: Mapping[str, Any], start: float, end: float) -> float:
    """Seconds a speed change from *start* to *end* takes with the entry's dynamics (0: at once)."""
    if params.get("shape") == "step":
        return 0.0
    if "rate" in params:
        return abs(end - start) / float(params["rate"])
    if "distance" in params:
        return 2 * float(params["distance"]) / (start + end) if start + end > 0 else 0.0
    return float(params.get("duration", 0))


def _lateral_span(params: Mapping[str, Any], change: float, speed: float, rate_is: str) -> float:
    """Seconds a lateral change of *change* m takes: *duration*, or *distance* at the present *speed*, or from
    the peak lateral speed (``rate``: a lane change's) or acceleration (``max_lateral_acc``: a lane offset's)
    the shape reaches - the same shapes as :data:`SHAPES` over the span."""
    shape, change = params.get("shape", "sinusoidal"), abs(change)
    if shape == "step" or change == 0:
        return 0.0
    if "duration" in params:
        return float(params["duration"])
    if "distance" in params:
        return float(params["distance"]) / speed if speed > 0 else 0.0
    if rate_is == "speed" and "rate" in params:  # peak lateral speed of each shape: 1, 1.5, pi/2 times change/T
        return change * {"linear": 1.0, "cubic": 1.5, "sinusoidal": math.pi / 2}[shape] / float(params["rate"])
    if rate_is == "acceleration" and "max_lateral_acc" in params:  # peak lateral acceleration: 6, pi^2/2 times change/T^2
        if shape == "linear":
            return 0.0
        return math.sqrt(change * {"cubic": 6.0, "sinusoidal": math.pi**2 / 2}[shape] / float(params["max_lateral_acc"]))
    return 0.0


class Release(SumoAction):
    """``sumo.release {vehicle}``: give speed and lane control back to SUMO's driver model."""

    def begin(self, system: SumoSystem) -> None:
        vid = self.params["vehicle"]
        if self.need(system, vid):
            system.release(vid)
            self.feedback_message = f"{vid} released"


class Lane(SumoAction):
    """``sumo.lane {vehicle, lane, duration = 0, timeout = 10, safe = true}``: change lane.

    Succeeds on the first tick the vehicle is on *lane* (index, 0 = rightmost);
    fails when it is not there after *timeout*. The request to SUMO lasts until
    then: on arrival it is replaced by one that keeps the vehicle on the lane
    for *duration* seconds (with 0, SUMO's driver model decides again at once),
    and after a *timeout* it has ended. ``safe: false`` lets the change ignore
    the gaps of other vehicles (lane change mode 0, which also stops the
    vehicle's own lane changes until ``sumo.release``): a forced cut-in.
    """

    def begin(self, system: SumoSystem) -> None:
        vid = self.params["vehicle"]
        if self.need(system, vid):
            system.change_lane(vid, self.params["lane"], float(self.params.get("timeout", TIMEOUT)), self.params.get("safe", True))

    def step(self, system: SumoSystem) -> Status:
        vid, lane = self.params["vehicle"], self.params["lane"]
        if not system.present(vid):
            self.feedback_message = system.absent_reason(vid)
            return _FAILURE
        now_on = system.lane(vid)
        if now_on == lane:
            system.change_lane(vid, lane, float(self.params.get("duration", 0)), self.params.get("safe", True))
            self.feedback_message = f"{vid} on lane {lane}"
            return _SUCCESS
        timeout = self.timed_out(TIMEOUT)
        if timeout is not None:
            self.feedback_message = f"{vid} still on lane {now_on}, not {lane}, after {timeout:g} s"
            return _FAILURE
        self.feedback_message = f"{vid} on lane {now_on} -> {lane}"
        return _RUNNING


class Spawn(SumoAction):
    """``sumo.spawn {vehicle, route, type?, lane?, position?, speed?, timeout = 10}``: insert a vehicle.

    Defaults are SUMO's (type ``DEFAULT_VEHTYPE``, first lane, position base,
    speed 0). Succeeds once the vehicle is in the network (normally one tick
    later); fails when SUMO could not insert it within *timeout* (blocked).
    """

    def begin(self, system: SumoSystem) -> None:
        p = self.params
        system.spawn(p["vehicle"], p["route"], p.get("type"), p.get("lane"), p.get("position"), p.get("speed"))

    def step(self, system: SumoSystem) -> Status:
        vid = self.params["vehicle"]
        if system.present(vid):
            self.feedback_message = f"{vid} in the network"
            return _SUCCESS
        timeout = self.timed_out(TIMEOUT)
        if timeout is not None:
            self.feedback_message = f"SUMO could not insert {vid!r} within {timeout:g} s (its place is blocked?)"
            return _FAILURE
        self.feedback_message = f"waiting for {vid} to be inserted"
        return _RUNNING


class Signal(SumoAction):
    """``sumo.signal {tls, state}``: set a traffic light's state (one letter per controlled link).

    The light keeps the state until another ``sumo.signal`` (SUMO's fixed
    "online" program).
    """

    def begin(self, system: SumoSystem) -> None:
        system.set_signal(self.params["tls"], self.params["state"])
        self.feedback_message = f"{self.params['tls']} = {self.params['state']}"


class Controller(SumoAction):
    """``sumo.controller {vehicle, active = true, longitudinal = true, lateral = true}``: OpenSCENARIO's
    ActivateControllerAction. Active: SUMO's driver model drives the vehicle in the domains named (its own
    speed, car-following and safe speed; its own lane changes); inactive: storyboard-exact again (speed and
    lane-change mode 0, holding the speed it has). Succeeds at once (docs/opendrive.md)."""

    def begin(self, system: SumoSystem) -> None:
        vid, p = self.params["vehicle"], self.params
        if self.need(system, vid):
            if p.get("active", True):
                system.control(vid, p.get("longitudinal", True), p.get("lateral", True))
                self.feedback_message = f"{vid} driven by SUMO's driver model"
            else:
                system.uncontrol(vid)
                self.feedback_message = f"{vid} storyboard-exact"


class RoadAction(SumoAction):
    """Base of the actions on an OpenDRIVE road: they need the case's ``road`` (docs/opendrive.md)."""

    def pose_of(self, system: SumoSystem, vid: str) -> Pose:
        if system.road is None or vid not in system.road.entities:
            raise CommandError(f"{self.entry.action} needs an entity of a case on an OpenDRIVE road, not {vid!r}")
        if not system.present(vid):
            raise CommandError(system.absent_reason(vid))
        pose = system.pose(vid)
        if pose is None:
            raise CommandError(f"{vid!r} is on no lane of the road")
        return pose


def _home(system: SumoSystem, vid: str, pose: Pose) -> int:
    """The lane *vid*'s lane offsets refer to (:attr:`SumoSystem.home`), where it is on the same road, else its lane."""
    home = system.home.get(vid)
    return home[1] if home is not None and home[0] == pose.road else pose.lane


class Sideways(RoadAction):
    """A lateral motion of the reference point from its road ``t`` to a target ``t`` with a shape (each tick
    the place for SUMO's next step): the base of ``sumo.lane_change`` and ``sumo.lane_offset``."""

    rate_is = "speed"

    def begin(self, system: SumoSystem) -> None:
        vid = self.params["vehicle"]
        pose = self.pose_of(system, vid)
        self.start, self.goal, self.lane = pose.t, *self.target(system, pose)
        self.span = _lateral_span(self.params, self.goal - self.start, system.speed(vid), self.rate_is)

    def target(self, system: SumoSystem, pose: Pose) -> tuple[float, int]:
        raise NotImplementedError

    def step(self, system: SumoSystem) -> Status:
        vid = self.params["vehicle"]
        if not system.present(vid):
            self.feedback_message = system.absent_reason(vid)
            return _FAILURE
        elapsed = self.elapsed()
        if reached(elapsed, self.span):
            return self.arrived(system, vid)
        share = min(1.0, (elapsed + system.tick_length) / self.span)
        shape = SHAPES[self.params.get("shape", "sinusoidal")]
        system.move_sideways(vid, self.start + (self.goal - self.start) * shape(share))
        self.feedback_message = f"{vid} moving sideways to t = {self.goal:.3f} m"
        return _RUNNING

    def arrived(self, system: SumoSystem, vid: str) -> Status:
        pose = system.pose(vid)
        if pose is None or pose.lane != self.lane:
            self.feedback_message = f"{vid} is on lane {pose.lane if pose else 'none'}, not {self.lane}, at the end of the change"
            return _FAILURE
        self.feedback_message = f"{vid} on lane {self.lane} (t = {pose.t:.3f} m)"
        system.home[vid] = (pose.road, self.lane)
        return _SUCCESS


class LaneChange(Sideways):
    """``sumo.lane_change {vehicle, lane | relative: {entity, value}, target_offset = 0, shape = sinusoidal,
    duration | rate | distance}``: OpenSCENARIO's LaneChangeAction.

    The target is an OpenDRIVE lane id, or *value* lanes from *entity*'s lane (positive: to the left in
    that entity's driving direction), and *target_offset* m from its centre (left of the road's reference
    line +, as a LanePosition's offset). The reference point moves sideways from where it is to there with
    the shape over the span the dynamics give: *duration* (s), *distance* (m, at the present speed), or
    *rate*, the peak lateral speed (m/s) - linear: change/T, cubic 1.5 change/T, sinusoidal
    pi/2 change/T. Its ``s`` goes on with its speed meanwhile. Succeeds at the end of the span when the
    reference point is in the lane asked, fails otherwise (docs/opendrive.md)."""

    def target(self, system: SumoSystem, pose: Pose) -> tuple[float, int]:
        assert system.road is not None
        road = system.road.network.roads[pose.road]
        if "lane" in self.params:
            lane = int(self.params["lane"])
        else:
            ref = self.pose_of(system, self.params["relative"]["entity"])
            value = int(self.params["relative"]["value"])
            lane = shift_lane(ref.lane, value if system.road.network.roads[ref.road].forward(ref.lane) else -value)
        try:
            t = road.lane_t(lane, pose.s)
        except KeyError:
            raise CommandError(f"road {road.id!r} has no lane {lane} at s = {pose.s:.3f}") from None
        return t + float(self.params.get("target_offset", 0.0)), lane


class LaneOffset(Sideways):
    """``sumo.lane_offset {vehicle, offset | relative: {entity, value}, shape = sinusoidal, duration |
    max_lateral_acc, continuous = false}``: OpenSCENARIO's LaneOffsetAction.

    Moves the reference point to *offset* m from the centre of the lane it is on (positive: left in its
    driving direction; relative: *entity*'s offset plus *value*), with the shape over *duration*, or the span
    whose peak lateral acceleration is *max_lateral_acc* (cubic: 6 change/T², sinusoidal: pi²/2 change/T²;
    linear and step: at once). Succeeds when there; ``continuous``: holds the offset and never ends."""

    rate_is = "acceleration"

    def target(self, system: SumoSystem, pose: Pose) -> tuple[float, int]:
        assert system.road is not None
        network = system.road.network
        road = network.roads[pose.road]
        lane = _home(system, self.params["vehicle"], pose)
        sign = 1.0 if road.forward(lane) else -1.0
        if "offset" in self.params:
            offset = float(self.params["offset"])
        else:
            name = self.params["relative"]["entity"]
            ref = self.pose_of(system, name)
            ref_lane = _home(system, name, ref)
            ref_road = network.roads[ref.road]
            ref_sign = 1.0 if ref_road.forward(ref_lane) else -1.0
            offset = (ref.t - ref_road.lane_t(ref_lane, ref.s)) * ref_sign + float(self.params["relative"]["value"])
        return road.lane_t(lane, pose.s) + sign * offset, road.lane_at(pose.s, road.lane_t(lane, pose.s) + sign * offset) or lane

    def arrived(self, system: SumoSystem, vid: str) -> Status:
        pose = system.pose(vid)
        if pose is None:
            self.feedback_message = f"{vid} is on no lane of the road"
            return _FAILURE
        self.feedback_message = f"{vid} {pose.t - self.goal:+.3f} m from its offset (t = {pose.t:.3f} m)"
        if abs(pose.t - self.goal) > 0.1:
            return _FAILURE
        return _RUNNING if self.params.get("continuous", False) else _SUCCESS



class Teleport(RoadAction):
    """``sumo.teleport {vehicle, position}``: OpenSCENARIO's TeleportAction at run time. The reference point is
    where the position object puts it (relative ones against the entities' places now) from SUMO's next step
    on, heading along its lane; the speed stays. Succeeds at once."""

    def begin(self, system: SumoSystem) -> None:
        vid = self.params["vehicle"]
        self.pose_of(system, vid)
        assert system.road is not None
        poses = {e: p for e in system.road.entities if system.present(e) and (p := system.pose(e)) is not None}
        try:
            pose = resolve(system.road.network, self.params["position"], poses, "position")
        except OpenDriveError as exc:
            raise CommandError(str(exc)) from None
        system.place(vid, pose.x, pose.y, pose.h)
        system.home[vid] = (pose.road, pose.lane)
        self.feedback_message = f"{vid} to road {pose.road} lane {pose.lane} s = {pose.s:.3f}"


class Trajectory(RoadAction):
    """``sumo.trajectory {vehicle, vertices: [{time, position}, ...], closed = false, following = position,
    time_scale = 1, time_offset = 0, absolute = false}``: OpenSCENARIO's FollowTrajectoryAction with a polyline
    and timing.

    Vertex *k* is a position object (relative ones against the entities' places when the action starts)
    that the reference point reaches at ``time * time_scale + time_offset`` s after the action started
    (``absolute``: at that simulation time). Between vertices it moves along the straight segment at the
    segment's speed, heading along it; ``closed`` goes back to the first vertex at the last time plus the
    first segment's duration. Each tick puts it where the polyline says it is at the end of SUMO's next
    step; its speed is that segment's (SUMO's ``E.speed``), kept after the last vertex. ``following`` is
    ``position`` only: ``follow`` (a controller steering along it) is refused at its JSON path, not run as
    ``position``. Succeeds when the last vertex's time is reached."""

    def begin(self, system: SumoSystem) -> None:
        vid, p = self.params["vehicle"], self.params
        self.pose_of(system, vid)
        assert system.road is not None
        poses = {e: q for e in system.road.entities if system.present(e) and (q := system.pose(e)) is not None}
        scale, offset = float(p.get("time_scale", 1.0)), float(p.get("time_offset", 0.0))
        points: list[tuple[float, float, float]] = []
        for i, vertex in enumerate(p["vertices"]):
            try:
                pose = resolve(system.road.network, vertex["position"], poses, f"vertices/{i}/position")
            except OpenDriveError as exc:
                raise CommandError(str(exc)) from None
            points.append((float(vertex["time"]) * scale + offset, pose.x, pose.y))
        if p.get("closed", False) and len(points) > 1:
            first, second, last = points[0], points[1], points[-1]
            points.append((last[0] + (second[0] - first[0]), first[1], first[2]))
        if any(b[0] < a[0] for a, b in zip(points, points[1:])):
            raise CommandError("the vertices' times must not decrease")
        self.points = points

    def step(self, system: SumoSystem) -> Status:
        vid = self.params["vehicle"]
        if not system.present(vid):
            self.feedback_message = system.absent_reason(vid)
            return _FAILURE
        at = self.elapsed() if not self.params.get("absolute", False) else system.now()
        points = self.points
        if reached(at, points[-1][0]):
            self.feedback_message = f"{vid} at the trajectory's last vertex"
            return _SUCCESS
        then = at + system.tick_length
        if then >= points[0][0]:
            i = max(0, min(len(points) - 2, next((k for k in range(len(points) - 1) if then < points[k + 1][0]), len(points) - 2)))
            (t0, x0, y0), (t1, x1, y1) = points[i], points[min(i + 1, len(points) - 1)]
            share = 1.0 if t1 <= t0 else min(1.0, max(0.0, (then - t0) / (t1 - t0)))
            length = math.hypot(x1 - x0, y1 - y0)
            pose = system.pose(vid)
            heading = math.atan2(y1 - y0, x1 - x0) if length > 1e-9 else (pose.h if pose is not None else 0.0)
            system.place(vid, x0 + (x1 - x0) * share, y0 + (y1 - y0) * share, heading)
            system.set_speed(vid, length / (t1 - t0) if t1 > t0 else 0.0, False)
        self.feedback_message = f"{vid} following its trajectory"
        return _RUNNING


class Follow(RoadAction):
    """``sumo.follow {vehicle, entity, distance | time_gap, freespace = false, displacement =
    trailingReferencedEntity, continuous = false, max_accel?, max_decel?, max_speed?}``: OpenSCENARIO's
    LongitudinalDistanceAction along the road.

    The vehicle is to be *distance* m (or *time_gap* s at the speed of the one behind) behind *entity*
    (``leadingReferencedEntity``: ahead of it; ``any``: on the side it is on), measured between the
    reference points or, with *freespace*, between the bounding boxes, in ``s``. Without limits the
    vehicle is put there, in its own lane, at *entity*'s speed, from SUMO's next step (the leaf succeeds
    then); with *max_accel*/*max_decel*/*max_speed* its speed is steered there within them (the distance
    error closed in 1 s) and the leaf succeeds once within 0.1 m and 0.1 m/s. ``continuous``: it keeps
    the distance and never ends."""

    def begin(self, system: SumoSystem) -> None:
        self.pose_of(system, self.params["vehicle"])
        self.pose_of(system, self.params["entity"])

    def step(self, system: SumoSystem) -> Status:
        vid, ref = self.params["vehicle"], self.params["entity"]
        p = self.params
        try:
            me, other = self.pose_of(system, vid), self.pose_of(system, ref)
        except CommandError as exc:
            self.feedback_message = str(exc)
            return _FAILURE
        assert system.road is not None
        road = system.road.network.roads[other.road]
        sign = 1.0 if road.forward(other.lane) else -1.0
        v_ref, v_me = system.speed(ref), system.speed(vid)
        side = p.get("displacement", "trailingReferencedEntity")
        ahead = side == "leadingReferencedEntity" or (side == "any" and sign * (me.s - other.s) > 0)
        behind_speed = v_ref if ahead else v_me
        gap = float(p["distance"]) if "distance" in p else float(p["time_gap"]) * behind_speed
        if p.get("freespace", False):
            e_me, e_ref = system.road.entities[vid], system.road.entities[ref]
            gap += (e_ref.front + e_me.rear) if ahead else (e_me.front + e_ref.rear)
        want = other.s + sign * (gap if ahead else -gap)  # the s the vehicle's reference point should have
        error = sign * (want - me.s)  # + : it should be further along
        limited = any(k in p for k in ("max_accel", "max_decel", "max_speed"))
        if not limited:
            step = v_ref * system.tick_length
            x, y, h = road.point(min(max(want + sign * step, 0.0), road.length), me.t)
            system.place(vid, x, y, h if sign > 0 else h + math.pi)
            system.set_speed(vid, v_ref, False)
            self.feedback_message = f"{vid} {gap:.3f} m {'ahead of' if ahead else 'behind'} {ref}"
            return _RUNNING if p.get("continuous", False) else _SUCCESS if abs(error) < 0.1 else _RUNNING
        speed = v_ref + error / 1.0
        dt = system.tick_length
        speed = min(speed, v_me + float(p.get("max_accel", math.inf)) * dt)
        speed = max(speed, v_me - float(p.get("max_decel", math.inf)) * dt, 0.0)
        speed = min(speed, float(p.get("max_speed", math.inf)))
        system.set_speed(vid, speed, False)
        self.feedback_message = f"{vid} {error:+.3f} m from {gap:.3f} m {'ahead of' if ahead else 'behind'} {ref}"
        if abs(error) < 0.1 and abs(v_me - v_ref) < 0.1 and not p.get("continuous", False):
            return _SUCCESS
        return _RUNNING


_DESCRIPTIONS = {
    "speed": "take over a vehicle's speed: change it to 'to' (or a relative target) with a shape over 'duration', 'rate' or 'distance', then hold it ('safe': false disables SUMO's checks)",
    "release": "give a vehicle back to SUMO's driver model",
    "lane": "change lane; succeed once on 'lane', fail after 'timeout'",
    "spawn": "insert a vehicle on a route; succeed once it is in the network",
    "signal": "set a traffic light's state string",
    "controller": "hand a vehicle to SUMO's driver model ('active': false takes it back: storyboard-exact)",
    "lane_change": "move an entity of an OpenDRIVE road to another lane with a shape (LaneChangeAction)",
    "lane_offset": "move an entity of an OpenDRIVE road sideways within its lane with a shape (LaneOffsetAction)",
    "teleport": "put an entity of an OpenDRIVE road at a position (TeleportAction)",
    "follow": "keep an entity of an OpenDRIVE road at a distance or time gap from another (LongitudinalDistanceAction)",
    "trajectory": "move an entity of an OpenDRIVE road along a polyline with times (FollowTrajectoryAction)",
}
_LEAVES = {"speed": Speed, "release": Release, "lane": Lane, "spawn": Spawn, "signal": Signal, "controller": Controller,
           "lane_change": LaneChange, "lane_offset": LaneOffset, "teleport": Teleport, "follow": Follow,
           "trajectory": Trajectory}


def register(registry: Registry) -> Registry:
    """Add the ``sumo`` system type and its ``sumo.*`` actions to *registry*."""
    registry.register_system(SUMO)
    for action, leaf in _LEAVES.items():
        registry.register(f"sumo.{action}", leaf, kind="behavior", params_schema=PARAMS[action],
                          description=_DESCRIPTIONS[action])  # fmt: skip
    return registry
