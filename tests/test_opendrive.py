"""SUMO cases on OpenDRIVE roads (docs/opendrive.md): netconvert's network cached by content, positions
mapped exactly (checked against libsumo's own getters and the road's own numbers), the road's signals,
storyboard-exact entities, and bad roads refused with exit 2.

The curved roads are the ALKS corpus's (radius 250 m and 1000 m); those tests skip where it is absent.
"""

from __future__ import annotations

import importlib.util
import json
import math
import os
import pathlib
import shutil
from typing import Any

import pytest
from py_trees.blackboard import Blackboard

import btgen_pytrees
from btgen_pytrees import generate
from btgen_pytrees.cli import main
from btgen_pytrees.leaves import default_registry
from btgen_pytrees.run import run_tree
from btgen_pytrees.systems.sumo import roads
from btgen_pytrees.systems.sumo.opendrive import OpenDriveError, read_opendrive

pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("libsumo") is None and not os.environ.get("CI"),
    reason="libsumo is not installed (pip install -e '.[sumo]'; CI installs it)",
)

CORPUS = pathlib.Path(__file__).resolve().parents[2] / "shared" / "corpus" / "openscenario" / "alks"
ROADS = CORPUS / "logical_scenarios" / "concrete_scenarios" / "road_networks"
if not ROADS.is_dir():
    ROADS = pathlib.Path("/work/shared/corpus/openscenario/alks/logical_scenarios/concrete_scenarios/road_networks")

# the corpus's lanes: t of each lane's centre (borders 2 and 0.75 m wide, driving lanes 3.5 m, the stop lane 3 m)
BORDERS = {-3: (-6.25, -2.75), -4: (-9.75, -6.25), -5: (-13.25, -9.75)}

STRAIGHT = """<?xml version="1.0"?>
<OpenDRIVE><header revMajor="1" revMinor="6"/>
 <road id="7" length="600" junction="-1">
  <planView><geometry s="0" x="10" y="20" hdg="0.5" length="600"><line/></geometry></planView>
  <lanes><laneSection s="0">
   <left><lane id="1" type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/></lane></left>
   <center><lane id="0" type="none"/></center>
   <right><lane id="-1" type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/></lane>
          <lane id="-2" type="driving"><width sOffset="0" a="3.25" b="0" c="0" d="0"/></lane></right>
  </laneSection></lanes>
 </road>
</OpenDRIVE>
"""


@pytest.fixture(autouse=True)
def cache(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch) -> pathlib.Path:
    folder = tmp_path_factory.getbasetemp() / "btgen-cache"
    monkeypatch.setenv("BTGEN_CACHE", str(folder))
    return folder


def entity(position: dict[str, Any], speed: Any = 0.0, **more: Any) -> dict[str, Any]:
    return {"length": 4.5, "width": 1.8, "center": [1.3, 0.0, 0.7], "position": position, "speed": speed, **more}


def write_case(folder: pathlib.Path, road: str, entities: dict[str, Any], expect: str = "sim.collisions >= 0",
               timeout: float = 0.1, execute: list[dict[str, Any]] | None = None) -> pathlib.Path:  # fmt: skip
    case = {"name": "road", "tick": 0.1, "timeout": timeout,
            "system": {"type": "sumo", "road": road, "entities": entities},
            "execute": execute or [{"id": "W", "kind": "constraint", "action": "wait", "params": {"duration": timeout}}],
            "oracle": {"criteria": [{"id": "R1", "type": "record", "expect": expect}]}}  # fmt: skip
    path = folder / "case.json"
    path.write_text(json.dumps(case))
    return path


def ticks(path: pathlib.Path, getters: Any) -> tuple[Any, list[dict[str, Any]], list[Any]]:
    """Run the case; per tick its signals and what *getters* (called with libsumo) read from SUMO itself."""
    import libsumo

    registry = default_registry()
    case = btgen_pytrees.load(str(path), registry=registry)
    system = btgen_pytrees.run.create_system(case, registry)
    root = generate(case, registry=registry, clock=system)
    prefix = root.btgen_env.namespace + "/signals/"
    signals: list[dict[str, Any]] = []
    read: list[Any] = []

    def seen(_k: int, _t: float) -> None:
        signals.append({k[len(prefix):]: v for k, v in Blackboard.storage.items() if k.startswith(prefix)})
        read.append(getters(libsumo))

    report = run_tree(root, case, system=system, record=True, progress=seen)
    root.btgen_env.clear()
    return report, signals, read


def arc(k: float, s: float, t: float) -> tuple[float, float, float]:
    """World point and heading of road coordinates (s, t) on a road that starts at the origin heading east with
    constant curvature k (the corpus's roads), by the circle's own formula."""
    if k == 0:
        return s, t, 0.0
    h = k * s
    return math.sin(h) / k - t * math.sin(h), (1 - math.cos(h)) / k + t * math.cos(h), h


def test_netconvert_output_is_cached_by_content_and_the_same_bytes_every_time(tmp_path: pathlib.Path, cache: pathlib.Path) -> None:
    if roads.netconvert_binary() is None:
        pytest.fail("netconvert is missing (the sumo extra installs it)") if os.environ.get("CI") else pytest.skip("no netconvert")
    a = tmp_path / "a.xodr"
    a.write_text(STRAIGHT)
    net, network = roads.convert(str(a))
    assert network.roads["7"].length == 600
    text = pathlib.Path(net).read_text()
    assert "generated on" not in text and str(tmp_path) not in text  # no time stamp, no path of the user's
    assert '<param key="origId" value="7_-2"/>' in text and '<param key="origId" value="7_1"/>' in text
    stamp = os.stat(net).st_mtime_ns
    b = tmp_path / "b.xodr"  # the same bytes under another name: the same network, not converted again
    shutil.copy(a, b)
    assert roads.convert(str(b))[0] == net and os.stat(net).st_mtime_ns == stamp
    assert str(cache) in net and not any(p.suffix == ".xml" for p in tmp_path.iterdir())  # nothing in the user's tree
    a.write_text(STRAIGHT.replace('length="600"', 'length="500"'))  # other content: another network
    assert roads.convert(str(a))[0] != net


