"""Signal temporal logic formulas: the ``expect`` of ``temporal`` criteria.

A formula nests the project's expressions (:mod:`btgen_pytrees.expressions`) under temporal
operators. Like an expression it comes from a JSON file anyone may have written, so it is parsed
by hand - a tokeniser and a recursive-descent parser over a fixed grammar - and every atom goes
through :func:`btgen_pytrees.expressions.parse`, the checked whitelist parser. Nothing is evaluated.

The language (tightest binding first)::

    atom            an expression without && / || / ! at its top:  ego.gap >= 10,  abs(y2 - y1) <= 20, flag
    ( φ )           grouping
    ! φ   not φ     negation
    always[a,b](φ)  always(φ)  eventually[a,b](φ)           future: a window [t+a, t+b] in seconds
    once[a,b](φ)  historically[a,b](φ)  (also without a window: since the run's first tick)
                                                           past: a window [t-b, t-a]
    φ until[a,b] ψ  φ since[a,b] ψ                          (since also without a window)
    φ && ψ  φ and ψ
    φ || ψ  φ or ψ
    φ -> ψ  φ implies ψ                                     (right-associative)

``eventually`` and ``until`` must have a window (a requirement on a finite run must say by when);
``always`` without one means "to the end of the run". ``0 <= a <= b``. The operators are rtamt's
(its discrete-time semantics are the reference the tests compare with: docs/semantics.md).

>>> f = parse("always[0, 2](gap >= 10 -> eventually[0, 1.5](accel < 0))")
>>> f.op, f.window, f.children[0].op, sorted(f.names)
('always', (0.0, 2.0), 'implies', ['accel', 'gap'])
>>> f.span
3.5
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from functools import cached_property, lru_cache
from typing import Iterator

from .expressions import MAX_LENGTH, Expression, ExpressionError, bounds
from .expressions import parse as parse_expression
from .text import did_you_mean

__all__ = ["Formula", "FormulaError", "parse", "OPERATORS", "UNARY", "BINARY", "FUTURE", "PAST", "formula_bounds"]

UNARY = ("always", "eventually", "once", "historically")
"""The temporal operators written ``op[a,b](φ)``."""
BINARY = ("until", "since")
"""The temporal operators written ``φ op[a,b] ψ``."""
FUTURE = ("always", "eventually", "until")
PAST = ("once", "historically", "since")
BOUNDED = ("eventually", "until")
"""Operators that must have a window."""
OPERATORS = (*UNARY, *BINARY, "implies", "and", "or", "not")
"""Every word of the formula language (none may be a signal's name in a formula)."""

_TOKEN = re.compile(
    r"""
    (?P<ws>\s+)
  | (?P<arrow>->)
  | (?P<and>&&)
  | (?P<or>\|\|)
  | (?P<ne>!=)
  | (?P<not>!)
  | (?P<open>\()
  | (?P<close>\))
  | (?P<lbr>\[)
  | (?P<rbr>\])
  | (?P<name>[A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)*)
  | (?P<number>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)
  | (?P<other>==|<=|>=|[<>+\-*/%,])
    """,
    re.VERBOSE,
)
_WORDS = {"and": "and", "or": "or", "not": "not", "implies": "arrow"}
MAX_DEPTH = 64
"""Deepest nesting of operators accepted."""


class FormulaError(ExpressionError):
    """The text is not a formula of the language; ``str()`` says why and where (``at column N``)."""


@dataclass(frozen=True, eq=False)
class Formula:
    """A checked formula, or one of its sub-formulas.

    Attributes:
        op: ``atom``, ``not``, ``and``, ``or``, ``implies`` or a temporal operator (:data:`OPERATORS`)
        children: the operands (none for an atom; two for ``implies``, ``until``, ``since``; two or more
            for ``and``/``or``)
        window: ``(a, b)`` in seconds; ``b`` is None for an unbounded window; None for non-temporal nodes
        atom: an atom's parsed expression
        source: the text of this (sub-)formula as written
    """

    op: str
    children: tuple[Formula, ...] = ()
    window: tuple[float, float | None] | None = None
    atom: Expression | None = None
    source: str = field(default="")

    @cached_property
    def names(self) -> frozenset[str]:
        """The signal names the formula reads."""
        if self.atom is not None:
            return self.atom.names
        return frozenset().union(*(c.names for c in self.children))

    @cached_property
    def ordered_names(self) -> tuple[str, ...]:
        return tuple(sorted(self.names))

    @cached_property
    def span(self) -> float:
        """How far past its anchor the formula looks, in seconds (``inf``: to the end of the run)."""
        inner = max((c.span for c in self.children), default=0.0)
        if self.op in FUTURE:
            assert self.window is not None
            high = self.window[1]
            return math.inf if high is None else inner + high
        return inner

    def walk(self) -> Iterator[Formula]:
        """This formula and its sub-formulas, depth first, each before its operands."""
        yield self
        for child in self.children:
            yield from child.walk()

    def __str__(self) -> str:
        return self.source


def parse(text: str) -> Formula:
    """Parse and check *text*; raise :class:`FormulaError` (position and, for a misspelt operator,
    "did you mean") when it is not a formula.

    The same text gives the same object (formulas are immutable).
    """
    if not isinstance(text, str):
        raise FormulaError("a formula must be a string")
    return _parse(text)


@lru_cache(maxsize=256)
def _parse(text: str) -> Formula:
    if len(text) > MAX_LENGTH:
        raise FormulaError(f"formula longer than {MAX_LENGTH} characters")
    if not text.strip():
        raise FormulaError("empty formula")
    return _Parser(text).formula()


class _Parser:
    def __init__(self, text: str):
        self.text = text
        self.tokens: list[tuple[str, str, int]] = []  # (kind, text, column from 0)
        pos = 0
        while pos < len(text):
            m = _TOKEN.match(text, pos)
            if m is None:
                raise FormulaError(f"unexpected character {text[pos]!r} at column {pos + 1}")
            kind = m.lastgroup or ""
            if kind != "ws":
                word = m.group()
                if kind == "name" and word in _WORDS:
                    kind = _WORDS[word]
                elif kind == "name" and word in (*UNARY, *BINARY):
                    kind = word
                self.tokens.append((kind, word, pos))
            pos = m.end()
        self.tokens.append(("end", "", len(text)))
        self.i = 0
        self.depth = 0

    # -- tokens ---------------------------------------------------------------------------------------
    def peek(self, ahead: int = 0) -> tuple[str, str, int]:
        return self.tokens[min(self.i + ahead, len(self.tokens) - 1)]

    def take(self) -> tuple[str, str, int]:
        token = self.peek()
        self.i += 1
        return token

    def where(self, token: tuple[str, str, int]) -> str:
        return "at the end" if token[0] == "end" else f"at column {token[2] + 1}"

    def expect(self, kind: str, what: str) -> tuple[str, str, int]:
        token = self.peek()
        if token[0] != kind:
            found = "the end of the formula" if token[0] == "end" else repr(token[1])
            raise FormulaError(f"expected {what} {self.where(token)}, found {found}")
        return self.take()

    def text_from(self, start: int) -> str:
        """The source text from column *start* to the last token taken."""
        last = self.tokens[self.i - 1]
        return self.text[start : last[2] + len(last[1])].strip()

    # -- grammar --------------------------------------------------------------------------------------
    def formula(self) -> Formula:
        f = self.implication()
        token = self.peek()
        if token[0] != "end":
            raise FormulaError(f"unexpected {token[1]!r} {self.where(token)}{self.hint(token)}")
        return f

    def implication(self) -> Formula:
        start = self.peek()[2]
        left = self.disjunction()
        if self.peek()[0] == "arrow":
            self.take()
            right = self.implication()
            return Formula("implies", (left, right), source=self.text_from(start))
        return left

    def disjunction(self) -> Formula:
        return self.nary("or", self.conjunction)

    def conjunction(self) -> Formula:
        return self.nary("and", self.binary)

    def nary(self, kind: str, operand: "type[object] | object") -> Formula:
        start = self.peek()[2]
        parts = [operand()]  # type: ignore[operator]
        while self.peek()[0] == kind:
            self.take()
            parts.append(operand())  # type: ignore[operator]
        if len(parts) == 1:
            return parts[0]
        return Formula(kind, tuple(parts), source=self.text_from(start))

    def binary(self) -> Formula:
        start = self.peek()[2]
        left = self.unary()
        while self.peek()[0] in BINARY:
            op = self.take()
            window = self.window(op, required=op[1] in BOUNDED)
            right = self.unary()
            left = Formula(op[1], (left, right), window, source=self.text_from(start))
        return left

    def window(self, op: tuple[str, str, int], required: bool) -> tuple[float, float | None]:
        if self.peek()[0] != "lbr":
            if required:
                raise FormulaError(f"{op[1]!r} needs a window, e.g. {op[1]}[0, 2] {self.where(self.peek())} "
                                   "(a requirement on a finite run says by when)")  # fmt: skip
            return (0.0, None)
        self.take()
        low = self.bound()
        if self.peek()[1] != ",":
            self.expect("comma", "','")  # raises: says what was found
        self.take()
        high = self.bound()
        close = self.expect("rbr", "']'")
        if low > high:
            raise FormulaError(f"window [{low:g}, {high:g}] of {op[1]!r} {self.where(close)}: the start is after the end")
        return (low, high)

    def bound(self) -> float:
        token = self.peek()
        if token[0] != "number":
            found = "the end of the formula" if token[0] == "end" else repr(token[1])
            raise FormulaError(f"expected a window bound in seconds (a number >= 0) {self.where(token)}, found {found}")
        self.take()
        value = float(token[1])
        if not math.isfinite(value):
            raise FormulaError(f"window bound {token[1]!r} {self.where(token)} is out of range")
        return value

    def unary(self) -> Formula:
        self.depth += 1
        if self.depth > MAX_DEPTH:
            raise FormulaError(f"formula nested deeper than {MAX_DEPTH} levels {self.where(self.peek())}")
        try:
            return self.unary_inner()
        finally:
            self.depth -= 1

    def unary_inner(self) -> Formula:
        token = self.peek()
        start = token[2]
        kind = token[0]
        if kind == "not":
            self.take()
            inner = self.unary()
            return Formula("not", (inner,), source=self.text_from(start))
        if kind in UNARY:
            self.take()
            window = self.window(token, required=token[1] in BOUNDED)
            self.expect("open", f"'(' after {token[1]}{'[a, b]' if self.tokens[self.i - 1][0] == 'rbr' else ''}")
            inner = self.implication()
            self.expect("close", "')'")
            return Formula(token[1], (inner,), window, source=self.text_from(start))
        if kind in BINARY or kind in ("and", "or", "arrow"):
            raise FormulaError(f"{token[1]!r} {self.where(token)} needs an operand before it")
        if kind == "name" and self.peek(1)[0] in ("lbr", "open") and token[1] not in ("abs", "min", "max"):
            hint = did_you_mean(token[1], (*UNARY, *BINARY))
            if hint or self.peek(1)[0] == "lbr":
                raise FormulaError(f"unknown operator {token[1]!r} {self.where(token)}{hint}")
        if kind == "open" and self.grouped():
            self.take()
            inner = self.implication()
            self.expect("close", "')'")
            return inner
        return self.atom()

    def grouped(self) -> bool:
        """Whether the ``(`` here opens a sub-formula (its ``)`` followed by a formula operator or the end),
        not an arithmetic group of an atom (``(a + b) / 2 <= 3``)."""
        depth = 0
        for j in range(self.i, len(self.tokens)):
            kind = self.tokens[j][0]
            if kind == "open":
                depth += 1
            elif kind == "close":
                depth -= 1
                if depth == 0:
                    return self.tokens[j + 1][0] in ("end", "close", "and", "or", "arrow", *BINARY)
            elif kind in (*UNARY, *BINARY, "arrow", "and", "or", "not"):
                return True  # a formula operator inside: a sub-formula
        return True

    def atom(self) -> Formula:
        """The longest run of tokens that is part of no formula operator: one expression."""
        first = self.peek()
        depth = 0
        while True:
            kind = self.peek()[0]
            if kind == "end" or depth == 0 and kind in ("close", "and", "or", "arrow", *BINARY):
                break
            if kind in (*UNARY, "not", "lbr", "rbr") or depth and kind in ("and", "or", "arrow", *BINARY):
                token = self.peek()
                raise FormulaError(f"unexpected {token[1]!r} {self.where(token)} inside the atom starting at column "
                                   f"{first[2] + 1}{self.hint(token)}")  # fmt: skip
            depth += kind == "open"
            depth -= kind == "close"
            self.take()
        if self.peek() is first:
            found = "the end of the formula" if first[0] == "end" else repr(first[1])
            raise FormulaError(f"expected a sub-formula {self.where(first)}, found {found}")
        text = self.text_from(first[2])
        try:
            expression = parse_expression(text)
        except ExpressionError as exc:
            raise FormulaError(f"bad atom {text!r} at column {first[2] + 1}: {exc}") from None
        reserved = sorted(expression.names & set(OPERATORS))
        if reserved:
            raise FormulaError(f"{reserved[0]!r} is an operator of formulas, not a signal (at column {first[2] + 1})")
        return Formula("atom", atom=expression, source=text)

    def hint(self, token: tuple[str, str, int]) -> str:
        return did_you_mean(token[1], OPERATORS) if token[0] == "name" else ""


def formula_bounds(formula: Formula) -> list[tuple[str, str, float]]:
    """:func:`~btgen_pytrees.expressions.bounds` of each atom, in the order written (what plots draw)."""
    found: list[tuple[str, str, float]] = []
    for node in formula.walk():
        if node.atom is not None:
            found.extend(b for b in bounds(node.atom) if b not in found)
    return found
