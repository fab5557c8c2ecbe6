"""The pytest plugin, tested with pytest's own ``pytester`` (docs/pytest.md).

Each test runs a real pytest session on a directory of test cases: in this
process (``runpytest``) or, where the run needs a process of its own (xdist
workers, the cache of ``--lf``/``--sw`` across runs, a libsumo made absent, the
``CI`` rule), in a subprocess. The plugin is named with ``-p``; where the package
is installed with its entry point (CI, a fresh venv) that is the same plugin,
loaded once (the entry point has the module's name).
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import json
import pathlib
import shutil
import xml.etree.ElementTree as ET

import pytest

from btgen_pytrees.cli import main as cli_main

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
    base = "fig1_failing.json_fig1_failing-" + hashlib.sha256(b"fig1_failing.json::fig1_failing").hexdigest()[:12]
    written = sorted(p.name for p in (cases.path / "out").iterdir())  # the passing case writes nothing
    assert written == [".btgen-artifacts", f"{base}.plot.svg", f"{base}.replay.html", f"{base}.report.json"]
    report = json.loads((cases.path / "out" / f"{base}.report.json").read_text())
    assert report["verdict"] == "fail" and "false by 1" in report["explanation"][0]
    result.stdout.fnmatch_lines([f"written: */out/{base}.report.json"])


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


# -- attacks (issue 35): nothing lost, nothing green by accident ----------------------------------


def waiting(name: str, need: float, **more: object) -> dict[str, object]:
    """A case that waits for ``x >= need`` (x stays 0): passes at once for 0, times out after 0.2 s above."""
    return {"name": name, "tick": 0.1, "timeout": 0.2, "signals": {"x": 0}, **more,
            "execute": [{"id": "A", "kind": "constraint", "action": "until", "params": {"expect": f"x >= {need}"}}]}  # fmt: skip


def failed_ids(result: pytest.RunResult) -> set[str]:
    return {line.split(" ")[1] for line in result.outlines if line.startswith("FAILED ")}


def test_last_failed_reruns_the_cases_named_with_brackets(pytester: pytest.Pytester) -> None:
    """7 failures, names with brackets among them; one fixed: ``--lf`` reruns the 7 (the 6 still fail, exit 1),
    then exactly the 6."""
    names = ["brake[hard]", "brake[soft]", "turn[left][fast]", "empty[]", "plain"]
    for i, name in enumerate(names):
        (pytester.path / f"c{i}.json").write_text(json.dumps(waiting(name, 1)))
    sweep = waiting("sweep[x]", "$need", parameters={"need": 1}, variations={"need": [1, 2]})
    (pytester.path / "sweep.json").write_text(json.dumps(sweep))
    first = pytester.runpytest_inprocess(*PLUGIN, "--btgen-files=*.json", "-q")
    everything = {f"c{i}.json::{name}" for i, name in enumerate(names)} | {
        "sweep.json::sweep[x][need=1]", "sweep.json::sweep[x][need=2]"}  # fmt: skip
    assert first.ret == pytest.ExitCode.TESTS_FAILED and failed_ids(first) == everything
    (pytester.path / "c1.json").write_text(json.dumps(waiting("brake[soft]", 0)))  # fixed
    again = pytester.runpytest_inprocess(*PLUGIN, "--btgen-files=*.json", "--lf", "-q")
    again.assert_outcomes(passed=1, failed=6)  # the 7 that failed: the fixed one passes, the others still fail
    assert failed_ids(again) == everything - {"c1.json::brake[soft]"}
    still = pytester.runpytest_inprocess(*PLUGIN, "--btgen-files=*.json", "--lf", "-q")
    still.assert_outcomes(failed=6)  # and then exactly the 6
    assert failed_ids(still) == everything - {"c1.json::brake[soft]"}
    one = pytester.runpytest_inprocess(*PLUGIN, "--btgen-files=*.json", "c0.json::brake[hard]", "-q")
    one.assert_outcomes(failed=1)  # a node id with brackets selects its item on the command line too


EXITS_IN_A_LEAF = '''
import os
import py_trees
from py_trees.common import Status


class Leaf(py_trees.behaviour.Behaviour):
    def __init__(self, entry, env):
        super().__init__(name=entry.name)
        self.how = entry.action

    def update(self):
        if self.how == "exit0":
            os._exit(0)
        return Status.SUCCESS


def register(registry):
    for action in ("exit0", "fine"):
        registry.register(action, lambda e, env: Leaf(e, env), kind="behavior")
'''


def test_a_leaf_ending_the_process_fails_its_item_and_the_session_goes_on(pytester: pytest.Pytester) -> None:
    """``os._exit(0)`` in a plugin leaf: its item fails, the cases after it run, pytest exits 1; at the plugin's
    import: exit 4. (Processes of their own: were the run not supervised, it would end the session that runs it.)"""
    (pytester.path / "leaves.py").write_text(EXITS_IN_A_LEAF)
    for name, action in (("a_exit", "exit0"), ("b_fine", "fine")):
        case = {"name": name, "tick": 0.1, "timeout": 1, "execute": [{"id": "A", "kind": "behavior", "action": action}]}
        (pytester.path / f"{name}.json").write_text(json.dumps(case))
    (pytester.path / "c_fail.json").write_text(json.dumps(waiting("c_fail", 1)))
    result = pytester.runpytest_subprocess(*PLUGIN, "--btgen-files=*.json", "--btgen-plugin=leaves.py",
                                           "-p", "no:cacheprovider", "--junitxml=out.xml")  # fmt: skip
    assert result.ret == pytest.ExitCode.TESTS_FAILED
    result.assert_outcomes(passed=1, failed=2)
    result.stdout.fnmatch_lines(["a_exit: ERROR - the run's process exited with status 0 before giving a verdict "
                                 "(user code - a plugin, a leaf or a system - ended it, e.g. with os._exit)*",
                                 "FAILED a_exit.json::a_exit - a_exit: ERROR - *", "FAILED c_fail.json::c_fail *"])  # fmt: skip
    suite = ET.parse(pytester.path / "out.xml").getroot()
    verdicts = {c.get("name"): {p.get("value") for p in c.iter("property")} for c in suite.iter("testcase")}
    assert verdicts == {"a_exit": {"error"}, "b_fine": {"pass"}, "c_fail": {"timeout"}}
    # a plugin that ends the process as it is imported: a usage error, never a session ended with 0
    (pytester.path / "exits.py").write_text("import os\nos._exit(0)\n")
    at_import = pytester.runpytest_subprocess(*PLUGIN, "--btgen-files=*.json", "--btgen-plugin=exits.py", "-p", "no:cacheprovider")
    assert at_import.ret == pytest.ExitCode.USAGE_ERROR
    at_import.stderr.fnmatch_lines(["ERROR: btgen_pytrees: error: the process loading the plugins exited with status 0 "
                                    "before giving a verdict *"])  # fmt: skip


def test_items_and_the_fixture_have_the_budget_of_run(pytester: pytest.Pytester) -> None:
    """A case ``run --max-work`` stops as ``error`` (exit 1) fails under pytest with that budget, from the command
    line or the ini file, and the fixture's runs have it; a case over it at its first tick is refused as by run."""
    long = {"name": "long", "tick": 0.1, "timeout": 10, "signals": {"x": 0},
            "execute": [{"id": "A", "kind": "constraint", "action": "wait", "params": {"duration": 5}}]}  # fmt: skip
    (pytester.path / "long.json").write_text(json.dumps(long))
    assert cli_main(["run", str(pytester.path / "long.json"), "--max-work", "500"]) == 1  # 11 a tick: ~45 ticks
    assert cli_main(["run", str(pytester.path / "long.json")]) == 0
    pytester.makepyfile(test_fixture="""
        def test_budget(btgen):
            assert btgen.run("long.json").verdict == "error"
    """)
    spent = "long: ERROR - stopped: the work budget of 500 units is spent after 45 ticks x 11*"
    result = pytester.runpytest_inprocess(*PLUGIN, "--btgen-files=*.json", "--btgen-max-work=500")
    result.assert_outcomes(passed=1, failed=1)
    result.stdout.fnmatch_lines([spent])
    pytester.makeini("[pytest]\nbtgen_files = *.json\nbtgen_max_work = 5e2\n")
    pytester.runpytest_inprocess(*PLUGIN).assert_outcomes(passed=1, failed=1)
    refused = pytester.runpytest_inprocess(*PLUGIN, "--btgen-max-work=10")
    refused.stdout.fnmatch_lines(["long.json: /execute: *more than the whole budget, 10*"])
    refused.assert_outcomes(errors=1)
    for bad in ("0", "many"):
        wrong = pytester.runpytest_inprocess(*PLUGIN, f"--btgen-max-work={bad}")
        assert wrong.ret == pytest.ExitCode.USAGE_ERROR and "Traceback" not in wrong.stderr.str()
        wrong.stderr.fnmatch_lines([f"*btgen_pytrees: --btgen-max-work {bad}: *"])


