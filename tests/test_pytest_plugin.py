"""The pytest plugin, tested with pytest's own ``pytester`` (docs/pytest.md).

Each test runs a real pytest session on a directory of test cases: in this
process (``runpytest``) or, where the run needs a process of its own (xdist
workers, the cache of ``--lf``/``--sw`` across runs, a libsumo made absent, the
``CI`` rule), in a subprocess. The plugin is named with ``-p``; where the package
is installed with its entry point (CI, a fresh venv) that is the same plugin,
loaded once (the entry point has the module's name).
"""

from __future__ import annotations

import importlib.metadata
import json
import pathlib
import shutil
import xml.etree.ElementTree as ET

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"
PLUGIN = ("-p", "btgen_pytrees.pytest_plugin")

pytest_plugins = ["pytester"]

FIG1_SWEEP_IDS = [f"fig1_sweep[top_speed={s},limit={lim}]" for s in range(10, 45, 5) for lim in (20, 25, 30, 35)]


@pytest.fixture
def cases(pytester: pytest.Pytester) -> pytest.Pytester:
    """A directory with fig1 (passes), fig1_failing (fails) and fig1_sweep (28 variations, some fail)."""
    for name in ("fig1.json", "fig1_failing.json", "fig1_sweep.json"):
        shutil.copy(EXAMPLES / name, pytester.path / name)
    return pytester


def esc(pattern: str) -> str:
    """*pattern* for ``fnmatch_lines`` with its ``[`` literal (an id's brackets are not a character class)."""
    return pattern.replace("[", "[[]")


def ids(result: pytest.RunResult) -> list[str]:
    return [line for line in result.outlines if "::" in line]


# -- collection ----------------------------------------------------------------------------------


def test_off_until_asked_for(cases: pytest.Pytester) -> None:
    """Loaded but not asked: a .json file is not a test, and the working module is not even registered."""
    cases.makeconftest("""
        def pytest_collection_finish(session):
            print("cases registered:", session.config.pluginmanager.has_plugin("btgen_pytrees.pytest_cases"))
    """)
    result = cases.runpytest(*PLUGIN, "-s")
    assert result.ret == pytest.ExitCode.NO_TESTS_COLLECTED
    result.stdout.fnmatch_lines(["cases registered: False"])


def test_each_case_an_item_each_variation_an_item_with_a_readable_id(cases: pytest.Pytester) -> None:
    result = cases.runpytest(*PLUGIN, "--btgen-files=*.json", "--collect-only", "-q")
    assert ids(result) == ["fig1.json::fig1", "fig1_failing.json::fig1_failing",
                           *(f"fig1_sweep.json::{i}" for i in FIG1_SWEEP_IDS)]  # fmt: skip


def test_ini_option_and_glob(cases: pytest.Pytester) -> None:
    cases.makeini("[pytest]\nbtgen_files = fig1_f*.json\n")
    sub = cases.mkdir("sub")
    shutil.copy(EXAMPLES / "fig1_failing.json", sub / "fig1_failing.json")
    result = cases.runpytest(*PLUGIN, "--collect-only", "-q")
    assert ids(result) == ["fig1_failing.json::fig1_failing", "sub/fig1_failing.json::fig1_failing"]
    # a pattern with a '/' matches the whole path, as pytest's python_files does
    result = cases.runpytest(*PLUGIN, "--btgen-files=sub/*.json", "--collect-only", "-q")
    assert ids(result) == ["sub/fig1_failing.json::fig1_failing"]


def test_a_file_named_on_the_command_line_is_collected(cases: pytest.Pytester) -> None:
    result = cases.runpytest(*PLUGIN, "--btgen-files=test_*.json", "fig1.json", "-q")
    result.assert_outcomes(passed=1)


def test_invalid_case_is_a_collection_error_naming_file_and_json_path(cases: pytest.Pytester) -> None:
    bad = json.loads((EXAMPLES / "fig1.json").read_text())
    bad["execute"][1]["after"] = ["B9"]
    (cases.path / "bad.json").write_text(json.dumps(bad))
    result = cases.runpytest(*PLUGIN, "--btgen-files=*.json")
    assert result.ret == pytest.ExitCode.INTERRUPTED
    result.assert_outcomes(errors=1)
    result.stdout.fnmatch_lines(["*ERROR collecting bad.json*", "bad.json: /execute/1/after/0: unknown id 'B9'*"])
    assert "Traceback" not in result.stdout.str()


