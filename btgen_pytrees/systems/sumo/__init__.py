"""Eclipse SUMO as a system under test (``"system": {"type": "sumo", "config": "x.sumocfg"}``).

* :mod:`.scenario` - reads and checks the ``.sumocfg`` and its files at load time
* :mod:`.system` - :class:`SumoSystem`, one libsumo simulation per run (or one kept open and set back
  to time 0 between the runs of a :func:`reuse_simulations` block); the signals

The ``sumo.*`` action leaves, and the ``register`` function that adds them and this
system type to a registry, are :mod:`btgen_pytrees.leaves.sumo`: they act on the system,
the system knows nothing of them. Nothing here imports libsumo: only starting a
SUMO run does, so cases without SUMO never need the ``sumo`` extra, and a SUMO
run without it ends with a message saying how to install it. See docs/sumo.md.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import re
import sys
from typing import TYPE_CHECKING, Any, Iterable, Iterator, Mapping

from ...contracts.system import SystemFailure, SystemInfo, SystemSpec
from ...errors import Problem
from ...expressions import RESERVED
from ...model import DEFAULT_TICK
from ...text import did_you_mean
from .opendrive import OpenDriveError
from .roads import RoadCase, road_case
from .scenario import OPTIONS, Scenario, parse_options, read_scenario
from .system import ATTRIBUTES, PAIR_ATTRIBUTES, ROAD_ATTRIBUTES, ROAD_SIM_SIGNALS, INSTALL_HINT, SIM_SIGNALS, SumoSystem, keep_simulations, kept_simulation, release_simulations, reuse_for, reuse_simulations, tick_problem

if TYPE_CHECKING:  # pragma: no cover
    from ...model import TestCase

__all__ = ["SumoType", "SUMO", "SumoSystem", "signal_vehicles", "reuse_simulations", "reuse_for", "kept_simulation", "keep_simulations", "release_simulations"]

_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*(?![\s\S])")


def libsumo_installed() -> bool:
    """Whether libsumo can be imported (without importing it: that takes about a second).

    Once a run has imported it the answer is at hand; before, the import system is asked
    (``find_spec``: tens of microseconds, every time a SUMO case is checked)."""
    if sys.modules.get("libsumo") is not None:
        return True
    return importlib.util.find_spec("libsumo") is not None


def signal_vehicles(vehicles: Iterable[str]) -> list[str]:
    """Those vehicle ids that can be read in expressions (``ego.speed``): names, not ``sim``, not reserved."""
    return [v for v in vehicles if _NAME.match(v) and v != "sim" and v not in RESERVED]


def _sumo_entries(case_data: Mapping[str, Any]) -> Iterator[tuple[int, str, Mapping[str, Any]]]:
    execute = case_data.get("execute")
    for i, entry in enumerate(execute if isinstance(execute, list) else []):
        if isinstance(entry, dict) and isinstance(entry.get("action"), str) and entry["action"].startswith("sumo."):
            params = entry.get("params", {})
            yield i, entry["action"][5:], params if isinstance(params, dict) else {}


class SumoType:
    """The ``sumo`` system type: checks a case's scenario and makes a :class:`SumoSystem` per run."""

    name = "sumo"
    options = tuple("--" + name for name in OPTIONS)

    def describe(self, spec: SystemSpec, case_data: Mapping[str, Any]) -> SystemInfo:
        problems: list[Problem] = []
        if not libsumo_installed():
            problems.append(Problem(("system", "type"), "the 'sumo' system needs libsumo, which is not installed: "
                                    f"{INSTALL_HINT}", "system"))  # fmt: skip
        for index, message in parse_options(list(spec.options))[1]:
            problems.append(Problem(("system", "options", index), message, "system"))
        tick = tick_problem(case_data.get("tick", DEFAULT_TICK))
        if tick is not None:
            problems.append(Problem(("tick",), tick, "system"))
        road: RoadCase | None = None
        if spec.road is not None:
            if spec.config:
                problems.append(Problem(("system", "road"), "give either 'config' (a .sumocfg) or 'road' (an OpenDRIVE "
                                        "file with 'entities'), not both", "system"))  # fmt: skip
                return SystemInfo((), tuple(problems))
            road, problem = _road_case(spec)
            if problem is not None:
                problems.append(problem)
                return SystemInfo((), tuple(problems))
            assert road is not None
            config = road.config
        elif not spec.config:
            problems.append(Problem(("system",), "a 'sumo' system needs 'config': a .sumocfg file next to the case "
                                    "(or 'road' and 'entities': docs/opendrive.md)", "system"))  # fmt: skip
            return SystemInfo((), tuple(problems))
        else:
            config = spec.config
        scenario = read_scenario(config)
        if scenario.problems:
            problems += [Problem(("system", "config"), p, "system") for p in scenario.problems]
            return SystemInfo((), tuple(problems))
        spawned: dict[str, int] = {}
        for i, action, params in _sumo_entries(case_data):
            problems += self._check_action(scenario, spawned, i, action, params)
            problems += _check_road_action(road, i, action, params)
        for i, action, params in _sumo_entries(case_data):
            vid = params.get("vehicle")
            if action != "spawn" and isinstance(vid, str) and vid not in scenario.vehicles and vid not in spawned:
                known = [*scenario.vehicles, *spawned]
                problems.append(Problem(("execute", i, "params", "vehicle"),
                                        f"unknown vehicle {vid!r}{did_you_mean(vid, known)}", "system"))  # fmt: skip
        vehicles = signal_vehicles([*scenario.vehicles, *spawned])
        signals = [f"{v}.{a}" for v in vehicles for a in ATTRIBUTES] + list(SIM_SIGNALS)
        if road is not None:
            named = [v for v in vehicles if v in road.entities]
            signals += [f"{v}.{a}" for v in named for a in ROAD_ATTRIBUTES]
            signals += [f"{a}.{b}.{x}" for a in named for b in named if a != b for x in PAIR_ATTRIBUTES]
            signals += list(ROAD_SIM_SIGNALS)
        writers = {f"{v}.{a}": w for v in vehicles for a, w in (("speed", "sumo.speed"), ("lane", "sumo.lane"))}
        return SystemInfo(tuple(signals), tuple(problems), {"scenario": scenario}, writers=writers)

    @staticmethod
    def _check_action(scenario: Scenario, spawned: dict[str, int], i: int, action: str,
                      params: Mapping[str, Any]) -> list[Problem]:  # fmt: skip
        out = []

        def bad(key: str, message: str) -> None:
            out.append(Problem(("execute", i, "params", key), message, "system"))

        if action == "spawn":
            vid, route, vtype, lane = (params.get(k) for k in ("vehicle", "route", "type", "lane"))
            if isinstance(vid, str):
                if vid in scenario.vehicles:
                    bad("vehicle", f"vehicle {vid!r} is already declared in the route files")
                elif vid in spawned:
                    bad("vehicle", f"vehicle {vid!r} is already spawned by execute entry {spawned[vid]}")
                elif vid == "sim":
                    bad("vehicle", "'sim' is reserved for the simulation's signals")
                else:
                    spawned[vid] = i
            if isinstance(route, str) and route not in scenario.routes:
                bad("route", f"unknown route {route!r}{did_you_mean(route, scenario.routes)}")
            if isinstance(vtype, str) and vtype not in scenario.types:
                bad("type", f"unknown vehicle type {vtype!r}{did_you_mean(vtype, scenario.types)}")
            edge = scenario.route_edges.get(route) if isinstance(route, str) else None
            if isinstance(lane, int) and edge is not None and lane >= scenario.lanes.get(edge, 0):
                bad("lane", f"lane {lane} does not exist: edge {edge!r} has {scenario.lanes.get(edge, 0)} lane(s)")
        elif action == "lane":
            lane, most = params.get("lane"), max(scenario.lanes.values(), default=0)
            if isinstance(lane, int) and not isinstance(lane, bool) and lane >= most:
                bad("lane", f"lane {lane} does not exist: no edge of the network has more than {most} lane(s)")
        elif action == "signal":
            tls, state = params.get("tls"), params.get("state")
            if isinstance(tls, str) and tls not in scenario.signals:
                bad("tls", f"unknown traffic light {tls!r}{did_you_mean(tls, scenario.signals)}"
                    + ("" if scenario.signals else " (the network has none)"))  # fmt: skip
            elif isinstance(tls, str) and isinstance(state, str) and len(state) != scenario.signals[tls]:
                bad("state", f"traffic light {tls!r} controls {scenario.signals[tls]} links; "
                    f"the state has {len(state)} letters")  # fmt: skip
        return out

    def files(self, spec: SystemSpec) -> tuple[str, ...]:
        """The files a run of *spec* reads (the ``.sumocfg`` and every file it names): what a
        cluster ships to its workers. Empty when the configuration cannot be used (validation says why),
        and for a case on an OpenDRIVE road (its files are made where it runs, from its ``road``)."""
        if not spec.config:
            return ()
        scenario = read_scenario(spec.config)
        return () if scenario.problems else scenario.files

    def create(self, spec: SystemSpec, case: "TestCase") -> SumoSystem:
        road: RoadCase | None = None
        if spec.road is not None:
            road, problem = _road_case(spec)
            if problem is not None or road is None:
                raise SystemFailure(f"{spec.road}: {problem.message if problem else 'cannot be used'}")
            config = road.config
        elif not spec.config:
            raise SystemFailure("a 'sumo' system needs 'config': a .sumocfg file")
        else:
            config = spec.config
        scenario = read_scenario(config)
        if scenario.problems:
            raise SystemFailure(f"{spec.config}: {scenario.problems[0]}")
        options = {**scenario.options, **parse_options(list(spec.options))[0]}
        spawned = [e.params["vehicle"] for e in case.entries if e.action == "sumo.spawn"]
        tracked = signal_vehicles([*scenario.vehicles, *spawned])
        if road is not None:  # SUMO's saved state is not the start of a road case: start SUMO for every run
            scenario = dataclasses.replace(scenario, restore_problem=ROAD_RESTORE_PROBLEM)
        return SumoSystem(scenario, options, case.tick, tracked, spawns=bool(spawned), road=road)


