"""The loader's shortcuts for valid documents report exactly what the words of its rules say when they fail."""

from __future__ import annotations

import pytest
from helpers import case, entry

import btgen_pytrees
from btgen_pytrees.errors import InvalidTestCase
from btgen_pytrees.load import parse_json


def _problems(data: dict) -> list[str]:
    with pytest.raises(InvalidTestCase) as info:
        btgen_pytrees.load(data)
    return [f"{p.pointer}: {p.message}" for p in info.value.problems]


def test_entries_with_equal_params_share_one_mapping() -> None:
    loaded = btgen_pytrees.load(case(*[entry(f"E{i}", [f"E{i - 1}"] if i else [], duration=0.5) for i in range(5)]))
    assert len({id(e.params) for e in loaded.entries}) == 1
    assert dict(loaded.entries[3].params) == {"duration": 0.5}


@pytest.mark.parametrize("bad", [-1, True, "1"])
def test_a_bad_value_after_good_equal_looking_ones_is_still_reported(bad: object) -> None:
    entries = [entry(f"E{i}", duration=1) for i in range(3)] + [entry("E3", duration=bad)]
    problems = _problems(case(*entries))
    assert len(problems) == 1 and problems[0].startswith("/execute/3/params/duration: ")


def test_signal_params_are_checked_per_entry() -> None:
    data = case(entry("A", action="set", signal="speed", value=1), entry("B", action="set", signal="sped", value=1),
                signals={"speed": 0})  # fmt: skip
    assert _problems(data) == ["/execute/1/params/signal: unknown signal 'sped' (did you mean 'speed'?)"]


def test_after_problems_keep_their_paths() -> None:
    data = case(entry("A"), entry("B", ["A", "A", "B", "Z"]))
    assert _problems(data) == ["/execute/1/after/1: 'A' is listed twice", "/execute/1/after/2: 'B' cannot come after itself",
                               "/execute/1/after/3: unknown id 'Z'"]  # fmt: skip


def test_a_cycle_among_entries_named_later_in_the_file() -> None:
    data = case(entry("A", ["C"]), entry("B", ["A"]), entry("C", ["B"]), entry("D", ["E"]), entry("E"))
    assert _problems(data) == ["/execute/0/after/0: cycle: A -> B -> C -> A"]
    btgen_pytrees.load(case(entry("D", ["E"]), entry("E")))  # backwards but acyclic


def test_duplicate_keys_name_the_first_repeated_key() -> None:
    with pytest.raises(InvalidTestCase) as info:
        parse_json('{"a": 1, "b": 2, "c": {"x": 1, "y": 2, "x": 3}, "b": 4}')
    assert "key 'x' appears twice" in info.value.problems[0].message
