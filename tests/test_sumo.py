"""Eclipse SUMO as the system under test (docs/sumo.md).

The scenario checks read XML only and always run. Everything that runs the
simulator needs libsumo (the ``sumo`` extra): those tests skip without it,
except under CI (``CI`` set), where ``.ci/run`` installs the extra - the same
rule as the Graphviz tests.
"""

from __future__ import annotations

import importlib.util
import os
import pathlib
import shutil
from typing import Any

import pytest

from btgen_pytrees.systems.sumo.scenario import OPTIONS, parse_options, read_scenario

ROOT = pathlib.Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples" / "sumo"

needs_sumo = pytest.mark.skipif(
    importlib.util.find_spec("libsumo") is None and not os.environ.get("CI"),
    reason="libsumo is not installed (pip install -e '.[sumo]'; CI installs it)",
)

NET = (EXAMPLES / "road.net.xml").read_text(encoding="utf-8")
ROUTES = """<routes>
    <vType id="car" sigma="0"/>
    <route id="east" edges="A0B0 B0C0"/>
    <vehicle id="ego" type="car" route="east" depart="0" departSpeed="10"/>
</routes>
"""
CONFIG = """<configuration>
    <input>
        <net-file value="road.net.xml"/>
        <route-files value="r.rou.xml"/>
    </input>
</configuration>
"""


def scenario_dir(tmp_path: pathlib.Path, config: str = CONFIG, routes: str = ROUTES, **files: str) -> pathlib.Path:
    """A scenario directory with the example network; returns the .sumocfg path."""
    (tmp_path / "road.net.xml").write_text(NET, encoding="utf-8")
    (tmp_path / "r.rou.xml").write_text(routes, encoding="utf-8")
    for name, text in files.items():
        (tmp_path / name.replace("__", ".")).write_text(text, encoding="utf-8")
    cfg = tmp_path / "s.sumocfg"
    cfg.write_text(config, encoding="utf-8")
    return cfg


# ---------------------------------------------------------------------------
# reading the scenario (no simulator)


def test_example_scenario_declares_vehicles_routes_lanes_and_the_traffic_light() -> None:
    s = read_scenario(str(EXAMPLES / "acc.sumocfg"))
    assert s.problems == ()
    assert sorted(s.vehicles) == ["ego", "lead"]
    assert s.routes == {"east"}
    assert {"car", "acc", "DEFAULT_VEHTYPE"} <= s.types
    assert s.lanes == {"A0B0": 2, "B0A0": 2, "B0C0": 2, "C0B0": 2}
    assert s.signals == {"B0": 4}
    assert s.route_edges == {"east": "A0B0"}


@pytest.mark.parametrize(
    ("config", "files", "expected"),
    [
        ("<configuration><input><net-file value='road.net.xml'/></input><output><fcd-output value='f.xml'/></output></configuration>",
         {}, "s.sumocfg:1: option 'fcd-output' is not allowed"),
        ("<configuration><input><net-file value='road.net.xml'/><route-files value='r.rou.xml'/></input>"
         "<report><log value='log.txt'/></report></configuration>", {}, "option 'log' is not allowed"),
        ("<configuration><input><net-file value='/etc/passwd'/></input></configuration>", {},
         "'/etc/passwd' must be a relative path inside the configuration's directory"),
        ("<configuration><input><net-file value='../road.net.xml'/></input></configuration>", {},
         "'../road.net.xml' must not leave the configuration's directory"),
        ("<configuration><input><net-file value='http://example.com/n.xml'/></input></configuration>", {},
         "must be a relative path"),
        ("<configuration><input><net-file value='road.net.xml'/><route-files value='missing.rou.xml'/></input></configuration>",
         {}, "missing.rou.xml: cannot read: No such file or directory"),
        ("<configuration><input><net-file value='road.net.xml'/>", {}, "s.sumocfg:1: not well-formed XML"),
        ("<configuration><input><route-files value='r.rou.xml'/></input></configuration>", {},
         "needs exactly one 'net-file' (found 0)"),
        ("<configuration><input><net-file value='r.rou.xml'/></input></configuration>", {},
         "r.rou.xml:1: not a SUMO network (root element <routes>)"),
        ("<configuration><input><net-file value='road.net.xml'/><additional-files value='a.add.xml'/></input></configuration>",
         {"a__add__xml": "<additional>\n<inductionLoop id='d' lane='A0B0_0' pos='5' period='1' file='out.xml'/></additional>"},
         "a.add.xml:2: attribute 'file' of <inductionLoop> names a file"),
        ("<configuration><input><net-file value='road.net.xml'/><additional-files value='a.add.xml'/></input></configuration>",
         {"a__add__xml": "<additional><include href='/etc/x.xml'/></additional>"}, "<include> is not allowed"),
        ("<configuration><input><net-file value='road.net.xml'/><additional-files value='a.add.xml'/></input></configuration>",
         {"a__add__xml": "<additional><vType id='t'><param key='device.ssm.probability' value='1'/></vType></additional>"},
         "equips a device"),
        ("<configuration><input><net-file value='road.net.xml'/><additional-files value='a.add.xml'/></input></configuration>",
         {"a__add__xml": "<?xml version='1.0'?><!DOCTYPE a [<!ENTITY x 'y'>]><additional/>"}, "a DOCTYPE is not allowed"),
        ("<configuration><input><net-file value='road.net.xml'/><additional-files value='a.add.xml'/></input></configuration>",
         {"a__add__xml": "<additional><route id='r' edges='A0B0 nowhere'/></additional>"},
         "the route uses edge 'nowhere', which the network does not have"),
        ("<configuration><input><net-file value='road.net.xml'/><additional-files value='a.add.xml'/></input></configuration>",
         {"a__add__xml": "<additional><vehicle id='v' route='west' depart='0'/></additional>"},
         "vehicle 'v' uses route 'west', which no file declares"),
        ("<configuration><input><net-file value='road.net.xml'/></input><time><step-length value='1'/></time></configuration>",
         {}, "option 'step-length' is not allowed"),
        ("<configuration><processing><collision.action value='explode'/></processing></configuration>", {},
         "collision.action: expected one of none, warn, teleport, remove, not 'explode'"),
        ("", {}, "not well-formed XML"),
    ],
)
def test_a_scenario_that_could_read_or_write_other_files_or_is_broken_is_a_problem(
        tmp_path: pathlib.Path, config: str, files: dict[str, str], expected: str) -> None:  # fmt: skip
    cfg = scenario_dir(tmp_path, config, **files)
    problems = read_scenario(str(cfg)).problems
    assert len(problems) == 1 and expected in problems[0], problems


