"""OpenSCENARIO files as other authors write them (docs/openscenario.md, "Tried on other authors'
scenarios"): each test is a small scenario of our own with the one trait that an ASAM, esmini or CARLA
example has and that the importer once refused or mistook - the schema reference on the root, an entity
placed relative to one declared after it, a distance to a point relative to an entity, a vehicle that
could tow a trailer and tows none, a CARLA town for a road. The files themselves are not copied here."""

from __future__ import annotations

import json
import pathlib

import pytest

from btgen_pytrees.errors import InvalidTestCase
from btgen_pytrees.openscenario import read_openscenario

ROAD = (pathlib.Path(__file__).parent.parent / "examples" / "openscenario" / "straight_3lanes.xodr").read_text()

CAR = """<Vehicle name="car" vehicleCategory="car">
      <BoundingBox><Center x="1.4" y="0" z="0.9"/><Dimensions width="2" length="5" height="1.8"/></BoundingBox>
      <Performance maxSpeed="70" maxAcceleration="5" maxDeceleration="9"/>{extra}</Vehicle>"""


def scenario(init: str, story: str = "", root: str = "<OpenSCENARIO>", ego: str = "", stop: str = "3") -> str:
    """Ego and Lead on the straight three-lane road of the examples; *init* places them."""
    return f"""<?xml version="1.0" encoding="utf-8"?>
{root}
  <FileHeader revMajor="1" revMinor="3" date="2024-01-01T00:00:00" description="test" author="me"/>
  <ParameterDeclarations/>
  <CatalogLocations/>
  <RoadNetwork><LogicFile filepath="road.xodr"/></RoadNetwork>
  <Entities>
    <ScenarioObject name="Ego">{CAR.format(extra=ego)}</ScenarioObject>
    <ScenarioObject name="Lead">{CAR.format(extra="")}</ScenarioObject>
  </Entities>
  <Storyboard>
    <Init><Actions>{init}</Actions></Init>
    {story}
    <StopTrigger><ConditionGroup><Condition name="end" delay="0" conditionEdge="none"><ByValueCondition>
      <SimulationTimeCondition value="{stop}" rule="greaterOrEqual"/></ByValueCondition></Condition></ConditionGroup></StopTrigger>
  </Storyboard>
</OpenSCENARIO>"""


def place(entity: str, position: str, speed: float) -> str:
    return f"""<Private entityRef="{entity}">
      <PrivateAction><TeleportAction><Position>{position}</Position></TeleportAction></PrivateAction>
      <PrivateAction><LongitudinalAction><SpeedAction><SpeedActionDynamics dynamicsShape="step" dynamicsDimension="time" value="0"/>
        <SpeedActionTarget><AbsoluteTargetSpeed value="{speed}"/></SpeedActionTarget></SpeedAction></LongitudinalAction></PrivateAction>
    </Private>"""


LANE = '<LanePosition roadId="1" laneId="-1" s="{s}" offset="0"/>'
BEHIND = '<RelativeLanePosition entityRef="{ref}" dLane="0" ds="{ds}"/>'
BOTH = place("Ego", LANE.format(s=10), 20) + place("Lead", BEHIND.format(ref="Ego", ds=40), 0)


def write(tmp_path: pathlib.Path, text: str) -> str:
    (tmp_path / "road.xodr").write_text(ROAD)
    (tmp_path / "s.xosc").write_text(text)
    return str(tmp_path / "s.xosc")


def problems(path: str) -> list[str]:
    with pytest.raises(InvalidTestCase) as info:
        read_openscenario(path)
    return [f"{p.pointer}: {p.message}" for p in info.value.problems]


def run(tmp_path: pathlib.Path, text: str) -> dict:
    from btgen_pytrees.cli import main
    pytest.importorskip("libsumo")
    path, report = write(tmp_path, text), tmp_path / "r.json"
    assert main(["run", path, "--json", str(report)]) in (0, 1)
    return json.loads(report.read_text())


