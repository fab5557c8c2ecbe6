"""The one validation path reads a file entry by entry or whole, and builds the same case either way.

A file is first read entry by entry, each entry checked and built as it is read, with the
conditions alone (``load.case._streamed``); at the first failed condition it is read whole and
the same checks run with their words (``load.case._checked``, also what ``validate`` runs on
parsed data). For every document, reading entry by entry either answers ``None`` (not decided
there) or returns a case equal, field by field, to the one the whole reading returns - params
shared between the same entries, the same expressions, the same warnings. It must never accept
a document the whole reading rejects.

A longer, random run (after touching load/)::

    BTGEN_ONEPASS_EXAMPLES=5000 python -m pytest tests/test_entries.py -q
"""

from __future__ import annotations

import json
import os
import pathlib
import random
import tempfile
from typing import Any

import pytest
from helpers import case, crit, entry
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_fuzz import mutants

import btgen_pytrees
from btgen_pytrees.errors import InvalidTestCase
from btgen_pytrees.leaves import default_registry
from btgen_pytrees.load import parse_json, validate
from btgen_pytrees.load.case import _checked, _streamed
from btgen_pytrees.load.entries import entry_rules
from btgen_pytrees.load.read import NotStreamed
from btgen_pytrees.model import TestCase

ROOT = pathlib.Path(__file__).resolve().parent.parent
REGISTRY = default_registry()
_LONG = int(os.environ.get("BTGEN_ONEPASS_EXAMPLES", "0"))  # a longer, random run: after touching the loader
SETTINGS = settings(max_examples=_LONG or 200, deadline=None, derandomize=not _LONG, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])  # fmt: skip


def detailed(raw: bytes | str, source: str = "case.json") -> TestCase | None:
    """The case as read whole, with words (None: invalid)."""
    try:
        return _checked(parse_json(raw, source), source, REGISTRY, None)
    except InvalidTestCase:
        return None


def streamed(raw: bytes | str, source: str = "case.json") -> TestCase | None:
    """The case as read entry by entry, without words (None: not decided there)."""
    try:
        return _streamed(raw.encode("utf-8") if isinstance(raw, str) else raw, source, REGISTRY, None)
    except NotStreamed:
        return None


def fields(c: TestCase) -> Any:
    """Everything a case holds, comparable with ==; which entries share one params mapping."""
    first: dict[int, int] = {}
    entries = [(e.id, e.kind, e.action, _typed(e.params), e.after, e.join, e.name, e.index,
                {k: x.source for k, x in e.expressions.items()}, first.setdefault(id(e.params), e.index))
               for e in c.entries]  # fmt: skip
    criteria = [(x.id, x.type, x.expect.source, x.name, x.index, x.start, x.end, x.at, x.action, _typed(x.params),
                 {k: v.source for k, v in x.expressions.items()}) for x in c.criteria]  # fmt: skip
    return (c.name, c.description, _typed(c.signals), c.declares_signals, c.tick, c.timeout, c.join, entries, criteria,
            dict(c.relation), c.source, c.system, c.require_complete, [(w.path, w.message, w.cause) for w in c.warnings])  # fmt: skip


def _typed(mapping: Any) -> Any:
    return json.dumps(dict(mapping), sort_keys=True), sorted((k, type(v).__name__) for k, v in mapping.items())


def check(raw: bytes | str, source: str = "case.json") -> TestCase | None:
    """The answer of reading *raw* entry by entry, after checking it against reading it whole."""
    fast = streamed(raw, source)
    slow = detailed(raw, source)
    if fast is not None:
        assert slow is not None, "reading entry by entry accepted a document reading it whole rejects"
        assert fields(fast) == fields(slow)
    try:
        data = parse_json(raw, source)
    except InvalidTestCase:
        return fast
    try:
        from_data = validate(data, source, REGISTRY)
    except InvalidTestCase:
        from_data = None
    assert (from_data is None) == (slow is None), "validate() on parsed data and reading the file disagree"
    if from_data is not None:
        assert slow is not None, "validate() accepted a document reading it whole rejects"
        assert fields(from_data) == fields(slow)
    return fast


