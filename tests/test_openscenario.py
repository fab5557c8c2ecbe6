"""OpenSCENARIO files as test-case documents: safe XML, parameters and expressions, catalogs,
the storyboard as the timeline, distributions as sweeps (docs/openscenario.md).

The corpus tests read /work/shared/corpus/openscenario/alks (or $BTGEN_OSC_CORPUS) and skip
when it is absent."""

from __future__ import annotations

import math
import os
import pathlib
import random
import shutil

import pytest

from btgen_pytrees.errors import InvalidTestCase
from btgen_pytrees.openscenario import read_openscenario
from btgen_pytrees.openscenario.formula import FormulaError, evaluate
from btgen_pytrees.openscenario.xmltree import MAX_DEPTH, read_xml

CORPUS = pathlib.Path(os.environ.get("BTGEN_OSC_CORPUS", "/work/shared/corpus/openscenario/alks"))
LOGICAL = CORPUS / "logical_scenarios"
CONCRETE = LOGICAL / "concrete_scenarios"
need_corpus = pytest.mark.skipif(not CONCRETE.is_dir(), reason="the ALKS corpus is not on this machine")

ROAD = (pathlib.Path(__file__).parent.parent / "examples" / "openscenario" / "straight_3lanes.xodr").read_text()


def scenario(body: str, params: str = "", extra: str = "", rev: str = "2") -> str:
    return f"""<?xml version="1.0" encoding="utf-8"?>
<OpenSCENARIO>
  <FileHeader revMajor="1" revMinor="{rev}" date="2024-01-01T00:00:00" description="test" author="me"/>
  <ParameterDeclarations>{params}</ParameterDeclarations>
  <CatalogLocations/>
  <RoadNetwork><LogicFile filepath="road.xodr"/></RoadNetwork>
  <Entities>
    <ScenarioObject name="Ego"><Vehicle name="car" vehicleCategory="car">
      <BoundingBox><Center x="1.4" y="0" z="0.9"/><Dimensions width="2" length="5" height="1.8"/></BoundingBox>
      <Performance maxSpeed="70" maxAcceleration="5" maxDeceleration="9"/><Axles/><Properties/></Vehicle></ScenarioObject>
    <ScenarioObject name="Lead"><Vehicle name="car" vehicleCategory="car">
      <BoundingBox><Center x="1.4" y="0" z="0.9"/><Dimensions width="2" length="5" height="1.8"/></BoundingBox>
      <Performance maxSpeed="70" maxAcceleration="5" maxDeceleration="9"/></Vehicle></ScenarioObject>
  </Entities>
  <Storyboard>
    <Init><Actions>
      <Private entityRef="Ego">
        <PrivateAction><TeleportAction><Position><LanePosition roadId="1" laneId="-1" s="10" offset="0"/></Position></TeleportAction></PrivateAction>
        <PrivateAction><LongitudinalAction><SpeedAction><SpeedActionDynamics dynamicsShape="step" dynamicsDimension="time" value="0"/>
          <SpeedActionTarget><AbsoluteTargetSpeed value="20"/></SpeedActionTarget></SpeedAction></LongitudinalAction></PrivateAction>
      </Private>
      <Private entityRef="Lead">
        <PrivateAction><TeleportAction><Position><RelativeLanePosition entityRef="Ego" dLane="0" ds="40" offset="0"/></Position></TeleportAction></PrivateAction>
      </Private>
    </Actions></Init>
    {body}
    {extra}
  </Storyboard>
</OpenSCENARIO>"""


BRAKE = """<Story name="S"><Act name="A">
  <ManeuverGroup name="G" maximumExecutionCount="1"><Actors selectTriggeringEntities="false"><EntityRef entityRef="Lead"/></Actors>
    <Maneuver name="M"><Event name="Brake" priority="override">
      <Action name="BrakeAction"><PrivateAction><LongitudinalAction><SpeedAction>
        <SpeedActionDynamics dynamicsShape="linear" dynamicsDimension="rate" value="$Decel"/>
        <SpeedActionTarget><AbsoluteTargetSpeed value="${$Target / 3.6}"/></SpeedActionTarget></SpeedAction></LongitudinalAction></PrivateAction></Action>
      <StartTrigger><ConditionGroup><Condition name="Gap" delay="0.5" conditionEdge="rising"><ByEntityCondition>
        <TriggeringEntities triggeringEntitiesRule="any"><EntityRef entityRef="Ego"/></TriggeringEntities>
        <EntityCondition><RelativeDistanceCondition entityRef="Lead" relativeDistanceType="longitudinal" value="30" freespace="true" rule="lessThan" coordinateSystem="entity"/></EntityCondition>
      </ByEntityCondition></Condition></ConditionGroup></StartTrigger>
    </Event></Maneuver></ManeuverGroup>
  <StartTrigger><ConditionGroup><Condition name="T0" delay="0" conditionEdge="none"><ByValueCondition><SimulationTimeCondition value="1" rule="greaterOrEqual"/></ByValueCondition></Condition></ConditionGroup></StartTrigger>
</Act></Story>"""

STOP = """<StopTrigger><ConditionGroup><Condition name="End" delay="2" conditionEdge="rising"><ByValueCondition>
  <StoryboardElementStateCondition storyboardElementType="action" storyboardElementRef="BrakeAction" state="completeState"/>
</ByValueCondition></Condition></ConditionGroup></StopTrigger>"""

PARAMS = """<ParameterDeclaration name="Decel" parameterType="double" value="4">
  <ConstraintGroup><ValueConstraint rule="greaterThan" value="0"/></ConstraintGroup></ParameterDeclaration>
<ParameterDeclaration name="Target" parameterType="double" value="36"/>"""


needs_sumo = pytest.mark.skipif(os.environ.get("CI") != "true" and shutil.which("netconvert") is None,
                                reason="the sumo extra is not installed (a road case's checks run netconvert)")