def brake_when(condition: str) -> str:
    """A story whose event (Lead keeps standing: a step to 0) starts when the Ego's *condition* holds."""
    return f"""<Story name="S"><Act name="A">
  <ManeuverGroup name="G" maximumExecutionCount="1"><Actors selectTriggeringEntities="false"><EntityRef entityRef="Lead"/></Actors>
    <Maneuver name="M"><Event name="Near" priority="override">
      <Action name="Hold"><PrivateAction><LongitudinalAction><SpeedAction>
        <SpeedActionDynamics dynamicsShape="step" dynamicsDimension="time" value="0"/>
        <SpeedActionTarget><AbsoluteTargetSpeed value="0"/></SpeedActionTarget></SpeedAction></LongitudinalAction></PrivateAction></Action>
      <StartTrigger><ConditionGroup><Condition name="c" delay="0" conditionEdge="none"><ByEntityCondition>
        <TriggeringEntities triggeringEntitiesRule="any"><EntityRef entityRef="Ego"/></TriggeringEntities>
        <EntityCondition>{condition}</EntityCondition></ByEntityCondition></Condition></ConditionGroup></StartTrigger>
    </Event></Maneuver></ManeuverGroup>
  <StartTrigger><ConditionGroup><Condition name="t0" delay="0" conditionEdge="none"><ByValueCondition>
    <SimulationTimeCondition value="0" rule="greaterOrEqual"/></ByValueCondition></Condition></ConditionGroup></StartTrigger>
</Act></Story>"""


def test_the_schema_reference_every_asam_example_carries_is_no_unsupported_attribute(tmp_path):
    root = ('<OpenSCENARIO xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" '
            'xsi:noNamespaceSchemaLocation="../Schema/OpenSCENARIO.xsd">')  # fmt: skip
    doc = read_openscenario(write(tmp_path, scenario(BOTH, root=root)))
    assert list(doc["system"]["entities"]) == ["Ego", "Lead"]
    # an attribute of another namespace is still one the conversion does not read
    other = root.replace("xsi:noNamespaceSchemaLocation", 'xmlns:v="urn:vendor" v:colour="red" xsi:noNamespaceSchemaLocation')
    assert problems(write(tmp_path, scenario(BOTH, root=other))) == ["/OpenSCENARIO: unsupported attribute {urn:vendor}colour='red' of OpenSCENARIO"]


def test_an_entity_placed_relative_to_one_declared_after_it_is_placed_after_it(tmp_path):
    # ASAM's SlowPrecedingVehicle: the Ego 200 m behind A1, whose Private comes later in the Init
    init = place("Ego", BEHIND.format(ref="Lead", ds=-40), 20) + place("Lead", LANE.format(s=50), 10)
    doc = read_openscenario(write(tmp_path, scenario(init)))
    entities = doc["system"]["entities"]
    assert list(entities) == ["Lead", "Ego"]  # the SUMO system places them in this order
    assert entities["Ego"]["position"] == {"RelativeLanePosition": {"entityRef": "Lead", "dLane": 0, "ds": -40.0}}
    circle = place("Ego", BEHIND.format(ref="Lead", ds=-40), 20) + place("Lead", BEHIND.format(ref="Ego", ds=40), 10)
    assert problems(write(tmp_path, scenario(circle))) == [
        "/OpenSCENARIO/Storyboard/Init: entities 'Ego', 'Lead' are placed relative to each other in a circle"]


def test_a_distance_to_a_point_relative_to_an_entity_is_measured_from_that_entitys_view(tmp_path):
    point = '<Position><RelativeObjectPosition entityRef="Lead" dx="{dx}" dy="0"/></Position>'
    condition = '<DistanceCondition value="5" freespace="false" rule="lessThan">' + point.format(dx=-10) + "</DistanceCondition>"
    doc = read_openscenario(write(tmp_path, scenario(BOTH, brake_when(condition))))
    assert next(e for e in doc["execute"] if e["id"] == "Near")["when"] == \
        "(Lead.Ego.dx + 10) * (Lead.Ego.dx + 10) + (Lead.Ego.dy - 0) * (Lead.Ego.dy - 0) < 25"  # fmt: skip
    reach = '<ReachPositionCondition tolerance="2">' + point.format(dx=-10) + "</ReachPositionCondition>"
    doc = read_openscenario(write(tmp_path, scenario(BOTH, brake_when(reach))))
    assert next(e for e in doc["execute"] if e["id"] == "Near")["when"].endswith("<= 4")
    road = condition.replace('rule="lessThan"', 'rule="lessThan" coordinateSystem="road"').replace('dx="-10"', 'dx="0"')
    doc = read_openscenario(write(tmp_path, scenario(BOTH, brake_when(road))))
    assert next(e for e in doc["execute"] if e["id"] == "Near")["when"] == "Ego.Lead.ds * Ego.Lead.ds + Ego.Lead.dt * Ego.Lead.dt < 25"
    offset_in_road = road.replace('dx="0"', 'dx="3"')
    assert problems(write(tmp_path, scenario(BOTH, brake_when(offset_in_road))))[0].endswith(
        "a RelativeObjectPosition with dx or dy in road coordinates is not supported (dx=0, dy=0 is)")


