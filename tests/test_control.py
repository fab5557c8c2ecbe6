"""The control-flow keys (docs/format.md#control-flow, docs/semantics.md#control-flow): each one run, tick by tick.

Every test runs the generated tree against the simulated system and checks the times the report and the
trace give - tick-exact, at tick 0.1 (tick k at t = round(k * 0.1, 9)).
"""

from __future__ import annotations

import importlib.util
import json
import os
import pathlib
import subprocess
import sys

import pytest

from btgen_pytrees import InvalidTestCase, generate, load
from btgen_pytrees.leaves.control import Attempts, Controlled, Gate, Repetitions, StopGuard, VirtualTimeout
from btgen_pytrees.leaves.wiring import Cuttable
from btgen_pytrees.run import run

from helpers import case, crit, entry


def results(report):  # type: ignore[no-untyped-def]
    return {e.id: (e.status, e.start, e.end) for e in report.execute}


def traced(data):  # type: ignore[no-untyped-def]
    lines: list[str] = []
    report = run(load(data), trace=lines.append)
    return report, [" ".join(line.split()) for line in lines]


def ramp_x(to: float = 10, duration: float = 2) -> dict:
    """``x`` from 0 to *to* over *duration*: x = to / duration * t."""
    return entry("R", action="ramp", signal="x", to=to, duration=duration)


def test_when_without_after_starts_on_the_first_tick_it_holds() -> None:
    # x = 5 t, written by R before B ticks (R is first): x > 3 first holds at t = 0.7 (x = 3.5)
    b = {**entry("B", duration=0.5), "when": "x > 3"}
    report = run(load(case(ramp_x(), b, signals={"x": 0})))
    assert results(report)["B"] == ("success", 0.7, 1.2)


def test_when_waits_after_the_predecessors() -> None:
    # A ends at 1.0; x > 3 holds since 0.7: B starts on the tick A ended
    b = {**entry("B", ["A"], duration=0.5), "when": "x > 3"}
    report = run(load(case(ramp_x(), entry("A", duration=1), b, signals={"x": 0})))
    assert results(report)["B"] == ("success", 1.0, 1.5)


def test_rising_edge_never_fires_on_the_first_evaluation() -> None:
    # x > 3 already holds when B begins to wait (A ends at 1.0): with rising, it must become false and true again
    hold_b = {**entry("B", ["A"], duration=0.2), "when": "x > 3", "edge": "rising"}
    report = run(load(case(ramp_x(), entry("A", duration=1), hold_b, signals={"x": 0}, timeout=5)))
    assert results(report)["B"] == ("not-started", None, None)
    # from the start, x rises through 3 at 0.7: the edge between 0.6 (x = 3, false) and 0.7 (true)
    early = {**entry("B", duration=0.2), "when": "x > 3", "edge": "rising"}
    report = run(load(case(ramp_x(), early, signals={"x": 0})))
    assert results(report)["B"] == ("success", 0.7, 0.9)


def test_falling_and_any_edges() -> None:
    # x falls from 10 to 0 over 2 s (x = 10 - 5 t): x > 3 turns false at 1.4 (x = 3)
    down = entry("R", action="ramp", signal="x", to=0, duration=2)
    falling = {**entry("B", duration=0.1), "when": "x > 3", "edge": "falling"}
    either = {**entry("C", duration=0.1), "when": "x > 3", "edge": "any"}
    report = run(load(case(down, falling, either, signals={"x": 10})))
    assert results(report)["B"] == ("success", 1.4, 1.5)
    assert results(report)["C"] == ("success", 1.4, 1.5)


def test_delay_counts_from_the_trigger() -> None:
    b = {**entry("B", duration=0.5), "when": "x > 3", "delay": 0.25}  # fires at 0.7, starts at the first tick >= 0.95
    a = {**entry("A", ["B"], duration=0.1)}
    report = run(load(case(ramp_x(), b, a, signals={"x": 0})))
    assert results(report)["B"] == ("success", 1.0, 1.5)
    assert results(report)["A"] == ("success", 1.5, 1.6)
    only_delay = {**entry("D", duration=0.5), "delay": 2}
    assert results(run(load(case(only_delay))))["D"] == ("success", 2.0, 2.5)