def write(tmp_path: pathlib.Path, text: str, name: str = "s.xosc") -> str:
    (tmp_path / "road.xodr").write_text(ROAD)
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def problems(path: str) -> list[str]:
    with pytest.raises(InvalidTestCase) as info:
        read_openscenario(path)
    return [f"{p.pointer}: {p.message}" for p in info.value.problems]


# -- the storyboard as the timeline ---------------------------------------------------------------

def test_storyboard_becomes_entries_with_triggers_and_stop(tmp_path):
    doc = read_openscenario(write(tmp_path, scenario(BRAKE, PARAMS, STOP)))
    by_id = {e["id"]: e for e in doc["execute"]}
    assert [by_id[i]["name"] for i in ("S", "A", "G", "M", "Brake")] == ["Story S", "Act A", "ManeuverGroup G", "Maneuver M", "Event Brake"]
    assert by_id["A"]["after"] == ["S"] and by_id["A"]["when"] == "sim.time >= 1"  # the road system's time
    event = by_id["Brake"]
    assert (event["when"], event["edge"], event["delay"]) == ("abs(Ego.Lead.dx_free) < 30", "rising", 0.5)
    action = by_id["BrakeAction"]
    assert action["after"] == ["Brake"] and action["action"] == "sumo.speed"
    assert action["params"] == {"vehicle": "Lead", "shape": "linear", "rate": 4.0, "to": 10.0}
    # the state of the action the StopTrigger names: set when it starts and when it completes
    state = doc["stop"][0]["when"].split()[0]
    assert doc["stop"][0] == {"when": f"{state} == 2", "edge": "rising", "delay": 2.0}
    setters = [e for e in doc["execute"] if e["action"] == "set" and e["params"]["signal"] == state]
    assert [(s["params"]["value"], s["after"]) for s in setters] == [(1, ["Brake"]), (2, ["BrakeAction", setters[0]["id"]])]
    assert setters[1]["join"] == "all"
    # the storyboard runs until its StopTrigger: an entry that never succeeds keeps the timeline running
    assert doc["execute"][0] == {"id": "Storyboard", "kind": "constraint", "action": "until", "params": {"expect": "false"},
                                 "name": "Storyboard (until its StopTrigger)"}
    assert doc["stop"][1] == {"when": "Ego.end_of_road"}  # SUMO removes a vehicle there: the run ends, and fails
    assert doc["signals"][state] == 0
    # the Init: places and speeds of the entities
    ego = doc["system"]["entities"]["Ego"]
    assert ego["position"] == {"LanePosition": {"roadId": "1", "laneId": -1, "s": 10.0, "offset": 0.0}} and ego["speed"] == 20.0
    assert doc["system"]["entities"]["Lead"]["position"]["RelativeLanePosition"]["ds"] == 40.0
    # the default criteria: no collision of the ego, every started event completed
    criteria = {c["id"]: c for c in doc["oracle"]["criteria"]}
    assert criteria["no_collision"]["expect"] == "not Ego.collided"
    assert any(c["type"] == "final" and c["expect"].endswith("!= 1") for c in criteria.values())


def test_condition_groups_are_or_of_and_with_latches_for_edges(tmp_path):
    trigger = """<StartTrigger>
      <ConditionGroup>
        <Condition name="a" delay="0" conditionEdge="none"><ByValueCondition><SimulationTimeCondition value="1" rule="greaterThan"/></ByValueCondition></Condition>
        <Condition name="b" delay="0" conditionEdge="rising"><ByEntityCondition><TriggeringEntities triggeringEntitiesRule="all"><EntityRef entityRef="Ego"/><EntityRef entityRef="Lead"/></TriggeringEntities>
          <EntityCondition><SpeedCondition value="5" rule="lessThan"/></EntityCondition></ByEntityCondition></Condition>
      </ConditionGroup>
      <ConditionGroup><Condition name="c" delay="0" conditionEdge="none"><ByValueCondition><SimulationTimeCondition value="9" rule="equalTo"/></ByValueCondition></Condition></ConditionGroup>
    </StartTrigger>"""
    body = BRAKE.replace(BRAKE[BRAKE.index("<StartTrigger><ConditionGroup><Condition name=\"Gap\""):BRAKE.index("</Event>")], trigger)
    doc = read_openscenario(write(tmp_path, scenario(body, PARAMS)))
    by_id = {e["id"]: e for e in doc["execute"]}
    latch = next(e for e in doc["execute"] if e["name"] == "Condition b")
    assert latch["when"] == "(Ego.speed < 5) && (Lead.speed < 5)" and latch["edge"] == "rising" and latch["after"] == ["M"]
    signal = latch["params"]["signal"]
    assert by_id["Brake"]["when"] == f"((sim.time > 1) && {signal}) || (sim.time == 9)"


def test_override_priority_stops_the_other_events(tmp_path):
    second = BRAKE.replace('<Event name="Brake" priority="override">', '<Event name="Brake" priority="parallel">').replace(
        "</Event></Maneuver>", """</Event><Event name="Go" priority="override"><Action name="GoAction"><PrivateAction><LongitudinalAction><SpeedAction>
        <SpeedActionDynamics dynamicsShape="step" dynamicsDimension="time" value="0"/><SpeedActionTarget><AbsoluteTargetSpeed value="30"/></SpeedActionTarget>
        </SpeedAction></LongitudinalAction></PrivateAction></Action></Event></Maneuver>""")
    doc = read_openscenario(write(tmp_path, scenario(second, PARAMS)))
    by_id = {e["id"]: e for e in doc["execute"]}
    assert by_id["Go"]["stops"] == ["BrakeAction"] and "stops" not in by_id["Brake"]
    assert "when" not in by_id["Go"]  # no StartTrigger: starts with its maneuver


# -- nothing silently dropped; clear exit 2 ----------------------------------------------------

