"""One round of corrections (issue 10, defect 5): params problems come with the shape problems,
in the same friendly words, and the printed schema lets an editor catch them too."""

from __future__ import annotations

import json
import pathlib
import subprocess
import sys
from typing import Any

import jsonschema
import pytest
from helpers import case, crit, entry

import btgen_pytrees
from btgen_pytrees import InvalidTestCase


def problems(data: Any) -> list[tuple[str, str]]:
    with pytest.raises(InvalidTestCase) as info:
        btgen_pytrees.load(data)
    return [(p.pointer, p.message) for p in info.value.problems]


def mixed() -> dict[str, Any]:
    """Shape problems (a misspelt kind, an unknown key, tick 0) and params problems, in one file."""
    data = case(
        {"id": "A", "kind": "behaviour", "action": "hold", "params": {"duration": 1}},
        entry("B", duration=1), entry("C"), entry("D", action="hodl", duration=1),
        {"id": "E", "kind": "behavior", "action": "hold", "params": {"duraton": 3}},
        {"id": "F", "kind": "behavior", "action": "hold", "params": {"duration": "3"}, "afer": ["A"]},
        tick=0,
    )  # fmt: skip
    return data


def test_params_problems_come_in_the_same_round_as_shape_problems() -> None:
    assert problems(mixed()) == [
        ("/execute/0/kind", "'behaviour' is not one of 'behavior', 'constraint' (did you mean 'behavior'?)"),
        ("/execute/3/action", "unknown behavior action 'hodl' (did you mean 'hold'?); known: hold, profile, ramp, set "
                              "(a plugin may add it: --plugin MODULE or FILE.py)"),
        ("/execute/4/params", "missing required key 'duration'"),
        ("/execute/4/params/duraton", "unknown key 'duraton' (did you mean 'duration'?)"),
        ("/execute/5/afer", "unknown key 'afer' (did you mean 'after'?)"),
        ("/execute/5/params/duration", "'3' is not of type 'number': expected seconds, >= 0"),
        ("/tick", "0 is less than or equal to the minimum of 0"),
    ]


def test_fixing_that_round_leaves_nothing() -> None:
    data = mixed()
    data["execute"][0]["kind"] = "behavior"
    data["execute"][3]["action"] = "hold"
    data["execute"][4]["params"] = {"duration": 3}
    data["execute"][5]["params"] = {"duration": 3}
    data["execute"][5]["after"] = data["execute"][5].pop("afer")
    data["tick"] = 0.1
    assert len(btgen_pytrees.load(data).entries) == 6


def test_a_criterion_params_problem_comes_with_shape_problems() -> None:
    data = case(entry("A"), criteria=[{"id": "F", "type": "final", "expect": "true", "params": {"x": 1}}], timeout=-1)
    assert problems(data) == [
        ("/oracle/criteria/0/params", '{"x": 1} is expected to be empty'),
        ("/timeout", "-1 is less than or equal to the minimum of 0"),
    ]


def test_the_printed_schema_describes_each_actions_params(tmp_path: pathlib.Path) -> None:
    out = subprocess.run([sys.executable, "-m", "btgen_pytrees", "schema"], capture_output=True, check=True)
    printed = json.loads(out.stdout)
    jsonschema.Draft202012Validator.check_schema(printed)
    validator = jsonschema.Draft202012Validator(printed)
    found = {"/" + "/".join(map(str, e.absolute_path)) for e in validator.iter_errors(mixed())}
    assert {"/execute/4/params", "/execute/5/params/duration"} <= found  # what an editor now flags
    assert not list(validator.iter_errors(json.loads((pathlib.Path(__file__).parent.parent / "examples" / "fig1.json").read_text())))
    ramp = next(r["then"]["properties"]["params"] for r in printed["$defs"]["entry"]["allOf"]
                if r["if"]["properties"]["action"] == {"const": "ramp"})  # fmt: skip
    assert ramp["required"] == ["signal", "to", "duration"] and "linearly" in ramp["description"]


@pytest.mark.parametrize("key, value", [("signals", [{"x": 0}]), ("system", 5), ("oracle", []), ("execute", {"A": 1}),
                                        ("signals", {"x": "text"}), ("join", 3)])  # fmt: skip
def test_any_malformed_top_level_value_still_gives_the_params_problems(key: str, value: Any) -> None:
    """Fuzz finding: the early params check must not depend on the shape of the rest of the document."""
    data = case(entry("A"), {"id": "B", "kind": "behavior", "action": "hold", "params": {"duraton": 1}},
                criteria=[crit("F", "final", "true")])  # fmt: skip
    data[key] = value
    found = [p for p, _ in problems(data)]
    assert found and all(p.startswith("/") for p in found)
    if key not in ("execute",):
        assert "/execute/1/params/duraton" in found