def test_timeout_fails_the_entry_on_the_first_tick_past_it() -> None:
    report = run(load(case({**entry("A", duration=5), "timeout": 1.25})))
    assert report.verdict == "fail"
    assert results(report)["A"] == ("failure", 0.0, 1.3)
    assert report.execute[0].message == "timed out after 1.25 s"
    # an action that finishes on the tick the timeout falls due keeps its success
    assert results(run(load(case({**entry("A", duration=1), "timeout": 1}))))["A"] == ("success", 0.0, 1.0)


def test_attempts_start_again_on_the_tick_the_last_failed() -> None:
    a = {**entry("A", action="until", expect="x > 100", timeout=0.5), "attempts": 3}
    report, lines = traced(case(a, signals={"x": 0}))
    assert results(report)["A"] == ("failure", 0.0, 1.5)
    assert report.execute[0].message.startswith("attempt 3 of 3 failed: x > 100 still false after 0.5 s")
    assert "0.5 attempt A 2 of 3 after: x > 100 still false after 0.5 s (x=0)" in lines
    assert "1 attempt A 3 of 3 after: x > 100 still false after 0.5 s (x=0)" in lines
    assert lines[-2].startswith("1.5 failure A attempt 3 of 3 failed")


def test_an_attempt_that_succeeds_ends_the_entry() -> None:
    # the second attempt of A sees x > 3 (x = 5 t from 0): until x > 3 with 0.5 s per attempt: 0-0.5 fails, 0.5-0.7 holds
    a = {**entry("A", action="until", expect="x > 3", timeout=0.5), "attempts": 3}
    report = run(load(case(ramp_x(), a, signals={"x": 0})))
    assert results(report)["A"] == ("success", 0.0, 0.7)


def test_timeout_inside_attempts_times_each_attempt() -> None:
    a = {**entry("A", duration=5), "timeout": 1, "attempts": 2}
    report, lines = traced(case(a))
    assert results(report)["A"] == ("failure", 0.0, 2.0)
    assert report.execute[0].message == "attempt 2 of 2 failed: timed out after 1 s"
    # the retry's line says why the attempt before failed: its timeout, not the action's progress ("1/5 s")
    assert "1 attempt A 2 of 2 after: timed out after 1 s" in lines


def test_repeat_runs_in_a_row_and_waits_for_when_again() -> None:
    report, lines = traced(case({**entry("A", duration=0.5), "repeat": 3}, {**entry("B", ["A"], duration=0.1)}))
    assert results(report)["A"] == ("success", 0.0, 1.5)
    assert results(report)["B"] == ("success", 1.5, 1.6)
    assert "0.5 repeat A repetition 2 of 3" in lines and "1 repeat A repetition 3 of 3" in lines
    # each repetition waits for its when: y toggles every 0.5 s (a set of 1 or 0 for 0.5 s, in a loop of 4)
    toggles = [entry(f"T{i}", [f"T{i - 1}"] if i else [], action="set", signal="y", value=i % 2, duration=0.5)
               for i in range(8)]  # fmt: skip
    rep = {**entry("C", duration=0.1), "when": "y == 1", "edge": "rising", "repeat": 2}
    report = run(load(case(*toggles, rep, signals={"y": 0})))
    # y is 1 from 0.5 (rising seen at 0.5), 0 from 1.0, 1 from 1.5: C at 0.5-0.6, waits, again at 1.5-1.6
    assert results(report)["C"] == ("success", 0.5, 1.6)


def test_repeat_fails_at_the_first_failure() -> None:
    a = {**entry("A", action="until", expect="x > 1", timeout=0.3), "repeat": 2}
    report = run(load(case(ramp_x(to=10, duration=10), a, signals={"x": 0})))  # x = t: x > 1 from 1.1
    assert results(report)["A"] == ("failure", 0.0, 0.3)
    assert report.execute[1].message.startswith("repetition 1 of 2 failed: x > 1 still false after 0.3 s")


def test_stops_stops_the_running_entries_on_the_next_tick() -> None:
    # K starts at 2 and stops A (running) and C (not started: A's successor); A's successor never starts
    data = case(entry("A", duration=10), entry("C", ["A"]), entry("W", duration=2),
                {**entry("K", ["W"], duration=1), "stops": ["A", "C"]})  # fmt: skip
    report, lines = traced(data)
    assert report.verdict == "pass"  # no criteria: the timeline ended (A stopped, C never started)
    got = results(report)
    assert got["A"] == ("stopped", 0.0, 2.1) and got["C"] == ("not-started", None, None)
    assert got["K"] == ("success", 2.0, 3.0)
    assert report.execute[0].message == "stopped by K at 2 s"
    assert "2.1 stopped A stopped by K at 2 s" in lines
    assert report.duration == 3.0