@pytest.mark.parametrize("content, message", [
    (None, "road.xodr: cannot read"),
    ('<?xml version="1.0"?>\n<!DOCTYPE x [<!ENTITY a "aaaa">]>\n<OpenDRIVE/>', "road.xodr:2: a DOCTYPE is not allowed"),
    ("<OpenDRIVE><road id='1' length='10'>", "road.xodr:1: not well-formed XML"),
    ("<routes/>", "road.xodr: not an OpenDRIVE file"),
    (STRAIGHT.replace("<line/>", "<include file='/etc/passwd'/>"), "is not allowed"),
    (STRAIGHT.replace("<line/>", ""), "road '7' has no reference line"),
    (STRAIGHT.replace("<line/>", "<line/></geometry><geometry s='1' x='0' y='0' hdg='0' length='nan'><line/>"), "length='nan' is not a finite number"),
], ids=["missing", "doctype", "malformed", "not-opendrive", "include", "no-geometry", "nan"])  # fmt: skip
def test_a_road_that_is_missing_unsafe_or_unreadable_is_exit_2_naming_the_file(
        tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str], content: str | None, message: str) -> None:  # fmt: skip
    if content is not None:
        (tmp_path / "road.xodr").write_text(content)
    case = write_case(tmp_path, "road.xodr", {"Ego": entity({"LanePosition": {"roadId": "7", "laneId": -1, "s": 10}})})
    assert main(["validate", str(case)]) == 2
    err = capsys.readouterr().err
    assert "case.json: /system/road: " in err and message in err, err
    assert "Traceback" not in err


@pytest.mark.parametrize("position, where, message", [
    ({"LanePosition": {"roadId": "8", "laneId": -1, "s": 10}}, "/system/entities/Ego/position", "has no road '8' (roads: 7)"),
    ({"LanePosition": {"roadId": "7", "laneId": -3, "s": 10}}, "/system/entities/Ego/position", "has no lane -3 at s = 10"),
    ({"LanePosition": {"roadId": "7", "laneId": -1, "s": 700}}, "/system/entities/Ego/position", "s = 700 is outside road '7'"),
    ({"RelativeLanePosition": {"entityRef": "Lead", "dLane": 0, "ds": 5}}, "/system/entities/Ego/position/RelativeLanePosition/entityRef",
     "'Lead' is not an entity placed before"),
    ({"GeoPosition": {}}, "/system/entities/Ego/position", "give exactly one of LanePosition"),
    ({"LanePosition": {"roadId": "7", "laneId": -1, "s": "ten"}}, "/system/entities/Ego/position/LanePosition/s", "expected a number"),
], ids=["road", "lane", "s", "later-entity", "kind", "not-a-number"])  # fmt: skip
def test_a_position_off_the_road_is_exit_2_with_its_json_path(tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str],
                                                             position: dict[str, Any], where: str, message: str) -> None:  # fmt: skip
    (tmp_path / "road.xodr").write_text(STRAIGHT)
    case = write_case(tmp_path, "road.xodr", {"Ego": entity(position), "Lead": entity({"LanePosition": {"roadId": "7", "laneId": -1, "s": 90}})})
    assert main(["validate", str(case)]) == 2
    err = capsys.readouterr().err
    assert f"case.json: {where}: " in err and message in err, err


def placements(road: str) -> dict[str, Any]:
    return {
        "Ego": entity({"LanePosition": {"roadId": "0", "laneId": -4, "s": 5.0}}, 16.0),
        "Side": entity({"RelativeLanePosition": {"entityRef": "Ego", "dLane": 1, "ds": 40.0}}, 10.0),
        "Far": entity({"LanePosition": {"roadId": "0", "laneId": -5, "s": 300.0, "offset": 0.4}}, 0.0, length=12.0, width=2.5, center=[4.0, 0.0, 1.5]),
        "Onc": entity({"RoadPosition": {"roadId": "0", "s": 500.0, "t": 8.0}}, 20.0),
        "Obj": entity({"RelativeObjectPosition": {"entityRef": "Ego", "dx": 30.0, "dy": -3.5}}, 0.0),
        "Lane": entity({"RelativeLanePosition": {"entityRef": "Ego", "dLane": 1, "dsLane": 40.0}}, 0.0),
    }  # fmt: skip


def expected(k: float) -> dict[str, tuple[int, float, float]]:
    """entity -> (lane id, s, t) of its reference point, from the scenario's own numbers."""
    ego_x, ego_y, ego_h = arc(k, 5.0, -8.0)
    ox, oy = ego_x + 30 * math.cos(ego_h) + 3.5 * math.sin(ego_h), ego_y + 30 * math.sin(ego_h) - 3.5 * math.cos(ego_h)
    # the object's s and t: the foot of the perpendicular on the reference line, by the circle's formula
    if k == 0:
        obj_s, obj_t = ox, oy
    else:
        centre = (0.0, 1 / k)
        obj_s = (math.atan2(ox - centre[0], -(oy - centre[1])) if k > 0 else math.atan2(ox, oy - centre[1])) / abs(k)
        obj_t = (1 / k - math.copysign(math.hypot(ox - centre[0], oy - centre[1]), 1 / k))
    return {"Ego": (-4, 5.0, -8.0), "Side": (-3, 45.0, -4.5), "Far": (-5, 300.0, -11.1), "Onc": (4, 500.0, 8.0),
            "Lane": (-3, 5.0 + 40.0 / (1 - k * -4.5), -4.5),  # 40 m along lane -3's centre, of radius 1/k + 4.5
            "Obj": (next(lane for lane, (low, high) in BORDERS.items() if low <= obj_t <= high), obj_s, obj_t)}  # fmt: skip


