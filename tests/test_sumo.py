"""Eclipse SUMO as the system under test (docs/sumo.md).

The scenario checks read XML only and always run. Everything that runs the
simulator needs libsumo (the ``sumo`` extra): those tests skip without it,
except under CI (``CI`` set), where ``.ci/run`` installs the extra - the same
rule as the Graphviz tests.
"""

from __future__ import annotations

import contextlib
import importlib.util
import math
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


def test_a_scenario_is_read_once_per_content_and_again_whenever_a_file_changes(tmp_path: pathlib.Path) -> None:
    """read_scenario keeps what it read (a search reads the same scenario for every run) and gives
    it back only while every file has the same real path, size and content - not the same mtime."""
    outside, tmp_path = tmp_path / "outside", tmp_path / "scenario"
    outside.mkdir()
    tmp_path.mkdir()
    cfg = scenario_dir(tmp_path)
    first = read_scenario(str(cfg))
    assert first.problems == () and read_scenario(str(cfg)) is first
    routes = tmp_path / "r.rou.xml"
    stamp = routes.stat()
    routes.write_text(ROUTES.replace('id="ego"', 'id="egg"'), encoding="utf-8")  # same size, same mtime
    os.utime(routes, ns=(stamp.st_atime_ns, stamp.st_mtime_ns))
    second = read_scenario(str(cfg))
    assert second is not first and sorted(second.vehicles) == ["egg"]
    assert read_scenario(str(cfg)) is second
    (tmp_path / "more.rou.xml").write_text(ROUTES.replace('id="ego"', 'id="other"'), encoding="utf-8")
    cfg.write_text(CONFIG.replace("r.rou.xml", "r.rou.xml more.rou.xml"), encoding="utf-8")
    assert sorted(read_scenario(str(cfg)).vehicles) == ["egg", "other"]
    (tmp_path / "more.rou.xml").write_text("<routes><vehicle id='x' route='nowhere' depart='0'/></routes>", encoding="utf-8")
    (problem,) = read_scenario(str(cfg)).problems
    assert "vehicle 'x' uses route 'nowhere', which no file declares" in problem
    assert read_scenario(str(cfg)).problems == (problem,)  # a scenario with problems is read again every time
    (outside / "road.net.xml").write_text(NET, encoding="utf-8")
    (tmp_path / "more.rou.xml").unlink()
    cfg.write_text(CONFIG, encoding="utf-8")
    assert read_scenario(str(cfg)).vehicles == {"egg": "0"}
    (tmp_path / "road.net.xml").unlink()
    os.symlink(outside / "road.net.xml", tmp_path / "road.net.xml")  # the same bytes, now out of the directory
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


# ---------------------------------------------------------------------------
# loading SUMO cases (the loader asks the sumo system type)

import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402

import btgen_pytrees  # noqa: E402
from btgen_pytrees.run import run  # noqa: E402

from helpers import crit, entry  # noqa: E402

SCENARIO = """<routes>
    <vType id="car" length="5" minGap="2.5" maxSpeed="30" accel="2.6" decel="4.5" emergencyDecel="9" sigma="0"
           lcSpeedGain="0" lcKeepRight="0"/>
    <route id="east" edges="A0B0 B0C0"/>
    <route id="short" edges="B0C0"/>
    <vehicle id="ego" type="car" route="east" depart="0" departPos="20" departLane="0" departSpeed="10"/>
    <vehicle id="other" type="car" route="east" depart="0" departPos="20" departLane="1" departSpeed="10"/>
    <vehicle id="late" type="car" route="east" depart="100" departLane="0"/>
</routes>
"""


def sumo_case(tmp_path: pathlib.Path, *entries: dict[str, Any], criteria: list[dict[str, Any]] | None = None,
              routes: str = SCENARIO, options: list[str] | None = None, timeout: float = 20,
              name: str = "t", tick: float = 0.1) -> pathlib.Path:  # fmt: skip
    """A case file over the example road with *routes*; returns its path."""
    scenario_dir(tmp_path, routes=routes)
    data: dict[str, Any] = {"name": name, "tick": tick, "timeout": timeout,
                            "system": {"type": "sumo", "config": "s.sumocfg", "options": options or []},
                            "execute": list(entries)}  # fmt: skip
    if criteria is not None:
        data["oracle"] = {"criteria": criteria}
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(data), encoding="utf-8")
    return path


def problems_of(path: pathlib.Path) -> list[str]:
    with pytest.raises(btgen_pytrees.InvalidTestCase) as info:
        btgen_pytrees.load(path)
    return [f"{p.pointer}: {p.message}" for p in info.value.problems]


def cli(*args: str, cwd: pathlib.Path = ROOT) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "btgen_pytrees", *args], capture_output=True, text=True,
                          cwd=cwd, timeout=300, check=False)  # fmt: skip


@pytest.fixture
def with_libsumo(monkeypatch: pytest.MonkeyPatch) -> None:
    """Loading checks that libsumo is installed; these tests only read files, so pretend it is."""
    monkeypatch.setattr("btgen_pytrees.systems.sumo.libsumo_installed", lambda: True)


