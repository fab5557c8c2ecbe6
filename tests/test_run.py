"""Run semantics, proven by ticking: timing, once-only, oracle verdicts, isolation."""

from __future__ import annotations

import json
import pathlib
from typing import Any

import jsonschema
import py_trees
import pytest
from helpers import broken_registry, case, crit, entry, generate, run_case

import btgen_pytrees
from btgen_pytrees.clock import VirtualClock
from btgen_pytrees.run import run, run_tree

ROOT = pathlib.Path(__file__).resolve().parent.parent


def times(report: Any) -> dict[str, tuple[Any, Any, str]]:
    return {e.id: (e.start, e.end, e.status) for e in report.execute}


def test_fig1_runs_to_pass_with_paper_timing(fig1_path: str) -> None:
    report = run(btgen_pytrees.load(fig1_path))
    assert (report.verdict, report.duration, report.ticks) == ("pass", 3.0, 31)
    assert times(report) == {
        "B1": (0.0, 0.0, "success"),
        "C1": (0.0, 0.0, "success"),
        "B2": (0.0, 2.0, "success"),
        "C2": (0.0, 1.0, "success"),
        "B3": (1.0, 1.5, "success"),
        "B4": (1.5, 1.5, "success"),  # join any: starts when B3 (the first of B2, B3) ends
    }
    verdicts = {o.id: (o.verdict, o.at) for o in report.oracles}
    assert verdicts == {"R1": ("pass", 3.0), "P1": ("pass", 3.0), "F1": ("pass", 2.0)}


def test_join_all_waits_for_the_last() -> None:
    data = case(entry("A", duration=1), entry("B", duration=2), entry("J", ["A", "B"], join="all", duration=0.5))
    assert times(run_case(data))["J"] == (2.0, 2.5, "success")
    data["execute"][2]["join"] = "any"
    assert times(run_case(data))["J"] == (1.0, 1.5, "success")


def test_ramp_reaches_target_exactly_at_its_end() -> None:
    data = case(entry("R", action="ramp", signal="v", to=10, duration=1), signals={"v": 0},
                criteria=[crit("P", "period", "0 <= v && v <= 10"), crit("F", "final", "v == 10")])  # fmt: skip
    report = run_case(data)
    assert report.verdict == "pass" and times(report)["R"] == (0.0, 1.0, "success")
    samples = [v["v"] for _, v in report.oracles[0].samples]
    assert samples == sorted(samples) and samples[-1] == 10 and len(samples) == 11


def test_set_with_duration_holds() -> None:
    data = case(entry("S", action="set", signal="v", value=3, duration=0.5), entry("T", ["S"], action="set", signal="v", value=4))
    assert times(run_case(data)) == {"S": (0.0, 0.5, "success"), "T": (0.5, 0.5, "success")}


def test_until_succeeds_when_expectation_holds() -> None:
    data = case(entry("R", action="ramp", signal="v", to=10, duration=1),
                entry("U", action="until", expect="v >= 5", timeout=2))  # fmt: skip
    assert times(run_case(data))["U"] == (0.0, 0.5, "success")


def test_until_timeout_fails_the_run_naming_the_entry() -> None:
    data = case(entry("A"), entry("U", ["A"], action="until", expect="v > 1", timeout=0.5), signals={"v": 0})
    report = run_case(data)
    assert report.verdict == "fail" and times(report)["U"] == (1.0, 1.5, "failure")
    assert report.message.startswith("U failed") and "v > 1 still false after 0.5 s (v=0)" in report.message


def test_global_timeout() -> None:
    report = run_case(case(entry("A", duration=10), timeout=2))
    assert (report.verdict, report.duration, report.ticks) == ("timeout", 2.0, 21)
    assert times(report)["A"] == (0.0, None, "running")


def test_exit_condition_stops_the_timeline() -> None:
    data = case(entry("A", duration=10), criteria=[crit("F", "final", "true", at=2)])
    report = run_case(data)
    assert report.verdict == "pass" and report.duration == 2.0 and times(report)["A"] == (0.0, None, "stopped")


# -- oracle truth tables ------------------------------------------------------
# x ramps 0 -> 10 during [0, 1]; the run lasts until 1 s unless a window says otherwise.
PASS = {"record": crit("R", "record", "x <= 10"), "period": crit("P", "period", "x >= 0", to=2), "final": crit("F", "final", "x == 10")}
FAIL = {"record": crit("R", "record", "x < 5"), "period": crit("P", "period", "x < 5"), "final": crit("F", "final", "x == 0")}
FAIL_AT = {"record": 0.5, "period": 0.5, "final": 1.0}


def ramp_case(criteria: list[dict[str, Any]], relation: str) -> dict[str, Any]:
    return case(entry("A", action="ramp", signal="x", to=10, duration=1), signals={"x": 0}, criteria=criteria, relation=relation)