@pytest.mark.parametrize("name, k", [("alks_road_straight", 0.0), ("alks_road_right_radius_250m", -0.004),
                                     ("alks_road_left_radius_1000m", 0.001)])  # fmt: skip
def test_positions_map_to_sumo_exactly_and_back_on_straight_and_curved_roads(tmp_path: pathlib.Path, name: str, k: float) -> None:
    xodr = ROADS / f"{name}.xodr"
    if not xodr.is_file():
        pytest.skip("the ALKS corpus is not here")
    entities = placements(name)
    ids = list(entities)
    case = write_case(tmp_path, str(xodr), entities)
    report, signals, read = ticks(case, lambda ls: {v: (ls.vehicle.getPosition(v), ls.vehicle.getLaneID(v), ls.vehicle.getSpeed(v)) for v in ids})
    assert report.verdict == "pass", report.message
    want = expected(k)
    first, sumo = signals[0], read[0]
    for vid in ids:
        lane, s, t = want[vid]
        e = entities[vid]
        x, y, h = arc(k, s, t)
        if lane > 0:
            h += math.pi
        # the road's signals: the reference point where the scenario puts it, within 0.1 m
        assert math.hypot(first[f"{vid}.ref_x"] - x, first[f"{vid}.ref_y"] - y) < 0.1, (vid, first[f"{vid}.ref_x"], x, first[f"{vid}.ref_y"], y)
        assert first[f"{vid}.lane_id"] == lane and first[f"{vid}.road"] == 0
        assert abs(first[f"{vid}.s"] - s) < 0.1 and abs(first[f"{vid}.t"] - t) < 0.1, (vid, first[f"{vid}.s"], s, first[f"{vid}.t"], t)
        # libsumo's own getters: SUMO's front bumper is length/2 + centre ahead of that point, along the lane
        (fx, fy), sumo_lane, speed = sumo[vid]
        ax, ay = _along_lane(k, s, t, e["center"][0] + e["length"] / 2, lane > 0)
        assert math.hypot(fx - ax, fy - ay) < 0.1, (vid, (fx, fy), (ax, ay))
        assert sumo_lane.startswith("-0_" if lane < 0 else "0_")
        expected_speed = e["speed"] if not isinstance(e["speed"], dict) else 16.0 + e["speed"]["value"]
        assert speed == pytest.approx(expected_speed)
        assert first[f"{vid}.speed"] == pytest.approx(expected_speed)
    # pairs: Side is 40 m ahead of Ego along the reference line, one lane to its left
    assert first["Ego.Side.ds"] == pytest.approx(40.0, abs=0.1) and first["Ego.Side.dlane"] == 1
    assert first["Ego.Side.ds_free"] == pytest.approx(40.0 - 4.5, abs=0.1)
    assert first["Ego.Side.headway"] == pytest.approx(40.0 / 16.0, abs=0.01)
    assert first["Ego.Side.ttc"] == pytest.approx(40.0 / 6.0, abs=0.05)
    assert first["Side.Ego.ds"] == pytest.approx(-40.0, abs=0.1) and first["Side.Ego.ttc"] == math.inf


def _along_lane(k: float, s: float, t: float, ahead: float, backwards: bool) -> tuple[float, float]:
    """The point *ahead* m further along the lane at offset t (against s on left lanes), by the circle's formula."""
    if k == 0:
        return (s - ahead, t) if backwards else (s + ahead, t)
    radius = 1 / k - t  # the lane's own radius (signed like 1/k)
    ds = ahead * (1 / k) / radius
    x, y, _ = arc(k, s - ds if backwards else s + ds, t)
    return x, y


def test_an_entity_without_a_controller_keeps_its_speed_and_runs_into_a_standing_car(tmp_path: pathlib.Path) -> None:
    (tmp_path / "road.xodr").write_text(STRAIGHT)
    entities = {"Ego": entity({"LanePosition": {"roadId": "7", "laneId": -1, "s": 10}}, 20.0),
                "Lead": entity({"LanePosition": {"roadId": "7", "laneId": -1, "s": 60}}, 0.0)}  # fmt: skip
    case = write_case(tmp_path, "road.xodr", entities, timeout=4,
                      execute=[{"id": "C", "kind": "constraint", "action": "until", "params": {"expect": "Ego.collided", "timeout": 4}}])  # fmt: skip
    report, signals, read = ticks(case, lambda ls: (ls.simulation.getCollisions(), ls.vehicle.getSpeedMode("Ego"),
                                                    ls.vehicle.getLaneChangeMode("Ego")))  # fmt: skip
    assert report.execute[0].status == "success"
    # 50 m between the reference points, 4.5 m of car between the bumpers: contact after 45.5 / 20 = 2.275 s
    hit = next(i for i, s in enumerate(signals) if s["Ego.collided"])
    assert hit == 23  # the state at 2.3 s is the first with the bumpers overlapping
    assert all(s["Ego.speed"] == 20.0 for s in signals[:hit])  # no car-following: no braking at all
    assert [c.collider for c in read[hit][0]] == ["Ego"]  # SUMO's own collision
    assert {r[1:] for r in read} == {(0, 0)}  # SUMO's speed and lane-change mode 0 all along
    assert signals[hit]["Ego.Lead.ds_free"] == 0 and signals[hit - 1]["Ego.Lead.ds_free"] == pytest.approx(45.5 - 2.2 * 20, abs=1e-3)
    assert signals[hit]["Lead.still"] == pytest.approx(2.3) and signals[hit]["Ego.still"] == 0