def test_unknown_vehicles_signals_routes_and_lights_are_validation_errors(tmp_path: pathlib.Path, with_libsumo: None) -> None:
    path = sumo_case(
        tmp_path,
        entry("B1", action="sumo.speed", vehicle="egoo", to=5),
        entry("B2", action="sumo.spawn", vehicle="ego", route="esat", lane=0),
        entry("B3", action="sumo.spawn", vehicle="new", route="east", lane=2),
        entry("B4", action="sumo.signal", tls="B0x", state="rrrr"),
        entry("B5", action="sumo.signal", tls="B0", state="rr"),
        entry("B6", action="sumo.lane", vehicle="ego", lane=5),
        entry("B7", action="set", signal="ego.speed", value=3),
        criteria=[crit("R1", "record", "ego.sped > 0")],
    )
    assert problems_of(path) == [
        "/execute/0/params/vehicle: unknown vehicle 'egoo' (did you mean 'ego'?)",
        "/execute/1/params/route: unknown route 'esat' (did you mean 'east'?)",
        "/execute/1/params/vehicle: vehicle 'ego' is already declared in the route files",
        "/execute/2/params/lane: lane 2 does not exist: edge 'A0B0' has 2 lane(s)",
        "/execute/3/params/tls: unknown traffic light 'B0x' (did you mean 'B0'?)",
        "/execute/4/params/state: traffic light 'B0' controls 4 links; the state has 2 letters",
        "/execute/5/params/lane: lane 5 does not exist: no edge of the network has more than 2 lane(s)",
        "/execute/6/params/signal: signal 'ego.speed' belongs to the 'sumo' system and is read-only for the test; "
        "use the action 'sumo.speed' instead",
    ]


def test_an_unknown_attribute_is_an_unknown_signal_with_a_hint(tmp_path: pathlib.Path, with_libsumo: None) -> None:
    path = sumo_case(tmp_path, entry("C1", action="wait"),
                     criteria=[crit("R1", "record", "ego.sped > 0 && new.speed >= 0 && sim.collisions == 0")])
    assert problems_of(path) == [
        "/oracle/criteria/0/expect: unknown signal 'ego.sped' in 'ego.sped > 0 && new.speed >= 0 && sim.collisions == 0' "
        "(did you mean 'ego.speed'?)",
        "/oracle/criteria/0/expect: unknown signal 'new.speed' in 'ego.sped > 0 && new.speed >= 0 && sim.collisions == 0' "
        "(did you mean 'ego.speed'?)",
    ]


def test_options_outside_the_allow_list_and_unsafe_configurations_exit_2_with_the_json_path(
        tmp_path: pathlib.Path) -> None:  # fmt: skip
    path = sumo_case(tmp_path, entry("C1", action="wait"), options=["--seed", "3", "--fcd-output", "f.xml"])
    (tmp_path / "s.sumocfg").write_text(
        "<configuration>\n<input><net-file value='road.net.xml'/></input>\n"
        "<output><tripinfo-output value='/tmp/x.xml'/></output>\n</configuration>", encoding="utf-8")
    done = cli("run", str(path))
    assert done.returncode == 2, done
    assert f"{path}: /system/options/2: option '--fcd-output' is not allowed" in done.stderr
    assert f"{path}: /system/config: s.sumocfg:3: option 'tripinfo-output' is not allowed" in done.stderr
    assert "Traceback" not in done.stderr and done.stdout == ""


