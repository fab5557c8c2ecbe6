"""The storyboard's execution semantics (ASAM OpenSCENARIO XML 1.3, clause 8.3-8.4), run on SUMO.

Each test converts a small scenario, runs it on SUMO (two standing cars on a straight road, so nothing
moves but time) and reads what happened tick by tick from the run's signals: the state signals of the
storyboard elements (0 standby, 1 running, 2 complete), the entries' statuses and the variables the
events set. docs/openscenario.md states the rules with their clauses.
"""

from __future__ import annotations

import csv
import json
import os
import pathlib
import shutil

import pytest

from btgen_pytrees.errors import InvalidTestCase
from btgen_pytrees.openscenario import read_openscenario

ROAD = (pathlib.Path(__file__).parent.parent / "examples" / "openscenario" / "straight_3lanes.xodr").read_text()

pytestmark = pytest.mark.skipif(os.environ.get("CI") != "true" and shutil.which("netconvert") is None,
                                reason="the sumo extra is not installed (a road case runs netconvert and SUMO)")


def scenario(stories: str, stop: str = "5", variables: str = "") -> str:
    """Two standing cars, the *stories*, variables v, w (0) and *variables*, a StopTrigger at *stop* s
    (or the StopTrigger element given)."""
    trigger = stop if stop.startswith("<") else f"""<StopTrigger><ConditionGroup><Condition name="end" delay="0" conditionEdge="none">
      <ByValueCondition><SimulationTimeCondition value="{stop}" rule="greaterOrEqual"/></ByValueCondition></Condition></ConditionGroup></StopTrigger>"""
    return f"""<?xml version="1.0" encoding="utf-8"?>
<OpenSCENARIO>
  <FileHeader revMajor="1" revMinor="2" date="2024-01-01T00:00:00" description="semantics" author="me"/>
  <ParameterDeclarations/>
  <VariableDeclarations><VariableDeclaration name="v" variableType="double" value="0"/>
    <VariableDeclaration name="w" variableType="double" value="0"/>{variables}</VariableDeclarations>
  <CatalogLocations/>
  <RoadNetwork><LogicFile filepath="road.xodr"/></RoadNetwork>
  <Entities>
    <ScenarioObject name="Ego"><Vehicle name="car" vehicleCategory="car">
      <BoundingBox><Center x="1.4" y="0" z="0.9"/><Dimensions width="2" length="5" height="1.8"/></BoundingBox>
      <Performance maxSpeed="70" maxAcceleration="5" maxDeceleration="9"/></Vehicle></ScenarioObject>
    <ScenarioObject name="Lead"><Vehicle name="car" vehicleCategory="car">
      <BoundingBox><Center x="1.4" y="0" z="0.9"/><Dimensions width="2" length="5" height="1.8"/></BoundingBox>
      <Performance maxSpeed="70" maxAcceleration="5" maxDeceleration="9"/></Vehicle></ScenarioObject>
  </Entities>
  <Storyboard>
    <Init><Actions>
      <Private entityRef="Ego"><PrivateAction><TeleportAction><Position>
        <LanePosition roadId="1" laneId="-1" s="10" offset="0"/></Position></TeleportAction></PrivateAction></Private>
      <Private entityRef="Lead"><PrivateAction><TeleportAction><Position>
        <LanePosition roadId="1" laneId="-1" s="60" offset="0"/></Position></TeleportAction></PrivateAction></Private>
    </Actions></Init>
    {stories}
    {trigger}
  </Storyboard>
</OpenSCENARIO>"""


def at_time(rule: str, value: float) -> str:
    return f"""<Condition name="t{value:g}" delay="0" conditionEdge="none"><ByValueCondition>
      <SimulationTimeCondition value="{value}" rule="{rule}"/></ByValueCondition></Condition>"""