def test_the_distance_to_a_point_behind_a_standing_car_triggers_when_the_ego_is_there(tmp_path):
    # the Ego (20 m/s from s = 10) comes within 5 m of the point 10 m behind the Lead's reference point
    # (s = 40) at s = 35: 25 m, 1.25 s. Had dx been taken the other way (s = 60) it would be 2.25 s.
    point = '<Position><RelativeObjectPosition entityRef="Lead" dx="-10" dy="0"/></Position>'
    condition = '<DistanceCondition value="5" freespace="false" rule="lessThan">' + point + "</DistanceCondition>"
    report = run(tmp_path, scenario(BOTH, brake_when(condition)))
    near = next(e for e in report["execute"] if e["id"] == "Near")
    assert near["start"] == pytest.approx(1.3, abs=1e-9)  # the first tick (0.1 s) at or after 1.25 s


def test_a_vehicle_that_could_tow_a_trailer_and_tows_none_is_read(tmp_path):
    # ASAM's 1.3 catalog gives car2 a TrailerHitch; esmini's car_white an empty Trailer reference
    hitch = '<TrailerHitch dx="-1.2"/><Trailer><EntityRef entityRef=""/></Trailer>'
    doc = read_openscenario(write(tmp_path, scenario(BOTH, ego=hitch)))
    assert doc["system"]["entities"]["Ego"]["length"] == 5
    towed = '<TrailerHitch dx="-1.2"/><Trailer><EntityRef entityRef="Lead"/></Trailer>'
    assert problems(write(tmp_path, scenario(BOTH, ego=towed))) == [
        "/OpenSCENARIO/Entities/ScenarioObject[@name='Ego']/Vehicle[@name='car']/Trailer: a towed Trailer ('Lead') is not supported"]


def test_a_carla_town_for_a_road_is_a_clear_exit_2(tmp_path, capsys):
    from btgen_pytrees.cli import main
    path = write(tmp_path, scenario(BOTH).replace('filepath="road.xodr"', 'filepath="Town04_Opt"'))
    assert main(["validate", path]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{path}: /OpenSCENARIO/RoadNetwork/LogicFile: road network 'Town04_Opt' not found") and \
        err.rstrip().endswith("a CARLA town (Town04) is a map inside CARLA: give its .xodr") and "Traceback" not in err  # fmt: skip


def test_coverage_counts_what_a_stopped_conversion_did_not_reach_as_not_reached(tmp_path, capsys):
    import jsonschema

    from btgen_pytrees.cli import main
    weather = """<GlobalAction><EnvironmentAction><Environment name="icy"><TimeOfDay animation="false" dateTime="2024-01-01T12:00:00"/>
      <RoadCondition frictionScaleFactor="0.5"/></Environment></EnvironmentAction></GlobalAction>"""
    write(tmp_path, scenario(weather + BOTH))
    assert main(["coverage", str(tmp_path), "--format", "json"]) == 1
    data = json.loads(capsys.readouterr().out)
    schema = json.loads((pathlib.Path(__file__).parent.parent / "schemas" / "coverage.schema.json").read_text())
    jsonschema.validate(data, schema)
    rows = {r["element"]: (r["supported"], r["unsupported"], r["unreached"]) for r in data["elements"]}
    # the conversion stopped at the RoadCondition (a friction it does not apply): it is unsupported, the
    # teleports after it were not reached - not "unsupported" - and the header and time of day before it were used
    assert rows["RoadCondition"] == (0, 1, 0) and rows["TimeOfDay"] == (1, 0, 0) and rows["EnvironmentAction"] == (1, 0, 0)
    assert rows["TeleportAction"] == (0, 0, 2) and rows["FileHeader"] == (1, 0, 0)
    assert data["summary"]["unreached"] == sum(1 for r in rows.values() if r[2])
    assert main(["coverage", str(tmp_path), "--format", "markdown"]) == 1
    table = capsys.readouterr().out
    assert "| element | occurrences | supported | not reached |" in table and "| `TeleportAction` | 2 | 0 | 2 |" in table


def test_a_named_object_controller_is_the_one_activate_controller_action_names(tmp_path):
    # ASAM's 1.3 EndOfTrafficJam: <ObjectController name="EgoMovementController"> and an
    # ActivateControllerAction objectControllerRef="EgoMovementController"
    controller = '</Vehicle><ObjectController name="Mover"><Controller name="External" controllerType="movement"/></ObjectController><Vehicle name="x">'
    activate = """<PrivateAction><ControllerAction><ActivateControllerAction objectControllerRef="{ref}" longitudinal="true" lateral="false"/>
      </ControllerAction></PrivateAction></Private>"""
    init = BOTH.replace("</Private>", activate.format(ref="Mover"), 1)
    text = scenario(init).replace("</Vehicle></ScenarioObject>", controller.split("<Vehicle")[0] + "</ScenarioObject>", 1)
    doc = read_openscenario(write(tmp_path, text))
    assert doc["system"]["entities"]["Ego"]["controller"] is True  # SUMO's driver model from time 0
    wrong = scenario(BOTH.replace("</Private>", activate.format(ref="Other"), 1)).replace(
        "</Vehicle></ScenarioObject>", controller.split("<Vehicle")[0] + "</ScenarioObject>", 1)
    assert problems(write(tmp_path, wrong)) == [
        "/OpenSCENARIO/Storyboard/Init/Actions/Private[@entityRef='Ego']/PrivateAction[3]/ControllerAction/ActivateControllerAction: "
        "objectControllerRef='Other' names no ObjectController of 'Ego'"]


def test_the_pytest_plugin_names_the_scenario_a_distributions_problem_is_in(tmp_path):
    # ASAM's SlowPrecedingVehicleDeterministicParameterSet.xosc: the problem is in the scenario it names;
    # `/OpenSCENARIO/Storyboard/...` is no place in the distribution (the CLI names the scenario too)
    import subprocess
    import sys
    weather = "<GlobalAction>" + environment(friction="0.5") + "</GlobalAction>"
    write(tmp_path, scenario(weather + BOTH).replace("<ParameterDeclarations/>", '<ParameterDeclarations><ParameterDeclaration name="V" parameterType="double" value="1"/></ParameterDeclarations>'))
    (tmp_path / "d.xosc").write_text("""<?xml version="1.0" encoding="utf-8"?><OpenSCENARIO>
  <FileHeader revMajor="1" revMinor="3" date="2024-01-01T00:00:00" description="d" author="me"/>
  <ParameterValueDistribution><ScenarioFile filepath="s.xosc"/><Deterministic><DeterministicSingleParameterDistribution parameterName="V">
    <DistributionSet><Element value="1"/><Element value="2"/></DistributionSet></DeterministicSingleParameterDistribution></Deterministic>
  </ParameterValueDistribution></OpenSCENARIO>""")
    done = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:randomly", "-p", "no:cacheprovider",
                           "--btgen-files=d.xosc"], cwd=tmp_path, capture_output=True, text=True, timeout=300)  # fmt: skip
    assert done.returncode != 0
    where = "/OpenSCENARIO/Storyboard/Init/Actions/GlobalAction/EnvironmentAction/Environment[@name='sunny']/RoadCondition: frictionScaleFactor 0.5"
    assert f"s.xosc: {where}" in done.stdout and f"d.xosc: {where}" not in done.stdout, done.stdout