ROAD_RESTORE_PROBLEM = ("a case on an OpenDRIVE road: SUMO's saved state rounds the vehicles' places to centimetres and "
                        "drops their lateral departure offsets, so a loaded state is not the case's start")
"""Why a simulation of a case on an OpenDRIVE road is not kept between runs (docs/opendrive.md)."""

_ROAD_ACTIONS = ("lane_change", "lane_offset", "teleport", "follow", "trajectory")


def _check_road_action(road: RoadCase | None, i: int, action: str, params: Mapping[str, Any]) -> list[Problem]:
    """The entities an action on an OpenDRIVE road names must be the case's (docs/opendrive.md)."""
    out = []
    refs = [("vehicle", params.get("vehicle"))] if action in _ROAD_ACTIONS else []
    relative = params.get("relative")
    if isinstance(relative, dict):
        refs.append(("relative", relative.get("entity")))
    if action == "follow":
        refs.append(("entity", params.get("entity")))
    if refs and road is None:
        return [Problem(("execute", i, "action"), f"sumo.{action} needs a case on an OpenDRIVE road ('road' and "
                        "'entities' in its system: docs/opendrive.md)", "system")]  # fmt: skip
    for key, name in refs:
        if isinstance(name, str) and road is not None and name not in road.entities:
            path = ("execute", i, "params", key) + (("entity",) if key == "relative" else ())
            out.append(Problem(path, f"unknown entity {name!r}{did_you_mean(name, list(road.entities))}", "system"))
    return out


def _road_case(spec: SystemSpec) -> tuple[RoadCase | None, Problem | None]:
    """The scenario made from the case's ``road`` and ``entities``, or the problem with it (JSON path and message)."""
    assert spec.road is not None
    if spec.entities is None:
        return None, Problem(("system",), "a 'sumo' system on a 'road' needs 'entities' (docs/opendrive.md)", "system")
    try:
        return road_case(spec.road, json.loads(spec.entities)), None
    except OpenDriveError as exc:
        message = str(exc)
        if message.startswith("/system/"):
            head, _, rest = message.partition(": ")
            return None, Problem(tuple(head.strip("/").split("/")), rest, "system")
        return None, Problem(("system", "road"), message, "system")


SUMO = SumoType()
"""The ``sumo`` system type, as registered."""


__all__ += ["INSTALL_HINT"]