# -- selecting and re-running, as pytest users expect --------------------------------------------


def test_k_selects_cases_and_variations(cases: pytest.Pytester) -> None:
    result = cases.runpytest(*PLUGIN, "--btgen-files=*.json", "-k", "fig1_sweep and 35", "-q")
    # top_speed=35 at the 4 limits (fails at 20, 25, 30) and limit=35 at the other 6 speeds (fails at 40)
    result.assert_outcomes(passed=6, failed=4, deselected=20)
    result.stdout.fnmatch_lines([esc("FAILED fig1_sweep.json::fig1_sweep[top_speed=35,limit=20]*"),
                                 esc("FAILED fig1_sweep.json::fig1_sweep[top_speed=40,limit=35]*")])  # fmt: skip
    node = cases.runpytest(*PLUGIN, "--btgen-files=*.json", "fig1_sweep.json::fig1_sweep[top_speed=40,limit=35]")
    node.assert_outcomes(failed=1)


def test_x_stops_at_the_first_failure(cases: pytest.Pytester) -> None:
    result = cases.runpytest(*PLUGIN, "--btgen-files=*.json", "-x", "-q")
    result.assert_outcomes(passed=1, failed=1)


def test_last_failed_and_stepwise(cases: pytest.Pytester) -> None:
    first = cases.runpytest_subprocess(*PLUGIN, "--btgen-files=*.json", "-q")
    first.assert_outcomes(passed=19, failed=11)  # fig1_failing, and the 10 variations with top_speed > limit
    again = cases.runpytest_subprocess(*PLUGIN, "--btgen-files=*.json", "--lf", "-q")
    again.assert_outcomes(failed=11)  # the passed ones are not even collected
    again.stdout.fnmatch_lines(["FAILED fig1_failing.json::fig1_failing*"])
    # stepwise: stop at the first failure (top_speed=10 to 20 pass at every limit), then start from it
    step = cases.runpytest_subprocess(*PLUGIN, "--btgen-files=fig1_sweep.json", "--sw", "-q")
    step.assert_outcomes(passed=12, failed=1)
    step.stdout.fnmatch_lines([esc("FAILED fig1_sweep.json::fig1_sweep[top_speed=25,limit=20]*")])
    step = cases.runpytest_subprocess(*PLUGIN, "--btgen-files=fig1_sweep.json", "--sw", "-q")
    step.assert_outcomes(failed=1, deselected=12)


def test_xdist(cases: pytest.Pytester) -> None:
    pytest.importorskip("xdist")
    result = cases.runpytest_subprocess(*PLUGIN, "--btgen-files=*.json", "-n", "2", "-q")
    result.assert_outcomes(passed=19, failed=11)
    workers = {line.split("]")[0] for line in result.outlines if line.startswith("[gw")}
    assert workers == {"[gw0", "[gw1"}  # each failure's report names the worker it ran on: both ran items


def test_junitxml(cases: pytest.Pytester) -> None:
    result = cases.runpytest(*PLUGIN, "--btgen-files=fig1*.json", "--junitxml=out.xml", "-q", "-k", "fig1 and not sweep")
    result.assert_outcomes(passed=1, failed=1)
    suite = ET.parse(cases.path / "out.xml").getroot().find("testsuite")
    assert suite is not None and suite.get("tests") == "2" and suite.get("failures") == "1"
    names = {case.get("name"): case for case in suite.iter("testcase")}
    assert set(names) == {"fig1", "fig1_failing"}
    failure = names["fig1_failing"].find("failure")
    assert failure is not None
    assert "false by" in failure.get("message", "") and "tree at the end" in (failure.text or "")
    verdicts = {p.get("name"): p.get("value") for p in names["fig1"].iter("property")}
    assert verdicts == {"verdict": "pass"}


# -- what a failure says -------------------------------------------------------------------------


