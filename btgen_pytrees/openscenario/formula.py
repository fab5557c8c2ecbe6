"""OpenSCENARIO's ``${...}`` expressions, evaluated without :func:`eval`.

The language of the standard (ASAM OpenSCENARIO 1.2, clause 7.4 "Parameters" - expressions;
1.0 and 1.1 files use the same ``${...}`` form):

* numbers (``1``, ``2.5``, ``1e3``), ``true``/``false``, parameter references ``$name``;
* arithmetic ``+ - * / %`` and unary ``-``; comparisons ``== != < <= > >=``;
  ``not``, ``and``, ``or``; parentheses;
* the functions ``round floor ceil sqrt pow sin cos tan asin acos atan sign abs max min``.

A hand-written recursive-descent parser over a bounded text (:data:`MAX_LENGTH` characters,
:data:`MAX_NESTING` levels of parentheses), so nothing in a file can reach Python's evaluator,
attributes, imports or the recursion limit. ``round``, ``floor`` and ``ceil`` give integers, as
the standard says; ``round`` rounds halves away from zero.

>>> evaluate("${$a / 3.6 + max(1, 2)}", {"a": 36})
12.0
>>> evaluate("${not ($a > 2) or false}", {"a": 1})
True
"""

from __future__ import annotations

import math
import re
from typing import Any, Callable, Mapping

__all__ = ["FormulaError", "evaluate", "is_expression", "MAX_LENGTH", "MAX_NESTING", "FUNCTIONS", "references"]

MAX_LENGTH = 1000
MAX_NESTING = 50


class FormulaError(ValueError):
    """The text is not an expression of the standard, or its value cannot be computed; ``str()`` says why."""


def _round(x: float) -> int:
    return int(math.floor(abs(x) + 0.5)) * (1 if x >= 0 else -1)


def _sign(x: float) -> int:
    return (x > 0) - (x < 0)


FUNCTIONS: dict[str, tuple[int, Callable[..., Any]]] = {
    "round": (1, _round), "floor": (1, lambda x: int(math.floor(x))), "ceil": (1, lambda x: int(math.ceil(x))),
    "sqrt": (1, math.sqrt), "pow": (2, math.pow), "sin": (1, math.sin), "cos": (1, math.cos), "tan": (1, math.tan),
    "asin": (1, math.asin), "acos": (1, math.acos), "atan": (1, math.atan), "sign": (1, _sign), "abs": (1, abs),
    "max": (2, max), "min": (2, min),
}  # fmt: skip

_TOKEN = re.compile(r"\s*(?:(?P<num>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)|(?P<ref>\$[A-Za-z_][A-Za-z0-9_]*)"
                    r"|(?P<word>[A-Za-z_][A-Za-z0-9_]*)|(?P<op>==|!=|<=|>=|[-+*/%()<>,]))")
REFERENCE = re.compile(r"\$([A-Za-z_][A-Za-z0-9_]*)")


def is_expression(text: str) -> bool:
    return text.startswith("${") and text.endswith("}")


def references(text: str) -> list[str]:
    """The parameter names a value refers to (``$name`` or inside ``${...}``)."""
    return REFERENCE.findall(text)


def _tokens(text: str) -> list[tuple[str, str]]:
    out, at = [], 0
    while at < len(text):
        if text[at:].strip() == "":
            break
        m = _TOKEN.match(text, at)
        if not m or m.end() == at:
            raise FormulaError(f"unexpected {text[at:].strip()[:20]!r} in expression")
        kind = m.lastgroup or ""
        out.append((kind, m.group(kind)))
        at = m.end()
    return out