def test_a_stopped_entry_does_not_feed_a_join() -> None:
    # J waits for all of A and B: A is stopped, so J never runs and the timeline still ends (join given up)
    data = case(entry("A", duration=5), entry("B", duration=0.5), entry("J", ["A", "B"], join="all"),
                {**entry("K", ["B"], duration=0.1), "stops": ["A"]})  # fmt: skip
    report = run(load(data))
    got = results(report)
    assert got["A"][0] == "stopped" and got["J"] == ("not-started", None, None)
    assert report.verdict == "pass" and report.duration == 0.6
    # with join any, J starts from B
    data["execute"][2]["join"] = "any"
    assert results(run(load(data)))["J"] == ("success", 0.5, 1.5)


def test_race_first_to_succeed_stops_the_others() -> None:
    data = case({**entry("A1", duration=1), "race": "r"}, {**entry("A2", duration=2), "race": "r"},
                {**entry("A3", duration=3), "race": "r"}, entry("N", ["A1", "A2", "A3"], duration=0.5))  # fmt: skip
    report = run(load(data))
    got = results(report)
    assert got["A1"] == ("success", 0.0, 1.0)
    assert got["A2"] == ("stopped", 0.0, 1.1) and got["A3"] == ("stopped", 0.0, 1.1)
    assert report.execute[1].message == "lost the race to A1"
    assert got["N"] == ("success", 1.0, 1.5)


def test_race_ties_on_one_tick_both_win() -> None:
    data = case({**entry("A1", duration=1), "race": "r"}, {**entry("A2", duration=1), "race": "r"})
    got = results(run(load(data)))
    assert got["A1"] == ("success", 0.0, 1.0) and got["A2"] == ("success", 0.0, 1.0)


def test_stop_ends_the_run_with_the_oracles_verdict() -> None:
    data = case(ramp_x(), entry("L", duration=30), criteria=[crit("F", "final", "x >= 5"), crit("P", "record", "x < 9")],
                signals={"x": 0}, stop=[{"when": "x >= 6"}])  # fmt: skip
    report, lines = traced(data)
    # x >= 6 first holds on the tick at 1.2 (R writes 6 then): the stop, checked again after the entries, ends it then
    assert report.verdict == "pass" and report.duration == 1.2
    assert results(report)["L"][0] == "stopped"
    assert report.execute[1].message == "stopped by stop[0] at 1.2 s"
    assert [o.verdict for o in report.oracles] == ["pass", "pass"]
    assert lines[-1].endswith("end pass")
    data["oracle"]["criteria"][0]["expect"] = "x >= 7"
    assert run(load(data)).verdict == "fail"


def test_stop_with_delay_and_edge() -> None:
    data = case(ramp_x(), entry("L", duration=30), signals={"x": 0},
                stop=[{"when": "x > 3", "edge": "rising", "delay": 0.5}])  # fmt: skip
    report = run(load(data))
    # rising seen at 0.7 (x written at 0.7, seen by the stop's check after the entries): due at 1.2
    assert report.verdict == "pass" and report.duration == 1.2


def test_a_when_reads_another_entrys_state_from_the_next_tick() -> None:
    data = case(entry("A", duration=1), {**entry("B", duration=0.5), "when": "A.ended"},
                {**entry("C", duration=0.5), "when": "A.running && !A.ended"})  # fmt: skip
    got = results(run(load(data)))
    assert got["B"] == ("success", 1.1, 1.6)  # A ended at 1.0: seen from 1.1 on, whatever the order
    assert got["C"] == ("success", 0.1, 0.6)  # A started at 0: seen running from 0.1