def test_unsupported_element_is_named_with_its_place(tmp_path):
    body = BRAKE.replace("<Maneuver name=\"M\">", "<Maneuver name=\"M\"><Frobnicate/>")
    found = problems(write(tmp_path, scenario(body, PARAMS)))
    assert found == ["/OpenSCENARIO/Storyboard/Story[@name='S']/Act[@name='A']/ManeuverGroup[@name='G']/Maneuver[@name='M']/Frobnicate: "
                     "unsupported element Frobnicate: not converted (see docs/openscenario.md)"]


def test_unsupported_action_and_attribute(tmp_path):
    body = BRAKE.replace("<LongitudinalAction><SpeedAction>", "<LongitudinalAction><SpeedProfileAction/><SpeedAction>", 1)
    assert "must hold exactly one element" in problems(write(tmp_path, scenario(body, PARAMS)))[0]
    body = BRAKE.replace('<EntityRef entityRef="Lead"/></Actors>', '<EntityRef entityRef="Lead" colour="red"/></Actors>')
    assert problems(write(tmp_path, scenario(body, PARAMS)))[0].endswith("unsupported attribute colour='red' of EntityRef")


def test_missing_road_and_catalog_name_the_file(tmp_path):
    path = write(tmp_path, scenario(BRAKE, PARAMS))
    os.remove(tmp_path / "road.xodr")
    assert problems(path) == ["/OpenSCENARIO/RoadNetwork/LogicFile: road network 'road.xodr' not found "
                              f"(looked for {str(tmp_path / 'road.xodr')!r})"]
    text = scenario(BRAKE, PARAMS).replace("<CatalogLocations/>", '<CatalogLocations><VehicleCatalog><Directory path="./nowhere"/></VehicleCatalog></CatalogLocations>')
    text = text.replace('<ScenarioObject name="Lead"><Vehicle', '<ScenarioObject name="Lead"><CatalogReference catalogName="v" entryName="car"/><Vehicle')
    found = problems(write(tmp_path, text))
    assert "catalog directory" in found[0] and "nowhere" in found[0]


@pytest.mark.parametrize("text, words", [
    ('<?xml version="1.0"?><!DOCTYPE x [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;">]><OpenSCENARIO>&b;</OpenSCENARIO>', "refused XML"),
    ('<?xml version="1.0"?><!DOCTYPE x [<!ENTITY e SYSTEM "file:///etc/passwd">]><OpenSCENARIO>&e;</OpenSCENARIO>', "refused XML"),
    ("<OpenSCENARIO>" + "<a>" * (MAX_DEPTH + 5) + "</a>" * (MAX_DEPTH + 5) + "</OpenSCENARIO>", f"deeper than {MAX_DEPTH}"),
    ("<OpenSCENARIO><unclosed></OpenSCENARIO>", "not well-formed"),
])
def test_unsafe_or_malformed_xml_is_refused(tmp_path, text, words):
    path = tmp_path / "bad.xosc"
    path.write_text(text)
    with pytest.raises(InvalidTestCase) as info:
        read_xml(str(path))
    assert words in str(info.value) and str(path) in str(info.value)


def test_exit_2_on_the_command_line(tmp_path, capsys):
    from btgen_pytrees.cli import main
    path = write(tmp_path, scenario(BRAKE.replace("$Decel", "$Deccel"), PARAMS))
    assert main(["validate", path]) == 2
    err = capsys.readouterr().err
    assert f"{path}: /OpenSCENARIO/Storyboard/Story[@name='S']/Act[@name='A']/ManeuverGroup[@name='G']" in err
    assert "unknown parameter '$Deccel'" in err and "Traceback" not in err


# -- parameters, expressions, constraints ------------------------------------------------------

def test_expressions_follow_the_standard():
    values = {"a": 36, "b": 2.5, "t": True, "s": "car"}
    assert evaluate("${$a / 3.6}", values) == 10.0
    assert evaluate("${-$a + 2 * (1 + 1)}", values) == -32
    assert evaluate("${round(2.5)} ", values.copy()) if False else True  # (trailing text is not an expression)
    assert [evaluate(f"${{{f}}}", values) for f in ("round(2.5)", "round(-2.5)", "floor(-1.5)", "ceil(1.2)", "sign(-3)", "abs(-2)")] == [3, -3, -2, 2, -1, 2]
    assert evaluate("${pow(2, 10) + sqrt(16) + max(1, $b) + min(1, $b)}", values) == 1024 + 4 + 2.5 + 1
    assert math.isclose(evaluate("${sin(0) + cos(0) + tan(0) + asin(1) + acos(1) + atan(1)}", values), 1 + math.pi / 2 + math.pi / 4)
    assert evaluate("${not $t or 1 > 2}", values) is False
    assert evaluate("${$a % 5 == 1 and $b != 2}", values) is True
    for bad, words in [("${1 +}", "ends too early"), ("${__import__('os')}", "unexpected"), ("${$x}", "unknown parameter"),
                       ("${1 / 0}", "division by zero"), ("${sqrt(-1)}", "sqrt()"), ("${pow(1)}", "takes 2"),
                       ("${" + "(" * 60 + "1" + ")" * 60 + "}", "nests deeper"), ("${$s + 1}", "not a number")]:
        with pytest.raises(FormulaError, match=words.replace("(", r"\(").replace(")", r"\)")):
            evaluate(bad, values)


def test_constraint_groups_are_checked(tmp_path):
    params = PARAMS.replace('value="4">', 'value="-1">')
    found = problems(write(tmp_path, scenario(BRAKE, params)))
    assert found == ["/OpenSCENARIO/ParameterDeclarations/ParameterDeclaration[@name='Decel']: "
                     "parameter 'Decel' = -1 breaks its ConstraintGroups: not greaterThan 0"]
    two = """<ParameterDeclaration name="Decel" parameterType="double" value="-2">
      <ConstraintGroup><ValueConstraint rule="equalTo" value="4"/></ConstraintGroup>
      <ConstraintGroup><ValueConstraint rule="lessThan" value="${-1}"/><ValueConstraint rule="greaterOrEqual" value="-3"/></ConstraintGroup>
    </ParameterDeclaration><ParameterDeclaration name="Target" parameterType="int" value="36"/>"""
    assert read_openscenario(write(tmp_path, scenario(BRAKE, two)))["execute"]