def test_the_road_signals_are_read_only_where_the_tree_reads_them(tmp_path: pathlib.Path) -> None:
    (tmp_path / "road.xodr").write_text(STRAIGHT)
    entities = {"Ego": entity({"LanePosition": {"roadId": "7", "laneId": -1, "s": 10}}, 20.0),
                "Lead": entity({"LanePosition": {"roadId": "7", "laneId": -2, "s": 60}}, 10.0)}  # fmt: skip
    case = btgen_pytrees.load(str(write_case(tmp_path, "road.xodr", entities, expect="Ego.Lead.ds < 100 && Ego.s > 0", timeout=1)))
    registry = default_registry()
    system = btgen_pytrees.run.create_system(case, registry)
    root = generate(case, registry=registry, clock=system)
    prefix = root.btgen_env.namespace + "/signals/"
    published: list[set[str]] = []
    run_tree(root, case, system=system, record=False, progress=lambda _k, _t: published.append(
        {k[len(prefix):] for k in Blackboard.storage if k.startswith(prefix) and ("." in k[len(prefix):])}))
    root.btgen_env.clear()
    road_signals = {n for n in published[-1] if n.split(".")[-1] in roads_attributes()}
    assert road_signals == {"Ego.Lead.ds", "Ego.s"}, road_signals


def roads_attributes() -> set[str]:
    from btgen_pytrees.systems.sumo.system import PAIR_ATTRIBUTES, ROAD_ATTRIBUTES

    return set(PAIR_ATTRIBUTES) | set(ROAD_ATTRIBUTES)


def test_the_opendrive_reader_evaluates_spirals_and_finds_road_coordinates_back(tmp_path: pathlib.Path) -> None:
    xodr = ROADS / "alks_road_different_curvatures.xodr"
    if not xodr.is_file():
        pytest.skip("the ALKS corpus is not here")
    network = read_opendrive(str(xodr))
    road = network.roads["0"]
    assert [g.kind for g in road.geometries][:4] == ["line", "spiral", "arc", "spiral"]
    # the reference line is continuous from piece to piece (each piece starts where the one before ends)
    for before, after in zip(road.geometries, road.geometries[1:]):
        x, y, h = before.at(before.length)
        assert math.hypot(x - after.x, y - after.y) < 1e-3 and abs(math.remainder(h - after.hdg, 2 * math.pi)) < 1e-6
    for s in (10.0, 333.3, 1234.5, 4000.0):
        pose = network.lane_pose("0", -4, s, 0.3)
        back = network.locate(pose.x, pose.y)
        assert back is not None and back.lane == -4 and back.s == pytest.approx(s, abs=1e-6) and back.offset == pytest.approx(0.3, abs=1e-6)
    with pytest.raises(OpenDriveError, match="has no lane 9"):
        network.lane_pose("0", 9, 10.0)


def test_an_activated_controller_brakes_where_the_storyboard_exact_entity_ran_into_the_car(tmp_path: pathlib.Path) -> None:
    (tmp_path / "road.xodr").write_text(STRAIGHT)
    entities = {"Ego": entity({"LanePosition": {"roadId": "7", "laneId": -1, "s": 10}}, 20.0),
                "Lead": entity({"LanePosition": {"roadId": "7", "laneId": -1, "s": 110}}, 0.0)}  # fmt: skip
    execute = [{"id": "A", "kind": "behavior", "action": "sumo.controller", "params": {"vehicle": "Ego", "lateral": False}},
               {"id": "C", "kind": "constraint", "after": ["A"], "action": "until", "params": {"expect": "Ego.still >= 1", "timeout": 15}}]  # fmt: skip
    case = write_case(tmp_path, "road.xodr", entities, expect="!Ego.collided", timeout=15, execute=execute)
    report, signals, read = ticks(case, lambda ls: (ls.vehicle.getSpeedMode("Ego"), ls.vehicle.getLaneChangeMode("Ego")))
    assert report.verdict == "pass", report.message
    # SUMO's own modes: its driver model for the speed only (with lane changes allowed too, it overtakes)
    assert read[-1] == (31, 0)
    # its desired speed is the one it had (not the lane's limit): it never drives faster, and sim.time is the tick's
    assert max(s["Ego.speed"] for s in signals) == pytest.approx(20.0, abs=1e-6)
    assert [s["sim.time"] for s in signals] == pytest.approx([k / 10 for k in range(len(signals))])
    assert signals[-1]["Ego.speed"] < 0.1 and 2.5 <= signals[-1]["Ego.Lead.ds_free"] < 3  # stopped behind the car, minGap (2.5 m) away


SHAPE = {"step": lambda u: 1.0, "linear": lambda u: u, "cubic": lambda u: u * u * (3 - 2 * u),
         "sinusoidal": lambda u: (1 - math.cos(math.pi * u)) / 2}  # fmt: skip