def test_the_schema_entry_is_the_one_the_entry_loop_implements() -> None:
    # If this fails, testcase.schema.json's entry changed: update load/entries.py's _ENTRY and Entries.add_all with it.
    assert entry_rules() is not None


@pytest.mark.parametrize("path", sorted(p.relative_to(ROOT).as_posix() for p in (ROOT / "examples").rglob("*.json")
                                         if not p.name.endswith(".oracle.json")))  # an OpenSCENARIO sidecar is not a case
def test_examples(path: str) -> None:
    raw = (ROOT / path).read_bytes()
    fast = check(raw, str(ROOT / path))
    if path.startswith("examples/fig1") and "sweep" not in path:
        assert fast is not None  # within reach: read entry by entry, in one pass


def _dump(data: Any, style: int) -> str:
    if style == 0:
        return json.dumps(data, separators=(",", ":"))
    if style == 1:
        return json.dumps(data)
    if style == 2:
        return json.dumps(data, indent=2)
    return json.dumps(data, indent="\t", separators=(" ,", " : "))  # white space before colons: the hooked reader


@st.composite
def documents(draw: Any) -> tuple[dict[str, Any], int]:
    """Valid-looking documents of every kind the one pass handles, in every key order and layout."""
    n = draw(st.integers(1, 12))
    ids = [f"E{i}" for i in range(n)]
    entries = []
    for i, id_ in enumerate(ids):
        kind = draw(st.sampled_from(["hold", "wait", "set", "ramp", "until", "hold"]))
        params: dict[str, Any] = {
            "hold": {"duration": draw(st.sampled_from([0, 1, 1.0, 0.5, -0.0]))},
            "wait": {"duration": draw(st.sampled_from([1, 1.0, True, 2]))},
            "set": {"signal": draw(st.sampled_from(["x", "y", "z"])), "value": draw(st.sampled_from([1, True, 2.5]))},
            "ramp": {"signal": "x", "to": 3, "duration": 1},
            "until": {"expect": draw(st.sampled_from(["x > 1", "y == 0", "q", "x >"]))},
        }[kind]
        e = entry(id_, draw(st.lists(st.sampled_from(ids), max_size=3, unique=True)), action=kind, **params)
        if draw(st.booleans()) and i % 3 == 0:
            e["join"] = draw(st.sampled_from(["any", "all"]))
        if draw(st.integers(0, 5)) == 0:
            e["name"] = draw(st.sampled_from(["step", 'a ":" b', "é", ""]))
        if draw(st.integers(0, 9)) == 0:
            e[draw(st.sampled_from(["params", "after", "join", "name"]))] = draw(st.sampled_from([None, 1, [], {}]))
        entries.append(e)
    criteria = [crit("C", "record", draw(st.sampled_from(["x >= 0", "z < 1"])))] if draw(st.booleans()) else None
    if criteria and draw(st.integers(0, 4)) == 0:
        criteria[0]["id"] = draw(st.sampled_from(ids))  # an id shared with an entry
    top: dict[str, Any] = {}
    if draw(st.booleans()):
        top["signals"] = {"x": 0, "y": 1}
    if draw(st.booleans()):
        top["join"] = draw(st.sampled_from(["any", "all"]))
    data = case(*entries, criteria=criteria, **top)
    keys = list(data)
    random.Random(draw(st.integers(0, 1000))).shuffle(keys)  # 'execute' first, last, between
    return {k: data[k] for k in keys}, draw(st.integers(0, 3))


@SETTINGS
@given(documents())
def test_generated_documents(doc: tuple[dict[str, Any], int]) -> None:
    data, style = doc
    fast = check(_dump(data, style))
    if detailed(_dump(data, style)) is not None and '":' not in json.dumps([e.get("name") for e in data["execute"]]):
        assert fast is not None  # a valid document within reach is read entry by entry, in one pass


