"""What a process that validates and runs many similar cases (a sweep, a search) keeps or skips between
them gives the answers it gave without: an expression parsed once per text, the schema's verdict on the
rest of a document asked once per text, a margin's "always" without lists, the namespaces of many trees
of one case, the missing-signal check of an expression."""

from __future__ import annotations

import math
import re
import types
from collections.abc import Mapping
from typing import Any, Iterator

import pytest
from helpers import case, crit, entry
from hypothesis import given
from py_trees.blackboard import Blackboard
from hypothesis import strategies as st

import btgen_pytrees
from btgen_pytrees import expressions
from btgen_pytrees.contracts import environment
from btgen_pytrees.expressions import PARSED, ExpressionError, conjunction, parse
from btgen_pytrees.leaves.oracles import always
from btgen_pytrees.load import document
from btgen_pytrees.load.document import rest_fits
from btgen_pytrees.load.entries import STAND_IN
from btgen_pytrees.load.schema import case_validator
from btgen_pytrees.run import run

# -- expressions, parsed once per text ------------------------------------------------------------------


def test_the_same_text_is_the_same_expression_parsed_once() -> None:
    first = parse("cutter.x - 5 - ego.x <= 12.5 && sim.collisions == 0")
    again = parse("cutter.x - 5 - ego.x <= 12.5 && sim.collisions == 0")
    assert again is first
    values = {"cutter.x": 27.5, "ego.x": 10.0, "sim.collisions": 0}
    assert first.judge(values) == (True, 0.0) and first._judge is again._judge  # its evaluator built once
    assert parse("cutter.x - 5 - ego.x <= 12.6 && sim.collisions == 0") is not first


def test_a_text_that_fails_fails_every_time() -> None:
    for _ in range(3):
        with pytest.raises(ExpressionError, match="names starting with '_' are not allowed"):
            parse("_x > 1")
        with pytest.raises(ExpressionError, match="an expression must be a string"):
            parse(3)  # type: ignore[arg-type]


def test_more_texts_than_it_keeps() -> None:
    texts = [f"x <= {i}" for i in range(PARSED + 10)]
    kept = [parse(t) for t in texts]
    assert parse(texts[-1]) is kept[-1]  # kept; the first ones were forgotten, and come back parsed anew:
    assert [parse(t).source for t in texts] == texts
    assert all(e.judge({"x": 3}) == (3 <= i, float(i - 3)) for i, e in zip(range(PARSED + 10), kept))


def test_loading_twice_shares_the_expressions_and_runs_the_same() -> None:
    data = case(entry("A", action="set", signal="x", value=3), entry("B", ["A"], action="until", expect="x >= 3", timeout=1),
                criteria=[crit("R", "record", "x <= 5")], signals={"x": 0})  # fmt: skip
    one, two = btgen_pytrees.load(data), btgen_pytrees.load(data)
    assert one.criteria[0].expect is two.criteria[0].expect
    assert one.entries[1].expressions["expect"] is two.entries[1].expressions["expect"]
    assert run(one).to_json() == run(two).to_json()


class _Values(Mapping[str, Any]):
    """A mapping that is not a dict."""

    def __init__(self, data: dict[str, Any]):
        self._data = data

    def __getitem__(self, key: str) -> Any:
        return self._data[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self._data)

    def __len__(self) -> int:
        return len(self._data)


@pytest.mark.parametrize("wrap", [dict, types.MappingProxyType, _Values])
def test_a_missing_signal_is_named_for_every_mapping(wrap: Any) -> None:
    e = parse("b + a > c")
    for values, missing in (({"b": 1}, "a"), ({"a": 1, "b": 2}, "c"), ({}, "a"), ({"a": 1, "z": 2}, "b")):
        for method in (e.evaluate, e.judge):
            with pytest.raises(ExpressionError, match=f"^signal '{missing}' has no value$"):
                method(wrap(values))
    full = wrap({"a": 1, "b": 2, "c": 2, "extra": 9})
    assert e.evaluate(full) is True and e.judge(full) == (True, 1.0)