def test_speed_actions_reach_their_targets_at_the_times_their_dynamics_give(tmp_path: pathlib.Path) -> None:
    (tmp_path / "road.xodr").write_text(STRAIGHT)
    lanes = {"A": (-1, 10), "B": (-2, 10), "C": (1, 500), "D": (-1, 200), "E": (-2, 200)}
    entities = {n: entity({"LanePosition": {"roadId": "7", "laneId": lane, "s": s}}, 10.0) for n, (lane, s) in lanes.items()}
    actions = {  # entity: (params, start speed, target, span in s)
        "A": ({"to": 20, "shape": "linear", "rate": 2}, 10.0, 20.0, 5.0),
        "B": ({"to": 0, "shape": "cubic", "duration": 4}, 10.0, 0.0, 4.0),
        "C": ({"to": 20, "shape": "sinusoidal", "distance": 60}, 10.0, 20.0, 4.0),  # 60 m at a mean of 15 m/s
        "D": ({"to": 5, "shape": "step", "duration": 3}, 10.0, 5.0, 0.0),  # a step takes no time, whatever is given
        "E": ({"relative": {"entity": "A", "value": 1.5, "type": "factor"}, "shape": "linear", "duration": 2}, 10.0, 15.0, 2.0),
    }  # fmt: skip
    execute = [{"id": f"S{n}", "kind": "behavior", "action": "sumo.speed", "params": {"vehicle": n, **p}} for n, (p, *_) in actions.items()]
    case = write_case(tmp_path, "road.xodr", entities, timeout=6, execute=execute)
    report, signals, read = ticks(case, lambda ls: {n: ls.vehicle.getSpeed(n) for n in lanes})
    assert report.verdict == "pass", report.message
    ends = {e.id: e.end for e in report.execute}
    for n, (_, v0, v1, span) in actions.items():
        assert ends[f"S{n}"] == pytest.approx(math.ceil(span * 10 - 1e-9) / 10), n  # the first tick at or after the span
        shape = SHAPE[actions[n][0].get("shape", "linear")]
        for k, speeds in enumerate(read):
            t = round(k * 0.1, 10)
            want = v1 if span == 0 or t >= span else v0 + (v1 - v0) * shape(t / span)
            if k == 0 and span > 0:
                want = v0 + (v1 - v0) * shape(0.1 / span)  # the first command acts from the first tick on
            if k == 0:
                continue
            assert speeds[n] == pytest.approx(want, abs=1e-6), (n, t, speeds[n], want)  # libsumo's own speed
            assert signals[k][f"{n}.speed"] == pytest.approx(want, abs=1e-6)


@pytest.mark.parametrize("road", ["inline", "alks_road_right_radius_250m"])
def test_lane_change_offset_teleport_and_distance_move_as_the_dynamics_say(tmp_path: pathlib.Path, road: str) -> None:
    if road == "inline":
        (tmp_path / "road.xodr").write_text(STRAIGHT)
        xodr, rid, ego_lane, cut_lane, far_lane, t_from, t_to, kappa = "road.xodr", "7", -1, -2, -1, -5.125, -1.75, 0.0
    else:
        if not (ROADS / f"{road}.xodr").is_file():
            pytest.skip("the ALKS corpus is not here")
        xodr, rid, ego_lane, cut_lane, far_lane, t_from, t_to, kappa = str(ROADS / f"{road}.xodr"), "0", -4, -5, -3, -11.5, -8.0, -0.004
    entities = {"Ego": entity({"LanePosition": {"roadId": rid, "laneId": ego_lane, "s": 5.0}}, 10.0),
                "Cut": entity({"RelativeLanePosition": {"entityRef": "Ego", "dLane": cut_lane - ego_lane, "ds": 30.0}}, 10.0),
                "Far": entity({"LanePosition": {"roadId": rid, "laneId": far_lane, "s": 200.0}}, 10.0),
                "Back": entity({"LanePosition": {"roadId": rid, "laneId": far_lane, "s": 100.0}}, 10.0,
                               distance={"entityRef": "Far", "timeGap": 1.5, "freespace": True})}  # fmt: skip
    rate = 2.0
    span = abs(t_to - t_from) * math.pi / 2 / rate  # sinusoidal: the peak lateral speed is pi/2 times the mean
    execute = [
        {"id": "L", "kind": "behavior", "action": "sumo.lane_change",
         "params": {"vehicle": "Cut", "relative": {"entity": "Ego", "value": 0}, "shape": "sinusoidal", "rate": rate}},
        {"id": "O", "kind": "behavior", "after": ["L"], "action": "sumo.lane_offset",
         "params": {"vehicle": "Cut", "offset": 0.5, "shape": "sinusoidal", "max_lateral_acc": 1.0}},
        {"id": "T", "kind": "behavior", "after": ["O"], "action": "sumo.teleport",
         "params": {"vehicle": "Ego", "position": {"RelativeLanePosition": {"entityRef": "Far", "dLane": 0, "ds": -60.0}}}},
        {"id": "P", "kind": "constraint", "after": ["T"], "action": "wait", "params": {"duration": 0.3}},
        {"id": "F", "kind": "behavior", "after": ["P"], "action": "sumo.follow",
         "params": {"vehicle": "Ego", "entity": "Far", "distance": 20.0, "freespace": True}},
        {"id": "W", "kind": "constraint", "after": ["F"], "action": "wait", "params": {"duration": 0.5}},
    ]  # fmt: skip
    case = write_case(tmp_path, xodr, entities, timeout=8, execute=execute)
    report, signals, read = ticks(case, lambda ls: (ls.vehicle.getLaneID("Cut"), ls.vehicle.getPosition("Ego")))
    assert report.verdict == "pass", report.message
    end = {e.id: e.end for e in report.execute}
    # Init's LongitudinalDistanceAction: 1.5 s at Back's 10 m/s between the bumpers
    assert signals[0]["Back.Far.ds_free"] == pytest.approx(15.0, abs=0.05)
    # the lane change: t follows the sinusoid from lane to lane and ends in the lane asked, on the tick the span ends
    assert end["L"] == pytest.approx(math.ceil(span * 10) / 10)
    k_end = round(end["L"] * 10)
    for k in range(1, k_end + 1):
        want = t_from + (t_to - t_from) * SHAPE["sinusoidal"](min(1.0, k * 0.1 / span))
        assert signals[k]["Cut.t"] == pytest.approx(want, abs=0.03), (k, signals[k]["Cut.t"], want)
    assert signals[k_end]["Cut.lane_id"] == ego_lane and read[k_end][0] in {f"-{rid}_{i}" for i in range(8)}
    # s goes on meanwhile: 10 m/s along the lane, whose length per metre of s is 1 - kappa t on a curve of curvature kappa
    assert signals[k_end]["Cut.s"] - signals[0]["Cut.s"] == pytest.approx(10.0 * end["L"] / (1 - kappa * (t_from + t_to) / 2), rel=0.005)
    # the lane offset: 0.5 m to the left in pi * sqrt(0.5 / 2) s (a sinusoid's peak lateral acceleration is pi^2/2 change/T^2)
    assert end["O"] - end["L"] == pytest.approx(math.ceil(math.pi * math.sqrt(0.5 / 2) * 10) / 10, abs=1e-9)
    k_o = round(end["O"] * 10)
    assert signals[k_o]["Cut.offset"] == pytest.approx(0.5, abs=0.03) and signals[k_o]["Cut.lane_id"] == ego_lane
    # the teleport: Ego's reference point 60 m behind where Far's was on its tick, on the tick after it (Far has
    # driven on 1 m meanwhile); both drive on at 10 m/s
    k_t = round(end["T"] * 10) + 1
    assert signals[k_t]["Ego.Far.ds"] == pytest.approx(61.0, abs=0.1) and signals[k_t]["Ego.lane_id"] == far_lane
    assert signals[k_t + 1]["Ego.Far.ds"] == pytest.approx(61.0, abs=0.1)
    # the distance: 20 m between the bumpers from the tick the action succeeded on
    k_f = round(end["F"] * 10)
    for k in range(k_f, len(signals)):
        assert signals[k]["Ego.Far.ds_free"] == pytest.approx(20.0, abs=0.1), (k, signals[k]["Ego.Far.ds_free"])


