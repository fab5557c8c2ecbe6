"""The expression language is safe: everything outside it is rejected at load time, and evaluation is bounded.

``expect`` texts come from JSON files anyone may write. Each construct below
would reach attributes, builtins, imports or unbounded work if the text were
handed to Python; each must raise :class:`ExpressionError` from
:func:`~btgen_pytrees.expressions.parse` and be reported by
:func:`btgen_pytrees.load` at the JSON path of the text - before anything runs.
"""

from __future__ import annotations

import dis
import types
from typing import Any

import pytest
from helpers import case, crit, entry
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import btgen_pytrees
from btgen_pytrees import InvalidTestCase
from btgen_pytrees.expressions import MAX_LENGTH, ExpressionError, parse

REJECTED = {
    # attribute access
    "attribute": "speed.__class__",
    "attribute-of-literal": "1 .real > 0",
    "attribute-of-tuple": "().__class__",
    "attribute-of-call": "abs(speed).__class__.__base__",
    "attribute-of-function": "max.__self__",
    # dunder and underscore names
    "import": '__import__("os")',
    "import-call-chain": "__import__('os').system('true')",
    "builtins": "__builtins__",
    "dunder": "__class__ == 0",
    "underscore": "_speed > 0",
    # calls other than abs/min/max, and odd calls of those
    "open": 'open("x")',
    "eval": "eval(1)",
    "exec": "exec(speed)",
    "getattr": "getattr(speed, speed)",
    "globals": "globals()",
    "print": "print(speed)",
    "signal-call": "speed(1)",
    "call-of-call": "max(1, 2)(3)",
    "keyword-argument": "max(speed, key=abs)",
    "starred": "max(1, *speed)",
    "abs-arity": "abs(1, 2)",
    "min-arity": "min(1)",
    "bare-function": "abs",
    # comprehensions and generators
    "list-comprehension": "[x for x in y]",
    "generator": "(x for x in y)",
    "generator-argument": "max(x for x in y)",
    # lambdas
    "lambda-call": "(lambda: 1)()",
    "lambda": "lambda x: x",
    # huge powers and products (no power operator, no strings)
    "power": "2 ** 10 ** 10",
    "power-small": "2 ** 2",
    "pow-call": "pow(2, 10)",
    "string-product": '"a" * 10**9',
    "string-product-single-quotes": "'a' * 1000000000",
    "shift": "1 << 10000000",
    # other syntax outside the language
    "conditional": "x if y else z",
    "subscript": "a[0]",
    "slice": "a[::-1]",
    "dict": "{}",
    "set": "{1}",
    "tuple": "(1, 2)",
    "empty-tuple": "()",
    "string": "'fast'",
    "string-comparison": 'speed == "fast"',
    "walrus": "(x := 1)",
    "is": "x is y",
    "in": "x in y",
    "not-in": "x not in y",
    "floor-division": "x // y",
    "invert": "~x",
    "matmul": "x @ y",
    "statement": "x; import os",
    "newline-statement": "x\nimport os",
    "await": "await x",
    "yield": "yield x",
    "ellipsis": "...",
    "none": "None",
    "python-true": "True",
    # numbers outside the language
    "hex": "0x10",
    "huge-hex": "0x" + "f" * 900,
    "binary": "0b101",
    "octal": "0o17",
    "complex": "1j",
    "glued-keyword": "1or 2",
    "underscore-digits": "1_000",
    "infinite": "1e999",
    "long-literal": "9" * 41,
    # unicode look-alikes (Python would NFKC-normalise these to ASCII names)
    "fullwidth": "ｅｖａｌ(1)",
    "ligature": "ﬁle > 0",
    "accented": "spéed > 0",
    # empty and too long
    "empty": "",
    "blank": "   ",
    "too-long": "1" + " " * MAX_LENGTH,
    # too deep for the parser
    "parentheses": "(" * 400 + "1" + ")" * 400,
    "unary-chain": "-" * 999 + "1",
    # dotted signal names (ego.speed) are one name, never attribute access
    "dotted-dunder": "ego.__class__ > 0",
    "dotted-dunder-inside": "ego.__dict__.speed > 0",
    "dotted-underscore-part": "ego._speed > 0",
    "dotted-call": "ego.speed(1)",
    "dotted-function-call": "max.x(1, 2)",
    "dotted-subscript": "ego.speed[0]",
    "dotted-after-call": "abs(x).real > 0",
    "dotted-after-group": "(ego).speed > 0",
    "dotted-spaced": "ego . speed > 0",
    "dotted-trailing": "ego. > 0",
    "dotted-leading": ".speed > 0",
    "dotted-number-part": "ego.1 > 0",
    "dotted-alias": "_s0 > 0",
    "dotted-literal": "1.real > 0",
}


