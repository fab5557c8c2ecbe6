"""Every class of bad input: a clear message at the right JSON path, exit code 2, no traceback."""

from __future__ import annotations

import json
import subprocess
import sys
from typing import Any

import pytest
from helpers import case, crit, entry

import btgen_pytrees
from btgen_pytrees import InvalidTestCase


def problems(data: Any) -> list[tuple[str, str]]:
    with pytest.raises(InvalidTestCase) as info:
        btgen_pytrees.load(data)
    return [(p.pointer, p.message) for p in info.value.problems]


def only(data: Any) -> tuple[str, str]:
    found = problems(data)
    assert len(found) == 1, found
    return found[0]


def test_valid_minimal_case_loads() -> None:
    loaded = btgen_pytrees.load(case(entry("A")))
    assert [e.id for e in loaded.entries] == ["A"]


def test_unknown_key_is_named_with_a_suggestion() -> None:
    e = entry("B", ["A"])
    e["afer"] = e.pop("after")
    pointer, message = only(case(entry("A"), e))
    assert pointer == "/execute/1/afer" and "unknown key 'afer'" in message and "'after'" in message


def test_unknown_top_level_key() -> None:
    assert only({**case(entry("A")), "oracles": {}})[0] == "/oracles"


@pytest.mark.parametrize(
    "mutate, pointer, words",
    [
        (lambda d: d.pop("name"), "/", "missing required key 'name'"),
        (lambda d: d.update(execute=[]), "/execute", "should be non-empty"),
        (lambda d: d["execute"][0].update(kind="bahavior"), "/execute/0/kind", "is not one of"),
        (lambda d: d["execute"][0].update(id="1A"), "/execute/0/id", "identifier"),
        (lambda d: d.update(tick=0), "/tick", "less than or equal to the minimum"),
        (lambda d: d.update(timeout="60"), "/timeout", "is not of type 'number'"),
        (lambda d: d.update(signals={"s": "high"}), "/signals/s", "is not of type"),
        (lambda d: d.update(join="some"), "/join", "is not one of"),
    ],
)
def test_schema_errors(mutate: Any, pointer: str, words: str) -> None:
    data = case(entry("A"))
    mutate(data)
    got = only(data)
    assert got[0] == pointer and words in got[1], got


def test_criterion_keys_depend_on_type() -> None:
    data = case(entry("A"), criteria=[crit("R", "record", "true", at=1), crit("F", "final", "true", **{"from": 1})])
    assert problems(data) == [
        ("/oracle/criteria/0/at", "'at' is only allowed on final criteria"),
        ("/oracle/criteria/1/from", "'from' is only allowed on period and temporal criteria"),
    ]


def test_all_schema_errors_are_reported() -> None:
    data = case(entry("A"), entry("B"))
    data["execute"][0]["kind"] = 3
    data["execute"][1]["afer"] = []
    assert [p for p, _ in problems(data)] == ["/execute/0/kind", "/execute/1/afer"]


def test_duplicate_ids_across_execute_and_oracle() -> None:
    data = case(entry("A"), entry("A"), criteria=[crit("A", "final", "true")])
    assert problems(data) == [
        ("/execute/1/id", "duplicate id 'A' (first used at /execute/0/id)"),
        ("/oracle/criteria/0/id", "duplicate id 'A' (first used at /execute/0/id)"),
    ]


def test_after_unknown_self_and_twice() -> None:
    data = case(entry("A"), entry("B", ["A", "A", "B", "Z"]))
    assert problems(data) == [
        ("/execute/1/after/1", "'A' is listed twice"),
        ("/execute/1/after/2", "'B' cannot come after itself"),
        ("/execute/1/after/3", "unknown id 'Z'"),
    ]


def test_after_naming_a_criterion() -> None:
    assert only(case(entry("A", ["F"]), criteria=[crit("F", "final", "true")]))[1] == "'F' is an oracle criterion, not an execute entry"


def test_cycle_is_named() -> None:
    data = case(entry("A", ["C"]), entry("B", ["A"]), entry("C", ["B"]), entry("D"))
    assert only(data) == ("/execute/0/after/0", "cycle: A -> B -> C -> A")


def test_two_cycles_both_reported() -> None:
    data = case(entry("A", ["B"]), entry("B", ["A"]), entry("C", ["D"]), entry("D", ["C"]))
    assert [m for _, m in problems(data)] == ["cycle: A -> B -> A", "cycle: C -> D -> C"]


def test_period_window_must_be_ordered() -> None:
    data = case(entry("A"), criteria=[crit("P", "period", "true", **{"from": 3, "to": 3})])
    assert only(data) == ("/oracle/criteria/0/from", "'from' (3) must be less than 'to' (3)")


def test_negative_duration() -> None:
    assert only(case(entry("A", duration=-1))) == ("/execute/0/params/duration", "must not be negative (got -1)")


def test_missing_and_unknown_params() -> None:
    data = case({"id": "A", "kind": "behavior", "action": "set", "params": {"signal": "s", "valeu": 1}})
    assert problems(data) == [("/execute/0/params", "missing required key 'value'"),
                              ("/execute/0/params/valeu", "unknown key 'valeu' (did you mean 'value'?)")]  # fmt: skip