def test_the_documented_controller_plugin_stops_the_ego_short_of_the_standing_car(tmp_path: pathlib.Path) -> None:
    doc = (pathlib.Path(__file__).resolve().parent.parent / "docs" / "opendrive.md").read_text()
    code = doc.split("```python\n", 1)[1].split("```", 1)[0]
    (tmp_path / "aeb.py").write_text(code)
    (tmp_path / "road.xodr").write_text(STRAIGHT)
    entities = {"Ego": entity({"LanePosition": {"roadId": "7", "laneId": -1, "s": 10}}, 20.0),
                "Lead": entity({"LanePosition": {"roadId": "7", "laneId": -1, "s": 110}}, 0.0)}  # fmt: skip
    execute = [{"id": "AEB", "kind": "behavior", "action": "my.aeb", "params": {}},
               {"id": "C", "kind": "constraint", "action": "until", "params": {"expect": "Ego.still >= 0.5", "timeout": 10}}]  # fmt: skip
    case = write_case(tmp_path, "road.xodr", entities, expect="!Ego.collided", timeout=10, execute=execute)
    assert main(["run", str(case), "--plugin", str(tmp_path / "aeb.py"), "--json", str(tmp_path / "r.json")]) == 0
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["verdict"] == "pass" and [e["status"] for e in report["execute"]] == ["success", "success"]


def test_an_offset_into_the_next_lane_puts_the_vehicle_there_and_lane_offsets_keep_to_the_lane_named(tmp_path: pathlib.Path) -> None:
    # ALKS 4.6.2's placement: a side vehicle on the ego's lane id with an offset that reaches into the next lane
    (tmp_path / "road.xodr").write_text(STRAIGHT)
    entities = {"Ego": entity({"LanePosition": {"roadId": "7", "laneId": -1, "s": 20}}, 10.0),
                "Side": entity({"RelativeLanePosition": {"entityRef": "Ego", "dLane": 0, "ds": 0, "offset": -3.5}}, 10.0)}  # fmt: skip
    execute = [{"id": "O", "kind": "behavior", "action": "sumo.lane_offset",
                "params": {"vehicle": "Side", "relative": {"entity": "Ego", "value": -2.5}, "shape": "sinusoidal", "max_lateral_acc": 1.0}}]  # fmt: skip
    case = write_case(tmp_path, "road.xodr", entities, expect="!Ego.collided && !Side.collided", timeout=3, execute=execute)
    report, signals, read = ticks(case, lambda ls: (ls.vehicle.getLaneID("Ego"), ls.vehicle.getLaneID("Side")))
    assert report.verdict == "pass", report.message
    assert read[0] == ("-7_1", "-7_0") and signals[0]["Side.lane_id"] == -2  # SUMO's lanes: side by side
    assert signals[0]["Side.t"] == pytest.approx(-1.75 - 3.5, abs=0.01) and signals[0]["Ego.Side.dt"] == pytest.approx(-3.5, abs=0.01)
    # the offset relative to Ego's (0) in the lane the position named (-1): -2.5 m from its centre, after
    # pi * sqrt(1 / 2) s (the sinusoid's peak lateral acceleration is pi^2/2 change/T^2)
    end = report.execute[0].end
    assert end == pytest.approx(math.ceil(math.pi * math.sqrt(1.0 / 2) * 10) / 10)
    k = round(end * 10)
    assert signals[k]["Side.t"] == pytest.approx(-1.75 - 2.5, abs=0.03) and signals[k]["Side.lane_id"] == -2