def variable_is(name: str, value: float, edge: str = "none") -> str:
    return f"""<Condition name="{name}{value:g}" delay="0" conditionEdge="{edge}"><ByValueCondition>
      <VariableCondition variableRef="{name}" value="{value}" rule="equalTo"/></ByValueCondition></Condition>"""


def state_is(kind: str, ref: str, state: str, edge: str = "none") -> str:
    return f"""<Condition name="{ref}_{state}" delay="0" conditionEdge="{edge}"><ByValueCondition>
      <StoryboardElementStateCondition storyboardElementType="{kind}" storyboardElementRef="{ref}" state="{state}"/>
    </ByValueCondition></Condition>"""


def trigger(*conditions: str) -> str:
    return f"<StartTrigger><ConditionGroup>{''.join(conditions)}</ConditionGroup></StartTrigger>"


def set_var(action: str, name: str, value: float) -> str:
    return f"""<Action name="{action}"><GlobalAction><VariableAction variableRef="{name}"><SetAction value="{value}"/>
      </VariableAction></GlobalAction></Action>"""


def hold(action: str, seconds: float) -> str:
    """An action that runs *seconds*: Lead keeps its speed (0) by a linear SpeedAction of that duration."""
    return f"""<Action name="{action}"><PrivateAction><LongitudinalAction><SpeedAction>
      <SpeedActionDynamics dynamicsShape="linear" dynamicsDimension="time" value="{seconds}"/>
      <SpeedActionTarget><AbsoluteTargetSpeed value="0"/></SpeedActionTarget></SpeedAction></LongitudinalAction></PrivateAction></Action>"""


def event(name: str, body: str, start: str = "", priority: str = "parallel", count: int = 1) -> str:
    return f'<Event name="{name}" priority="{priority}" maximumExecutionCount="{count}">{body}{start}</Event>'


def story(name: str, events: str, count: int = 1) -> str:
    return f"""<Story name="S{name}"><Act name="A{name}">
      <ManeuverGroup name="G{name}" maximumExecutionCount="{count}"><Actors selectTriggeringEntities="false"><EntityRef entityRef="Lead"/></Actors>
        <Maneuver name="M{name}">{events}</Maneuver></ManeuverGroup>
      {trigger(at_time("greaterOrEqual", 0))}</Act></Story>"""


def switches(*changes: tuple[float, str, float]) -> str:
    """A story whose events set variables at given times: ``(time, variable, value)``."""
    return story("switch", "".join(event(f"set_{name}_{k}", set_var(f"do_{name}_{k}", name, value), trigger(at_time("greaterOrEqual", t)))
                                   for k, (t, name, value) in enumerate(changes)))  # fmt: skip


def run(tmp_path: pathlib.Path, text: str) -> tuple[dict, list[dict[str, str]]]:
    """Run the scenario on SUMO: (the JSON report, the signals tick by tick)."""
    from btgen_pytrees.cli import main
    pytest.importorskip("libsumo")
    (tmp_path / "road.xodr").write_text(ROAD)
    path = tmp_path / "s.xosc"
    path.write_text(text)
    report, signals = tmp_path / "r.json", tmp_path / "s.csv"
    assert main(["run", str(path), "--json", str(report), "--signals-out", str(signals)]) in (0, 1)
    return json.loads(report.read_text()), list(csv.DictReader(signals.open()))


def series(rows: list[dict[str, str]], column: str) -> list[tuple[float, float]]:
    """The changes of the number *column*: (time, value) where it differs from the row before."""
    out: list[tuple[float, float]] = []
    for row in rows:
        value = float({"true": 1, "false": 0}.get(row[column], row[column]))  # type: ignore[arg-type]
        if not out or out[-1][1] != value:
            out.append((round(float(row["time"]), 6), value))
    return out


def statuses(report: dict) -> dict[str, dict]:
    return {e["id"]: e for e in report["execute"]}


def verdicts(report: dict) -> dict[str, str]:
    return {o["id"]: o["verdict"] for o in report["oracles"]}