# -- the margin of "always" --------------------------------------------------------------------------

_MARGINS = st.one_of(st.none(), st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([0.0, -0.0, math.nan]))


@given(_MARGINS, _MARGINS)
def test_always_is_the_conjunction_of_two(before: float | None, margin: float | None) -> None:
    got, expected = always(before, margin), conjunction((before, margin))
    assert repr(got) == repr(expected)  # NaN and the sign of 0 too


# -- the schema's verdict on the rest of a document, asked once per text --------------------------------


def _rest(**changes: Any) -> dict[str, Any]:
    doc = {"name": "t", "tick": 0.1, "timeout": 5, "signals": {"x": 0},
           "oracle": {"criteria": [{"id": "R", "type": "record", "expect": "x <= 5"}]}, "execute": [STAND_IN]}  # fmt: skip
    doc.update(changes)
    return doc


_TWINS = [
    # (a document, a twin that prints as the same JSON or compares equal to it but is not the same JSON)
    (_rest(), _rest(oracle={"criteria": ({"id": "R", "type": "record", "expect": "x <= 5"},)})),  # a tuple: not an array
    (_rest(timeout=1), _rest(timeout=True)),  # True == 1
    (_rest(tick=1.0), _rest(tick=True)),
    (_rest(signals={"x1": 0}), _rest(signals={"x1": 0, 1: 0})),  # a key that is not a string
]


@pytest.mark.parametrize("first_twin", [False, True])
@pytest.mark.parametrize(("doc", "twin"), _TWINS)
def test_the_remembered_verdict_is_jsonschemas(doc: dict[str, Any], twin: dict[str, Any], first_twin: bool,
                                               monkeypatch: pytest.MonkeyPatch) -> None:  # fmt: skip
    monkeypatch.delitem(case_validator().__dict__, "fast", raising=False)  # as in a process that never compiled it
    document._fits.cache_clear()
    full = case_validator().full
    for d in ([twin, doc] if first_twin else [doc, twin]) * 2:
        assert rest_fits(d) is bool(full.is_valid(d))
    assert rest_fits(doc) != rest_fits(twin)  # the twin is not the same JSON: another verdict