def test_the_generated_sumo_files_are_written_where_convert_asks(tmp_path: pathlib.Path) -> None:
    (tmp_path / "road.xodr").write_text(STRAIGHT)
    case = roads.road_case(str(tmp_path / "road.xodr"), {"Ego": entity({"LanePosition": {"roadId": "7", "laneId": -1, "s": 20}})})
    out = tmp_path / "out"
    out.mkdir()
    written = roads.write_sumo_files(case, str(out))
    assert sorted(pathlib.Path(p).suffix for p in written) == [".sumocfg", ".xml", ".xml"]
    from btgen_pytrees.systems.sumo.scenario import read_scenario

    scenario = read_scenario(str(next(out.glob("*.sumocfg"))))
    assert scenario.problems == () and list(scenario.vehicles) == ["Ego"]


def test_a_pedestrian_crosses_the_road_along_its_trajectory_on_time(tmp_path: pathlib.Path) -> None:
    # ALKS 4.2.3's crossing: from 3 m right of a lane's centre to 3 m left of it at 5 km/h, across two lanes
    (tmp_path / "road.xodr").write_text(STRAIGHT)
    walker = {"length": 0.3, "width": 0.5, "center": [0.15, 0.0, 0.9], "category": "pedestrian"}
    entities = {"Ego": entity({"LanePosition": {"roadId": "7", "laneId": -1, "s": 10}}, 10.0),
                "Walker": {**walker, "position": {"LanePosition": {"roadId": "7", "laneId": -1, "s": 100, "offset": -3.0},
                                                  "Orientation": {"h": 1.57, "type": "relative"}}}}  # fmt: skip
    speed = 5 / 3.6
    span = 6.0 / speed  # 4.32 s
    vertices = [{"time": 0, "position": {"LanePosition": {"roadId": "7", "laneId": -1, "s": 100, "offset": -3.0}}},
                {"time": span, "position": {"LanePosition": {"roadId": "7", "laneId": -1, "s": 100, "offset": 3.0}}}]  # fmt: skip
    execute = [{"id": "X", "kind": "behavior", "action": "sumo.trajectory", "params": {"vehicle": "Walker", "vertices": vertices}}]
    case = write_case(tmp_path, "road.xodr", entities, timeout=6, execute=execute)
    report, signals, read = ticks(case, lambda ls: ls.vehicle.getLaneID("Walker"))
    assert report.verdict == "pass", report.message
    end = report.execute[0].end
    assert end == pytest.approx(math.ceil(span * 10) / 10)
    for k in range(1, round(end * 10) + 1):
        t = -1.75 - 3.0 + 6.0 * min(1.0, k * 0.1 / span)
        assert signals[k]["Walker.t"] == pytest.approx(t, abs=0.02) and signals[k]["Walker.s"] == pytest.approx(100, abs=0.02), k
        assert signals[k]["Walker.lane_id"] == (-2 if t < -3.5 else -1 if t < 0 else 1)  # lanes -2, -1, then 1
        assert signals[k]["Walker.speed"] == pytest.approx(speed)
        assert signals[k]["Walker.heading"] == pytest.approx(0.5 + math.pi / 2, abs=1e-6)  # across the road (it runs at 0.5 rad)
    assert read[round(end * 10)] == "7_0"  # SUMO has it on the lane the other way now


def test_road_actions_name_entities_of_a_road_case(tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "road.xodr").write_text(STRAIGHT)
    entities = {"Ego": entity({"LanePosition": {"roadId": "7", "laneId": -1, "s": 10}})}
    execute = [{"id": "L", "kind": "behavior", "action": "sumo.lane_change", "params": {"vehicle": "Ego", "relative": {"entity": "Egoo", "value": 1}, "duration": 2}},
               {"id": "F", "kind": "behavior", "action": "sumo.follow", "params": {"vehicle": "Ego", "entity": "Lead", "distance": 5}}]  # fmt: skip
    case = write_case(tmp_path, "road.xodr", entities, execute=execute)
    assert main(["validate", str(case)]) == 2
    err = capsys.readouterr().err
    assert "case.json: /execute/0/params/relative/entity: unknown entity 'Egoo' (did you mean 'Ego'?)" in err, err
    assert "case.json: /execute/1/params/entity: unknown entity 'Lead'" in err


def test_an_unknown_key_of_an_entity_is_refused_not_ignored(tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "road.xodr").write_text(STRAIGHT)
    case = write_case(tmp_path, "road.xodr", {"Ego": {**entity({"LanePosition": {"roadId": "7", "laneId": -1, "s": 10}}), "lenght": 4}})
    assert main(["validate", str(case)]) == 2
    assert "case.json: /system/entities/Ego/lenght: not a key of an entity" in capsys.readouterr().err


def test_the_end_of_the_road_is_a_signal_until_sumo_takes_the_vehicle_off(tmp_path: pathlib.Path) -> None:
    (tmp_path / "road.xodr").write_text(STRAIGHT)
    entities = {"Ego": entity({"LanePosition": {"roadId": "7", "laneId": -1, "s": 570}}, 10.0),
                "Stay": entity({"LanePosition": {"roadId": "7", "laneId": -2, "s": 100}}, 0.0)}  # fmt: skip
    case = write_case(tmp_path, "road.xodr", entities, timeout=4, expect="Stay.present")
    report, signals, read = ticks(case, lambda ls: ls.vehicle.getIDList())
    ends = [s.get("Ego.end_of_road") for s in signals]
    last = max(k for k, s in enumerate(signals) if "Ego" in read[k])
    # its front reaches the road's end (600 m) 600 - 570 - 3.55 = 26.45 m on: on the state at 2.6 s it is within
    # one step of it, and SUMO takes it off in the step after
    assert ends[last] is True and not any(ends[:last]) and last == 26
    assert "Ego.s" not in signals[last + 1]  # gone: no value