def test_catalog_reference_with_parameter_assignments(tmp_path):
    (tmp_path / "cat").mkdir()
    (tmp_path / "cat" / "vehicles.xosc").write_text("""<?xml version="1.0"?><OpenSCENARIO>
      <FileHeader revMajor="1" revMinor="1" date="2024-01-01T00:00:00" description="c" author="me"/>
      <Catalog name="vehicles">
        <Vehicle name="box" vehicleCategory="truck"><ParameterDeclarations><ParameterDeclaration name="Len" parameterType="double" value="4"/></ParameterDeclarations>
          <BoundingBox><Center x="1" y="0" z="1"/><Dimensions width="2.5" length="$Len" height="3"/></BoundingBox>
          <Performance maxSpeed="30" maxAcceleration="2" maxDeceleration="6"/></Vehicle>
        <Vehicle name="unused"><Whatever/></Vehicle>
      </Catalog></OpenSCENARIO>""")
    text = scenario(BRAKE, PARAMS).replace("<CatalogLocations/>", '<CatalogLocations><VehicleCatalog><Directory path="cat"/></VehicleCatalog></CatalogLocations>')
    start, end = text.index('<ScenarioObject name="Lead">'), text.index("</Entities>")
    text = text[:start] + """<ScenarioObject name="Lead"><CatalogReference catalogName="vehicles" entryName="box">
      <ParameterAssignments><ParameterAssignment parameterRef="Len" value="${$Target / 3}"/></ParameterAssignments></CatalogReference></ScenarioObject>""" + text[end:]
    lead = read_openscenario(write(tmp_path, text))["system"]["entities"]["Lead"]
    assert (lead["length"], lead["category"], lead["max_speed"]) == (12.0, "truck", 30.0)  # the unused entry is not read
    bad = text.replace('parameterRef="Len"', 'parameterRef="Width"')
    assert "assigns Width, which entry 'box' does not declare" in problems(write(tmp_path, bad))[0]


@pytest.mark.parametrize("rev", ["0", "1", "2", "3"])
def test_versions_1_0_to_1_3(tmp_path, rev):
    assert read_openscenario(write(tmp_path, scenario(BRAKE, PARAMS, rev=rev)))["execute"]


def test_version_1_4_is_refused(tmp_path):
    assert problems(write(tmp_path, scenario(BRAKE, PARAMS, rev="4"))) == [
        "/OpenSCENARIO/FileHeader: OpenSCENARIO 1.4 is not supported (1.0 to 1.3 are)"]


# -- distributions --------------------------------------------------------------------------------

def distribution(inner: str, scenario_file: str = "s.xosc") -> str:
    return f"""<?xml version="1.0"?><OpenSCENARIO>
      <FileHeader revMajor="1" revMinor="2" date="2024-01-01T00:00:00" description="v" author="me"/>
      <ParameterValueDistribution><ScenarioFile filepath="{scenario_file}"/>{inner}</ParameterValueDistribution></OpenSCENARIO>"""


def test_deterministic_distribution_is_the_product_in_order(tmp_path):
    write(tmp_path, scenario(BRAKE, PARAMS))
    path = write(tmp_path, distribution("""<Deterministic>
      <DeterministicSingleParameterDistribution parameterName="Decel"><DistributionRange stepWidth="1.5"><Range lowerLimit="1" upperLimit="4"/></DistributionRange></DeterministicSingleParameterDistribution>
      <DeterministicMultiParameterDistribution><ValueSetDistribution>
        <ParameterValueSet><ParameterAssignment parameterRef="Target" value="10"/></ParameterValueSet>
        <ParameterValueSet><ParameterAssignment parameterRef="Target" value="20"/></ParameterValueSet>
      </ValueSetDistribution></DeterministicMultiParameterDistribution></Deterministic>"""), "v.xosc")
    sweep = read_openscenario(path)
    v = sweep.scenario_variations
    assert v.total == v.count == 6 and v.names == ("Decel", "Target")
    assert [dict(p) for p in v.points()] == [{"Decel": d, "Target": t} for d in (1.0, 2.5, 4.0) for t in (10.0, 20.0)]
    doc = sweep.render({"Decel": 2.5, "Target": 20.0})
    brake = next(e for e in doc["execute"] if e["id"] == "BrakeAction")["params"]
    assert math.isclose(brake["to"], 20 / 3.6) and brake["rate"] == 2.5
    assert doc["system"]["road"] == "road.xodr"


def test_variations_breaking_constraints_are_discarded(tmp_path):
    write(tmp_path, scenario(BRAKE, PARAMS))
    path = write(tmp_path, distribution("""<Deterministic><DeterministicSingleParameterDistribution parameterName="Decel">
      <DistributionSet><Element value="-1"/><Element value="3"/><Element value="0"/><Element value="5"/></DistributionSet>
    </DeterministicSingleParameterDistribution></Deterministic>"""), "v.xosc")
    v = read_openscenario(path).scenario_variations
    assert (v.total, v.count, v.discarded) == (4, 2, 2)
    assert [dict(p)["Decel"] for p in v.points()] == [3.0, 5.0]


STOCHASTIC = """<Stochastic numberOfTestRuns="200" randomSeed="7">
  <StochasticDistribution parameterName="Decel"><NormalDistribution expectedValue="4" variance="1"><Range lowerLimit="2" upperLimit="6"/></NormalDistribution></StochasticDistribution>
  <StochasticDistribution parameterName="Target"><ProbabilityDistributionSet><Element value="10" weight="3"/><Element value="50" weight="1"/></ProbabilityDistributionSet></StochasticDistribution>
</Stochastic>"""


