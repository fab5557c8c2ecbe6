"""Entries act in file order within a tick, and the loader warns when two may write one signal at once
(issue 10, defect 10)."""

from __future__ import annotations

import json
import pathlib
import subprocess
import sys
from typing import Any

from helpers import case, crit, entry, run_case

import btgen_pytrees


def setter(id: str, value: Any, after: tuple[str, ...] = (), **kw: Any) -> dict[str, Any]:
    return entry(id, after, action="set", signal="x", value=value, **kw)


def warned(data: dict[str, Any]) -> list[tuple[str, str]]:
    return [(w.pointer, w.message) for w in btgen_pytrees.load(data).warnings]


def test_two_roots_writing_one_signal_the_later_in_the_file_wins() -> None:
    for first, second in ((1, 2), (2, 1)):
        data = case(setter("A", first), setter("B", second), signals={"x": 0},
                    criteria=[crit("F", "final", f"x == {second}", at=0)])  # fmt: skip
        report = run_case(data)
        assert report.verdict == "pass", report.table()
        assert report.oracles[0].values == {"x": second}


def test_a_roots_chain_acts_before_the_next_root() -> None:
    """Tick order is tree order: C (after root A, later in the file than B) acts before root B."""
    data = case(entry("A", duration=0), setter("B", 2), setter("C", 3, ["A"]), signals={"x": 0},
                criteria=[crit("F", "final", "x == 2", at=0)])  # fmt: skip
    report = run_case(data)
    assert report.verdict == "pass" and {e.id: e.start for e in report.execute} == {"A": 0.0, "B": 0.0, "C": 0.0}


def test_unordered_writers_are_warned_about_as_data() -> None:
    data = case(setter("A", 1), setter("B", 2))
    assert warned(data) == [("/execute/1/params/signal", "signal 'x' is also written by A (/execute/0) and the timeline "
                                                         "does not order the two: on a tick both write it, the one ticked later wins")]  # fmt: skip
    assert btgen_pytrees.load(data).warnings[0].cause == "overlap"


def test_ordered_writers_are_not_warned_about() -> None:
    assert warned(case(setter("A", 1), setter("B", 2, ["A"]), setter("C", 3, ["B"]))) == []
    # all: J starts after both A and R have finished
    data = case(entry("R", action="ramp", signal="x", to=5, duration=2), setter("A", 1),
                setter("J", 2, ["A", "R"], join="all"))  # fmt: skip
    assert [p for p, _ in warned(data)] == ["/execute/1/params/signal"]  # A and R are roots: they overlap
    data["execute"][1] = entry("A", action="hold", duration=1)
    assert warned(data) == []


def test_a_join_any_does_not_order_its_entry_after_every_predecessor() -> None:
    # J starts when H (1 s) ends while R is still ramping x until 2 s
    data = case(entry("R", action="ramp", signal="x", to=5, duration=2), entry("H", duration=1),
                setter("J", 2, ["R", "H"], join="any"))  # fmt: skip
    assert warned(data) == [("/execute/2/params/signal", "signal 'x' is also written by R (/execute/0) and the timeline "
                                                         "does not order the two: on a tick both write it, the one ticked later wins")]  # fmt: skip
    # ... and indeed on the tick J writes 2, R overwrote it by the next tick
    report = run_case(dict(data, signals={"x": 0}, oracle={"criteria": [crit("F", "final", "x == 5")]}))
    assert report.verdict == "pass"


def test_the_cli_prints_warnings_on_stderr_and_still_succeeds(tmp_path: pathlib.Path) -> None:
    path = tmp_path / "w.json"
    path.write_text(json.dumps(case(setter("A", 1), setter("B", 2))))
    for command in (["validate"], ["run"], ["show"]):
        result = subprocess.run([sys.executable, "-m", "btgen_pytrees", *command, str(path)], capture_output=True, text=True)
        assert result.returncode == 0, result.stderr
        assert f"{path}: /execute/1/params/signal: warning: signal 'x' is also written by A" in result.stderr, command


def test_a_long_chain_of_writers_is_checked_in_linear_time() -> None:
    data = case(*[setter(f"S{i}", i, [f"S{i - 1}"] if i else []) for i in range(5000)])
    assert warned(data) == []


def test_the_check_gives_up_with_a_warning_when_its_budget_is_spent(monkeypatch: Any) -> None:
    from btgen_pytrees.load import warnings as overlap

    monkeypatch.setattr(overlap, "BUDGET_PER_ENTRY", 0)
    monkeypatch.setattr(overlap, "BUDGET_BASE", 0)
    assert warned(case(setter("A", 1), setter("B", 2), setter("C", 3))) == [
        ("/execute/0/params/signal", "signal 'x' is written by 3 entries; too many to check which of them may write it at the same time")]