def test_dotted_names_are_looked_up_whole_never_as_attributes() -> None:
    e = parse("x.real + ego.speed > 1 && abs(x.imag) == 0")
    assert e.names == {"x.real", "ego.speed", "x.imag"}
    assert e.evaluate({"x.real": 5, "ego.speed": 0, "x.imag": 0}) is True
    with pytest.raises(ExpressionError, match="'x.imag' has no value"):
        e.evaluate({"x": 3, "x.real": 5, "ego.speed": 0})  # not 3 .imag
    assert sorted(e._code.co_names) == ["_s0", "_s1", "_s2", "abs"]  # plain name loads, no attribute names


@pytest.mark.parametrize("text", list(REJECTED.values()), ids=list(REJECTED))
def test_rejected_by_parse(text: str) -> None:
    with pytest.raises(ExpressionError):
        parse(text)


@pytest.mark.parametrize("text", list(REJECTED.values()), ids=list(REJECTED))
def test_reported_at_load_with_the_json_path(text: str) -> None:
    data = case(entry("A"), criteria=[crit("R", "record", text)])
    with pytest.raises(InvalidTestCase) as info:
        btgen_pytrees.load(data)
    [problem] = info.value.problems
    assert problem.pointer == "/oracle/criteria/0/expect"
    # "" and over-long texts are caught by the schema first, at the same path
    assert problem.cause == ("schema" if not text or len(text) > MAX_LENGTH else "expression"), problem


@pytest.mark.parametrize("text", ["speed.__class__", '__import__("os")', "(lambda: 1)()", "2 ** 10 ** 10", "0x10"])
def test_rejected_in_until_constraints_too(text: str) -> None:
    data = case(entry("C", action="until", expect=text))
    with pytest.raises(InvalidTestCase) as info:
        btgen_pytrees.load(data)
    assert [(p.pointer, p.cause) for p in info.value.problems] == [("/execute/0/params/expect", "expression")]


def test_non_strings_are_rejected() -> None:
    for value in (1, None, b"1", ["x"]):
        with pytest.raises(ExpressionError):
            parse(value)  # type: ignore[arg-type]


def test_nothing_runs_at_load(tmp_path: Any, monkeypatch: Any) -> None:
    """A rejected text has no side effect: the file it would create does not appear."""
    monkeypatch.chdir(tmp_path)
    text = "__import__('os').system('touch pwned')"
    with pytest.raises(InvalidTestCase):
        btgen_pytrees.load(case(entry("A"), criteria=[crit("R", "record", text)]))
    assert not (tmp_path / "pwned").exists()


def test_evaluation_has_no_builtins() -> None:
    """Even a checked tree runs with empty builtins: a signal named like a builtin is just a value."""
    expr = parse("open + len > 0")
    assert sorted(expr.names) == ["len", "open"]
    assert expr.evaluate({"open": 1, "len": 1}) is True
    with pytest.raises(ExpressionError, match="has no value"):
        expr.evaluate({})


# ---------------------------------------------------------------------------
# evaluation is bounded


_JUMPS = set(getattr(dis, "hasjump", dis.hasjrel + dis.hasjabs))
_OPERATORS = {"+", "-", "*", "/", "%"}


def cost_problems(code: types.CodeType, length: int, names: set[str]) -> list[str]:
    """Why evaluating *code* (compiled from *length* characters reading *names*) might not be bounded; [] if it is.

    Boundedness without a clock: every jump goes forward, so each instruction runs at most once; there
    are at most 3 per character of text; nothing else is compiled in (no function, no comprehension);
    the only calls are abs/min/max (cost linear in their arguments, which are instructions too); and the
    only arithmetic is + - * / %, whose result is at most as long as its operands together (no ``**`` or
    ``<<``): so the numbers stay as long as the text allows (see the products below) and so does the work.
    """
    found = []
    instructions = list(dis.get_instructions(code))
    if len(instructions) > 3 * length + 10:
        found.append(f"{len(instructions)} instructions for {length} characters")
    for ins in instructions:
        if ins.opcode in _JUMPS and not ins.argval > ins.offset:
            found.append(f"backward jump at {ins.offset} ({ins.opname})")
        if ins.opname == "BINARY_OP" and ins.argrepr.rstrip("=") not in _OPERATORS:
            found.append(f"operator {ins.argrepr}")
    if any(isinstance(const, types.CodeType) for const in code.co_consts):
        found.append("nested code")
    if not set(code.co_names) <= names | {"abs", "min", "max"}:
        found.append(f"reads {sorted(set(code.co_names) - names - {'abs', 'min', 'max'})}")
    return found


def _bounded(text: str, values: dict[str, Any]) -> Any:
    """Parse *text*, check that its evaluation is bounded (:func:`cost_problems`), and evaluate it."""
    expr = parse(text)
    assert cost_problems(expr._code, len(text), set(expr.names) | {alias for alias, _ in expr._aliases}) == []
    return expr.evaluate(values)