def test_without_libsumo_a_sumo_case_says_how_to_install_it(tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr("btgen_pytrees.systems.sumo.libsumo_installed", lambda: False)
    path = sumo_case(tmp_path, entry("C1", action="wait"))
    assert problems_of(path) == [
        "/system/type: the 'sumo' system needs libsumo, which is not installed: pip install -e '.[sumo]'"]


# ---------------------------------------------------------------------------
# running the simulator


def final_values(report: Any, criterion: str) -> dict[str, Any]:
    (oracle,) = [o for o in report.oracles if o.id == criterion]
    return oracle.values


def sumo_processes() -> set[int]:
    """Pids of this process's descendants called sumo* (libsumo starts none; the diagnosis of a failed load
    may). Only descendants: under pytest-xdist another worker's tests may run SUMO at the same time."""
    found, parents = set(), {}
    for pid in os.listdir("/proc") if os.path.isdir("/proc") else ():
        try:
            with open(f"/proc/{pid}/stat", encoding="utf-8") as fh:
                stat = fh.read()
            parents[int(pid)] = int(stat[stat.rindex(")") + 2:].split()[1])
            with open(f"/proc/{pid}/comm", encoding="utf-8") as fh:
                if fh.read().startswith("sumo"):
                    found.add(int(pid))
        except (OSError, ValueError, IndexError):
            continue
    me = os.getpid()

    def descends(pid: int) -> bool:
        seen = set()
        while pid > 1 and pid not in seen:
            seen.add(pid)
            pid = parents.get(pid, 0)
            if pid == me:
                return True
        return False

    return {pid for pid in found if descends(pid)}


@needs_sumo
def test_the_examples_pass_and_fail_as_described_from_the_command_line() -> None:
    before = sumo_processes()
    done = cli("run", "examples/sumo/acc_hard_brake.json")
    assert done.returncode == 0, done.stdout + done.stderr
    assert "acc_hard_brake: PASS after 9.2 s" in done.stdout
    done = cli("run", "examples/sumo/cut_in.json")
    assert done.returncode == 1, done.stdout + done.stderr
    assert "R1 (no collision)           record  sim.collisions == 0   fail          4   sim.collisions == 0 false by 1 at 4 s (sim.collisions=1)" in done.stdout
    assert "criterion R1 (no collision) (record) failed: sim.collisions == 0 false by 1 at 4 s (sim.collisions=1)" in done.stdout
    assert "cut_in: FAIL after 4 s (41 ticks) - R1 failed" in done.stdout
    assert done.stderr == ""
    assert sumo_processes() <= before


@needs_sumo
def test_batch_mode_runs_sumo_cases_in_worker_processes() -> None:
    done = cli("run", "examples/sumo/", "--jobs", "2")
    assert done.returncode == 1, done.stdout + done.stderr
    assert "examples/sumo/acc_hard_brake.json  ok       pass after 9.2 s" in done.stdout
    assert "examples/sumo/cut_in.json          FAIL     fail after 4 s: R1 failed" in done.stdout


@needs_sumo
def test_acc_example_keeps_its_distance_and_runs_the_same_twice() -> None:
    case = btgen_pytrees.load(EXAMPLES / "acc_hard_brake.json")
    first, second = run(case), run(case)
    assert first.verdict == "pass" and first.to_json() == second.to_json()
    (gap,) = [o for o in first.oracles if o.id == "R2"]
    assert [o.verdict for o in first.oracles] == ["pass", "pass", "pass", "pass"]
    seen = [values["ego.gap"] for _, values in gap.samples]
    assert 10 <= min(seen) < 20  # the ACC closes in to about 18 m behind the lead when it is nearly stopped
    assert final_values(first, "F1")["lead.speed"] == 0


@needs_sumo
def test_signals_time_and_the_speed_ramp(tmp_path: pathlib.Path) -> None:
    path = sumo_case(
        tmp_path,
        entry("B1", action="sumo.speed", vehicle="ego", to=14, duration=2),
        entry("C1", action="wait", duration=3),
        criteria=[
            crit("F0", "final", "ego.present && ego.speed == 10 && ego.distance == 0 && ego.lane == 0 && ego.x == 20",
                 at=0),
            crit("F1", "final", "abs(ego.speed - 12) < 1e-6 && ego.accel > 0", at=1),
            crit("F2", "final", "abs(ego.speed - 14) < 1e-6 && ego.lane == 0 && other.lane == 1", at=2.5),
            crit("F3", "final", "!late.present && late.lane == -1 && !late.collided && sim.vehicles == 2 && "
                 "sim.collisions == 0 && ego.gap > 1e308 && ego.ttc > 1e308 && ego.lateral == 0", at=2.5),  # fmt: skip
        ],
    )
    report = run(btgen_pytrees.load(path))
    assert report.verdict == "pass", report.message
    assert final_values(report, "F0")["ego.x"] == 20  # departPos, the front bumper, on a road that starts at x = 0
    assert final_values(report, "F2")["other.lane"] == 1
    assert [o.at for o in report.oracles] == [0, 1, 2.5, 2.5]


@needs_sumo
def test_a_vehicle_that_has_not_departed_has_no_motion_signals_and_actions_on_it_fail(tmp_path: pathlib.Path) -> None:
    path = sumo_case(
        tmp_path,
        entry("B1", action="sumo.speed", vehicle="late", to=5),
        criteria=[crit("R1", "record", "late.speed >= 0")],
    )
    report = run(btgen_pytrees.load(path))
    assert report.verdict == "fail"
    assert report.execute[0].message == "vehicle 'late' is not in the network (it departs at '100')"
    (r1,) = report.oracles
    assert r1.message == "signal 'late.speed' has no value at 0 s"


@needs_sumo
def test_lane_change_release_spawn_and_signal(tmp_path: pathlib.Path) -> None:
    routes = SCENARIO.replace('departPos="20" departLane="1"', 'departPos="200" departLane="1"')
    path = sumo_case(
        tmp_path,
        entry("B1", action="sumo.lane", vehicle="ego", lane=1, timeout=3),
        entry("B2", ["B1"], action="sumo.spawn", vehicle="new", route="short", lane=0, speed=5),
        entry("B3", ["B2"], action="sumo.speed", vehicle="new", to=0, duration=1),
        entry("B4", ["B3"], action="sumo.release", vehicle="new"),
        entry("C4", ["B4"], action="until", expect="new.speed > 2", timeout=5),
        entry("B5", action="sumo.signal", tls="B0", state="rrrr"),
        criteria=[
            crit("F1", "final", "ego.lane == 1 && new.present && new.lane == 0 && new.speed > 2 && sim.vehicles == 3"),
        ],
        routes=routes,
    )
    report = run(btgen_pytrees.load(path))
    assert report.verdict == "pass", (report.message, report.execute)
    b1, b2, b3, b4, c4, b5 = report.execute
    assert (b1.status, b1.end) == ("success", 0.1)  # asked at 0, changed in SUMO's step at 0.1
    assert (b2.start, b2.end) == (0.1, 0.2)  # inserted in the next step
    assert b3.end == pytest.approx(1.2) and b4.end == pytest.approx(1.2)
    assert b5.status == "success"


@needs_sumo
def test_a_red_light_set_by_the_test_stops_the_traffic(tmp_path: pathlib.Path) -> None:
    path = sumo_case(
        tmp_path,
        entry("B1", action="sumo.signal", tls="B0", state="rrrr"),
        entry("C1", ["B1"], action="until", expect="ego.speed < 0.1 && ego.distance > 100", timeout=60),
        criteria=[crit("F1", "final", "ego.x < 500 && ego.x > 450")],
        timeout=70,
    )
    report = run(btgen_pytrees.load(path))
    assert report.verdict == "pass", report.message


@needs_sumo
def test_an_unsafe_speed_provokes_a_collision_a_safe_one_does_not(tmp_path: pathlib.Path) -> None:
    routes = SCENARIO.replace('departPos="20" departLane="1"', 'departPos="60" departLane="0"')
    for safe, verdict in ((True, "pass"), (False, "fail")):
        path = sumo_case(
            tmp_path,
            entry("B1", action="sumo.speed", vehicle="other", to=0, duration=0),
            entry("B2", action="sumo.speed", vehicle="ego", to=25, duration=2, safe=safe),
            entry("C1", action="wait", duration=8),
            criteria=[crit("R1", "record", "sim.collisions == 0 && !ego.collided")],
            routes=routes,
        )
        report = run(btgen_pytrees.load(path))
        assert report.verdict == verdict, (safe, report.message)
    assert report.oracles[0].values == {"sim.collisions": 1, "ego.collided": True}


@needs_sumo
def test_when_every_vehicle_has_arrived_the_run_ends_with_a_clear_error(tmp_path: pathlib.Path) -> None:
    routes = SCENARIO.replace('route="east" depart="0" departPos="20" departLane="0"', 'route="short" depart="0" departPos="480" departLane="0"')
    routes = routes.replace('<vehicle id="other"', '<!-- ').replace('departSpeed="10"/>\n    <vehicle id="late"', '-->\n    <vehicle id="late"')
    routes = routes.replace('<vehicle id="late" type="car" route="east" depart="100" departLane="0"/>', "")
    path = sumo_case(tmp_path, entry("C1", action="wait", duration=30), timeout=60, routes=routes)
    report = run(btgen_pytrees.load(path))
    assert report.verdict == "error"
    assert report.message.startswith("the SUMO simulation has no vehicles left at ")
    assert report.message.endswith(" s (every vehicle has arrived) while the test is still running")


@needs_sumo
def test_a_spawn_that_cannot_be_inserted_fails_after_its_timeout(tmp_path: pathlib.Path) -> None:
    path = sumo_case(
        tmp_path,
        entry("B0", action="sumo.speed", vehicle="ego", to=0, safe=False),  # stops at once, at about 20 m
        entry("B1", action="sumo.spawn", vehicle="new", route="east", lane=0, position=20, timeout=1),
    )
    report = run(btgen_pytrees.load(path))
    assert report.verdict == "fail"
    assert report.execute[1].message == "SUMO could not insert 'new' within 1 s (its place is blocked?)"


@needs_sumo
def test_a_leaf_that_raises_ends_the_run_and_closes_the_simulation(tmp_path: pathlib.Path) -> None:
    import libsumo
    import py_trees

    from btgen_pytrees.leaves import default_registry

    class Boom(py_trees.behaviour.Behaviour):
        def __init__(self, entry: Any, env: Any):
            super().__init__(entry.name)

        def update(self) -> Any:
            raise RuntimeError("boom")

    registry = default_registry()
    registry.register("boom", Boom)
    path = sumo_case(tmp_path, entry("C1", action="wait"), entry("B1", ["C1"], action="boom"))
    report = run(btgen_pytrees.load(path, registry=registry), registry=registry)
    assert (report.verdict, report.message) == ("error", "B1 raised RuntimeError: boom")
    assert not libsumo.simulation.isLoaded()
    assert run(btgen_pytrees.load(EXAMPLES / "cut_in.json")).verdict == "fail"  # the next run starts cleanly


@needs_sumo
def test_one_simulation_per_process(tmp_path: pathlib.Path) -> None:
    from btgen_pytrees.leaves import Environment
    from btgen_pytrees.run import create_system
    from btgen_pytrees.systems import SystemFailure

    case = btgen_pytrees.load(EXAMPLES / "cut_in.json")
    first, second = create_system(case), create_system(case)
    first.close()  # before start: nothing to do
    first.start(Environment("/sumo_test_1"))
    try:
        with pytest.raises(SystemFailure, match="libsumo runs one simulation per process"):
            second.start(Environment("/sumo_test_2"))
    finally:
        first.close()
        first.close()
    second.start(Environment("/sumo_test_2"))
    second.close()


@needs_sumo
def test_a_scenario_sumo_refuses_ends_the_run_with_sumo_s_message(tmp_path: pathlib.Path) -> None:
    routes = SCENARIO.replace('departPos="20" departLane="0"', 'departPos="20" departLane="7"')
    path = sumo_case(tmp_path, entry("C1", action="wait"), routes=routes)
    before = sumo_processes()
    report = run(btgen_pytrees.load(path))
    assert report.verdict == "error"
    assert report.message == "SUMO stopped at 0 s: Invalid departLane definition for vehicle 'ego'."
    assert sumo_processes() <= before
    routes = SCENARIO.replace('accel="2.6"', 'accel="fast"')
    path = sumo_case(tmp_path, entry("C1", action="wait"), routes=routes)
    report = run(btgen_pytrees.load(path))
    assert report.verdict == "error"
    assert report.message.startswith(f"SUMO could not load {tmp_path / 's.sumocfg'}: ")
    assert "Attribute accel. Cannot be parsed to float" in report.message, report.message
    assert sumo_processes() <= before


def test_a_sumo_action_in_a_case_without_the_sumo_system_is_a_validation_error() -> None:
    data = {"name": "t", "execute": [entry("B1", action="sumo.speed", vehicle="ego", to=3), entry("B2", action="sett")]}
    with pytest.raises(btgen_pytrees.InvalidTestCase) as info:
        btgen_pytrees.load(data)
    messages = [f"{p.pointer}: {p.message}" for p in info.value.problems]
    assert messages[0] == ("/execute/0/action: 'sumo.speed' is an action of the 'sumo' system; this case's system is "
                           "'simulated' (set \"system\": {\"type\": \"sumo\", ...})")  # fmt: skip
    assert messages[1].startswith("/execute/1/action: unknown behavior action 'sett' (did you mean 'set'?); known: hold, profile, ramp, set")


SAMPLES = {"seed": ["7"], "collision.action": ["none", "warn", "teleport", "remove"],
           "collision.check-junctions": ["true", "false"], "collision.mingap-factor": ["0.5"],
           "collision.stoptime": ["1"], "lateral-resolution": ["0.8"], "default.action-step-length": ["0.5"],
           "default.speeddev": ["0.1"], "default.carfollowmodel": ["IDM"],
           "time-to-teleport": ["100", "-1"], "time-to-teleport.highways": ["100"], "max-depart-delay": ["10", "-1"],
           "lanechange.duration": ["1"], "step-method.ballistic": ["true"], "ignore-junction-blocker": ["10"],
           "emergencydecel.warning-threshold": ["1.5"]}  # fmt: skip
"""Values of every allowed option that its check accepts; SUMO must accept them too."""


@needs_sumo
def test_sumo_knows_every_allowed_option_and_value(tmp_path: pathlib.Path) -> None:
    """An option the allow-list accepts but SUMO does not know would pass validation and end every run in
    'SUMO could not load' (``--default.sigma`` was one: SUMO sets sigma per vType only). Every allowed option,
    with values its check accepts (every car-following model), starts a simulation in libsumo (in this
    process: a sumo binary would be a process other tests look for)."""
    from btgen_pytrees.systems.sumo.system import libsumo_module

    libsumo = libsumo_module()
    models = ["Krauss", "KraussPS", "KraussOrig1", "SmartSK", "Daniel1", "IDM", "IDMM", "EIDM", "PWagner2009",
              "BKerner", "Wiedemann", "W99", "Rail", "ACC", "CACC"]  # fmt: skip
    allowed = (OPTIONS["default.carfollowmodel"][0]("?") or "").removeprefix("expected one of ").split(", not")[0]
    assert set(models) | {"CC"} == set(allowed.split(", "))
    # "CC" is known too, but SUMO loads it only for types that give its lanesCount: not this scenario's
    samples = {**SAMPLES, "default.carfollowmodel": models}
    assert set(samples) == set(OPTIONS)
    cfg = scenario_dir(tmp_path)
    for name, values in samples.items():
        for value in values:
            assert OPTIONS[name][0](value) is None, (name, value)
            try:
                libsumo.start(["sumo", "-c", str(cfg), f"--{name}", value, "--no-step-log", "true", "--no-warnings", "true"])
                libsumo.simulationStep()
            except Exception as exc:  # noqa: BLE001 - libsumo.TraCIException
                pytest.fail(f"--{name} {value}: {exc}")
            finally:
                with contextlib.suppress(Exception):
                    libsumo.close()


def test_the_option_allow_list_is_documented() -> None:
    format_md = (ROOT / "docs" / "format.md").read_text(encoding="utf-8")
    sumo_md = (ROOT / "docs" / "sumo.md").read_text(encoding="utf-8")
    for name in OPTIONS:
        assert f"`--{name}`" in format_md and f"`--{name}`" in sumo_md, name


@needs_sumo
def test_an_infinite_gap_is_written_to_the_json_report_as_text(tmp_path: pathlib.Path) -> None:
    import jsonschema

    path = sumo_case(tmp_path, entry("C1", action="wait"), criteria=[crit("F1", "final", "ego.gap < 1000")])
    done = cli("run", str(path), "--json", str(tmp_path / "r.json"))
    assert done.returncode == 1 and "ego.gap < 1000 false by inf at 1 s (ego.gap=inf)" in done.stdout, done.stderr
    text = (tmp_path / "r.json").read_text(encoding="utf-8")
    report = json.loads(text, parse_constant=lambda name: pytest.fail(f"{name} in the JSON report"))
    assert report["oracles"][0]["values"] == {"ego.gap": "inf"}
    jsonschema.validate(report, json.loads((ROOT / "schemas" / "report.schema.json").read_text(encoding="utf-8")))


@needs_sumo
@pytest.mark.usefixtures("pythons_ctrl_c")  # its KeyboardInterrupt is the host's Ctrl-C: goes on
def test_ctrl_c_in_a_sumo_run_closes_the_simulation_and_goes_on(tmp_path: pathlib.Path) -> None:
    import libsumo
    import py_trees

    from btgen_pytrees.leaves import default_registry

    class Interrupt(py_trees.behaviour.Behaviour):
        def __init__(self, entry: Any, env: Any):
            super().__init__(entry.name)

        def update(self) -> Any:
            raise KeyboardInterrupt

    registry = default_registry()
    registry.register("interrupt", Interrupt)
    path = sumo_case(tmp_path, entry("C1", action="wait"), entry("B1", ["C1"], action="interrupt"))
    with pytest.raises(KeyboardInterrupt):
        run(btgen_pytrees.load(path, registry=registry), registry=registry)
    assert not libsumo.simulation.isLoaded()
    assert run(btgen_pytrees.load(EXAMPLES / "cut_in.json")).verdict == "fail"


# ---------------------------------------------------------------------------
# the truth outside the project: libsumo's own getters, read by a probe leaf during the run


class Probe:
    """Registers ``probe {duration, vehicles}``: a leaf that, on every tick until *duration*, notes the run's time
    and what libsumo itself says - SUMO's time and step, and per vehicle its lane index and leader."""

    def __init__(self) -> None:
        self.seen: list[dict[str, Any]] = []

    def registry(self) -> Any:
        import libsumo
        import py_trees
        from py_trees.common import Status

        from btgen_pytrees.leaves import default_registry

        seen = self.seen

        class Leaf(py_trees.behaviour.Behaviour):
            def __init__(self, entry: Any, env: Any):
                super().__init__(entry.name)
                self.env, self.duration, self.vehicles = env, entry.params["duration"], entry.params.get("vehicles", [])

            def update(self) -> Any:
                present = set(libsumo.vehicle.getIDList())
                seen.append({
                    "now": self.env.now(), "sumo": libsumo.simulation.getTime(), "dt": libsumo.simulation.getDeltaT(),
                    "lane": {v: libsumo.vehicle.getLaneIndex(v) for v in self.vehicles if v in present},
                    "leader": {v: libsumo.vehicle.getLeader(v, 1000) for v in self.vehicles if v in present}})
                return Status.SUCCESS if self.env.now() >= self.duration - 1e-9 else Status.RUNNING

        registry = default_registry()
        registry.register("probe", Leaf)
        return registry

    def lanes(self, vid: str) -> list[tuple[float, int]]:
        return [(s["now"], s["lane"][vid]) for s in self.seen if vid in s["lane"]]


def probe(duration: float, *vehicles: str) -> dict[str, Any]:
    return entry("PROBE", action="probe", duration=duration, vehicles=list(vehicles))


def test_a_tick_that_sumo_cannot_step_is_refused_at_load_naming_the_nearest_valid_ticks(
        tmp_path: pathlib.Path, with_libsumo: None) -> None:  # fmt: skip
    def tick_problems(tick: float) -> list[str]:
        path = sumo_case(tmp_path, entry("C1", action="wait"), tick=tick, timeout=5)
        try:
            btgen_pytrees.load(path)
        except btgen_pytrees.InvalidTestCase as exc:
            return [f"{p.pointer}: {p.message}" for p in exc.problems]
        return []

    assert tick_problems(0.0125) == ["/tick: SUMO keeps time in whole milliseconds: a tick of 0.0125 s is not one; "
                                     "the nearest valid ticks are 0.012 and 0.013 s"]  # fmt: skip
    assert tick_problems(1 / 30) == ["/tick: SUMO keeps time in whole milliseconds: a tick of 0.0333333 s is not one; "
                                     "the nearest valid ticks are 0.033 and 0.034 s"]  # fmt: skip
    assert tick_problems(0.0005) == ["/tick: SUMO keeps time in whole milliseconds: a tick of 0.0005 s is below "
                                     "SUMO's resolution; the smallest valid tick is 0.001 s"]  # fmt: skip
    for tick in (0.001, 0.01, 0.1, 0.3, 0.7, 1, 2.5):
        assert tick_problems(tick) == [], tick
    done = cli("validate", str(sumo_case(tmp_path, entry("C1", action="wait"), tick=0.0125, timeout=5)))
    assert done.returncode == 2 and "/tick: SUMO keeps time in whole milliseconds" in done.stderr, done


@needs_sumo
def test_the_run_s_clock_is_sumo_s_own_time_on_every_tick(tmp_path: pathlib.Path) -> None:
    """Even a tick SUMO rounds (only reachable past the loader): every time of the run is SUMO's."""
    from btgen_pytrees import generate
    from btgen_pytrees.run import run_tree
    from btgen_pytrees.systems.sumo import SUMO

    spy = Probe()
    registry = spy.registry()
    path = sumo_case(tmp_path, probe(2, "ego"), entry("C1", action="wait", duration=1))
    loaded = btgen_pytrees.load(path, registry=registry)
    system = SUMO.create(loaded.system, loaded)
    system.tick_length = 0.0125  # SUMO steps 13 ms
    report = run_tree(generate(loaded, registry=registry, clock=system), loaded, system=system)
    assert report.verdict == "pass", report.message
    assert spy.seen and all(round(s["dt"], 9) == 0.013 for s in spy.seen)
    assert [s["now"] for s in spy.seen] == [round(s["sumo"] - s["dt"], 9) for s in spy.seen]  # SUMO's label of the state
    assert report.trace.times == [s["now"] for s in spy.seen]
    c1 = report.execute[1]
    assert (c1.start, c1.end) == (0.0, 1.001)  # 77 steps of 13 ms: the first SUMO time at least 1 s after the start


KEEPER = """<routes>
    <vType id="keeper" length="5" minGap="2.5" maxSpeed="30" accel="2.6" decel="4.5" emergencyDecel="9" sigma="0"
           lcKeepRight="100"/>
    <route id="east" edges="A0B0 B0C0"/>
    <vehicle id="ego" type="keeper" route="east" depart="0" departPos="20" departLane="0" departSpeed="10"/>
</routes>
"""
"""A driver model that wants the right lane (keep right): left to itself, it goes back to lane 0 at once."""


def arrived_and_back(lanes: list[tuple[float, int]]) -> tuple[float, float]:
    """When the vehicle was first on lane 1, and when it was next on lane 0 (libsumo's lane index)."""
    arrived = next(t for t, lane in lanes if lane == 1)
    back = next(t for t, lane in lanes if t > arrived and lane == 0)
    return arrived, back


@needs_sumo
def test_a_lane_change_without_duration_leaves_the_lane_to_the_driver_model_on_arrival(tmp_path: pathlib.Path) -> None:
    spy = Probe()
    registry = spy.registry()
    path = sumo_case(tmp_path, probe(5, "ego"), entry("B1", action="sumo.lane", vehicle="ego", lane=1),
                     routes=KEEPER)  # fmt: skip
    report = run(btgen_pytrees.load(path, registry=registry), registry=registry)
    assert report.verdict == "pass", report.message
    arrived, back = arrived_and_back(spy.lanes("ego"))
    assert report.execute[1].end == arrived == 0.1
    assert back - arrived <= 0.3 + 1e-9  # keep-right takes it back as soon as the test lets go (not after 10.1 s)


@needs_sumo
def test_a_lane_change_with_a_duration_keeps_the_lane_for_that_long_then_lets_go(tmp_path: pathlib.Path) -> None:
    spy = Probe()
    registry = spy.registry()
    path = sumo_case(tmp_path, probe(5, "ego"), entry("B1", action="sumo.lane", vehicle="ego", lane=1, duration=2),
                     routes=KEEPER)  # fmt: skip
    run(btgen_pytrees.load(path, registry=registry), registry=registry)
    arrived, back = arrived_and_back(spy.lanes("ego"))
    assert arrived == 0.1
    assert 2 < back - arrived <= 2.3 + 1e-9  # held through the steps up to arrival + 2 s, then keep-right at once


@needs_sumo
def test_release_ends_a_lane_hold_at_once(tmp_path: pathlib.Path) -> None:
    spy = Probe()
    registry = spy.registry()
    path = sumo_case(tmp_path, probe(6, "ego"),
                     entry("B1", action="sumo.lane", vehicle="ego", lane=1, duration=30),
                     entry("C1", ["B1"], action="wait", duration=1),
                     entry("B2", ["C1"], action="sumo.release", vehicle="ego"),
                     routes=KEEPER)  # fmt: skip
    report = run(btgen_pytrees.load(path, registry=registry), registry=registry)
    assert report.verdict == "pass", report.message
    released = report.execute[3].end
    lanes = spy.lanes("ego")
    assert released == pytest.approx(1.1)
    assert all(lane == 1 for t, lane in lanes if 0.1 <= t <= released)
    back = next(t for t, lane in lanes if t > released and lane == 0)
    assert back - released <= 0.3 + 1e-9  # not 30 s later


LONG_ROUTES = """<routes>
    <vType id="car" length="5" minGap="2.5" maxSpeed="30" sigma="0" lcKeepRight="0" lcSpeedGain="0" lcStrategic="-1"/>
    <route id="east" edges="A0B0"/>
    <vehicle id="far" type="car" route="east" depart="0" departPos="10" departLane="0" departSpeed="20"/>
    <vehicle id="farlead" type="car" route="east" depart="0" departPos="2000" departLane="0" departSpeed="20"/>
    <vehicle id="near" type="car" route="east" depart="0" departPos="10" departLane="1" departSpeed="20"/>
    <vehicle id="nearlead" type="car" route="east" depart="0" departPos="900" departLane="1" departSpeed="10"/>
</routes>
"""


@needs_sumo
def test_a_leader_beyond_the_documented_1000_m_is_no_leader(tmp_path: pathlib.Path) -> None:
    netgenerate = shutil.which("netgenerate")
    if netgenerate is None:
        if os.environ.get("CI"):
            pytest.fail("netgenerate is missing although CI installs the sumo extra")
        pytest.skip("netgenerate is not installed (pip install -e '.[sumo]')")
    subprocess.run([netgenerate, "--grid", "--grid.x-number", "2", "--grid.y-number", "1", "--grid.length", "3000",
                    "--default.lanenumber", "2", "--default.speed", "30", "--no-turnarounds", "true", "--seed", "1",
                    "--output-file", str(tmp_path / "long.net.xml")], check=True, capture_output=True, timeout=60)  # fmt: skip
    spy = Probe()
    registry = spy.registry()
    path = sumo_case(tmp_path, probe(1, "far", "near"),
                     criteria=[crit("R1", "record", "far.gap > 1e308 && far.ttc > 1e308 && near.gap <= 1000")],
                     routes=LONG_ROUTES)  # fmt: skip
    (tmp_path / "s.sumocfg").write_text(CONFIG.replace("road.net.xml", "long.net.xml"), encoding="utf-8")
    report = run(btgen_pytrees.load(path, registry=registry), registry=registry)
    assert report.verdict == "pass", (report.message, report.oracles)
    first = spy.seen[0]
    assert first["leader"]["far"][0] == "farlead" and first["leader"]["far"][1] + 2.5 > 1000  # SUMO sees it ...
    near_leader = first["leader"]["near"]
    assert near_leader[0] == "nearlead"
    samples = dict(report.oracles[0].samples)
    assert samples[0.0]["near.gap"] == pytest.approx(near_leader[1] + 2.5)  # ... a nearer one is what SUMO says
    assert report.trace.value_at("far.gap", 0) == math.inf and report.trace.value_at("far.ttc", 0) == math.inf


@needs_sumo
def test_a_vehicle_that_left_ends_its_signals_in_the_trace_when_libsumo_stops_listing_it(tmp_path: pathlib.Path) -> None:
    routes = SCENARIO.replace('<vehicle id="ego" type="car" route="east" depart="0" departPos="20"',
                              '<vehicle id="ego" type="car" route="short" depart="0" departPos="440"')  # fmt: skip
    spy = Probe()
    registry = spy.registry()
    path = sumo_case(tmp_path, probe(8, "ego"), criteria=[crit("F1", "final", "ego.speed >= 0", at=8)], routes=routes)
    report = run(btgen_pytrees.load(path, registry=registry), registry=registry)
    assert report.oracles[0].message == "signal 'ego.speed' has no value at 8 s"
    gone = next(s["now"] for s in spy.seen if "ego" not in s["lane"])  # libsumo no longer lists it
    trace = report.trace
    k = trace.times.index(gone)
    motion = ("speed", "accel", "x", "y", "lateral", "distance", "gap", "ttc")
    for attribute in motion:
        assert trace.value_at(f"ego.{attribute}", k - 1) is not None and trace.value_at(f"ego.{attribute}", k) is None
    assert trace.value_at("ego.present", k) is False and trace.value_at("ego.lane", k) == -1
    from btgen_pytrees.run.trace import ENDED

    for attribute in motion:
        ticks, values = trace.signals[f"ego.{attribute}"]
        assert (ticks[-1], values[-1]) == (k, ENDED), attribute  # ended on that tick, not held on


# ---------------------------------------------------------------------------
# many runs in one process (a worker of a sweep or a search): each as a fresh process would run it

_FRESH = ("import json, sys, btgen_pytrees\nfrom btgen_pytrees.run import run\n"
          "r = run(btgen_pytrees.load(sys.argv[1]))\n"
          "print(json.dumps([r.to_json(), r.trace.to_data() if r.trace is not None else None]))\n")


def _fresh(path: pathlib.Path) -> list[Any]:
    done = subprocess.run([sys.executable, "-c", _FRESH, str(path)], capture_output=True, text=True, cwd=ROOT,
                          timeout=300, check=True)  # fmt: skip
    return json.loads(done.stdout.splitlines()[-1])  # type: ignore[no-any-return]  # libsumo may warn first


@needs_sumo
@pytest.mark.usefixtures("pythons_ctrl_c")  # its KeyboardInterrupt is the host's Ctrl-C: goes on
def test_runs_one_after_the_other_in_a_process_match_a_fresh_process_byte_for_byte(tmp_path: pathlib.Path) -> None:
    """Whatever one run leaves in the process - libsumo's state after its close, the scenario read once
    (read_scenario keeps it), a run that SUMO refused, a run interrupted half-way, a run that took a
    vehicle over (speed and lane-change modes), another scenario - the next run's JSON report and trace are
    the bytes a fresh process writes."""
    cut_in, acc = EXAMPLES / "cut_in.json", EXAMPLES / "acc_hard_brake.json"
    (tmp_path / "broken").mkdir()
    (tmp_path / "takeover").mkdir()
    broken = sumo_case(tmp_path / "broken", entry("C1", action="wait"),
                       routes=SCENARIO.replace('accel="2.6"', 'accel="fast"'))  # read fine, refused by SUMO  # fmt: skip
    takeover = sumo_case(tmp_path / "takeover", entry("B1", action="sumo.speed", vehicle="ego", to=30, safe=False),
                         entry("B2", action="sumo.lane", vehicle="other", lane=0, safe=False),
                         entry("C1", ["B1"], action="wait", duration=3), name="takeover")  # fmt: skip
    fresh = {p: _fresh(p) for p in (cut_in, acc, broken, takeover)}
    assert fresh[broken][0].count('"verdict": "error"') == 1 and fresh[cut_in][1] is not None

    def here(path: pathlib.Path) -> list[Any]:
        report = run(btgen_pytrees.load(path))
        return json.loads(json.dumps([report.to_json(), report.trace.to_data() if report.trace is not None else None]))

    def interrupt(ticks: int, _now: float) -> None:
        if ticks == 20:
            raise KeyboardInterrupt

    for path in (cut_in, cut_in, takeover, acc, broken, cut_in, takeover, takeover, acc):
        assert here(path) == fresh[path], path.name
        if path is not broken:
            with pytest.raises(KeyboardInterrupt):
                run(btgen_pytrees.load(path), progress=interrupt)
    assert here(cut_in) == fresh[cut_in]


@needs_sumo
def test_a_run_that_records_no_trace_has_the_same_report(tmp_path: pathlib.Path) -> None:
    """A sweep's and a search's runs record no trace (their rows carry none): the report is the same."""
    for path in (EXAMPLES / "cut_in.json", EXAMPLES / "acc_hard_brake.json", ROOT / "examples" / "fig1.json"):
        case = btgen_pytrees.load(path)
        recorded, bare = run(case), run(case, record=False)
        assert recorded.trace is not None and bare.trace is None
        assert bare.to_json() == recorded.to_json(), path.name


def test_a_scenario_kept_is_given_back_without_reading_its_files_while_their_stamps_are_old(
        tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> None:  # fmt: skip
    """A hit costs a ``stat`` per file, not reading and hashing it, once the file's change time is older than
    STAMP_MARGIN_NS at the read (here the margin is moved, not the clock); a younger stamp is never trusted:
    its bytes are hashed, so a file rewritten with the same size and modification time within the time
    stamps' granularity is still seen (the test above)."""
    import sys

    from btgen_pytrees.systems.sumo import scenario as module

    cfg = scenario_dir(tmp_path)
    names = {str(tmp_path / n) for n in ("s.sumocfg", "road.net.xml", "r.rou.xml")}
    opened: list[str] = []

    def audit(event: str, args: tuple[Any, ...]) -> None:
        if event == "open" and isinstance(args[0], str) and args[0] in names:
            opened.append(args[0])

    sys.addaudithook(audit)
    first = read_scenario(str(cfg))
    assert first.problems == () and sorted(opened) == sorted(names)
    del opened[:]
    assert read_scenario(str(cfg)) is first and sorted(opened) == sorted(names)  # young stamps: hashed again
    monkeypatch.setattr(module, "STAMP_MARGIN_NS", -10**12)  # as if the files were written long before
    del opened[:]
    for _ in range(3):
        assert read_scenario(str(cfg)) is first
    assert opened == []  # stat only: the read before took the stamps anew after hashing the same bytes
    (tmp_path / "r.rou.xml").write_text(ROUTES.replace('id="ego"', 'id="egg"'), encoding="utf-8")
    assert sorted(read_scenario(str(cfg)).vehicles) == ["egg"]  # a write changes the change time


def test_a_scenario_kept_with_trusted_stamps_still_sees_its_files_real_paths(
        tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> None:  # fmt: skip
    """With every stamp trusted (the margin moved), a hit still checks each file's real path: a file named in a
    subdirectory whose directory is moved out and replaced by a symbolic link keeps its stamp (renaming a
    directory does not touch its files), so only the real path sees it; a file that is itself a symbolic link
    inside the directory is followed, and one re-pointed outside is seen."""
    from btgen_pytrees.systems.sumo import scenario as module

    monkeypatch.setattr(module, "STAMP_MARGIN_NS", -10**12)  # as if the files were written long before
    outside, folder = tmp_path / "outside", tmp_path / "scenario"
    outside.mkdir()
    folder.mkdir()
    (folder / "sub").mkdir()
    (folder / "sub" / "r.rou.xml").write_text(ROUTES, encoding="utf-8")
    (folder / "road.net.xml").write_text(NET, encoding="utf-8")
    (folder / "net.link.xml").symlink_to("road.net.xml")  # a link that stays inside: allowed
    cfg = folder / "s.sumocfg"
    cfg.write_text(CONFIG.replace("r.rou.xml", "sub/r.rou.xml").replace("road.net.xml", "net.link.xml"), encoding="utf-8")
    first = read_scenario(str(cfg))
    assert first.problems == () and read_scenario(str(cfg)) is first and read_scenario(str(cfg)) is first
    (folder / "sub").rename(outside / "sub")
    (folder / "sub").symlink_to(outside / "sub")  # the same file, the same stamp, now out of the directory
    (problem,) = read_scenario(str(cfg)).problems
    assert "leads outside the configuration's directory" in problem
    (folder / "sub").unlink()
    (outside / "sub").rename(folder / "sub")
    second = read_scenario(str(cfg))
    assert second.problems == () and read_scenario(str(cfg)) is second
    (outside / "road.net.xml").write_text(NET, encoding="utf-8")
    (folder / "net.link.xml").unlink()
    (folder / "net.link.xml").symlink_to(outside / "road.net.xml")  # the same bytes, now out of the directory
    (problem,) = read_scenario(str(cfg)).problems
    assert "leads outside the configuration's directory" in problem