def test_failure_is_the_explanation_not_a_traceback(cases: pytest.Pytester) -> None:
    result = cases.runpytest(*PLUGIN, "--btgen-files=fig1_failing.json")
    result.assert_outcomes(failed=1)
    out = result.stdout.str()
    result.stdout.fnmatch_lines([
        "*_ fig1_failing _*",
        "fig1_failing: FAIL - criterion R1 (record) failed: speed <= 15 false by 1 at 1.6 s (speed=16)",
        "criterion*type*expect*verdict*",
        "R1*record*speed <= 15*fail*speed <= 15 false by 1 at 1.6 s*",
        "why:",
        "tree at the end (last status of each node):",
        esc("/_/ fig1_failing [✕]"),
        esc("*--> R1 [✕] -- speed <= 15 false by 1 at 1.6 s*"),
        "FAILED fig1_failing.json::fig1_failing - fig1_failing: FAIL - criterion R1*",
    ])  # fmt: skip
    assert "Traceback" not in out and "pytest_cases.py" not in out and "raise " not in out


def test_timeout_says_what_was_still_waiting(pytester: pytest.Pytester) -> None:
    case = {"name": "stuck", "tick": 0.1, "timeout": 1, "signals": {"x": 0},
            "execute": [{"id": "A", "kind": "constraint", "action": "until", "params": {"expect": "x >= 2"}}]}  # fmt: skip
    (pytester.path / "stuck.json").write_text(json.dumps(case))
    result = pytester.runpytest(*PLUGIN, "--btgen-files=*.json")
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(["stuck: TIMEOUT - no verdict after 1 s", "*entries still running:",
                                 "*A running since 0 s (1 s): x >= 2 false by 2*"])  # fmt: skip


def test_artifacts_of_failing_items(cases: pytest.Pytester) -> None:
    pytest.importorskip("matplotlib")
    result = cases.runpytest(*PLUGIN, "--btgen-files=fig1*.json", "-k", "fig1 and not sweep", "--btgen-artifacts=out")
    result.assert_outcomes(passed=1, failed=1)
    written = sorted(p.name for p in (cases.path / "out").iterdir())
    assert "fig1_failing.json_fig1_failing.report.json" in written  # the passing case writes nothing
    assert "fig1_failing.json_fig1_failing.plot.svg" in written
    assert "fig1_failing.json_fig1_failing.replay.html" in written
    report = json.loads((cases.path / "out" / "fig1_failing.json_fig1_failing.report.json").read_text())
    assert report["verdict"] == "fail" and "false by 1" in report["explanation"][0]
    result.stdout.fnmatch_lines(["written: */out/fig1_failing.json_fig1_failing.report.json"])


# -- options -------------------------------------------------------------------------------------


def test_plugin_and_system_options(pytester: pytest.Pytester) -> None:
    shutil.copy(EXAMPLES / "host_app" / "pick.json", pytester.path / "pick.json")
    shutil.copy(EXAMPLES / "host_app" / "robot.py", pytester.path / "robot_leaves.py")
    without = pytester.runpytest(*PLUGIN, "--btgen-files=*.json")
    without.stdout.fnmatch_lines(["pick.json: /execute/0/action: unknown behavior action 'move_arm'*"])
    pytester.makeini("[pytest]\nbtgen_files = *.json\nbtgen_plugins = robot_leaves.py\n")
    pytester.runpytest(*PLUGIN).assert_outcomes(passed=1)
    pytester.runpytest(*PLUGIN, "--btgen-plugin=robot_leaves.py", "--btgen-system=simulated").assert_outcomes(passed=1)
    wrong = pytester.runpytest(*PLUGIN, "--btgen-system=nosuch")
    wrong.stdout.fnmatch_lines(["pick.json: /system/type: *nosuch*"])
    broken = pytester.runpytest(*PLUGIN, "--btgen-plugin=missing_module")
    assert broken.ret == pytest.ExitCode.USAGE_ERROR
    broken.stderr.fnmatch_lines(["*btgen_pytrees: plugin 'missing_module': cannot import*"])


# -- SUMO: skipped where the extra is missing, an error under CI ---------------------------------


@pytest.fixture
def sumo_case(pytester: pytest.Pytester) -> pytest.Pytester:
    for name in ("acc_hard_brake.json", "acc.sumocfg", "acc.rou.xml", "road.net.xml"):
        shutil.copy(EXAMPLES / "sumo" / name, pytester.path / name)
    shutil.copy(EXAMPLES / "fig1.json", pytester.path / "fig1.json")
    pytester.makeconftest("import sys\nsys.modules['libsumo'] = None  # libsumo absent, as without the extra\n")
    return pytester