def test_the_cost_check_can_fail() -> None:
    """What :func:`cost_problems` looks for, in code the language could never produce."""

    def problems(source: str, length: int = 100, mode: str = "eval") -> list[str]:
        return cost_problems(compile(source, "<t>", mode), length, {"x"})

    assert any(p.startswith("backward jump") for p in problems("while x: x -= 1", mode="exec"))
    assert problems("x ** x") == ["operator **"] and problems("x << x") == ["operator <<"]
    assert problems("sum(range(x))") == ["reads ['range', 'sum']"]
    assert "nested code" in problems("[y for y in x]")
    assert problems(" + ".join(["x"] * 20), length=1)[0].endswith("instructions for 1 characters")
    assert problems("min(x, 1) * abs(x) % 3") == []


def test_longest_literal_product_is_bounded() -> None:
    text = "9999999999 * " * 76 + "1"
    assert len(text) <= MAX_LENGTH
    result = _bounded(text, {})
    assert result == 9999999999**76 and result.bit_length() < 2600


def test_longest_signal_product_is_bounded() -> None:
    """Without a power operator, a product grows by at most one operand per factor.

    The loader accepts integers up to float range (about 2**1024), so the worst
    product of MAX_LENGTH characters has ~250 factors of 1024 bits each.
    """
    text = "s * " * 249 + "s"
    assert len(text) <= MAX_LENGTH
    result = _bounded(text, {"s": 2**1023})
    assert result == 2 ** (1023 * 250) and result.bit_length() == 1023 * 250 + 1
    assert _bounded(text, {"s": 1e308}) == float("inf")


def test_largest_integer_signal_the_loader_accepts() -> None:
    """Numbers are bounded by MAX_MAGNITUDE (1e300, issue 13: 2**1023 overflowed a ramp), integers exactly."""
    from btgen_pytrees.load import MAX_MAGNITUDE

    ok = case(entry("A"), signals={"s": int(MAX_MAGNITUDE)})
    btgen_pytrees.load(ok)
    for too_big in (int(MAX_MAGNITUDE) + 1, 2**1023, 2**1024):
        with pytest.raises(InvalidTestCase) as info:
            btgen_pytrees.load(case(entry("A"), signals={"s": too_big}))
        assert [(p.pointer, p.cause) for p in info.value.problems] == [("/signals/s", "limit")]


@pytest.mark.parametrize(
    "text",
    [
        "not " * 249 + "x",
        "1 + " * 249 + "1",
        "(" * 150 + "x" + ")" * 150,
        "max(" * 100 + "1" + ", 1)" * 100,
        " < ".join(["x"] * 250),
        "&&".join(["x>0"] * 200),
    ],
    ids=["not-chain", "sum-chain", "parentheses", "nested-max", "comparison-chain", "and-chain"],
)
def test_longest_accepted_shapes_parse_and_evaluate_bounded(text: str) -> None:
    assert len(text) <= MAX_LENGTH
    result = _bounded(text, {"x": 1})
    assert isinstance(result, (bool, int, float))


def test_arithmetic_errors_surface_as_expression_errors() -> None:
    for text in ("1 / 0", "x % 0", "max(x, 1) / (x - x)"):
        with pytest.raises(ExpressionError):
            parse(text).evaluate({"x": 1})
    with pytest.raises(ExpressionError):
        parse("x * 1.0").evaluate({"x": 2**1100})  # not a value the loader lets through; still no crash


ALPHABET = "sx01239.e+-*/%<>=!&|() ,_abcdmnortu'\"[]{}:;@~^\\\n"


@settings(max_examples=300, deadline=None, derandomize=True, database=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    text=st.text(alphabet=ALPHABET, max_size=80)
    | st.lists(st.sampled_from(["s", "x", "1", "1e308", "9" * 40, "(", ")", "-", "*", "/", "%", "<", "==", "&&", "||",
                                "!", "not", "and", "max(", "min(", "abs(", ",", " "]), max_size=300).map("".join),  # fmt: skip
    s=st.one_of(st.integers(-(2**1023), 2**1023), st.floats(allow_nan=False), st.booleans()),
)
def test_parse_and_evaluate_never_crash(text: str, s: Any) -> None:
    """Any text: parse() returns or raises ExpressionError; a parsed text's evaluation is bounded
    (:func:`cost_problems`) and returns or raises ExpressionError."""
    try:
        expr = parse(text)
    except ExpressionError:
        return
    assert all(name.isidentifier() and name.isascii() and not name.startswith("_") for name in expr.names)
    assert cost_problems(expr._code, len(text), set(expr.names) | {alias for alias, _ in expr._aliases}) == []
    try:
        expr.evaluate({name: s for name in expr.names})
    except ExpressionError:
        pass