def test_the_ego_reaching_the_end_of_its_road_ends_the_run_whatever_the_phase_of_its_last_step(tmp_path):
    # esmini's alks_r157_cut_in_quick_brake.xosc on straight_500m.xodr: the Ego's front came 2.08 m from
    # the end at 20 m/s, more than one step (2.0 m), and SUMO took it off the road at the next step - its
    # front within 0.1 m of the end (SUMO arrives a vehicle there) - before `Ego.end_of_road` ever held:
    # the run went on without it to an error. Here the front (reference point + 3.9 m) is 2.05 m from the
    # end of the 2000 m road at 0.9 s and would be 0.05 m from it at 1.0 s: the run ends at 0.9 s.
    init = place("Ego", LANE.format(s=1976.05), 20) + place("Lead", LANE.format(s=10), 0)
    report = run(tmp_path, scenario(init, stop="30"))
    verdicts = {o["id"]: o["verdict"] for o in report["oracles"]}
    assert report["verdict"] == "fail" and verdicts["stop_trigger"] == "fail", report["verdict"]
    assert report["duration"] == pytest.approx(0.9, abs=1e-9)


WEATHER = """<Environment name="{name}"><TimeOfDay animation="false" dateTime="2024-01-01T12:00:00"/>
  <Weather fractionalCloudCover="zeroOktas"><Sun illuminance="100000" azimuth="0" elevation="1.57"/><Fog visualRange="{fog}"/>
    <Precipitation precipitationType="rain" precipitationIntensity="2"/></Weather>
  <RoadCondition frictionScaleFactor="{friction}"/></Environment>"""


def environment(name: str = "sunny", fog: str = "100000", friction: str = "1.0") -> str:
    return f"<EnvironmentAction>{WEATHER.format(name=name, fog=fog, friction=friction)}</EnvironmentAction>"