def test_a_symbolic_link_out_of_the_directory_is_a_problem(tmp_path: pathlib.Path) -> None:
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "n.net.xml").write_text(NET, encoding="utf-8")
    inside = tmp_path / "scenario"
    inside.mkdir()
    os.symlink(outside / "n.net.xml", inside / "road.net.xml")
    cfg = inside / "s.sumocfg"
    cfg.write_text("<configuration><input><net-file value='road.net.xml'/></input></configuration>", encoding="utf-8")
    (problem,) = read_scenario(str(cfg)).problems
    assert "leads outside the configuration's directory" in problem


def test_a_missing_configuration_is_a_problem(tmp_path: pathlib.Path) -> None:
    (problem,) = read_scenario(str(tmp_path / "nope.sumocfg")).problems
    assert problem == "nope.sumocfg: cannot read: No such file or directory"


def test_options_are_checked_against_the_allow_list() -> None:
    values, problems = parse_options(["--seed", "7", "--collision.action=warn", "--lateral-resolution", "0.8"])
    assert values == {"seed": "7", "collision.action": "warn", "lateral-resolution": "0.8"} and problems == []
    _, problems = parse_options(["--fcd-output", "x.xml", "--seed", "x", "--collsion.action", "warn", "seed", "--seed"])
    assert problems == [
        (0, "option '--fcd-output' is not allowed for SUMO cases (see the allow-list in docs/sumo.md)"),
        (3, "--seed: expected an integer, not 'x'"),
        (4, "option '--collsion.action' is not allowed for SUMO cases (did you mean '--collision.action'?)"),
        (6, "expected an option such as '--seed', not 'seed'"),
        (7, "option '--seed' needs a value"),
    ]
    assert not any("file" in name or "output" in name for name in OPTIONS)


def test_the_example_network_is_what_its_documented_command_makes(tmp_path: pathlib.Path) -> None:
    netgenerate = shutil.which("netgenerate")
    if netgenerate is None:
        if os.environ.get("CI"):
            pytest.fail("netgenerate is missing under CI (the sumo extra installs it)")
        pytest.skip("netgenerate is not installed (pip install -e '.[sumo]')")
    script = (EXAMPLES / "make_network.sh").read_text(encoding="utf-8")
    assert "netgenerate --grid" in script
    shutil.copy(EXAMPLES / "make_network.sh", tmp_path / "make_network.sh")
    import subprocess

    subprocess.run(["sh", str(tmp_path / "make_network.sh")], check=True, capture_output=True, timeout=60)

    def body(text: str) -> list[str]:  # without the comment that holds the date of generation
        return text.split("-->", 1)[1].split("\n")

    assert body((tmp_path / "road.net.xml").read_text(encoding="utf-8")) == body(NET)