@SETTINGS
@given(mutants())
def test_mutated_documents(mutant: tuple[bytes, list[str]]) -> None:
    check(mutant[0])


@pytest.mark.parametrize("text", [
    '{"name":"t","execute":[{"id":"A","kind":"behavior","action":"hold","id":"B","params":{"duration":1}}]}',
    '{"name":"t","execute":[{"id":"A","kind":"behavior","action":"hold","params":{"duration":1,"duration":2}}]}',
    '{"name":"t","execute":[{"id":"A","kind":"behavior","action":"hold","params":{"duration":1}}],"name":"u"}',
    '{"name":"t","execute":[{"id":"A","kind":"behavior","action":"hold" ,"action" : "hold","params":{"duration":1}}]}',
    '{"name":"t","execute":[{"id":"A","kind":"behavior","action":"hold","params":{"duration":1}},]}',
    '{"name":"t","execute":[{"id":"A","kind":"behavior","action":"hold","params":{"duration":1}}]} x',
    '{"name":"t","execute":[{"id":"A","kind":"behavior","action":"hold","params":{"duration":NaN}}]}',
])  # fmt: skip
def test_what_json_loads_rejects_is_left_to_the_whole_reader(text: str, tmp_path: pathlib.Path) -> None:
    assert streamed(text) is None
    (tmp_path / "case.json").write_text(text, encoding="utf-8")
    with pytest.raises(InvalidTestCase):
        btgen_pytrees.load(tmp_path / "case.json")


def test_a_colon_inside_a_string_is_not_taken_for_a_key(tmp_path: pathlib.Path) -> None:
    text = '{"name":"t","execute":[{"id":"A","kind":"behavior","action":"hold","name":"a\\":b","params":{"duration":1}}]}'
    assert streamed(text) is None  # more '":' than keys: not decided here
    (tmp_path / "case.json").write_text(text, encoding="utf-8")
    assert btgen_pytrees.load(tmp_path / "case.json").entries[0].name == 'a":b'


def test_a_join_written_after_execute_is_every_entry_default() -> None:
    text = json.dumps({"name": "t", "execute": [entry("A"), entry("B"), entry("C", ["A", "B"]),
                                                 entry("D", ["A", "B"], join="any")], "join": "all"})  # fmt: skip
    fast = check(text)
    assert fast is not None and [e.join for e in fast.entries] == ["all", "all", "all", "any"]


def test_a_long_chain_is_read_in_one_pass() -> None:
    text = json.dumps(case(*[entry(f"E{i}", [f"E{i - 1}"] if i else [], duration=0.1) for i in range(3000)]))
    fast = check(text)
    assert fast is not None and len({id(e.params) for e in fast.entries}) == 1