def test_an_environment_action_is_read_and_changes_nothing_a_sumo_run_models(tmp_path):
    # 5 of ASAM's 7 1.3 examples and esmini's cut-in set the weather in the Init: SUMO models no light,
    # weather or fog (nor do esmini's physics). Read in the Init and in an event, the run is the same run.
    condition = '<SpeedCondition value="15" rule="greaterThan"/>'
    plain = scenario(BOTH, brake_when(condition), stop="1.5")
    init = "<GlobalAction>" + environment(fog="$Fog") + "</GlobalAction>" + BOTH
    story = brake_when(condition).replace('<Action name="Hold">', f'<Action name="Fog"><GlobalAction>{environment("foggy", "30")}</GlobalAction></Action><Action name="Hold">')
    foggy = scenario(init, story, stop="1.5").replace("<ParameterDeclarations/>", '<ParameterDeclarations><ParameterDeclaration name="Fog" parameterType="double" value="50"/></ParameterDeclarations>')
    doc = read_openscenario(write(tmp_path, foggy))
    fog = next(e for e in doc["execute"] if e["name"].startswith("Action Fog"))
    assert fog["name"] == "Action Fog (Environment foggy: read, no effect on a SUMO run)" and fog["params"] == {"duration": 0}
    (tmp_path / "a").mkdir(), (tmp_path / "b").mkdir()
    first, second = run(tmp_path / "a", plain), run(tmp_path / "b", foggy)
    assert second["verdict"] == first["verdict"] == "pass" and second["duration"] == first["duration"] == pytest.approx(1.5, abs=0.11)
    verdicts = [{o["id"]: o["verdict"] for o in r["oracles"]} for r in (first, second)]
    assert verdicts[0] == verdicts[1] and "completed-Near" in verdicts[0]
    starts = [{e["id"]: (e.get("start"), e.get("end")) for e in r["execute"] if e["id"] in ("Near", "Hold")} for r in (first, second)]
    assert starts[0] == starts[1] and starts[0]["Near"][0] is not None


def test_a_road_friction_other_than_1_is_refused_at_its_element(tmp_path):
    # a friction scale changes braking, which SUMO's vehicles would not do: refused, not silently dropped
    init = "<GlobalAction>" + environment(friction="0.5") + "</GlobalAction>" + BOTH
    assert problems(write(tmp_path, scenario(init))) == [
        "/OpenSCENARIO/Storyboard/Init/Actions/GlobalAction/EnvironmentAction/Environment[@name='sunny']/RoadCondition: "
        "frictionScaleFactor 0.5 is not supported: SUMO's vehicles brake and accelerate as on a dry road (only 1 is, which changes nothing)"]
    story = brake_when('<SpeedCondition value="15" rule="greaterThan"/>').replace(
        '<Action name="Hold">', f'<Action name="Ice"><GlobalAction>{environment("icy", friction="0.2")}</GlobalAction></Action><Action name="Hold">')
    assert problems(write(tmp_path, scenario(BOTH, story)))[0].endswith(
        "/Action[@name='Ice']/GlobalAction/EnvironmentAction/Environment[@name='icy']/RoadCondition: "
        "frictionScaleFactor 0.2 is not supported: SUMO's vehicles brake and accelerate as on a dry road (only 1 is, which changes nothing)")
    unknown = scenario("<GlobalAction>" + environment().replace("<TimeOfDay", "<Smog level='3'/><TimeOfDay") + "</GlobalAction>" + BOTH)
    assert problems(write(tmp_path, unknown)) == [
        "/OpenSCENARIO/Storyboard/Init/Actions/GlobalAction/EnvironmentAction/Environment[@name='sunny']/Smog: "
        "unsupported element Smog: not converted (see docs/openscenario.md)"]


def test_coverage_says_an_environment_is_read_with_no_effect(tmp_path, capsys):
    import jsonschema

    from btgen_pytrees.cli import main
    write(tmp_path, scenario("<GlobalAction>" + environment() + "</GlobalAction>" + BOTH))
    assert main(["coverage", str(tmp_path), "--format", "json"]) == 0
    data = json.loads(capsys.readouterr().out)
    jsonschema.validate(data, json.loads((pathlib.Path(__file__).parent.parent / "schemas" / "coverage.schema.json").read_text()))
    flagged = sorted(r["element"] for r in data["elements"] if r.get("no_effect"))
    assert flagged == ["Environment", "EnvironmentAction", "Fog", "Precipitation", "RoadCondition", "Sun", "TimeOfDay", "Weather"]
    assert main(["coverage", str(tmp_path)]) == 0
    assert capsys.readouterr().out.rstrip().endswith(
        "read, no effect on a SUMO run (light, weather, road surface: docs/openscenario.md): " + ", ".join(flagged))