def test_the_tree_holds_py_trees_decorators() -> None:
    data = case({**entry("A", duration=1), "when": "x > 0", "edge": "rising", "delay": 1, "timeout": 2, "attempts": 2,
                 "repeat": 3, "stops": ["B"]}, {**entry("B", duration=1), "race": "r"}, {**entry("C"), "race": "r"},
                signals={"x": 0}, stop=[{"when": "x > 5"}])  # fmt: skip
    root = generate(load(data))
    kinds = {type(n) for n in root.iterate()}
    assert {Controlled, Repetitions, Gate, Attempts, VirtualTimeout, StopGuard, Cuttable} <= kinds
    import py_trees

    assert issubclass(Attempts, py_trees.decorators.Retry) and issubclass(Repetitions, py_trees.decorators.Repeat)
    assert issubclass(VirtualTimeout, py_trees.decorators.Timeout)
    a = next(n for n in root.iterate() if isinstance(n, Controlled) and n.entry.id == "A")
    order = [a]
    while order[-1].children:
        order.append(order[-1].children[-1])
    assert [type(n).__name__ for n in order] == ["Controlled", "Repetitions", "Gate", "Attempts", "VirtualTimeout",
                                                 "Hold"]  # fmt: skip
    assert isinstance(Gate, type) and issubclass(Gate, py_trees.decorators.Decorator)


def test_the_control_nodes_start_as_py_trees_own_init_starts_them() -> None:
    """They are built without the chain of py_trees' ``__init__`` calls (leaves/control.py, ``_decorate``), so each is
    compared with one that py_trees' own chain started: the same attributes in the same order, with the same values."""
    import py_trees

    from btgen_pytrees.expressions import parse
    from btgen_pytrees.leaves import Environment
    from btgen_pytrees.leaves.control import Condition

    env = Environment("control_init", None, {"x": 0})
    owner = Controlled.__new__(Controlled)
    the_entry = load(case({**entry("A"), "attempts": 2})).entries[0]
    Gate(py_trees.behaviours.Success("first"), owner, Condition(parse("x > 1")), env)  # the one its names' client attaches to
    decorators = py_trees.decorators
    made = [(lambda c: VirtualTimeout(c, 1.5, env, owner), decorators.Timeout, {"name": "timeout 1.5 s", "duration": 1.5}),
            (lambda c: Attempts(c, 3, owner), decorators.Retry, {"name": "3 attempts", "num_failures": 3}),
            (lambda c: Repetitions(c, 2, owner, starts=True), decorators.Repeat, {"name": "repeat 2", "num_success": 2}),
            (lambda c: Gate(c, owner, Condition(parse("x > 1")), env), decorators.Decorator, {"name": "when x > 1"}),
            (lambda c: Controlled(c, the_entry, env), decorators.Decorator, {"name": "A"})]  # fmt: skip
    for make, base, arguments in made:
        ours, child = make(py_trees.behaviours.Success("a")), py_trees.behaviours.Success("a")
        stock = type(ours).__new__(type(ours))
        base.__init__(stock, child=child, **arguments)  # type: ignore[call-arg]
        expected = vars(stock)
        assert list(vars(ours))[: len(expected)] == list(expected), type(ours)
        for key, value in expected.items():
            got = vars(ours)[key]
            if key == "children":
                assert got == [ours.decorated] and value == [child] and ours.decorated.parent is ours
            elif key == "decorated":
                assert type(got) is type(value)
            else:
                assert type(got) is type(value) and got == value, (type(ours), key)
    with pytest.raises(TypeError, match="must be an instance of py_trees.behaviours.Behaviour"):
        Attempts("not a node", 2, owner)  # type: ignore[arg-type]


def test_plain_cases_build_no_control_nodes() -> None:
    root = generate(load(str(pathlib.Path(__file__).parents[1] / "examples" / "fig1.json")))
    assert not any(isinstance(n, (Controlled, Cuttable, StopGuard, Gate)) for n in root.iterate())


@pytest.mark.parametrize(
    "change, pointer, words",
    [
        ({"attempts": 0}, "/execute/1/attempts", "less than the minimum of 1"),
        ({"edge": "rise"}, "/execute/1/edge", "did you mean 'rising'"),
        ({"when": "spede > 1"}, "/execute/1/when", "unknown signal 'spede' in 'spede > 1' (did you mean 'speed'?)"),
        ({"stops": ["AA"]}, "/execute/1/stops/0", "unknown id 'AA' (did you mean 'A'?)"),
        ({"stops": ["B"]}, "/execute/1/stops/0", "'B' cannot stop itself"),
        ({"race": "r"}, "/execute/1/race", "race 'r' has one entry"),
        ({"edge": "rising"}, "/execute/1/edge", "an edge needs a 'when'"),
        ({"delay": -1}, "/execute/1/delay", "must not be negative (got -1)"),
        ({"timeout": 0}, "/execute/1/timeout", "less than or equal to the minimum of 0"),
        ({"when": "A.endd"}, "/execute/1/when", "unknown signal 'A.endd'"),
    ],
)
def test_bad_keys_are_named_at_their_pointer(change: dict, pointer: str, words: str) -> None:
    data = case(entry("A"), {**entry("B"), **change}, signals={"speed": 0})
    with pytest.raises(InvalidTestCase) as info:
        load(data)
    found = [(p.pointer, p.message) for p in info.value.problems]
    assert any(p == pointer and words in m for p, m in found), found