def reports_written(result: pytest.RunResult) -> list[pathlib.Path]:
    """The reports the failures say they wrote (not the short summary's lines: under CI, pytest writes them whole)."""
    lines = "\n".join(result.outlines).partition("short test summary info")[0].splitlines()
    return [pathlib.Path(line.split("written: ", 1)[1]) for line in lines
            if line.startswith("written: ") and line.endswith(".report.json")]  # fmt: skip


def test_artifacts_are_never_replaced_by_another_items(pytester: pytest.Pytester) -> None:
    """Ids alike once made a file name (``a b``/``a_b``, two cut at 200 characters), and the fixture's two runs
    in one test: each failure's ``written: PATH`` holds that run's report. The reports written in the collected
    folder are not collected the next time."""
    (pytester.path / "a b.json").write_text(json.dumps(waiting("x", 1)))
    (pytester.path / "a_b.json").write_text(json.dumps(waiting("x", 2)))
    sweep = waiting("n" * 195, "$need", parameters={"need": 1}, variations={"need": [1, 2]})
    (pytester.path / "long.json").write_text(json.dumps(sweep))
    pytester.makepyfile(test_twice="""
        def test_twice(btgen):
            assert btgen.run("a_b.json").verdict == btgen.run("a b.json").verdict == "timeout"
            assert False
    """)
    result = pytester.runpytest_inprocess(*PLUGIN, "--btgen-files=*.json", "--btgen-artifacts=out", "-p", "no:randomly")
    result.assert_outcomes(failed=5)
    written = reports_written(result)
    assert len(written) == 6 and len(set(written)) == 6 and {p.parent for p in written} == {pytester.path / "out"}
    reports = [json.loads(p.read_text()) for p in written]
    # in the order pytest runs and reports them: each file holds the report of its own run
    assert [(pathlib.Path(r["source"]).name, r["explanation"][0]) for r in reports] == [
        ("a b.json", "no verdict after 0.2 s"), ("a_b.json", "no verdict after 0.2 s"),
        ("long.json", "no verdict after 0.2 s"), ("long.json", "no verdict after 0.2 s"),
        ("a_b.json", "no verdict after 0.2 s"), ("a b.json", "no verdict after 0.2 s")]  # fmt: skip
    needs = [[need for need in (1, 2) if f"x >= {need} false by {need}" in json.dumps(r)] for r in reports]
    assert needs == [[1], [2], [1], [2], [2], [1]]
    assert len(list((pytester.path / "out").glob("*.report.json"))) == 6
    # the reports are in the collected folder, and match *.json: the next session does not take them for cases
    again = pytester.runpytest_inprocess(*PLUGIN, "--btgen-files=*.json", "-k", "not twice")
    again.assert_outcomes(failed=4)


@pytest.mark.parametrize("target", ["taken", "taken/sub"])
def test_artifacts_on_a_file_is_a_usage_error(pytester: pytest.Pytester, target: str) -> None:
    (pytester.path / "taken").write_text("a file")
    (pytester.path / "fail.json").write_text(json.dumps(waiting("fail", 1)))
    result = pytester.runpytest_inprocess(*PLUGIN, "--btgen-files=*.json", f"--btgen-artifacts={target}")
    assert result.ret == pytest.ExitCode.USAGE_ERROR
    result.stderr.fnmatch_lines([f"ERROR: btgen_pytrees: --btgen-artifacts {target}: taken is a file, not a directory"])
    assert "Traceback" not in result.stderr.str() + result.stdout.str()
    assert (pytester.path / "taken").read_text() == "a file"