def events(*specs: tuple[str, str, str, str]) -> str:
    """One maneuver of the Lead's events: (name, priority, StartTrigger body, action's speed dynamics + target)."""
    body = ""
    for name, priority, trigger, speed in specs:
        body += f"""<Event name="{name}" priority="{priority}"><Action name="{name}A"><PrivateAction><LongitudinalAction><SpeedAction>
        {speed}</SpeedAction></LongitudinalAction></PrivateAction></Action><StartTrigger>{trigger}</StartTrigger></Event>"""
    return f"""<Story name="S"><Act name="A">
  <ManeuverGroup name="G" maximumExecutionCount="1"><Actors selectTriggeringEntities="false"><EntityRef entityRef="Lead"/></Actors>
    <Maneuver name="M">{body}</Maneuver></ManeuverGroup>
  <StartTrigger><ConditionGroup><Condition name="t0" delay="0" conditionEdge="none"><ByValueCondition>
    <SimulationTimeCondition value="0" rule="greaterOrEqual"/></ByValueCondition></Condition></ConditionGroup></StartTrigger>
</Act></Story>"""


def at(t: float) -> str:
    return f"""<ConditionGroup><Condition name="t" delay="0" conditionEdge="none"><ByValueCondition>
      <SimulationTimeCondition value="{t}" rule="greaterOrEqual"/></ByValueCondition></Condition></ConditionGroup>"""


def linear(to: float, seconds: float = 1) -> str:
    return (f'<SpeedActionDynamics dynamicsShape="linear" dynamicsDimension="time" value="{seconds}"/>'
            f'<SpeedActionTarget><AbsoluteTargetSpeed value="{to}"/></SpeedActionTarget>')  # fmt: skip


# esmini's acc-test.xosc: five `overwrite` events in one maneuver, each stopping the one before
FIVE = events(*((f"E{k}", "overwrite", at(0.5 * k if k < 5 else 4.0), linear(k)) for k in range(1, 6)))


def test_override_events_write_their_stops_to_signals_of_their_own_so_validate_does_not_warn(tmp_path, capsys):
    # docs/openscenario.md "Stop": one stop signal per stopping entry and element; only a skip event's
    # branches may warn. (esmini's acc-test once printed 25 "does not order the two" warnings.)
    from btgen_pytrees.cli import main
    pytest.importorskip("libsumo")  # validating a SUMO case converts its road with SUMO's netconvert
    path = write(tmp_path, scenario(BOTH, FIVE, stop="5"))
    assert main(["validate", path]) == 0
    out, err = capsys.readouterr()
    assert out.startswith(f"{path}: ok:") and "warning" not in err, err
    doc = read_openscenario(path)
    writers: dict[str, list[str]] = {}
    for e in doc["execute"]:
        if e["action"] == "set" and e["params"]["signal"].startswith("stopped_"):
            writers.setdefault(e["params"]["signal"], []).append(e["id"])
    # each of the five stops the four others if they run: 20 stop signals, one writer each
    assert len(writers) == 20 and all(len(w) == 1 for w in writers.values()), writers


def test_a_stop_of_a_running_event_and_its_spare_both_succeed_and_a_stop_of_a_finished_one_loses(tmp_path):
    # docs/openscenario.md "Stop": the `set` of the stop signal waits for `when` the element runs; its
    # racing `wait` 0 s (the spare) always succeeds on the tick the stopping event starts. So on a running
    # element both succeed on that tick (a race in which both win); on an element not running the spare wins
    # and the `set` is stopped. E4 runs from 2.0 s to 3.0 s; E5 starts at 4.0 s.
    report = run(tmp_path, scenario(BOTH.replace('ds="40"', 'ds="200"'), FIVE, stop="5.5"))
    status = {e["id"]: (e["status"], e["start"], e["end"]) for e in report["execute"]}
    assert status["E2-stops-E1"] == ("success", 1.0, 1.0) and status["E2-spares-E1"] == ("success", 1.0, 1.0)
    assert status["E1A"][0] == "stopped" and status["E1A"][2] == pytest.approx(1.1)
    assert status["E5-spares-E4"] == ("success", 4.0, 4.0) and status["E5-stops-E4"][0] == "stopped"
    assert status["E4A"][0] == "success" and status["E4A"][2] == pytest.approx(3.0, abs=0.11)
    assert report["verdict"] == "pass", report["message"]