@pytest.mark.parametrize(
    "expect, words",
    [
        ("speed <=", "syntax error"),
        ("speed.real > 0", "unknown signal 'speed.real'"),  # a dotted name is one signal name, never an attribute
        ("__import__('os')", "names starting with '_'"),
        ("open(1) > 0", "only abs(), min() and max()"),
        ("2 ** 1000", "Pow"),
        ("[x for x in y]", "unexpected character"),
        ("lambda: 1", "unexpected character"),
    ],
)
def test_bad_expressions(expect: str, words: str) -> None:
    pointer, message = only(case(entry("A"), criteria=[crit("R", "record", expect)]))
    assert pointer == "/oracle/criteria/0/expect" and words in message, message


def test_unknown_signal_when_signals_declared() -> None:
    data = case(entry("A", action="set", signal="sped", value=1), signals={"speed": 0},
                criteria=[crit("R", "record", "speed < lim")])  # fmt: skip
    assert problems(data) == [
        ("/execute/0/params/signal", "unknown signal 'sped' (did you mean 'speed'?)"),
        ("/oracle/criteria/0/expect", "unknown signal 'lim' in 'speed < lim'"),
    ]


def test_any_signal_allowed_without_signals() -> None:
    btgen_pytrees.load(case(entry("A", action="set", signal="anything", value=1)))


def test_unknown_action_names_the_known_ones() -> None:
    pointer, message = only(case(entry("A", action="fly", kind="behavior")))
    assert pointer == "/execute/0/action" and "unknown behavior action 'fly'" in message and "hold, profile, ramp, set" in message


def test_action_of_the_other_kind() -> None:
    assert "'wait' is a constraint action" in only(case(entry("A", action="wait", kind="behavior")))[1]


def test_too_many_ticks() -> None:
    assert only(case(entry("A"), tick=1e-6, timeout=1e9))[0] == "/timeout"
    assert only(case(entry("A"), tick=1e-9, timeout=1e-3))[0] == "/tick"  # below MIN_TICK


def test_reserved_signal_name() -> None:
    assert only(case(entry("A"), signals={"max": 1}))[0] == "/signals/max"


@pytest.mark.parametrize(
    "text, words",
    [
        ("{", "invalid JSON at line 1"),
        ('{"name": NaN}', "NaN is not valid JSON"),
        ('{"name": "a", "name": "b"}', "appears twice"),
        ("[" * 100000 + "]" * 100000, "nested too deeply"),
        (b"\xff\xfe", "not UTF-8"),
    ],
)
def test_bad_json_files(tmp_path: Any, text: Any, words: str) -> None:
    path = tmp_path / "bad.json"
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    with pytest.raises(InvalidTestCase) as info:
        btgen_pytrees.load(path)
    assert info.value.problems[0].pointer == "/" and words in info.value.problems[0].message


def test_missing_file() -> None:
    with pytest.raises(InvalidTestCase, match="cannot read file"):
        btgen_pytrees.load("/nonexistent/test.json")


def cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "btgen_pytrees", *args], capture_output=True, text=True, timeout=60)


def test_cli_reports_every_problem_with_file_and_pointer_and_exit_2(tmp_path: Any) -> None:
    data = case(entry("A", ["C"]), entry("B", ["A"]), entry("C", ["B"]), entry("D", ["Q"]))
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    out = tmp_path / "tree.txt"
    result = cli(str(path), "-o", str(out))
    assert result.returncode == 2
    assert result.stderr.splitlines() == [f"{path}: /execute/3/after/0: unknown id 'Q'"]
    assert "Traceback" not in result.stderr and not out.exists()
    data["execute"][3]["after"] = []
    path.write_text(json.dumps(data))
    assert cli("run", str(path)).stderr.splitlines() == [f"{path}: /execute/0/after/0: cycle: A -> B -> C -> A"]


def test_cli_validate_many(tmp_path: Any, fig1_path: str) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    result = cli("validate", fig1_path, str(bad))
    assert result.returncode == 2
    assert f"{fig1_path}: ok" in result.stdout and f"{bad}: /: missing required key" in result.stderr
    assert cli("validate", fig1_path).returncode == 0


@pytest.mark.parametrize("name", ["lambda", "None", "in", "max"])
def test_python_keywords_and_functions_are_not_signal_names(name: str) -> None:
    assert only(case(entry("A"), signals={name: 1}))[0] == f"/signals/{name}"
    assert only(case(entry("A", action="set", signal=name, value=1)))[0] == "/execute/0/params/signal"


def test_id_with_trailing_newline_is_rejected() -> None:
    assert only(case(entry("A\n")))[0] == "/execute/0/id"


def test_entry_id_shared_with_a_criterion_is_only_a_duplicate() -> None:
    data = case(entry("A"), entry("B", ["A"]), criteria=[crit("A", "final", "true")])
    assert problems(data) == [("/oracle/criteria/0/id", "duplicate id 'A' (first used at /execute/0/id)")]


def test_builtin_criteria_take_no_params() -> None:
    assert only(case(entry("A"), criteria=[crit("F", "final", "true", params={"x": 1})]))[0] == "/oracle/criteria/0/params"