def test_stochastic_distribution_is_reproducible_and_respects_ranges(tmp_path):
    write(tmp_path, scenario(BRAKE, PARAMS))
    path = write(tmp_path, distribution(STOCHASTIC), "v.xosc")
    first = list(read_openscenario(path).scenario_variations.points())
    assert first == list(read_openscenario(path).scenario_variations.points())
    assert len(first) == 200 and [p[0] for p in first] == [("sample", i) for i in range(200)]
    decels = [dict(p)["Decel"] for p in first]
    assert all(2 <= d <= 6 for d in decels) and 3.7 < sum(decels) / 200 < 4.3
    share = sum(dict(p)["Target"] == 10.0 for p in first) / 200
    assert 0.65 < share < 0.85  # weight 3 of 4


@pytest.mark.parametrize("kind", [
    '<UniformDistribution><Range lowerLimit="1" upperLimit="3"/></UniformDistribution>',
    '<LogNormalDistribution expectedValue="3" variance="0.5"/>',
    '<PoissonDistribution expectedValue="3"><Range lowerLimit="1" upperLimit="8"/></PoissonDistribution>',
    '<Histogram><Bin weight="1"><Range lowerLimit="1" upperLimit="2"/></Bin><Bin weight="3"><Range lowerLimit="2" upperLimit="5"/></Bin></Histogram>',
])
def test_every_stochastic_kind_draws_positive_values(tmp_path, kind):
    write(tmp_path, scenario(BRAKE, PARAMS))
    inner = f'<Stochastic numberOfTestRuns="50" randomSeed="1"><StochasticDistribution parameterName="Decel">{kind}</StochasticDistribution></Stochastic>'
    values = [dict(p)["Decel"] for p in read_openscenario(write(tmp_path, distribution(inner), "v.xosc")).scenario_variations.points()]
    assert len(values) == 50 and all(float(v) > 0 for v in values) and len(set(values)) > 3


def test_user_defined_distribution_is_refused(tmp_path):
    write(tmp_path, scenario(BRAKE, PARAMS))
    inner = '<Deterministic><DeterministicSingleParameterDistribution parameterName="Decel"><UserDefinedDistribution type="x">1</UserDefinedDistribution></DeterministicSingleParameterDistribution></Deterministic>'
    found = problems(write(tmp_path, distribution(inner), "v.xosc"))
    assert found[0].endswith("UserDefinedDistribution is not supported: its content is a tool's own format")


def test_distribution_of_an_undeclared_parameter(tmp_path):
    write(tmp_path, scenario(BRAKE, PARAMS))
    inner = '<Deterministic><DeterministicSingleParameterDistribution parameterName="Nope"><DistributionSet><Element value="1"/></DistributionSet></DeterministicSingleParameterDistribution></Deterministic>'
    assert "'Nope' is not declared in 's.xosc'" in problems(write(tmp_path, distribution(inner), "v.xosc"))[0]


# -- the corpus -----------------------------------------------------------------------------------

WAITING: dict[str, str] = {}  # scenarios whose motion needs a leaf the road system does not have yet: none


@need_corpus
@pytest.mark.parametrize("name", sorted(p.name for p in CONCRETE.glob("*.xosc")) if CONCRETE.is_dir() else [])
def test_corpus_scenario_converts_with_no_unsupported_element(name):
    if name in WAITING:  # refused, clearly, at the action: never dropped
        with pytest.raises(InvalidTestCase) as info:
            read_openscenario(str(CONCRETE / name))
        assert [p.message for p in info.value.problems] == [
            f"{WAITING[name]} is not supported yet: the road system has no leaf for it "
            '(docs/openscenario.md "Actions")']
        return
    doc = read_openscenario(str(CONCRETE / name))
    assert doc["system"]["entities"] and doc["execute"] and doc["stop"]
    assert doc["oracle"]["criteria"][0]["expect"] == "not Ego.collided"


CORPUS_COUNTS = {  # the products the files define: sizes of their distributions multiplied
    "alks_scenario_4_1_1_free_driving_variation.xosc": 12,
    "alks_scenario_4_1_2_swerving_lead_vehicle_variation.xosc": 5 * 12 * 5,
    "alks_scenario_4_1_3_side_vehicle_variation.xosc": 12 * 5 * 5 * 2 * 2,
    "alks_scenario_4_2_1_fully_blocking_target_variation.xosc": 5 * 12 * 6,
    "alks_scenario_4_2_2_partially_blocking_target_variation.xosc": 5 * 12 * 6 * 17,
    "alks_scenario_4_2_3_crossing_pedestrian_variation.xosc": 5 * 12 * 2,
    "alks_scenario_4_2_4_multiple_blocking_targets_variation.xosc": 5 * 12 * 6 * 5,
    "alks_scenario_4_3_1_follow_lead_vehicle_comfortable_variation.xosc": 5 * 12 * 5 * 8,
    "alks_scenario_4_3_2_follow_lead_vehicle_emergency_brake_variation.xosc": 5 * 1 * 5 * 7 * 8,
    "alks_scenario_4_3_2_follow_lead_vehicle_emergency_brake_variation_reference.xosc": 5 * 12 * 5 * 1 * 10,
    "alks_scenario_4_4_1_cut_in_no_collision_variation.xosc": 5 * 5 * 2 * 5 * 7 * 6 * 5,
    "alks_scenario_4_5_1_cut_out_fully_blocking_variation.xosc": 12 * 2 * 10 * 6 * 6,
    "alks_scenario_4_5_2_cut_out_multiple_blocking_targets_variation.xosc": 12 * 2 * 10 * 6 * 6 * 5,
    "alks_scenario_4_6_1_forward_detection_range_variation.xosc": 2 * 3,
    "alks_scenario_4_6_2_lateral_detection_range_variation.xosc": 2,
}