def test_an_event_with_an_empty_start_trigger_starts_with_its_maneuver(tmp_path):
    # esmini's distance_test.xosc: `<StartTrigger/>` (no ConditionGroup) on an event; read as esmini runs
    # it (docs/openscenario.md "Triggers and conditions"): no condition, so the event starts on the tick
    # its maneuver does. Here the act waits for 0.5 s; the event with a trigger of its own for 1.0 s.
    story = events(("Now", "parallel", "", linear(2)), ("Later", "parallel", at(1.0), linear(3))).replace(
        'value="0" rule="greaterOrEqual"/></ByValueCondition></Condition></ConditionGroup></StartTrigger>\n</Act>',
        'value="0.5" rule="greaterOrEqual"/></ByValueCondition></Condition></ConditionGroup></StartTrigger>\n</Act>')
    doc = read_openscenario(write(tmp_path, scenario(BOTH, story)))
    now = next(e for e in doc["execute"] if e["id"] == "Now")
    assert "when" not in now and now["after"] == ["M"]
    report = run(tmp_path, scenario(BOTH.replace('ds="40"', 'ds="200"'), story))
    start = {e["id"]: e["start"] for e in report["execute"]}
    assert start["A"] == start["M"] == start["Now"] == start["NowA"] == pytest.approx(0.5) and start["Later"] == pytest.approx(1.0)


def test_an_entity_name_with_a_space_is_mapped_to_a_signal_name_the_expressions_can_read(tmp_path):
    # ASAM's SimpleOvertake names its cars "Vehicle 1", "Vehicle 2": a signal `Vehicle 1.speed` could not be
    # read by an expression, so the entity's signals (and its SUMO vehicle) carry `Vehicle_1`
    from btgen_pytrees.openscenario.scenario import signal_names
    assert signal_names(["Vehicle 1", "Vehicle_1", "and", "sim", "2nd car", "Ego", "Fahrzeug-ä"]) == {
        "Vehicle 1": "Vehicle_1_2", "Vehicle_1": "Vehicle_1", "and": "and_", "sim": "sim_", "2nd car": "E_2nd_car",
        "Ego": "Ego", "Fahrzeug-ä": "Fahrzeug__"}
    text = scenario(BOTH, brake_when('<SpeedCondition value="15" rule="greaterThan"/>'), stop="1.5")
    text = text.replace('"Lead"', '"Lead car"').replace('"Ego"', '"my ego"')
    doc = read_openscenario(write(tmp_path, text))
    assert list(doc["system"]["entities"]) == ["my_ego", "Lead_car"]
    assert doc["system"]["entities"]["Lead_car"]["position"] == {"RelativeLanePosition": {"entityRef": "my_ego", "dLane": 0, "ds": 40.0}}
    near = next(e for e in doc["execute"] if e["id"] == "Near")
    assert near["when"] == "my_ego.speed > 15"
    report = run(tmp_path, text.replace("</Storyboard>", "</Storyboard>"))
    start = {e["id"]: e["start"] for e in report["execute"]}
    assert report["verdict"] == "pass" and start["Hold"] == pytest.approx(0.0)  # my_ego.speed read from SUMO: 20 m/s > 15
    assert problems(write(tmp_path, text.replace('<EntityRef entityRef="Lead car"/>', '<EntityRef entityRef="Lead_car"/>'))) == [
        "/OpenSCENARIO/Storyboard/Story[@name='S']/Act[@name='A']/ManeuverGroup[@name='G']/Actors/EntityRef: "
        "entityRef='Lead_car' names no entity (entities: my ego, Lead car)"]


def test_coverage_says_a_distributions_scenario_does_not_convert(tmp_path, capsys):
    # ASAM's SlowPrecedingVehicle parameter sets: coverage said "ok" for a distribution whose scenario stops
    from btgen_pytrees.cli import main
    declared = '<ParameterDeclarations><ParameterDeclaration name="V" parameterType="double" value="1"/></ParameterDeclarations>'
    write(tmp_path, scenario("<GlobalAction>" + environment(friction="0.5") + "</GlobalAction>" + BOTH).replace("<ParameterDeclarations/>", declared))
    (tmp_path / "d.xosc").write_text("""<?xml version="1.0" encoding="utf-8"?><OpenSCENARIO>
  <FileHeader revMajor="1" revMinor="3" date="2024-01-01T00:00:00" description="d" author="me"/>
  <ParameterValueDistribution><ScenarioFile filepath="s.xosc"/><Deterministic><DeterministicSingleParameterDistribution parameterName="V">
    <DistributionSet><Element value="1"/><Element value="2"/></DistributionSet></DeterministicSingleParameterDistribution></Deterministic>
  </ParameterValueDistribution></OpenSCENARIO>""")
    assert main(["coverage", str(tmp_path), "--format", "json"]) == 1
    files = {f["file"]: f for f in json.loads(capsys.readouterr().out)["files"]}
    where = "/OpenSCENARIO/Storyboard/Init/Actions/GlobalAction/EnvironmentAction/Environment[@name='sunny']/RoadCondition: frictionScaleFactor 0.5"
    assert files["s.xosc"]["problems"][0].startswith(where)
    assert not files["d.xosc"]["converts"] and files["d.xosc"]["problems"][0].startswith("s.xosc: " + where)
    write(tmp_path, scenario(BOTH).replace("<ParameterDeclarations/>", declared))  # the scenario fixed: both convert
    assert main(["coverage", str(tmp_path)]) == 0
    assert "d.xosc" in capsys.readouterr().out