def test_one_walk_per_distinct_rest(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delitem(case_validator().__dict__, "fast", raising=False)
    document._fits.cache_clear()
    for timeout in (5, 6, 5, 6, 5):
        assert rest_fits(_rest(timeout=timeout))
    assert not rest_fits(_rest(timeout=-1)) and not rest_fits(_rest(timeout=-1))
    info = document._fits.cache_info()
    assert (info.misses, info.hits) == (3, 4)
    for odd in (_rest(timeout=math.nan), _rest(signals={"x": 0, 1: 0}), _rest(signals={"x": {1, 2}})):  # not JSON:
        assert rest_fits(odd) is bool(case_validator().full.is_valid(odd))  # asked jsonschema, not remembered
    assert document._fits.cache_info()[:2] == info[:2]


def test_similar_cases_load_and_run_as_each_alone() -> None:
    """Cases that differ in a value (as a sweep's variations do): loaded one after the other, with what the
    earlier ones left remembered, each gives the report it gives loaded with nothing remembered."""
    remembered, alone = [], []
    for v in (1, 2, 3, 9, 2):
        data = case(entry("A", action="set", signal="x", value=v), entry("B", ["A"], action="until", expect=f"x >= {v}", timeout=1),
                    criteria=[crit("R", "record", "x <= 5")], signals={"x": 0})  # fmt: skip
        remembered.append(run(btgen_pytrees.load(data)).to_json())
        document._fits.cache_clear()
        expressions._parse.cache_clear()
        alone.append(run(btgen_pytrees.load(data)).to_json())
    assert remembered == alone
    assert '"verdict": "fail"' in remembered[3] and '"verdict": "pass"' in remembered[0]


# -- the namespaces of many trees of one case ----------------------------------------------------------


def _reference(names: list[str], used: set[str]) -> list[str]:
    """The namespaces as the first search from '#1' for every tree gave them."""
    out = []
    for name in names:
        base = "/btgen_pytrees/" + (re.sub(r"[^A-Za-z0-9_-]", "_", name)[:64] or "_")
        candidate, n = base, 1
        while candidate in used:
            n += 1
            candidate = f"{base}#{n}"
        used.add(candidate)
        out.append(candidate)
    return out


@given(st.lists(st.sampled_from(["a", "b", "a b", "a_b", "a#2", "", "é"]), max_size=30))
def test_namespaces_as_before(names: list[str]) -> None:
    saved = set(environment._used_namespaces), dict(environment._last_number)
    try:
        environment._used_namespaces.clear()
        environment._last_number.clear()
        environment._used_namespaces.update({"/btgen_pytrees/b#3", "/btgen_pytrees/a_b#2"})  # taken by hand
        expected = _reference(names, set(environment._used_namespaces))
        assert [environment.unique_namespace(n) for n in names] == expected
    finally:
        environment._used_namespaces.clear()
        environment._used_namespaces.update(saved[0])
        environment._last_number.clear()
        environment._last_number.update(saved[1])


# -- what run() leaves on the blackboard -----------------------------------------------------------------


def test_run_takes_its_trees_keys_off_the_blackboard() -> None:
    """run() made the tree and drops it: its namespace's keys go too, so many runs in one process do not
    pile up on the blackboard (a host's own keys stay)."""
    Blackboard.storage["/host/kept"] = 1
    data = case(entry("A", action="set", signal="x", value=3), entry("B", ["A"]),
                criteria=[crit("R", "record", "x <= 5"), crit("S", "record", "x <= 6")], relation="||",
                signals={"x": 0})  # fmt: skip
    loaded = btgen_pytrees.load(data)
    before = (set(Blackboard.storage), set(Blackboard.metadata))
    reports = [run(loaded).to_json() for _ in range(5)]
    assert (set(Blackboard.storage), set(Blackboard.metadata)) == before
    assert Blackboard.storage.pop("/host/kept") == 1 and len(set(reports)) == 1 and '"pass"' in reports[0]


def test_run_leaves_no_reference_cycles_for_the_collector() -> None:
    """run() takes the tree it made apart once its report is made (take_apart): nothing of a run is left in
    reference cycles for the garbage collector - a tree of parents and children, its tick generators and
    its environment's listeners were ~270 objects a run of the SUMO cut-in, a collection every few runs -
    and the report is the one of a run whose tree was left whole."""
    import gc

    from btgen_pytrees.construct import generate
    from btgen_pytrees.run import run_tree

    data = case(entry("A", action="set", signal="x", value=3), entry("B", ["A"]), entry("C", ["A"]),
                entry("D", ["B", "C"]), criteria=[crit("R", "record", "x <= 5"), crit("F", "final", "x == 3")],
                signals={"x": 0})  # fmt: skip
    loaded = btgen_pytrees.load(data)
    whole = generate(loaded)
    expected = run_tree(whole, loaded).to_json()  # its tree is left as it is
    run(loaded)  # warm-up: what is made once per process
    enabled = gc.isenabled()
    gc.disable()
    gc.collect()
    gc.set_debug(gc.DEBUG_SAVEALL)
    try:
        reports = [run(loaded) for _ in range(3)]
        gc.collect()
        left = [type(o).__name__ for o in gc.garbage]
    finally:
        gc.set_debug(0)
        gc.garbage.clear()
        if enabled:
            gc.enable()
    assert left == [] and [r.to_json() for r in reports] == [expected] * 3
    whole.btgen_env.release()
    whole.btgen_env.clear()