@need_corpus
def test_corpus_variation_counts_are_the_products():
    from btgen_pytrees.openscenario.distributions import parse_distribution
    from btgen_pytrees.openscenario.parameters import Scope
    assert sorted(CORPUS_COUNTS) == sorted(p.name for p in LOGICAL.glob("*.xosc"))
    for name, count in CORPUS_COUNTS.items():
        assert parse_distribution(read_xml(str(LOGICAL / name)), Scope()).count == count, name
        if name.replace("variation", "template").replace("_reference", "") not in WAITING:
            assert read_openscenario(str(LOGICAL / name)).scenario_variations.total == count, name
    small = read_openscenario(str(LOGICAL / "alks_scenario_4_2_1_fully_blocking_target_variation.xosc"))
    v = small.scenario_variations
    points = list(v.points())
    assert len(points) == v.count == 360
    rng = random.Random(3)
    for point in rng.sample(points, 3):  # a variation's document carries its values
        doc = small.render(dict(point))
        assert doc["system"]["road"].startswith("concrete_scenarios/road_networks/")


# -- coverage ---------------------------------------------------------------------------------------

def test_coverage_names_unsupported_elements_and_fits_its_schema(tmp_path, capsys):
    import json

    import jsonschema

    from btgen_pytrees.cli import main

    write(tmp_path, scenario(BRAKE, PARAMS))
    write(tmp_path, scenario(BRAKE.replace("<Maneuver name=\"M\">", "<Maneuver name=\"M\"><Frobnicate/>"), PARAMS), "bad.xosc")
    assert main(["coverage", str(tmp_path), "--format", "json"]) == 1
    data = json.loads(capsys.readouterr().out)
    schema = json.loads((pathlib.Path(__file__).parent.parent / "schemas" / "coverage.schema.json").read_text())
    jsonschema.validate(data, schema)
    by_file = {f["file"]: f for f in data["files"]}
    assert by_file["s.xosc"]["converts"] and not by_file["bad.xosc"]["converts"]
    assert by_file["bad.xosc"]["problems"] == ["/OpenSCENARIO/Storyboard/Story[@name='S']/Act[@name='A']/ManeuverGroup[@name='G']/"
                                               "Maneuver[@name='M']/Frobnicate: unsupported element Frobnicate: not converted (see docs/openscenario.md)"]
    rows = {r["element"]: r for r in data["elements"]}
    assert rows["Frobnicate"] == {"element": "Frobnicate", "occurrences": 1, "supported": 0, "unsupported": 1, "unreached": 0}
    assert rows["SpeedAction"]["unsupported"] == 0 and rows["SpeedAction"]["occurrences"] == 4
    assert main(["coverage", str(tmp_path / "s.xosc")]) == 0
    assert "1 of 1 files convert" in capsys.readouterr().out


@need_corpus
def test_corpus_coverage_is_complete():
    from btgen_pytrees.openscenario.coverage import coverage
    data = coverage(str(CORPUS))
    assert data["summary"]["files"] == 30 and data["summary"]["converting"] == 30 - len(WAITING)
    failing = {f["file"].rsplit("/", 1)[-1] for f in data["files"] if not f["converts"]}
    assert failing == set(WAITING)


@need_corpus
def test_docs_table_is_what_the_coverage_command_prints():
    from btgen_pytrees.openscenario.coverage import coverage, markdown
    text = (pathlib.Path(__file__).parent.parent / "docs" / "openscenario.md").read_text(encoding="utf-8")
    shown = text.split("<!-- coverage:alks:begin -->\n")[1].split("<!-- coverage:alks:end -->")[0]
    assert shown == markdown(coverage(str(CORPUS)))


# -- the commands take .xosc; runs on SUMO ----------------------------------------------------------

EXAMPLES = pathlib.Path(__file__).parent.parent / "examples" / "openscenario"


@needs_sumo
def test_every_command_reads_xosc_through_the_loader(tmp_path, capsys):
    from btgen_pytrees.cli import main
    from btgen_pytrees.load import load_json
    path = write(tmp_path, scenario(BRAKE, PARAMS, STOP))
    assert load_json(path)["execute"]
    assert main(["validate", path]) == 0
    assert "ok:" in capsys.readouterr().out
    assert main(["show", path]) == 0
    tree = capsys.readouterr().out
    for label in ("Story S", "Act A", "ManeuverGroup G", "Maneuver M", "Event Brake", "Action BrakeAction"):
        assert label in tree  # every element named in the view


@needs_sumo
def test_a_distribution_is_a_sweep_for_validate_and_expand(tmp_path, capsys):
    import json

    from btgen_pytrees.cli import main
    write(tmp_path, scenario(BRAKE, PARAMS, STOP))
    path = write(tmp_path, distribution("""<Deterministic><DeterministicSingleParameterDistribution parameterName="Decel">
      <DistributionSet><Element value="-1"/><Element value="3"/><Element value="5"/></DistributionSet>
    </DeterministicSingleParameterDistribution></Deterministic>"""), "v.xosc")
    assert main(["validate", path]) == 0
    assert "2 variations (of 3 the file defines: 1 breaks the parameters' constraints)" in capsys.readouterr().out
    out = tmp_path / "out"
    assert main(["expand", path, "--out-dir", str(out)]) == 0
    written = sorted(p.name for p in out.glob("*.json"))
    assert len(written) == 2
    doc = json.loads((out / written[0]).read_text())
    assert next(e for e in doc["execute"] if e["id"] == "BrakeAction")["params"]["rate"] == 3
    assert doc["system"]["road"] == "../road.xodr"  # relative to the case, where it now is
    assert main(["validate", *(str(out / name) for name in written)]) == 0


@needs_sumo
def test_set_chooses_one_variation_of_a_distribution(tmp_path, capsys):
    import json

    from btgen_pytrees.cli import main
    write(tmp_path, scenario(BRAKE, PARAMS, STOP))
    path = write(tmp_path, distribution("""<Deterministic><DeterministicSingleParameterDistribution parameterName="Decel">
      <DistributionSet><Element value="3"/><Element value="5"/></DistributionSet>
    </DeterministicSingleParameterDistribution></Deterministic>"""), "v.xosc")
    out = tmp_path / "one"
    assert main(["expand", path, "--set", "Decel=4.5", "--out-dir", str(out)]) == 0
    (written,) = out.glob("*.json")
    doc = json.loads(written.read_text())
    assert doc["name"] == "v[Decel=4.5]"
    assert next(e for e in doc["execute"] if e["id"] == "BrakeAction")["params"]["rate"] == 4.5  # the scenario converted with it
    assert main(["expand", path, "--set", "Decell=4", "--out-dir", str(out)]) == 2
    assert "unknown parameter 'Decell' (did you mean 'Decel'?)" in capsys.readouterr().err
    assert main(["expand", path, "--set", "Decel=-1", "--out-dir", str(tmp_path / "two")]) == 2  # breaks its constraint