@pytest.mark.parametrize("path", ["examples/fig1.json", "examples/fig1_failing.json"])
def test_a_valid_document_builds_no_message(path: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Each rule's words run only where its condition failed: a valid document, read from its file or given
    as data, never reaches them."""
    from btgen_pytrees.load import case as case_module
    from btgen_pytrees.load import context as context_module
    from btgen_pytrees.load import entries as entries_module

    def words(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("a rule's words ran for a valid document")

    for module, name in [(case_module, "described"), (case_module, "value_problems"), (case_module, "schema_problems"),
                         (context_module, "described"), (context_module, "suggest"), (entries_module, "suggest")]:  # fmt: skip
        monkeypatch.setattr(module, name, words)
    raw = (ROOT / path).read_bytes()
    assert btgen_pytrees.load(ROOT / path).entries
    assert validate(parse_json(raw), path, REGISTRY).entries


def test_a_system_action_s_params_get_the_value_checks_too(tmp_path: pathlib.Path) -> None:
    """A dotted action (checked after the loop, with the whole document) had its params' values checked only
    when the file was read whole: read entry by entry, a lone surrogate or a number beyond the limit got through."""
    registry = default_registry()
    registry.register("my.act", lambda e, env: None, kind="behavior")
    for value, problem in [("\ud800", "not valid Unicode: lone surrogate"), (10**400, "number too large")]:
        data = case(entry("A", action="my.act", value=value))
        path = tmp_path / "case.json"
        path.write_bytes(json.dumps(data).encode())
        for load in (lambda: btgen_pytrees.load(path, registry=registry), lambda: validate(data, "case.json", registry)):
            with pytest.raises(InvalidTestCase) as info:
                load()
            assert [(p.pointer, p.message.startswith(problem)) for p in info.value.problems] == [("/execute/0/params/value", True)]


def _words(data: dict[str, Any]) -> list[str]:
    """The problems of *data*, read from a file and given as data: the same, in the same order."""
    found = []
    with tempfile.TemporaryDirectory() as folder:
        path = pathlib.Path(folder) / "case.json"
        path.write_text(json.dumps(data), encoding="utf-8")
        for load in (lambda: btgen_pytrees.load(path), lambda: btgen_pytrees.load(data)):
            with pytest.raises(InvalidTestCase) as info:
                load()
            found.append([f"{p.pointer}: {p.message}" for p in info.value.problems])
    assert found[0] == found[1]
    return found[0]


_IDENTIFIER = "is not valid: expected an identifier (a letter or '_', then letters, digits, '_' or '-')"
_KNOWN = "known: hold, profile, ramp, set (a plugin may add it: --plugin MODULE or FILE.py)"


def test_an_entry_checked_at_the_end_with_a_bad_id_gets_the_schema_s_words() -> None:
    # (messages as the loader gave them before the one path: an entry whose params name a signal is checked after
    # the loop; the ids' pattern, checked for all entries at once, must still reach it and an 'after' naming it)
    data = case(entry("A"), entry("-B", action="set", signal="x", value=1), entry("C", ["-B"]), signals={"x": 0})
    assert _words(data) == [f"/execute/1/id: '-B' {_IDENTIFIER}", f"/execute/2/after/0: '-B' {_IDENTIFIER}"]


def test_the_did_you_mean_budget_goes_to_the_first_problems_in_file_order() -> None:
    words = _words(case(*[entry(f"E{i}", action=f"hld{i}") for i in range(22)]))
    assert words[:2] == [f"/execute/{i}/action: unknown behavior action 'hld{i}' (did you mean 'hold'?); {_KNOWN}" for i in range(2)]
    assert ["did you mean" in w for w in words] == [True] * 20 + [False] * 2


def test_shape_problems_of_the_rest_and_the_entries_come_with_the_entries_leaves() -> None:
    data = case(entry("A"), entry("B", action="hodl"), entry("C", action="set", signal="x", value="q"))
    data["name"], data["execute"][0]["kind"] = 1, "behaviour"
    assert _words(data) == [
        "/execute/0/kind: 'behaviour' is not one of 'behavior', 'constraint' (did you mean 'behavior'?)",
        f"/execute/1/action: unknown behavior action 'hodl' (did you mean 'hold'?); {_KNOWN}",
        "/execute/2/params/value: 'q' is not of type 'number', 'boolean'",
        "/name: 1 is not of type 'string': expected Test name; the root node's name.",
    ]


def test_ids_and_after_across_entries_and_criteria() -> None:
    data = case(entry("A"), entry("A"), entry("B", ["A", "A", "B", "Zz", "C1"]), entry("C", ["D"]), entry("D", ["C"]),
                criteria=[crit("A", "record", "x > 1"), crit("C1", "record", "x > 1")])  # fmt: skip
    assert _words(data) == [
        "/execute/1/id: duplicate id 'A' (first used at /execute/0/id)",
        "/execute/2/after/1: 'A' is listed twice",
        "/execute/2/after/2: 'B' cannot come after itself",
        "/execute/2/after/3: unknown id 'Zz'",
        "/execute/2/after/4: 'C1' is an oracle criterion, not an execute entry",
        "/oracle/criteria/0/id: duplicate id 'A' (first used at /execute/0/id)",
    ]  # (the cycle C -> D -> C is not described while 'after' has other problems)