@pytest.mark.parametrize(
    "change, pointer, words",
    [
        ({"attempts": True}, "/execute/2/attempts", "true is not of type 'integer'"),
        ({"attempts": 2, "atempts": 2}, "/execute/2/atempts", "unknown key 'atempts' (did you mean 'attempts'?)"),
        ({"attempts": 2, "params": None}, "/execute/2/params", "null is not of type 'object'"),
        ({"attempts": 2.5}, "/execute/2/attempts", "2.5 is not of type 'integer'"),
        ({"attempts": 2, "stops": ["A", "A"]}, "/execute/2/stops/1", "'A' is listed twice"),
    ],
)
def test_entries_with_the_same_keys_share_one_control_and_a_near_copy_is_checked(tmp_path, change: dict, pointer: str,
                                                                                   words: str) -> None:  # fmt: skip  # type: ignore[no-untyped-def]
    """The loader builds an entry's keys once per distinct set (entries with equal keys share one Control): an
    entry whose keys look like an earlier one's - equal in Python (True == 1 == 1.0), or the same keys with one
    more - is still checked, from a dict and from a file."""
    first = {**entry("B", duration=0.1), "attempts": 2, "stops": ["A"]}
    same = {**entry("C", duration=0.1), "attempts": 2, "stops": ["A"]}
    good = case(entry("A", duration=1), first, same, {**entry("D", duration=0.1), "attempts": 2.0, "stops": ["A"]})
    loaded = load(good)
    assert loaded.entries[1].control is loaded.entries[2].control  # one Control for equal keys
    assert loaded.entries[3].control is not loaded.entries[1].control  # 2.0: a number of another type, built again
    assert [(c.attempts, c.stops) for c in (e.control for e in loaded.entries[1:])] == [(2, ("A",))] * 3
    assert results(run(loaded)) == {"A": ("stopped", 0.0, 0.1), **{k: ("success", 0.0, 0.1) for k in "BCD"}}
    bad = case(entry("A", duration=1), first, {**entry("C", duration=0.1), "stops": ["A"], **change})
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(bad))
    for source in (bad, str(path)):
        with pytest.raises(InvalidTestCase) as info:
            load(source)
        found = [(p.pointer, p.message) for p in info.value.problems]
        assert any(p == pointer and words in m for p, m in found), found


def test_a_problem_of_shared_keys_is_named_at_every_entry_that_holds_them() -> None:
    same = {"when": "spede > 1", "edge": "rising"}
    data = case(entry("A"), {**entry("B"), **same}, {**entry("C"), **same}, {**entry("D"), "edge": "any"},
                {**entry("E"), "edge": "any"}, signals={"speed": 0})  # fmt: skip
    with pytest.raises(InvalidTestCase) as info:
        load(data)
    assert [(p.pointer, p.message) for p in info.value.problems] == [
        ("/execute/1/when", "unknown signal 'spede' in 'spede > 1' (did you mean 'speed'?)"),
        ("/execute/2/when", "unknown signal 'spede' in 'spede > 1' (did you mean 'speed'?)"),
        ("/execute/3/edge", "an edge needs a 'when' to watch"), ("/execute/4/edge", "an edge needs a 'when' to watch")]


def test_repeat_in_a_race_is_refused_and_the_cli_exits_2(tmp_path) -> None:  # type: ignore[no-untyped-def]
    data = case({**entry("A"), "race": "r", "repeat": 2}, {**entry("B"), "race": "r"}, stop=[{"when": "B.strted"}])
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    done = subprocess.run([sys.executable, "-m", "btgen_pytrees", "run", str(path)], capture_output=True, text=True)
    assert done.returncode == 2
    assert f"{path}: /execute/0/repeat: 'A' runs in race 'r'" in done.stderr
    assert f"{path}: /stop/0/when: unknown signal 'B.strted'" in done.stderr
    assert "Traceback" not in done.stderr