@needs_sumo
def test_examples_run_on_sumo_to_their_verdicts(tmp_path, capsys):
    from btgen_pytrees.cli import main
    pytest.importorskip("libsumo")
    # a braking lead and SUMO's driver model: the NCAP-like sidecar's impact criterion holds
    assert main(["run", str(EXAMPLES / "braking_lead.xosc"), "--json", str(tmp_path / "b.json")]) == 0
    import json
    report = json.loads((tmp_path / "b.json").read_text())
    ids = {o["id"]: o["verdict"] for o in report["oracles"]} if "oracles" in report else {}
    assert report["verdict"] == "pass" and (not ids or ids.get("impact_speed") == "pass")
    # an uncontrolled ego follows the storyboard exactly: it runs into the car cutting in
    assert main(["run", str(EXAMPLES / "cut_in.xosc")]) == 1
    assert "no_collision failed" in capsys.readouterr().out


@needs_sumo
def test_convert_round_trips_to_the_same_report_from_any_directory(tmp_path, monkeypatch, capsys):
    import json

    from btgen_pytrees.cli import main
    pytest.importorskip("libsumo")
    scenario_file = EXAMPLES / "braking_lead.xosc"
    assert main(["run", str(scenario_file), "--json", str(tmp_path / "direct.json")]) == 0
    out = tmp_path / "converted"
    assert main(["convert", str(scenario_file), "--out-dir", str(out)]) == 0
    written = capsys.readouterr().out
    assert "braking_lead.json" in written and "straight_3lanes.xodr" in written
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    assert main(["run", str(out / "braking_lead.json"), "--json", "again.json"]) == 0
    direct, again = (json.loads(p.read_text()) for p in (tmp_path / "direct.json", elsewhere / "again.json"))
    for report in (direct, again):
        report.pop("source", None)
    assert direct == again
    assert main(["convert", str(EXAMPLES / "braking_lead_variation.xosc"), "--out-dir", str(out)]) == 2
    assert "use 'expand'" in capsys.readouterr().err


@needs_sumo
def test_pytest_plugin_collects_xosc_files(tmp_path):
    import subprocess
    import sys
    for name in ("braking_lead.xosc", "straight_3lanes.xodr"):
        shutil.copy(EXAMPLES / name, tmp_path / name)
    inner = ('<Stochastic numberOfTestRuns="2" randomSeed="3"><StochasticDistribution parameterName="Gap_m">'
             '<UniformDistribution><Range lowerLimit="12" upperLimit="40"/></UniformDistribution></StochasticDistribution></Stochastic>')
    (tmp_path / "v.xosc").write_text(distribution(inner, "braking_lead.xosc"))
    (tmp_path / "catalog.xosc").write_text('<OpenSCENARIO><FileHeader revMajor="1" revMinor="2" date="2024-01-01T00:00:00" '
                                           'description="c" author="a"/><Catalog name="c"/></OpenSCENARIO>')  # not collected
    done = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:randomly", "-p", "no:cacheprovider",
                           "--btgen-files=*.xosc"], cwd=tmp_path, capture_output=True, text=True, timeout=300)  # fmt: skip
    items = [line for line in done.stdout.splitlines() if "::" in line]
    assert done.returncode == 0, done.stdout + done.stderr
    assert items[0] == "braking_lead.xosc::braking_lead"
    assert [i.split("[")[1].split(",")[0] for i in items[1:]] == ["sample=0", "sample=1"]  # one item per variation


@need_corpus
@needs_sumo
def test_corpus_cut_in_events_start_on_the_tick_their_trigger_holds(tmp_path):
    """ALKS 4.4.1: the controller's event at 3 s (SimulationTime), the cut-in on the first tick the free
    longitudinal gap is below 30 m (rising), its lane change done when its sinusoidal dynamics end, the run
    ended by the StopTrigger 10 s after that (seen one tick later: the stop is checked before the timeline)."""
    import csv

    from btgen_pytrees.cli import main
    pytest.importorskip("libsumo")
    out = tmp_path / "s.csv"
    assert main(["run", str(CONCRETE / "alks_scenario_4_4_1_cut_in_no_collision_template.xosc"), "--signals-out", str(out)]) in (0, 1)
    rows = list(csv.DictReader(out.open()))

    def first(column: str, value: str) -> float:
        return next(float(r["time"]) for r in rows if r[column] == value)

    trigger = next(float(r["time"]) for r in rows if r["Ego.CutInVehicle.dx_free"] and abs(float(r["Ego.CutInVehicle.dx_free"])) < 30)
    assert first("status:ActivateALKSControllerAction", "success") == pytest.approx(3.0)
    assert first("status:CutInAction", "running") == pytest.approx(trigger)
    lateral = abs(float(rows[0]["Ego.CutInVehicle.dt"]))  # one lane: the distance between the lanes' centres
    done = first("status:CutInAction", "success")
    assert done == pytest.approx(trigger + math.pi / 2 * lateral / 2.0, abs=0.1)  # rate 2 m/s peak, sinusoidal
    assert float(rows[-1]["time"]) == pytest.approx(done + 10)