# -- 8.4.2.1: an event's executions ----------------------------------------------------------------

def test_an_event_is_in_standby_between_executions_and_may_run_fewer_times(tmp_path):
    """maximumExecutionCount 3: the event runs each time its trigger holds while it is in standby; between
    executions it is standby (0), not running; run twice of three, it is standby at the end, not a failure."""
    pulse = event("Pulse", hold("Hold", 0.5), trigger(variable_is("v", 1)), count=3)
    watch = story("watch", event("Watch", set_var("mark", "w", 1), trigger(state_is("event", "Pulse", "standbyState"), at_time("greaterThan", 2))))
    text = scenario(switches((1, "v", 1), (1.2, "v", 0), (3, "v", 1), (3.2, "v", 0)) + story("p", pulse) + watch)
    report, rows = run(tmp_path, text)
    # (-1 before its maneuver starts, on tick 0: a condition reads its standbyState)
    assert series(rows, "state_event_Pulse") == [(0.0, 0), (1.0, 1), (1.5, 0), (3.0, 1), (3.5, 0)]
    ids = statuses(report)
    runs = [e for e in report["execute"] if e["name"].startswith("Action Hold")]
    assert [(e["status"], e["start"]) for e in runs] == [("success", 1.0), ("success", 3.0), ("not-started", None)]
    assert series(rows, "var_w") == [(0.0, 0), (2.1, 1)]  # standbyState between the executions (8.3)
    assert verdicts(report)["completed-Pulse"] == "pass" and report["verdict"] == "pass"
    assert ids["Pulse"]["name"] == "Event Pulse (1 of 3)"


def test_a_maneuver_group_runs_its_maximum_execution_count_in_a_row(tmp_path):
    """maximumExecutionCount 2 of a ManeuverGroup: its second execution starts when the first is over (8.3.2)
    and waits for its events' triggers again; the group is standby between executions, complete after both."""
    text = scenario(switches((1, "v", 1), (1.2, "v", 0), (3, "v", 1)) + story("g", event("Go", hold("Run", 0.5), trigger(variable_is("v", 1))), count=2))
    report, rows = run(tmp_path, text)
    runs = [e for e in report["execute"] if e["name"].startswith("Action Run")]
    assert [(e["status"], e["start"], e["end"]) for e in runs] == [("success", 1.0, 1.5), ("success", 3.0, 3.5)]
    state = series(rows, "state_event_Go")
    assert state == [(0.0, 0), (1.0, 1), (1.5, 0), (3.0, 1), (3.5, 2)]  # standby again in the 2nd execution
    assert report["verdict"] == "pass"
    doc = read_openscenario(str(tmp_path / "s.xosc"))
    names = [e["name"] for e in doc["execute"] if e["name"].startswith("ManeuverGroup Gg")]
    assert names == ["ManeuverGroup Gg (1 of 2)", "ManeuverGroup Gg (1 of 2) over", "ManeuverGroup Gg (2 of 2)", "ManeuverGroup Gg (2 of 2) over"]


# -- 8.4.2.2: priorities ---------------------------------------------------------------------------