def test_runs_of_a_road_case_in_a_reuse_block_are_those_of_fresh_runs(tmp_path: pathlib.Path) -> None:
    from btgen_pytrees.systems.sumo import kept_simulation, reuse_simulations

    (tmp_path / "road.xodr").write_text(STRAIGHT)
    entities = {"Ego": entity({"LanePosition": {"roadId": "7", "laneId": -1, "s": 10}}, 10.0),
                "Cut": entity({"RelativeLanePosition": {"entityRef": "Ego", "dLane": -1, "ds": 20, "offset": 0.3}}, 10.0)}  # fmt: skip
    execute = [{"id": "L", "kind": "behavior", "action": "sumo.lane_change", "params": {"vehicle": "Cut", "lane": -1, "duration": 1}}]
    path = write_case(tmp_path, "road.xodr", entities, timeout=1.5, execute=execute, expect="Cut.t >= -6")
    registry = default_registry()
    case = btgen_pytrees.load(str(path), registry=registry)

    def once() -> str:
        system = btgen_pytrees.run.create_system(case, registry)
        root = generate(case, registry=registry, clock=system)
        report = run_tree(root, case, system=system, record=True)
        root.btgen_env.clear()
        return report.to_json()

    fresh = once()
    with reuse_simulations():
        again = [once(), once(), once()]
        kept = kept_simulation()
    assert again == [fresh] * 3 and '"verdict": "pass"' in fresh
    assert kept is None  # nothing kept for a road case


def test_a_cache_directory_that_cannot_be_written_is_exit_2_saying_so(tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str],
                                                                     monkeypatch: pytest.MonkeyPatch) -> None:  # fmt: skip
    (tmp_path / "road.xodr").write_text(STRAIGHT.replace('length="600"', 'length="599"'))
    (tmp_path / "file").write_text("not a directory")
    monkeypatch.setenv("BTGEN_CACHE", str(tmp_path / "file" / "cache"))
    case = write_case(tmp_path, "road.xodr", {"Ego": entity({"LanePosition": {"roadId": "7", "laneId": -1, "s": 10}})})
    assert main(["validate", str(case)]) == 2
    err = capsys.readouterr().err
    assert "case.json: /system/road: road.xodr: cannot write the cache directory" in err and "set BTGEN_CACHE" in err, err


TWO_ROADS = """<?xml version="1.0"?>
<OpenDRIVE><header revMajor="1" revMinor="6"/>
 <road id="1" length="100" junction="-1">
  <link><successor elementType="road" elementId="2" contactPoint="start"/></link>
  <planView><geometry s="0" x="0" y="0" hdg="0" length="100"><line/></geometry></planView>
  <lanes><laneSection s="0">
   <left><lane id="1" type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/><link><successor id="1"/></link></lane></left>
   <center><lane id="0" type="none"/></center>
   <right><lane id="-1" type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/><link><successor id="-1"/></link></lane></right>
  </laneSection><laneSection s="50">
   <left><lane id="1" type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/></lane></left>
   <center><lane id="0" type="none"/></center>
   <right><lane id="-1" type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/></lane>
          <lane id="-2" type="driving"><width sOffset="0" a="0" b="0.07" c="0" d="0"/></lane></right>
  </laneSection></lanes>
 </road>
 <road id="2" length="200" junction="-1">
  <link><predecessor elementType="road" elementId="1" contactPoint="end"/></link>
  <planView><geometry s="0" x="100" y="0" hdg="0" length="200"><arc curvature="0.005"/></geometry></planView>
  <lanes><laneSection s="0">
   <left><lane id="1" type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/><link><predecessor id="1"/></link></lane></left>
   <center><lane id="0" type="none"/></center>
   <right><lane id="-1" type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/><link><predecessor id="-1"/></link></lane></right>
  </laneSection></lanes>
 </road>
</OpenDRIVE>
"""


def test_an_entity_drives_on_across_lane_sections_and_roads_with_its_road_coordinates(tmp_path: pathlib.Path) -> None:
    # road 1: 100 m straight, a lane -2 widening from its second lane section on; road 2 its successor, an arc
    (tmp_path / "road.xodr").write_text(TWO_ROADS)
    entities = {"Ego": entity({"LanePosition": {"roadId": "1", "laneId": -1, "s": 10}}, 20.0)}
    execute = [{"id": "W", "kind": "constraint", "action": "until", "params": {"expect": "Ego.road == 2 && Ego.s >= 100", "timeout": 12}}]
    case = write_case(tmp_path, "road.xodr", entities, timeout=12, execute=execute, expect="Ego.lane_id == -1 && abs(Ego.offset) < 0.05")
    report, signals, read = ticks(case, lambda ls: ls.vehicle.getRoadID("Ego"))
    assert report.verdict == "pass", report.message
    roads_seen = [s["Ego.road"] for s in signals]
    assert roads_seen[0] == 1 and roads_seen[-1] == 2 and sorted(set(roads_seen)) == [1, 2]
    assert len({r for r in read if not r.startswith(":")}) >= 3  # SUMO's edges: two sections of road 1, road 2
    # 90 m to road 1's end, then 100 m of road 2's reference line (its lane -1 is 1.75 m outside the arc's: longer)
    assert report.execute[0].end == pytest.approx((90 + 100 * (1 + 0.005 * 1.75)) / 20, abs=0.1)