def test_a_directory_of_cases_holds_its_scenarios_not_the_sidecars_or_catalogs(tmp_path):
    from btgen_pytrees import batch
    found = [os.path.basename(p) for p in batch.expand([str(EXAMPLES)])]
    assert found == ["braking_lead.xosc", "braking_lead_variation.xosc", "cut_in.xosc"]  # the .json there are sidecars
    (tmp_path / "catalogs").mkdir()
    (tmp_path / "catalogs" / "cars.xosc").write_text(
        '<?xml version="1.0"?>\n<OpenSCENARIO><FileHeader revMajor="1" revMinor="2" date="2024-01-01T00:00:00" '
        'description="c" author="a"/><Catalog name="cars"/></OpenSCENARIO>')  # fmt: skip
    shutil.copy(EXAMPLES / "cut_in.xosc", tmp_path / "s.xosc")
    (tmp_path / "broken.xosc").write_text("<OpenSCENARIO><FileHeader")  # cannot be told: listed, the loader says why
    assert [os.path.relpath(p, tmp_path) for p in batch.expand([str(tmp_path)])] == ["broken.xosc", "s.xosc"]


def test_reach_position_and_distance_conditions_use_the_roads_world_point(tmp_path):
    trigger = """<StartTrigger><ConditionGroup>
      <Condition name="there" delay="0" conditionEdge="none"><ByEntityCondition>
        <TriggeringEntities triggeringEntitiesRule="any"><EntityRef entityRef="Ego"/></TriggeringEntities>
        <EntityCondition><ReachPositionCondition tolerance="2"><Position><LanePosition roadId="1" laneId="-2" s="100" offset="0"/></Position></ReachPositionCondition></EntityCondition>
      </ByEntityCondition></Condition>
      <Condition name="near" delay="0" conditionEdge="none"><ByEntityCondition>
        <TriggeringEntities triggeringEntitiesRule="any"><EntityRef entityRef="Lead"/></TriggeringEntities>
        <EntityCondition><DistanceCondition value="10" freespace="false" rule="lessThan"><Position><WorldPosition x="300" y="-5.25"/></Position></DistanceCondition></EntityCondition>
      </ByEntityCondition></Condition>
    </ConditionGroup></StartTrigger>"""
    body = BRAKE.replace(BRAKE[BRAKE.index("<StartTrigger><ConditionGroup><Condition name=\"Gap\""):BRAKE.index("</Event>")], trigger)
    doc = read_openscenario(write(tmp_path, scenario(body, PARAMS)))
    when = next(e for e in doc["execute"] if e["id"] == "Brake")["when"]
    # lane -2 of the straight road: its centre 5.25 m right of the reference line (two 3.5 m lanes)
    assert when == ("((Ego.ref_x - 100) * (Ego.ref_x - 100) + (Ego.ref_y + 5.25) * (Ego.ref_y + 5.25) <= 4) && "
                    "((Lead.ref_x - 300) * (Lead.ref_x - 300) + (Lead.ref_y + 5.25) * (Lead.ref_y + 5.25) < 100)")
    from btgen_pytrees.expressions import parse
    assert parse(when).evaluate({"Ego.ref_x": 101, "Ego.ref_y": -5.0, "Lead.ref_x": 295, "Lead.ref_y": -5.25}) is True


def test_an_acts_stop_trigger_stops_what_runs_in_it(tmp_path):
    act_stop = """<StopTrigger><ConditionGroup><Condition name="enough" delay="0" conditionEdge="rising"><ByValueCondition>
      <SimulationTimeCondition value="20" rule="greaterThan"/></ByValueCondition></Condition></ConditionGroup></StopTrigger>"""
    body = BRAKE.replace("</Act></Story>", act_stop + "</Act></Story>")
    doc = read_openscenario(write(tmp_path, scenario(body, PARAMS)))
    stop = next(e for e in doc["execute"] if e["name"] == "StopTrigger of Act A")
    assert (stop["after"], stop["when"], stop["edge"]) == (["A"], "sim.time > 20", "rising")
    assert {"G", "M", "Brake", "BrakeAction"} <= set(stop["stops"]) and "A" not in stop["stops"]


@need_corpus
@needs_sumo
def test_every_corpus_scenario_runs_on_sumo_to_a_verdict(capsys):
    from btgen_pytrees.cli import main
    pytest.importorskip("libsumo")
    files = sorted(str(p) for p in CONCRETE.glob("*.xosc"))
    code = main(["run", *files])
    out = capsys.readouterr().out
    rows = [line for line in out.splitlines() if "alks_scenario_" in line.split(" ")[0]]
    assert len(rows) == 15 and code in (0, 1), out
    assert all(line.split()[1] in ("ok", "FAIL") for line in rows), out  # never error, invalid or an internal error


def test_an_event_runs_up_to_its_maximum_execution_count(tmp_path):
    """The structure (the runs: tests/test_openscenario_semantics.py): one copy of the event per execution,
    each waiting for the trigger again after the one before is over and its state is written."""
    body = BRAKE.replace('<Event name="Brake" priority="override">', '<Event name="Brake" priority="override" maximumExecutionCount="3">')
    doc = read_openscenario(write(tmp_path, scenario(body, PARAMS, STOP)))
    markers = [e for e in doc["execute"] if e["name"] in ("Event Brake (1 of 3)", "Event Brake (2 of 3)", "Event Brake (3 of 3)")]
    assert [m["id"] for m in markers] == ["Brake", "Brake_2", "Brake_3"]
    actions = [e for e in doc["execute"] if e["name"] == "Action BrakeAction"]
    assert [a["after"] for a in actions] == [[m["id"]] for m in markers]
    by_id = {e["id"]: e for e in doc["execute"]}
    assert [m["after"] for m in markers] == [["M"], ["Brake-standby"], ["Brake_2-standby"]]  # each after the one before
    assert [by_id[f"{m['id']}-{w}"]["params"]["value"] for m, w in zip(markers, ("standby", "standby", "complete"))] == [0, 0, 2]
    assert all(m["when"] == markers[0]["when"] and m["edge"] == "rising" for m in markers)  # the trigger again
    too_many = BRAKE.replace('<Event name="Brake" priority="override">', '<Event name="Brake" priority="override" maximumExecutionCount="101">')
    assert problems(write(tmp_path, scenario(too_many, PARAMS)))[0].endswith("maximumExecutionCount 101 must be between 1 and 100")