def test_sumo_case_skipped_without_the_extra(sumo_case: pytest.Pytester, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("CI", raising=False)
    result = sumo_case.runpytest_subprocess(*PLUGIN, "--btgen-files=*.json", "-rs")
    result.assert_outcomes(passed=1, skipped=1)
    result.stdout.fnmatch_lines(["SKIPPED * acc_hard_brake.json: needs the 'sumo' extra, and libsumo is not installed*"])


def test_sumo_case_is_an_error_under_ci(sumo_case: pytest.Pytester, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CI", "true")
    result = sumo_case.runpytest_subprocess(*PLUGIN, "--btgen-files=*.json")
    result.assert_outcomes(errors=1)
    result.stdout.fnmatch_lines(["*acc_hard_brake.json: needs the 'sumo' extra*under CI=true this is an error*"])


# -- the btgen fixture ---------------------------------------------------------------------------


def test_fixture_runs_a_case_against_a_system_of_the_test(cases: pytest.Pytester) -> None:
    (cases.path / "cases").mkdir()
    follow = {"name": "follow", "tick": 0.1, "timeout": 5,
              "execute": [{"id": "W", "kind": "constraint", "action": "until", "params": {"expect": "speed >= 12", "timeout": 3}}],
              "oracle": {"criteria": [{"id": "R1", "type": "record", "expect": "speed <= 12"}]}}  # fmt: skip
    (cases.path / "cases" / "follow.json").write_text(json.dumps(follow))
    cases.makepyfile(test_controller="""
        class MyControllerSystem:
            '''A controller under test: speeds up by `gain` per tick; owns the signal `speed`.'''
            def __init__(self, gain):
                self.gain, self.k = gain, 0
            def start(self, env):
                self.k = 0
            def now(self):
                return round(self.k * 0.1, 9)
            def publish(self, env):
                env.publish("speed", self.gain * self.k)
            def tick(self):
                self.k += 1
            def close(self):
                pass

        def test_gentle(btgen):
            report = btgen.run("cases/follow.json", system=MyControllerSystem(gain=1))
            assert report.passed

        def test_too_fast(btgen):
            report = btgen.run("cases/follow.json", system=MyControllerSystem(gain=5))
            assert report.passed

        def test_parameters(btgen):
            report = btgen.run("fig1_sweep.json", parameters={"top_speed": 35, "limit": 40})
            assert report.passed and report.test == "fig1_sweep[top_speed=35,limit=40,ramp_time=2]"
    """)
    result = cases.runpytest(*PLUGIN, "-q")
    result.assert_outcomes(passed=2, failed=1)
    result.stdout.fnmatch_lines(["*- Captured btgen follow call -*", "follow: FAIL - criterion R1 (record) failed: "
                                 "speed <= 12 false by 3 at 0.3 s (speed=15)"])  # fmt: skip


# -- installed ------------------------------------------------------------------------------------


def test_entry_point_has_the_module_name() -> None:
    """pyproject declares the pytest11 entry point under the module's own name (so ``-p`` next to it loads once)."""
    tomllib = pytest.importorskip("tomllib")  # Python >= 3.11
    points = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["entry-points"]["pytest11"]
    assert points == {"btgen_pytrees.pytest_plugin": "btgen_pytrees.pytest_plugin"}
    installed = [ep for ep in importlib.metadata.entry_points(group="pytest11") if ep.value == "btgen_pytrees.pytest_plugin"]
    assert all(ep.name == ep.value for ep in installed)


def test_entry_point_loads_the_plugin_without_p(cases: pytest.Pytester) -> None:
    """Where the package is installed with its metadata (CI, a fresh venv), no ``-p`` is needed."""
    if not any(ep.value == "btgen_pytrees.pytest_plugin" for ep in importlib.metadata.entry_points(group="pytest11")):
        pytest.skip("this environment's btgen_pytrees metadata predates the entry point (pip install -e . again)")
    result = cases.runpytest_subprocess("--btgen-files=fig1.json", "-q")
    result.assert_outcomes(passed=1)
