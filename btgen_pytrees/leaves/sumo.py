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
from ..systems.sumo.system import CommandError, SumoSystem
from .simulated import SimulatedLeaf, reached

__all__ = ["SumoAction", "Speed", "Release", "Lane", "Spawn", "Signal", "Controller", "PARAMS", "TIMEOUT", "register"]

# the statuses as module constants: ``Status.SUCCESS`` is a look-up on the Enum class (~80 ns), every tick
_SUCCESS, _FAILURE, _RUNNING = Status.SUCCESS, Status.FAILURE, Status.RUNNING

_SECONDS = {"type": "number", "minimum": 0, "description": "seconds, >= 0"}
TIMEOUT = 10
"""Seconds ``sumo.lane`` and ``sumo.spawn`` wait when their entry gives no ``timeout``."""
_VEHICLE = {"type": "string", "minLength": 1, "maxLength": 200, "description": "a vehicle id"}


def _params(required: list[str], **properties: Any) -> dict[str, Any]:
    return {"type": "object", "required": required, "additionalProperties": False, "properties": properties}


PARAMS: dict[str, dict[str, Any]] = {
    "speed": _params(["vehicle", "to"], vehicle=_VEHICLE, to={"type": "number", "minimum": 0, "description": "m/s"},
                     duration=_SECONDS, safe={"type": "boolean"}),  # fmt: skip
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
    """``sumo.speed {vehicle, to, duration = 0, safe = true}``: take over the speed; ramp to *to*, then hold it.

    The leaf commands, on each tick, the speed of the linear ramp for the next
    step, and succeeds after *duration*; the vehicle keeps *to* until
    ``sumo.release``. ``safe: false`` switches SUMO's speed checks off (speed
    mode 0: no safe speed, no acceleration bounds, no right of way), which is how
    a test provokes a collision; with ``safe: true`` SUMO may drive slower than
    commanded to stay collision-free.
    """

    def begin(self, system: SumoSystem) -> None:
        vid = self.params["vehicle"]
        if self.need(system, vid):
            self.origin = system.speed(vid)

    def step(self, system: SumoSystem) -> Status:
        vid, target = self.params["vehicle"], float(self.params["to"])
        duration = float(self.params.get("duration", 0))
        if not system.present(vid):
            self.feedback_message = system.absent_reason(vid)
            return _FAILURE
        elapsed = self.elapsed()
        done = reached(elapsed, duration)
        share = 1.0 if done else min(1.0, (elapsed + system.tick_length) / duration)
        system.set_speed(vid, self.origin + (target - self.origin) * share, self.params.get("safe", True))
        self.feedback_message = f"{vid} speed {system.speed(vid):.4g} m/s -> {target:g}"
        return _SUCCESS if done else _RUNNING


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


_DESCRIPTIONS = {
    "speed": "take over a vehicle's speed: ramp to 'to' over 'duration', then hold it ('safe': false disables SUMO's checks)",
    "release": "give a vehicle back to SUMO's driver model",
    "lane": "change lane; succeed once on 'lane', fail after 'timeout'",
    "spawn": "insert a vehicle on a route; succeed once it is in the network",
    "signal": "set a traffic light's state string",
    "controller": "hand a vehicle to SUMO's driver model ('active': false takes it back: storyboard-exact)",
}
_LEAVES = {"speed": Speed, "release": Release, "lane": Lane, "spawn": Spawn, "signal": Signal, "controller": Controller}


def register(registry: Registry) -> Registry:
    """Add the ``sumo`` system type and its ``sumo.*`` actions to *registry*."""
    registry.register_system(SUMO)
    for action, leaf in _LEAVES.items():
        registry.register(f"sumo.{action}", leaf, kind="behavior", params_schema=PARAMS[action],
                          description=_DESCRIPTIONS[action])  # fmt: skip
    return registry