def test_a_skip_event_triggered_while_another_runs_is_skipped_not_delayed(tmp_path):
    """priority skip: triggered while another event of its maneuver runs, the event does not start; the skip
    counts as an execution (8.4.2.1): with one execution it is complete, with two it waits for its trigger again
    (here its next rising edge: a trigger that still holds would skip it again on the same tick)."""
    events = (event("Long", hold("LongHold", 1), trigger(at_time("greaterOrEqual", 1)))
              + event("Once", set_var("once", "w", 1), trigger(variable_is("v", 1)), priority="skip")
              + event("Twice", hold("TwiceHold", 0.2), trigger(variable_is("v", 1, "rising")), priority="skip", count=2))
    seen = story("seen", event("Saw", set_var("saw", "x", 1), trigger(state_is("event", "Once", "skipTransition"))))
    text = scenario(switches((1.5, "v", 1), (1.7, "v", 0), (3, "v", 1)) + story("k", events) + seen,
                    variables='<VariableDeclaration name="x" variableType="double" value="0"/>')
    report, rows = run(tmp_path, text)
    ids = {e["name"]: e for e in report["execute"]}
    assert ids["Action once"]["status"] == "not-started"  # skipped at 1.5 s (Long runs until 2 s), not started when Long ended
    assert series(rows, "var_w") == [(0.0, 0)]
    assert series(rows, "state_event_Once") == [(0.0, 0), (1.5, 2)]  # skipTransition to completeState
    assert series(rows, "var_x") == [(0.0, 0), (1.5, 1)]  # the skipTransition, seen by a trigger
    twice = [e for e in report["execute"] if e["name"].startswith("Action TwiceHold")]
    assert [(e["status"], e["start"]) for e in twice] == [("not-started", None), ("success", 3.0)]
    assert series(rows, "state_event_Twice") == [(0.0, 0), (3.0, 1), (3.2, 2)]
    assert report["verdict"] == "pass"


def test_an_overridden_event_and_a_stopped_acts_elements_are_complete_by_a_stop_transition(tmp_path):
    """8.4.2: an event overridden while it runs, and what a stopped Act holds, move to completeState with a
    stopTransition (the default criterion passes them); an event in standby is not overridden."""
    events = (event("Slow", hold("SlowHold", 3), trigger(at_time("greaterOrEqual", 1)))
              + event("Idle", set_var("idle", "w", 1), trigger(variable_is("v", 1)))
              + event("Urgent", set_var("urgent", "v", 2), trigger(at_time("greaterOrEqual", 2)), priority="override"))
    act_stop = f"<StopTrigger><ConditionGroup>{at_time('greaterOrEqual', 3)}</ConditionGroup></StopTrigger>"
    stopped = story("t", event("Later", hold("LaterHold", 5), trigger(at_time("greaterOrEqual", 1)))
                    + event("Never", set_var("never", "w", 2), trigger(variable_is("v", 9)))).replace("</Act>", act_stop + "</Act>")
    seen = story("seen", event("Saw", set_var("saw", "x", 1), trigger(state_is("event", "Slow", "stopTransition"))))
    text = scenario(story("o", events) + stopped + seen, variables='<VariableDeclaration name="x" variableType="double" value="0"/>')
    report, rows = run(tmp_path, text)
    by_name = {e["name"]: e for e in report["execute"]}
    assert (by_name["Action SlowHold"]["status"], by_name["Action SlowHold"]["end"]) == ("stopped", 2.1)
    # a stopped element's state signal keeps its value; its stop signal (one per stopper) makes it complete
    assert series(rows, "state_event_Slow") == [(0.0, 0), (1.0, 1)] and series(rows, "stopped_event_Slow") == [(0.0, 0), (2.0, 1)]
    assert series(rows, "state_event_Idle") == [(0.0, 0)] and series(rows, "stopped_event_Idle") == [(0.0, 0)]  # standby: not overridden
    assert series(rows, "var_x") == [(0.0, 0), (2.0, 1)]  # the stopTransition, seen by a trigger
    assert series(rows, "stopped_event_Later") == [(0.0, 0), (3.0, 1)]  # running when its act stopped
    assert series(rows, "stopped_event_Never") == [(0.0, 0), (3.0, 1)]  # in standby when its act stopped
    assert series(rows, "state_event_Urgent") == [(0.0, 0), (2.0, 2)] and "stopped_event_Urgent" not in rows[0]
    assert all(v == "pass" for k, v in verdicts(report).items() if k.startswith("completed-")) and report["verdict"] == "pass"


# -- 8.4.2 / 8.2: the storyboard's StopTrigger on an element's state -------------------------------