class _Parser:
    def __init__(self, tokens: list[tuple[str, str]], values: Mapping[str, Any]):
        self.tokens, self.at, self.values, self.depth = tokens, 0, values, 0

    def peek(self) -> str | None:
        return self.tokens[self.at][1] if self.at < len(self.tokens) else None

    def take(self) -> tuple[str, str]:
        if self.at >= len(self.tokens):
            raise FormulaError("the expression ends too early")
        self.at += 1
        return self.tokens[self.at - 1]

    def expect(self, op: str) -> None:
        kind, text = self.take()
        if text != op:
            raise FormulaError(f"expected {op!r}, found {text!r}")

    def or_(self) -> Any:
        left = self.and_()
        while self.peek() == "or":
            self.take()
            right = self.and_()
            left = _truth(left) or _truth(right)
        return left

    def and_(self) -> Any:
        left = self.not_()
        while self.peek() == "and":
            self.take()
            right = self.not_()
            left = _truth(left) and _truth(right)
        return left

    def not_(self) -> Any:
        if self.peek() == "not":
            self.take()
            return not _truth(self.not_())
        return self.compare()

    def compare(self) -> Any:
        left = self.sum()
        ops = {"==": lambda a, b: a == b, "!=": lambda a, b: a != b, "<": lambda a, b: a < b,
               "<=": lambda a, b: a <= b, ">": lambda a, b: a > b, ">=": lambda a, b: a >= b}  # fmt: skip
        if self.peek() in ops:
            op = self.take()[1]
            right = self.sum()
            return ops[op](_number(left), _number(right))
        return left

    def sum(self) -> Any:
        left = self.product()
        while self.peek() in ("+", "-"):
            op = self.take()[1]
            right = self.product()
            left = _number(left) + _number(right) if op == "+" else _number(left) - _number(right)
        return left

    def product(self) -> Any:
        left = self.unary()
        while self.peek() in ("*", "/", "%"):
            op = self.take()[1]
            right = _number(self.unary())
            left = _number(left)
            if op == "*":
                left = left * right
            elif right == 0:
                raise FormulaError("division by zero")
            else:
                left = left / right if op == "/" else math.fmod(left, right)
        return left

    def unary(self) -> Any:
        if self.peek() == "-":
            self.take()
            return -_number(self.unary())
        if self.peek() == "+":
            self.take()
            return _number(self.unary())
        return self.primary()

    def primary(self) -> Any:
        kind, text = self.take()
        if kind == "num":
            return float(text) if any(c in text for c in ".eE") else int(text)
        if kind == "ref":
            name = text[1:]
            if name not in self.values:
                raise FormulaError(f"unknown parameter {text!r}")
            return self.values[name]
        if kind == "word":
            if text in ("true", "false"):
                return text == "true"
            if text in FUNCTIONS:
                arity, fn = FUNCTIONS[text]
                self.expect("(")
                args = [self.nested()]
                while self.peek() == ",":
                    self.take()
                    args.append(self.nested())
                self.expect(")")
                if len(args) != arity:
                    raise FormulaError(f"{text}() takes {arity} argument{'s' if arity > 1 else ''}, not {len(args)}")
                try:
                    result = fn(*(_number(a) for a in args))
                except (ValueError, OverflowError) as exc:
                    raise FormulaError(f"{text}() of {', '.join(map(str, args))}: {exc}") from None
                return result
            raise FormulaError(f"unknown word {text!r} (functions: {', '.join(FUNCTIONS)})")
        if text == "(":
            value = self.nested()
            self.expect(")")
            return value
        raise FormulaError(f"unexpected {text!r}")

    def nested(self) -> Any:
        self.depth += 1
        if self.depth > MAX_NESTING:
            raise FormulaError(f"the expression nests deeper than {MAX_NESTING} levels")
        try:
            return self.or_()
        finally:
            self.depth -= 1


def _truth(value: Any) -> bool:
    if isinstance(value, bool):
        return value
    raise FormulaError(f"{value!r} is not a boolean")


def _number(value: Any) -> float | int:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise FormulaError(f"{value!r} is not a number")
    return value


def evaluate(text: str, values: Mapping[str, Any]) -> Any:
    """The value of ``${...}`` *text* with the parameters *values* (numbers, booleans, strings)."""
    if len(text) > MAX_LENGTH:
        raise FormulaError(f"the expression is longer than {MAX_LENGTH} characters")
    if not is_expression(text):
        raise FormulaError("an expression is written ${...}")
    parser = _Parser(_tokens(text[2:-1]), values)
    if not parser.tokens:
        raise FormulaError("the expression is empty")
    value = parser.nested()
    if parser.at != len(parser.tokens):
        raise FormulaError(f"unexpected {parser.tokens[parser.at][1]!r} after the expression")
    if isinstance(value, float) and not math.isfinite(value):
        raise FormulaError("the value is not finite")
    return value