@pytest.mark.parametrize("kind", ["record", "period", "final"])
@pytest.mark.parametrize("relation", ["&&", "||"])
def test_single_criterion(kind: str, relation: str) -> None:
    assert run_case(ramp_case([PASS[kind]], relation)).verdict == "pass"
    report = run_case(ramp_case([FAIL[kind]], relation))
    assert report.verdict == "fail" and report.oracles[0].verdict == "fail" and report.oracles[0].at == FAIL_AT[kind]


@pytest.mark.parametrize("kind", ["record", "period", "final"])
def test_and_fails_when_one_fails(kind: str) -> None:
    good, bad = dict(PASS[kind], id="G"), dict(FAIL[kind], id="B")
    report = run_case(ramp_case([good, bad], "&&"))
    assert report.verdict == "fail" and report.duration == FAIL_AT[kind]
    assert {o.id: o.verdict for o in report.oracles}["B"] == "fail"


@pytest.mark.parametrize("kind", ["period", "final"])
def test_or_passes_when_one_of_two_fails_and_the_other_passes(kind: str) -> None:
    good, bad = dict(PASS[kind], id="G"), dict(FAIL[kind], id="B")
    for order in ([good, bad], [bad, good]):
        report = run_case(ramp_case(order, "||"))
        assert report.verdict == "pass", order
        assert {o.id: o.verdict for o in report.oracles}["B"] == "fail"


def test_or_of_records_passes_if_one_holds() -> None:
    report = run_case(ramp_case([dict(FAIL["record"], id="B"), dict(PASS["record"], id="G")], "||"))
    assert report.verdict == "pass" and [o.verdict for o in report.oracles] == ["fail", "pass"]


def test_or_fails_only_at_the_last_failure() -> None:
    early = crit("E", "period", "x < 3")  # fails at 0.3
    late = crit("L", "final", "x == 0", at=0.8)  # fails at 0.8
    report = run_case(ramp_case([early, late], "||"))
    assert report.verdict == "fail" and report.duration == 0.8
    assert [(o.verdict, o.at) for o in report.oracles] == [("fail", 0.3), ("fail", 0.8)]


def test_mixed_relations() -> None:
    criteria = [dict(FAIL["record"], id="R1"), dict(PASS["record"], id="R2"), dict(PASS["final"], id="F1")]
    assert run_case(ramp_case(criteria, {"record": "||", "others": "&&"})).verdict == "pass"  # type: ignore[arg-type]
    assert run_case(ramp_case(criteria, {"record": "&&", "others": "||"})).verdict == "fail"  # type: ignore[arg-type]


def test_period_default_window_ends_with_execute() -> None:
    report = run_case(ramp_case([crit("P", "period", "x >= 0", **{"from": 0.5})], "&&"))
    assert report.verdict == "pass" and report.oracles[0].at == 1.0


def test_expression_error_fails_the_criterion() -> None:
    report = run_case(case(entry("A"), criteria=[crit("F", "final", "1 / zero > 0")], signals={"zero": 0}))
    assert report.verdict == "fail" and "division by zero" in report.oracles[0].message


# -- isolation and re-runs -----------------------------------------------------


def test_two_trees_ticked_alternately_keep_separate_state() -> None:
    def one(value: int) -> tuple[Any, VirtualClock]:
        data = case(entry("S", action="set", signal="x", value=value), entry("H", ["S"]), signals={"x": 0},
                    criteria=[crit("R", "record", f"x == 0 || x == {value}"), crit("F", "final", f"x == {value}")])  # fmt: skip
        clock = VirtualClock()
        return generate(data, clock=clock), clock

    (a, ca), (b, cb) = one(1), one(2)
    for k in range(20):
        for root, clock in ((a, ca), (b, cb)):
            clock.set(k * 0.1)
            if root.status not in (py_trees.common.Status.SUCCESS, py_trees.common.Status.FAILURE):
                root.tick_once()
    assert a.status == b.status == py_trees.common.Status.SUCCESS
    assert a.btgen_env.namespace != b.btgen_env.namespace
    assert a.btgen_env.read("x") == 1 and b.btgen_env.read("x") == 2


def test_same_tree_object_runs_twice_identically(fig1_path: str) -> None:
    loaded = btgen_pytrees.load(fig1_path)
    clock = VirtualClock()
    root = btgen_pytrees.generate(loaded, clock=clock)
    first = run_tree(root, loaded, clock).to_json()
    assert run_tree(root, loaded, clock).to_json() == first == run(loaded).to_json()