def test_a_stop_trigger_on_an_elements_state_ends_the_run_on_that_tick(tmp_path):
    stop = f"<StopTrigger><ConditionGroup>{state_is('event', 'Last', 'endTransition')}</ConditionGroup></StopTrigger>"
    text = scenario(story("e", event("Last", hold("LastHold", 1), trigger(at_time("greaterOrEqual", 1)))), stop=stop)
    report, rows = run(tmp_path, text)
    assert statuses(report)["LastHold"]["end"] == 2.0
    assert float(rows[-1]["time"]) == 2.0 and report["verdict"] == "pass"  # not 2.1: the stop is seen on its tick


# -- what stays refused ----------------------------------------------------------------------------

def test_a_transition_in_the_trigger_of_a_repeated_element_is_refused(tmp_path):
    pulse = event("Pulse", hold("Hold", 0.5), trigger(state_is("event", "Other", "startTransition")), count=2)
    text = scenario(story("p", pulse + event("Other", set_var("o", "w", 1), trigger(at_time("greaterOrEqual", 1)))))
    (tmp_path / "road.xodr").write_text(ROAD)
    (tmp_path / "s.xosc").write_text(text)
    with pytest.raises(InvalidTestCase) as info:
        read_openscenario(str(tmp_path / "s.xosc"))
    assert "startTransition in the trigger of an element executed more than once is not supported" in info.value.problems[0].message


def test_a_trajectory_followed_by_steering_is_refused_not_run_as_positions(tmp_path):
    """followingMode 'follow' (a controller steering along the path) is not approximated by 'position': the
    scenario's element and the case's JSON path are refused, exit 2."""
    from btgen_pytrees import load
    from btgen_pytrees.cli import main
    walk = """<Action name="walk"><PrivateAction><RoutingAction><FollowTrajectoryAction>
      <TrajectoryRef><Trajectory name="path" closed="false"><Shape><Polyline>
        <Vertex time="0"><Position><LanePosition roadId="1" laneId="-1" s="60" offset="0"/></Position></Vertex>
        <Vertex time="2"><Position><LanePosition roadId="1" laneId="-1" s="70" offset="0"/></Position></Vertex>
      </Polyline></Shape></Trajectory></TrajectoryRef>
      <TimeReference><None/></TimeReference><TrajectoryFollowingMode followingMode="follow"/>
    </FollowTrajectoryAction></RoutingAction></PrivateAction></Action>"""
    (tmp_path / "road.xodr").write_text(ROAD)
    (tmp_path / "s.xosc").write_text(scenario(story("f", event("Walk", walk, trigger(at_time("greaterOrEqual", 1))))))
    assert main(["validate", str(tmp_path / "s.xosc")]) == 2
    with pytest.raises(InvalidTestCase) as info:
        read_openscenario(str(tmp_path / "s.xosc"))
    assert info.value.problems[0].message == "followingMode 'follow' is not supported ('position' is)"
    assert "/FollowTrajectoryAction/TrajectoryFollowingMode" in "/".join(map(str, info.value.problems[0].path))
    case = {"name": "t", "system": {"type": "sumo", "road": str(tmp_path / "road.xodr"),
                                    "entities": {"Ego": {"position": {"LanePosition": {"roadId": "1", "laneId": -1, "s": 10}}}}},
            "execute": [{"id": "W", "kind": "behavior", "action": "sumo.trajectory",
                         "params": {"vehicle": "Ego", "following": "follow", "vertices": [
                             {"time": 0, "position": {"LanePosition": {"roadId": "1", "laneId": -1, "s": 10}}},
                             {"time": 2, "position": {"LanePosition": {"roadId": "1", "laneId": -1, "s": 20}}}]}}]}
    with pytest.raises(InvalidTestCase) as info:
        load(case)
    assert [(p.pointer, "'follow' is not one of" in p.message) for p in info.value.problems] == [("/execute/0/params/following", True)]
