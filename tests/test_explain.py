"""Every fail or timeout says why, in the table, the JSON report and the JUnit body (issue 10, "Explain the verdict")."""

from __future__ import annotations

import json
import pathlib
import xml.etree.ElementTree as ET
from typing import Any

import jsonschema
import pytest
from helpers import case, crit, entry, run_case

from btgen_pytrees.expressions import parse, why_false
from btgen_pytrees.run.explain import TREE_LINES

ROOT = pathlib.Path(__file__).resolve().parent.parent
SCHEMA = json.loads((ROOT / "schemas" / "report.schema.json").read_text())


@pytest.mark.parametrize("expect, values, why", [
    ("speed <= 30", {"speed": 32.4}, "speed <= 30 false by 2.4"),
    ("speed < 30", {"speed": 30}, "speed < 30 false by 0"),
    ("x == 10", {"x": 7.5}, "x == 10 false by 2.5"),
    ("x != 3", {"x": 3}, "x != 3 false by 0"),
    ("0 <= x < 5", {"x": -1}, "0 <= x false by 1"),
    ("0 <= x < 5", {"x": 8}, "x < 5 false by 3"),
    ("a > 1 && b < 2 && c == 0", {"a": 0, "b": 5, "c": 0}, "a > 1 false by 1; b < 2 false by 3"),
    ("a > 1 || b", {"a": 0, "b": False}, "a > 1 false by 1; b false"),
    ("abs(v - 3) < 0.5", {"v": 4}, "abs(v - 3) < 0.5 false by 0.5"),
    ("flag == true", {"flag": False}, "flag == true false by 1"),
    ("!(x > 1)", {"x": 2}, "not x > 1 false"),
    ("x > 1", {"x": 5}, ""),
])  # fmt: skip
def test_margins(expect: str, values: dict[str, Any], why: str) -> None:
    assert why_false(parse(expect), values) == why


def test_a_failed_criterion_says_expression_values_time_and_margin_everywhere() -> None:
    data = case(entry("A", action="ramp", signal="speed", to=40, duration=4), signals={"speed": 0},
                criteria=[dict(crit("R", "record", "speed <= 30"), name="limit")])  # fmt: skip
    report = run_case(data)
    why = "speed <= 30 false by 1 at 3.1 s (speed=31)"
    assert report.verdict == "fail" and report.oracles[0].message == why
    table = report.table()
    assert why in table and f"why:\n  criterion R (limit) (record) failed: {why}\n" in table
    data_json = json.loads(report.to_json())
    jsonschema.validate(data_json, SCHEMA)
    assert data_json["explanation"] == [f"criterion R (limit) (record) failed: {why}"]
    assert "--> limit [✕] -- " + why in data_json["tree"] and "--> A [*]" in data_json["tree"]
    failure = ET.fromstring(report.to_junit()).find(".//testcase/failure")
    assert failure is not None and failure.get("message") == why
    assert "tree at the end (last status of each node):\n/_/ t [✕]" in (failure.text or "")


def timeout_case() -> dict[str, Any]:
    return case(
        dict(entry("A", action="ramp", signal="speed", to=10, duration=10), name="accelerate"),
        entry("W", action="until", expect="speed >= 20"), entry("H", duration=1),
        entry("J", ["A", "H"], join="all"), entry("K", ["W"]),
        signals={"speed": 0}, timeout=3,
        criteria=[crit("F", "final", "speed == 10"), crit("P", "period", "speed < 50", **{"from": 1, "to": 5}),
                  crit("R", "record", "speed >= 0")],
    )  # fmt: skip


def test_a_timeout_says_what_was_waiting_running_and_undecided() -> None:
    report = run_case(timeout_case())
    assert report.verdict == "timeout"
    assert report.explanation == [
        "no verdict after 3 s",
        "triggers still waiting:",
        "  trigger before J waits for all of A, H; not done: A (running since 0 s)",
        "entries still running:",
        "  A (accelerate) running since 0 s (3 s): speed = 3",
        "  W running since 0 s (3 s): speed >= 20 false by 17",
        "criteria still undecided:",
        "  F (final: speed == 10) waits for the execute subtree to finish",
        "  P (period: speed < 50) window [1, 5] s had not closed",
    ]
    assert "\nwhy:\n  no verdict after 3 s\n  triggers still waiting:\n" in report.table()
    tree = report.tree.splitlines()
    assert "            {-} join J [*]" in tree and "                --> after all(A, H) [*] -- waiting for all of A, H" in tree
    assert "                            --> accelerate [*] -- speed = 3" in tree and "                        --> K [-]" in tree
    error = ET.fromstring(report.to_junit()).find(".//testcase[@name='execute']/error")
    assert error is not None and "trigger before J waits for all of A, H" in (error.text or "") and "--> K [-]" in (error.text or "")
    jsonschema.validate(json.loads(report.to_json()), SCHEMA)


def test_a_failed_entry_and_an_error_are_explained() -> None:
    report = run_case(case(entry("U", action="until", expect="v > 1", timeout=0.5), signals={"v": 0}))
    assert report.explanation == ["entry U failed at 0.5 s: v > 1 still false after 0.5 s (v=0)"]
    assert "--> U [✕] -- v > 1 still false after 0.5 s (v=0)" in report.tree


def test_pass_has_no_explanation_and_big_trees_are_folded() -> None:
    passed = run_case(case(entry("A")))
    assert passed.explanation == [] and passed.tree == "" and "why:" not in passed.table()
    assert json.loads(passed.to_json())["tree"] == ""
    big = case(*[entry(f"S{i}", [f"S{i - 1}"] if i else [], duration=0.1) for i in range(600)], timeout=30)
    report = run_case(big)
    lines = report.tree.splitlines()
    assert report.verdict == "timeout" and len(lines) <= TREE_LINES + 1
    assert any("all succeeded" in line for line in lines) and any("--> S300 [*]" in line for line in lines)


def test_require_complete_explains_what_did_not_finish() -> None:
    report = run_case(case(entry("A", duration=3), entry("B", ["A"]), criteria=[crit("F", "final", "true", at=1)],
                           require_complete=True))  # fmt: skip
    assert report.verdict == "fail"
    assert report.explanation == ["timeline incomplete: 1 entry stopped, 1 entry did not run (the case requires a complete timeline)",
                                  "  entry A: stopped", "  entry B: not-started"]  # fmt: skip
    assert "--> A [*]" in report.tree