def test_rerun_after_interrupt_starts_clean() -> None:
    data = case(entry("A", duration=1), entry("B", duration=2), entry("J", ["A", "B"], join="all"))
    loaded = btgen_pytrees.load(data)
    clock = VirtualClock()
    root = btgen_pytrees.generate(loaded, clock=clock)
    for k in range(25):  # A and B done, J ran
        clock.set(k * 0.1)
        root.tick_once()
    root.stop(py_trees.common.Status.INVALID)
    report = run_tree(root, loaded, clock)
    assert times(report)["J"] == (2.0, 3.0, "success")  # the stale done-flags of A and B did not fire J early


def test_report_matches_its_schema(fig1_path: str, tmp_path: pathlib.Path) -> None:
    schema = json.loads((ROOT / "schemas" / "report.schema.json").read_text())
    jsonschema.Draft202012Validator.check_schema(schema)
    for data in (btgen_pytrees.load(fig1_path), btgen_pytrees.load(case(entry("A", duration=10), timeout=1))):
        jsonschema.validate(json.loads(run(data).to_json()), schema)


def test_junit_names_each_criterion_and_the_failure(tmp_path: pathlib.Path) -> None:
    import xml.etree.ElementTree as ET

    report = run_case(ramp_case([dict(PASS["final"], id="G"), dict(FAIL["record"], id="B")], "&&"))
    suite = ET.fromstring(report.to_junit()).find("testsuite")
    assert suite is not None and suite.get("failures") == "1" and suite.get("tests") == "3"
    names = [(tc.get("name"), tc.find("failure") is not None) for tc in suite.iter("testcase")]
    assert names[0] == ("execute", False) and names[2][0].startswith("B (record") and names[2][1]


def test_cli_run_exit_codes_and_outputs(tmp_path: pathlib.Path, fig1_path: str) -> None:
    from btgen_pytrees.cli import main

    assert main(["run", fig1_path, "--json", str(tmp_path / "r.json"), "--junit", str(tmp_path / "r.xml")]) == 0
    assert json.loads((tmp_path / "r.json").read_text())["verdict"] == "pass"
    failing = ROOT / "examples" / "fig1_failing.json"
    assert main(["run", str(failing)]) == 1


def test_until_timeout_message_keeps_the_evaluation_error() -> None:
    report = run_case(case(entry("U", action="until", expect="1 / zero > 0", timeout=0.2), signals={"zero": 0}))
    assert report.execute[0].message == "1 / zero > 0 still false after 0.2 s (zero=0): division by zero in '1 / zero > 0'"
    report = run_case(case(entry("U", action="until", expect="false", timeout=0.2)))
    assert report.execute[0].message == "false still false after 0.2 s"


def test_a_leaf_s_timeout_is_written_once_in_simulated_leaf() -> None:
    """``SimulatedLeaf.timed_out(default)``, what ``until``, ``sumo.lane`` and ``sumo.spawn`` give up by: the
    ``timeout`` param (else *default*) on the first tick that many seconds after the leaf started (0.1 * 3
    counting as 0.3), ``None`` before then and for a leaf without either."""
    from btgen_pytrees.leaves import default_registry
    from btgen_pytrees.leaves.simulated import SimulatedLeaf

    seen: list[tuple[float, Any]] = []

    class Stuck(SimulatedLeaf):
        def update(self) -> py_trees.common.Status:
            timeout = self.timed_out(self.params.get("default"))
            seen.append((self.env.now(), timeout))
            if timeout is None:
                return py_trees.common.Status.RUNNING
            self.feedback_message = f"gave up after {timeout} s"
            return py_trees.common.Status.FAILURE

    registry = default_registry()
    registry.register("stuck", Stuck, params_schema={"type": "object", "properties": {
        "timeout": {"type": "number"}, "default": {"type": "number"}}})  # fmt: skip

    def stuck(**params: Any) -> Any:
        seen.clear()
        return run(btgen_pytrees.load(case(entry("S", action="stuck", **params), timeout=1), registry=registry), registry=registry)

    report = stuck(default=0.3)
    assert (report.execute[0].end, report.execute[0].message) == (0.3, "gave up after 0.3 s")
    assert [t for _, t in seen] == [None, None, None, 0.3]
    report = stuck(timeout=0.2, default=0.3)  # the param wins over the default
    assert (report.execute[0].end, report.execute[0].message) == (0.2, "gave up after 0.2 s")
    report = stuck()  # neither: never gives up, the run times out
    assert report.verdict == "timeout" and {t for _, t in seen} == {None} and len(seen) == 11


def test_a_leaf_that_raises_gives_verdict_error_not_a_traceback() -> None:
    registry = broken_registry()
    report = run(btgen_pytrees.load(case(entry("A"), entry("B", ["A"], action="broken")), registry=registry), registry=registry)
    assert (report.verdict, report.duration, report.message) == ("error", 1.0, "B raised RuntimeError: motor driver offline")
    assert [(e.status, e.start, e.end) for e in report.execute] == [("success", 0.0, 1.0), ("error", 1.0, 1.0)]
