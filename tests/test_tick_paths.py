"""The per-tick paths written for speed answer what the plainer code they replace answers.

``leaves.simulated.reached`` without ``max``; an oracle's "always" margin folded inline; an expression
evaluated with its functions in the globals (no dict of them per call); ``Environment.values`` reading
the keys it made once per names tuple. Each is compared with the formula it replaces, on values chosen
to break it: NaN, infinities, -0.0, integers, equal margins, signals without a value.
"""

from __future__ import annotations

import math
from typing import Any

import py_trees
from helpers import case, crit, entry
from hypothesis import given, settings
from hypothesis import strategies as st
from py_trees.blackboard import Blackboard

import btgen_pytrees
from btgen_pytrees.clock import VirtualClock
from btgen_pytrees.expressions import FUNCTIONS, ExpressionError, parse
from btgen_pytrees.leaves import Environment
from btgen_pytrees.leaves.oracles import Record, always
from btgen_pytrees.leaves.simulated import reached

_NUMBERS = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**12, 10**12),
                     st.sampled_from([0.0, -0.0, 1.0, -1.0, 1, 0.3, 0.1 * 3, 1e9, -1e9]))  # fmt: skip


@given(_NUMBERS, _NUMBERS)
def test_reached_is_the_formula_with_max(elapsed: Any, duration: Any) -> None:
    assert reached(elapsed, duration) == (elapsed >= duration - 1e-9 * max(1.0, abs(duration)))


def _stepped(expect: str, series: list[dict[str, float] | None]) -> list[tuple[Any, ...]]:
    """A record of *expect* ticked once per item of *series* (None: the signals have no value that tick):
    its verdict and margin after each tick, until it fails."""
    loaded = btgen_pytrees.load(case(entry("A", duration=1000), criteria=[crit("R", "record", expect)], tick=0.1))
    clock = VirtualClock()
    root = btgen_pytrees.generate(loaded, clock=clock)
    env = root.btgen_env
    record = next(node for node in root.iterate() if isinstance(node, Record))
    seen = []
    try:
        for k, values in enumerate(series):
            clock.set(k * 0.1)
            for name in ("x", "y"):
                Blackboard.storage.pop(env.signal_key(name), None)
            for name, value in (values or {}).items():
                env.publish(name, value)
            record.tick_once()
            seen.append((record.outcome.verdict, record.outcome.margin, record.judged))
            if record.status == py_trees.common.Status.FAILURE:
                break
    finally:
        env.release()
        env.clear()
    return seen


def _expected(expect: str, series: list[dict[str, float] | None]) -> list[tuple[Any, ...]]:
    """The same, from the expression's own judgement folded with ``always``."""
    parsed, margin, seen = parse(expect), None, []
    for k, values in enumerate(series):
        try:
            ok, now = parsed.judge(values or {})
        except ExpressionError:
            ok, now = False, None
        margin = now if k == 0 else always(margin, now)
        seen.append(("inconclusive" if ok else "fail", margin, k + 1))
        if not ok:
            break
    return seen


_VALUES = st.one_of(st.none(), st.fixed_dictionaries({"x": st.sampled_from([0.0, -0.0, 1.0, 2.0, 2.5, 3.0, 1e300, math.inf]),
                                                      "y": st.sampled_from([1.0, 1.5, 4.0, -0.0, 0.0])}))  # fmt: skip


@settings(max_examples=60, deadline=None)
@given(st.sampled_from(["x <= 3", "x <= 3 && y >= 0", "x - y <= 2 || y > 1"]), st.lists(_VALUES, min_size=1, max_size=12))
def test_a_records_margin_is_always_over_its_ticks(expect: str, series: list[dict[str, float] | None]) -> None:
    assert _stepped(expect, series) == _expected(expect, series)


def test_the_least_margin_stays_and_equal_margins_keep_the_earlier_one() -> None:
    """A margin that grows again does not count (the least so far stays); 0.0 then -0.0: ``always`` keeps the
    one before (equal, not less), and so does the record's inline fold; a tick without values: unknown."""
    for series in ([{"x": 2.0, "y": 1.0}, {"x": 0.0, "y": 1.0}, {"x": 2.5, "y": 1.0}, {"x": 1.0, "y": 1.0}],
                   [{"x": 3.0, "y": 0.0}, {"x": 3.0, "y": -0.0}], [{"x": 1.0, "y": 0.0}, None]):
        for expect in ("x <= 3", "x - y <= 3 || y > 1"):
            seen = _stepped(expect, series)
            assert seen == _expected(expect, series) and len(seen) == len(series)
    assert [math.copysign(1, m) for _, m, _ in _stepped("y <= 0", [{"x": 0.0, "y": 0.0}, {"x": 0.0, "y": -0.0}])] == [1, 1]


@settings(max_examples=80, deadline=None)
@given(st.sampled_from(["a.b + c * 2 > abs(d) - max(a.b, 1)", "min(c, d) <= 3", "c", "a.b", "abs(c - d) / 2",
                        "c + d.e.f", "c > 1 && d < 2 || !(c == d)"]),
       st.fixed_dictionaries({"a.b": _NUMBERS, "c": _NUMBERS, "d": _NUMBERS, "d.e.f": _NUMBERS}))  # fmt: skip
def test_evaluate_is_eval_with_the_functions_in_its_scope(text: str, values: dict[str, Any]) -> None:
    expression = parse(text)
    scope = {**FUNCTIONS, **values}
    for alias, name in expression._aliases:
        scope[alias] = values[name]
    try:
        expected: Any = eval(expression._code, {"__builtins__": {}}, scope)  # noqa: S307 - the code it replaces
    except (ArithmeticError, TypeError, ValueError) as exc:
        expected = ExpressionError(f"{exc} in {text!r}")
    try:
        found: Any = expression.evaluate(values)
    except ExpressionError as exc:
        found = exc
    if isinstance(expected, Exception):
        assert str(found) == str(expected)
    else:
        assert found == expected or (found != found and expected != expected)


def test_values_reads_the_same_keys_from_a_tuple_a_list_or_a_generator() -> None:
    env = Environment("/tick_paths/values", clock=VirtualClock())
    try:
        env.publish("a", 1)
        env.publish("b.c", 2.5)
        names = ("a", "b.c", "missing")
        expected = {"a": 1, "b.c": 2.5}
        for _ in range(2):  # the tuple's keys are made once, then found
            assert env.values(names) == expected and list(env.values(names)) == ["a", "b.c"]
        assert env.values(list(names)) == expected and env.values(n for n in names) == expected
        Blackboard.storage.pop(env.signal_key("a"))
        assert env.values(names) == {"b.c": 2.5}
        for k in range(2000):  # a host's many different tuples: kept up to a bound
            env.values((f"n{k}",))
        assert len(env._keys) <= 1024
    finally:
        env.clear()