def modified_case() -> dict:
    return case(ramp_x(), {**entry("B", duration=0.5), "when": "x > 3", "edge": "rising", "delay": 0.2, "timeout": 1,
                           "attempts": 2, "repeat": 2, "stops": ["R"]},
                signals={"x": 0}, stop=[{"when": "x > 9"}], timeout=5)  # fmt: skip


def test_the_views_show_each_modifier() -> None:
    from btgen_pytrees.render import text_tree, tree_data

    root = generate(load(modified_case()))
    text = text_tree(root)
    for words in ("B · behavior: when x > 3 (rising), delay 0.2 s, timeout 1 s, 2 attempts, repeat 2, stops R",
                  "trigger: starts when x > 3 (rising edge), then waits 0.2 s", "Retry: a failed attempt starts again",
                  "Repeat: runs 2 times in a row", "Timeout: fails an attempt still running after 1 s",
                  "action of B: behavior hold(duration=0.5)", "ends the run when x > 9"):  # fmt: skip
        assert words in text, words
    data = tree_data(root)
    found = {}
    stack = [data]
    while stack:
        node = stack.pop()
        stack.extend(node["children"])
        for key in ("control", "when", "attempts", "repeat", "timeout", "stop"):
            if key in node:
                found[key if key != "control" else f"control {node['id']}"] = node[key]
    assert found["control R"] == {}
    assert found["control B"] == {"when": "x > 3", "edge": "rising", "delay": 0.2, "timeout": 1.0, "attempts": 2,
                                "repeat": 2, "stops": ["R"]}  # fmt: skip
    assert found["attempts"] == 2 and found["repeat"] == 2 and found["timeout"] == 1.0
    assert found["stop"] == [{"when": "x > 9", "edge": "none", "delay": 0.0}]


def test_btcpp_export_uses_btcpps_own_decorators_and_the_btlog_records_them() -> None:
    import xml.etree.ElementTree as ET

    from btgen_pytrees.render.btcpp import btcpp_xml
    from btgen_pytrees.run.btlog import btlog_bytes, parse_btlog

    data = load(modified_case())
    xml = btcpp_xml(generate(data))
    tree = ET.fromstring(xml)
    repeat = tree.find(".//Repeat")
    assert repeat is not None and repeat.get("num_cycles") == "2"
    gate = repeat.find("./Decorator")
    assert gate is not None and gate.get("ID") == "Gate" and gate.get("when") == "x > 3" and gate.get("edge") == "rising"
    delay = gate.find("./Delay")
    assert delay is not None and delay.get("delay_msec") == "200"
    retry = delay.find("./RetryUntilSuccessful")
    assert retry is not None and retry.get("num_attempts") == "2"
    timeout = retry.find("./Timeout")
    assert timeout is not None and timeout.get("msec") == "1000"
    assert timeout.find("./Action").get("ID") == "hold"
    report = run(data)
    log = parse_btlog(btlog_bytes(report.trace, generate(data)))
    uids = {e.get("name"): int(e.get("_uid")) for e in ET.fromstring(log.xml).iter() if e.get("_uid")}
    changed = {uid for _, uid, _ in log.transitions}
    assert {uids["repeat 2"], uids["2 attempts"], uids["timeout 1 s"]} <= changed


def every_key_case() -> dict:
    """All eight keys and a ``stop``: K (when, edge, delay, timeout, attempts, stops L), T (timeout, attempts), P (when,
    repeat), a race of A1 and A2; the stop fires at 1.5 s (x = 5 t rises through 6 at 1.4 s, then 0.1 s)."""
    return case(ramp_x(), {**entry("K", duration=0.1), "when": "x > 3 && x < 100", "edge": "rising", "delay": 0.2,
                           "timeout": 1, "attempts": 2, "stops": ["L"]},
                entry("L", duration=5), {**entry("T", duration=0.2), "timeout": 0.3, "attempts": 3},
                {**entry("P", duration=0.5), "when": "x >= 0", "repeat": 3}, {**entry("A1", duration=0.2), "race": "r"},
                {**entry("A2", duration=0.6), "race": "r"}, signals={"x": 0},
                stop=[{"when": "x > 6", "edge": "rising", "delay": 0.1}])  # fmt: skip