def test_a_name_written_like_an_expression_is_a_name(tmp_path):
    # esmini's cut-in.xosc names a condition "${BrakeCondition_HWT + _ + $HeadwayTime_Brake}": a name is the
    # XSD's String (a $parameter or any text); expressions are numbers and booleans - it is read as text
    story = brake_when('<SpeedCondition value="15" rule="greaterThan"/>').replace('<Condition name="c"', '<Condition name="${Brake_HWT + _ + $V}"')
    story = story.replace('<Event name="Near"', '<Event name="$EventName"')
    declared = ('<ParameterDeclarations><ParameterDeclaration name="V" parameterType="double" value="1"/>'
                '<ParameterDeclaration name="EventName" parameterType="string" value="Near"/></ParameterDeclarations>')  # fmt: skip
    doc = read_openscenario(write(tmp_path, scenario(BOTH, story).replace("<ParameterDeclarations/>", declared)))
    assert next(e for e in doc["execute"] if e["id"] == "Near")["when"] == "Ego.speed > 15"
    assert problems(write(tmp_path, scenario(BOTH, story.replace('"$EventName"', '"$Nobody"')).replace("<ParameterDeclarations/>", declared)))[0].endswith(
        "unknown parameter '$Nobody' (declared: EventName, V)")


def test_an_environment_from_a_catalog_is_read_and_its_friction_checked_with_its_parameters(tmp_path):
    (tmp_path / "envs").mkdir()
    (tmp_path / "envs" / "e.xosc").write_text(f"""<?xml version="1.0" encoding="utf-8"?><OpenSCENARIO>
  <FileHeader revMajor="1" revMinor="3" date="2024-01-01T00:00:00" description="c" author="me"/>
  <Catalog name="Envs">{WEATHER.format(name="wet", fog="500", friction="$Mu").replace(
        '<TimeOfDay', '<ParameterDeclarations><ParameterDeclaration name="Mu" parameterType="double" value="1"/></ParameterDeclarations><TimeOfDay')}
  </Catalog></OpenSCENARIO>""")
    locations = '<CatalogLocations><EnvironmentCatalog><Directory path="envs"/></EnvironmentCatalog></CatalogLocations>'
    reference = ('<GlobalAction><EnvironmentAction><CatalogReference catalogName="Envs" entryName="wet">{}</CatalogReference>'
                 '</EnvironmentAction></GlobalAction>')  # fmt: skip
    text = scenario(reference.format("") + BOTH).replace("<CatalogLocations/>", locations)
    assert list(read_openscenario(write(tmp_path, text))["system"]["entities"]) == ["Ego", "Lead"]
    icy = '<ParameterAssignments><ParameterAssignment parameterRef="Mu" value="0.3"/></ParameterAssignments>'
    assert problems(write(tmp_path, scenario(reference.format(icy) + BOTH).replace("<CatalogLocations/>", locations))) == [
        f"/OpenSCENARIO/Catalog[@name='Envs']/Environment[@name='wet']/RoadCondition: {tmp_path / 'envs' / 'e.xosc'}: frictionScaleFactor 0.3 is not supported: "
        "SUMO's vehicles brake and accelerate as on a dry road (only 1 is, which changes nothing)"]


def test_an_event_whose_condition_group_needs_an_edge_starts_on_the_tick_the_group_holds(tmp_path):
    # ASAM's SimpleOvertake: "Turn right" waits for a rising RelativeDistanceCondition AND a time condition.
    # The rising condition is a latch entry; the event started one tick after the latch was set (it was
    # ticked before its latch). Here the group holds at 0.5 s (time > 0.45 rising, and time > 0.2).
    rising = at(0.45).replace('conditionEdge="none"', 'conditionEdge="rising"').replace('rule="greaterOrEqual"', 'rule="greaterThan"')
    group = rising.replace("</ConditionGroup>", '''<Condition name="u" delay="0" conditionEdge="none"><ByValueCondition>
      <SimulationTimeCondition value="0.2" rule="greaterThan"/></ByValueCondition></Condition></ConditionGroup>''')
    report = run(tmp_path, scenario(BOTH.replace('ds="40"', 'ds="200"'), events(("Both", "parallel", group, linear(2))), stop="1"))
    start = {e["id"]: e["start"] for e in report["execute"]}
    assert start["Both-t"] == pytest.approx(0.5) and start["Both"] == pytest.approx(0.5) and start["BothA"] == pytest.approx(0.5)