def test_the_explanation_says_where_each_entry_was_when_the_run_timed_out() -> None:
    data = every_key_case()
    del data["stop"]
    data["timeout"] = 0.8  # P's second repetition runs (0.5-1.0), K waits for x > 3 rising (fires at 0.7, + 0.2 s)
    report = run(load(data))
    assert report.verdict == "timeout"
    assert results(report)["P"] == ("running", 0.0, None) and results(report)["A2"] == ("stopped", 0.0, 0.3)
    messages = {e.id: e.message for e in report.execute}
    assert messages["P"] == "repetition 2 of 3 running at the timeout" and messages["A2"] == "lost the race to A1"
    assert messages["K"] == "waiting (when x > 3 && x < 100 (rising), delay 0.2 s)"
    why = [str(line) for line in report.explanation]
    assert "  P running since 0 s (0.8 s): repetition 2 of 3 running at the timeout" in why
    assert "  K waiting (when x > 3 && x < 100 (rising), delay 0.2 s)" in why


def test_every_view_and_export_carries_the_eight_keys_and_the_stop() -> None:
    """The tree ticked once for the run, then each view of the tree and of the run: ASCII, dot (the SVG's source), JSON,
    the replay page's nodes, BT.CPP XML with BehaviorTree.CPP's own nodes, and the .btlog (its tree and transitions)."""
    import xml.etree.ElementTree as ET

    from btgen_pytrees.render import text_tree, tree_data
    from btgen_pytrees.render.btcpp import btcpp_xml
    from btgen_pytrees.render.dot import dot_source
    from btgen_pytrees.run.btlog import btlog_bytes, parse_btlog
    from btgen_pytrees.run.replay import replay_html

    loaded = load(every_key_case())
    report = run(loaded)
    assert results(report) == {"R": ("stopped", 0.0, None), "K": ("success", 0.9, 1.0), "L": ("stopped", 0.0, 1.0),
                               "T": ("success", 0.0, 0.2), "P": ("stopped", 0.0, None), "A1": ("success", 0.0, 0.2),
                               "A2": ("stopped", 0.0, 0.3)}  # fmt: skip
    words = ["when x > 3 && x < 100 (rising), delay 0.2 s, timeout 1 s, 2 attempts, stops L", "timeout 0.3 s, 3 attempts", "when x >= 0, repeat 3", "race r",
             "ends the run when x > 6 (rising edge) + 0.1 s"]  # fmt: skip
    text = text_tree(generate(loaded), unicode=False)
    dot = " ".join(dot_source(generate(loaded)).replace("\\n", " ").split())
    page = replay_html(report, loaded, generate(loaded)).decode("utf-8")
    notes = " ".join(row[2] for row in json.loads(page.split('id="run-data">')[1].split("</script>")[0])["nodes"])
    for view, shown in (("ascii", text), ("dot", dot), ("replay", notes)):
        for w in words:
            assert w in shown, (view, w)
    controls, stop, stack = {}, None, [tree_data(generate(loaded))]
    while stack:
        node = stack.pop()
        stack.extend(node["children"])
        if "control" in node:
            controls[node["id"]] = node["control"]
        stop = node.get("stop", stop)
    assert controls == {"K": {"when": "x > 3 && x < 100", "edge": "rising", "delay": 0.2, "timeout": 1.0, "attempts": 2,
                              "stops": ["L"]}, "L": {},
                        "T": {"timeout": 0.3, "attempts": 3}, "P": {"when": "x >= 0", "repeat": 3},
                        "A1": {"race": "r"}, "A2": {"race": "r"}}  # fmt: skip
    assert stop == [{"when": "x > 6", "edge": "rising", "delay": 0.1}]
    log = parse_btlog(btlog_bytes(report.trace, generate(loaded)))
    for xml in (btcpp_xml(generate(loaded)), log.xml):  # BT.CPP's file, and the .btlog's (Groot2's: the tags are IDs)
        tree = ET.fromstring(xml).find("BehaviorTree")
        named = {e.get("name"): e for e in tree.iter() if (e.get("ID") or e.tag) == "Controlled"}
        assert named["K"].get("stops") == "L" and named["A1"].get("race") == named["A2"].get("race") == "r"
        gate = next(e for e in named["K"] if (e.get("ID") or e.tag) == "Gate")
        assert (gate.get("when"), gate.get("edge"), gate.find("./Delay").get("delay_msec")) == ("x > 3 && x < 100", "rising",
                                                                                              "200")  # fmt: skip
        assert gate.find("./Delay/RetryUntilSuccessful/Timeout").get("msec") == "1000"
        assert named["T"].find("./RetryUntilSuccessful").get("num_attempts") == "3"
        assert named["T"].find("./RetryUntilSuccessful/Timeout").get("msec") == "300"
        assert named["P"].find("./Repeat").get("num_cycles") == "3"
        guard = next(e for e in tree.iter() if (e.get("ID") or e.tag) == "StopGuard")
        assert (guard.get("when"), guard.get("edge"), guard.get("delay_msec")) == ("x > 6", "rising", "100")
    uids = {(e.tag, e.get("name")): int(e.get("_uid")) for e in ET.fromstring(log.xml).iter() if e.get("_uid")}
    seen: dict[int, set[int]] = {}
    for _, uid, status in log.transitions:  # BT.CPP's codes: 0 idle, 1 running, 2 success, 3 failure
        seen.setdefault(uid, set()).add(status)
    assert 3 in seen[uids["Controlled", "L"]] and 3 in seen[uids["Controlled", "A2"]]  # stopped: the entry failed
    assert {1, 2} <= seen[uids["Gate", "when x > 3 && x < 100 (rising), delay 0.2 s"]] and 1 in seen[uids["Repeat", "repeat 3"]]
    assert {1, 2} <= seen[uids["RetryUntilSuccessful", "3 attempts"]] and {1, 2} <= seen[uids["Timeout", "timeout 0.3 s"]]
    assert 2 in seen[uids["StopGuard", "stop when x > 6 (rising), delay 0.1 s"]]  # the stop fired: it succeeded


@pytest.mark.skipif(importlib.util.find_spec("libsumo") is None and not os.environ.get("CI"),
                    reason="libsumo is not installed (pip install -e '.[sumo]'; CI installs it)")  # fmt: skip
def test_a_when_on_a_sumo_signal_fires_on_the_tick_the_gap_first_falls_under_20_m() -> None:
    """examples/sumo/brake_on_gap.json: BRAKE starts on the first tick SUMO's ego.gap is under 20 m (rising: it
    was not on the tick before), as libsumo published it before that tick - the trace's sample of the tick."""
    path = pathlib.Path(__file__).parents[1] / "examples" / "sumo" / "brake_on_gap.json"
    report = run(load(str(path)))
    assert report.verdict == "pass"
    gap = report.trace.series("ego.gap")
    first = next(t for (t, g), (_, before) in zip(gap[1:], gap) if g < 20 <= before)
    brake = next(e for e in report.execute if e.id == "BRAKE")
    assert brake.status == "success" and brake.start == first == 4.3
    quiet = run(load(str(path)), record=False)  # the SUMO run that publishes only what the tree reads
    assert [(e.id, e.start, e.end) for e in quiet.execute] == [(e.id, e.start, e.end) for e in report.execute]


def test_the_benchmark_chains_run_and_differ_only_in_their_keys() -> None:
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))
    from benchmarks import control as bench

    plain, modified = load(bench.chain(40, False)), load(bench.chain(40, True))
    assert sum(e.control is not None for e in modified.entries) == 4 and all(e.control is None for e in plain.entries)
    a, b = run(plain), run(modified)
    assert a.verdict == b.verdict == "pass" and a.ticks == b.ticks == 41
    figures = bench.measure((20, 40), rounds=2)
    assert figures["sizes"][20]["ticks"] == 21 and figures["sizes"][40]["ticks"] == 41
    assert all(len(figures["sizes"][n][k]["ratios"]) == 2 for n in (20, 40) for k in ("build", "build_dict", "run"))
    assert set(figures["run_scaling"]) == {"plain", "modified"}
    text = bench.report(figures)
    assert "load+generate from the file" in text and "from the dict" in text and "1.0 = linear" in text


def test_parameters_stand_in_the_control_keys() -> None:
    data = case(ramp_x(), {**entry("B", duration=0.5), "when": "x > $lim", "delay": "$d", "attempts": "$n"},
                signals={"x": 0}, parameters={"lim": 3, "d": 0.5, "n": 2}, stop=[{"when": "x >= $top", "delay": "$d"}])  # fmt: skip
    data["parameters"]["top"] = 9
    loaded = load(data)
    control = loaded.entries[1].control
    assert control.when.source == "x > 3" and control.delay == 0.5 and control.attempts == 2
    assert loaded.stop[0].when.source == "x >= 9" and loaded.stop[0].delay == 0.5
    assert results(run(loaded))["B"] == ("success", 1.2, 1.7)  # x > 3 from 0.7, then 0.5 s
