"""A small, safe expression language for ``expect`` fields.

Oracles and ``until`` constraints state their expectations as text, e.g.
``"speed <= 30 && brake == 0"``. The text comes from a JSON file that may have
been written by anyone, so it is never handed to :func:`eval` as such. Instead it
is tokenised by hand, translated to Python syntax, parsed with :mod:`ast` and
checked against a whitelist of node types *at load time*. Only a checked tree is
compiled; evaluating it later cannot reach attributes, builtins or imports.

The language::

    numbers, true/false        1, 2.5, 1e3, true, false
    signal names               speed, brake_1          (not starting with "_")
    dotted signal names        ego.speed, sim.collisions  (a system's signals: one name,
                                                       never attribute access)
    arithmetic                 + - * / %               (no power operator at all)
    comparisons                == != < <= > >=         (chains like 0 <= x < 5 work)
    logic                      and or not   &&  ||  !
    calls                      abs(x) min(a, b, ...) max(a, b, ...)
    grouping                   ( ... )

Example:

>>> e = parse("0 <= speed && speed < max(limit, 10)")
>>> sorted(e.names)
['limit', 'speed']
>>> e.evaluate({"speed": 5, "limit": 3})
True
"""

from __future__ import annotations

import ast
import keyword
import math
import re
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Callable, Mapping

__all__ = ["Expression", "ExpressionError", "parse", "why_false", "bounds", "RESERVED", "MAX_LENGTH"]

MAX_LENGTH = 1000
"""Longest accepted expression, in characters (keeps parsing and products bounded)."""

FUNCTIONS: dict[str, Any] = {"abs": abs, "min": min, "max": max}
RESERVED = frozenset({"true", "false", *FUNCTIONS, *keyword.kwlist})
"""Words that cannot be used as signal names (no expression could read them)."""

_TOKEN = re.compile(
    r"""
    (?P<ws>\s+)
  | (?P<number>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)
  | (?P<name>[A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)*)
  | (?P<op>&&|\|\||==|!=|<=|>=|[<>+\-*/%(),!])
    """,
    re.VERBOSE,
)
_GLUED = re.compile(r"[A-Za-z0-9_.]+")
_TRANSLATE = {"&&": " and ", "||": " or ", "!": " not ", "true": "True", "false": "False"}
_ALIAS = "_s{}"
"""A dotted name reaches Python as ``_s0``, ``_s1``, ...: no attribute node can ever be
parsed, and no signal can be called so (names starting with "_" are refused)."""

_ALLOWED = (
    ast.Expression, ast.BoolOp, ast.And, ast.Or, ast.UnaryOp, ast.Not, ast.USub, ast.UAdd,
    ast.BinOp, ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Mod, ast.Compare, ast.Eq, ast.NotEq,
    ast.Lt, ast.LtE, ast.Gt, ast.GtE, ast.Constant, ast.Name, ast.Load, ast.Call,
)  # fmt: skip


class ExpressionError(ValueError):
    """The text is not an expression of the language; ``str()`` says why."""


@dataclass(frozen=True)
class Expression:
    """A checked, compiled expression.

    Attributes:
        source: the text as written in the test case
        names: the signal names it reads
    """

    source: str
    names: frozenset[str]
    _code: Any = field(repr=False, compare=False)
    _aliases: tuple[tuple[str, str], ...] = field(default=(), repr=False, compare=False)

    @cached_property
    def ordered_names(self) -> tuple[str, ...]:
        """:attr:`names` sorted: iterate this where the order shows in an output.

        A frozenset's iteration order depends on ``PYTHONHASHSEED``; dicts of values
        built from it would put keys in a different order in every process.
        """
        return tuple(sorted(self.names))

    def evaluate(self, values: Mapping[str, Any]) -> Any:
        """Evaluate against signal *values*.

        Raises:
            ExpressionError: a name has no value, or arithmetic failed
                (division by zero, comparing a number with nothing, ...).
        """
        missing = [n for n in self.names if n not in values]
        if missing:
            raise ExpressionError(f"signal {sorted(missing)[0]!r} has no value")
        scope = {**FUNCTIONS, **values}
        for alias, name in self._aliases:
            scope[alias] = values[name]
        try:
            return eval(self._code, {"__builtins__": {}}, scope)  # noqa: S307 - checked AST
        except (ArithmeticError, TypeError, ValueError) as exc:
            raise ExpressionError(f"{exc} in {self.source!r}") from None


def _translate(text: str, aliases: dict[str, str]) -> str:
    """Python source for *text*; each dotted name gets an alias in *aliases* (name -> alias)."""
    out: list[str] = []
    pos = 0
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if m is None:
            raise ExpressionError(f"unexpected character {text[pos]!r} at column {pos + 1}")
        kind, tok = m.lastgroup, m.group()
        if kind == "name" and any(part.startswith("_") for part in tok.split(".")):
            raise ExpressionError(f"names starting with '_' are not allowed ({tok!r})")
        if kind == "name" and "." in tok:
            tok = aliases.setdefault(tok, _ALIAS.format(len(aliases)))
        if kind == "name" and tok in ("True", "False", "None"):
            raise ExpressionError(f"unknown name {tok!r} (write true/false in lower case)")
        if kind == "number" and len(tok) > 40:
            raise ExpressionError(f"number literal too long ({len(tok)} characters)")
        # Fuzz finding: a name glued to a number became a Python literal outside the
        # language ("0x10", "0b1", "0o7"; hex escaped the 40-character limit) or a
        # SyntaxWarning printed on stderr ("1or 2", "2e").
        if kind == "number" and _GLUED.match(text, m.end()):
            raise ExpressionError(f"invalid number {_GLUED.match(text, pos).group()!r} at column {pos + 1}")  # type: ignore[union-attr]
        out.append(_TRANSLATE.get(tok, tok) if kind != "number" else tok)
        pos = m.end()
    return "".join(out)


def _check(tree: ast.AST, aliases: Mapping[str, str]) -> frozenset[str]:
    names: set[str] = set()
    dotted = {alias: name for name, alias in aliases.items()}
    called = {id(n.func) for n in ast.walk(tree) if isinstance(n, ast.Call)}
    for node in ast.walk(tree):
        if not isinstance(node, _ALLOWED):
            raise ExpressionError(f"{type(node).__name__} is not allowed")
        if isinstance(node, ast.Call):
            func = node.func
            if not (isinstance(func, ast.Name) and func.id in FUNCTIONS) or node.keywords:
                raise ExpressionError("only abs(), min() and max() may be called")
            if not node.args or (func.id == "abs" and len(node.args) != 1):
                raise ExpressionError(f"wrong number of arguments to {func.id}()")
            if func.id != "abs" and len(node.args) == 1:
                raise ExpressionError(f"{func.id}() needs at least two arguments")
        elif isinstance(node, ast.Name) and node.id not in FUNCTIONS:
            names.add(dotted.get(node.id, node.id))
        elif isinstance(node, ast.Name) and id(node) not in called:
            raise ExpressionError(f"{node.id!r} is a function; call it as {node.id}(...)")
        elif isinstance(node, ast.Constant):
            if isinstance(node.value, float) and not math.isfinite(node.value):
                raise ExpressionError("number literal out of range")
            if not isinstance(node.value, (int, float, bool)):
                raise ExpressionError("only numbers and true/false are allowed as constants")
    return frozenset(names)


def parse(text: str) -> Expression:
    """Parse and check *text*; raise :class:`ExpressionError` if it is not in the language."""
    if not isinstance(text, str):
        raise ExpressionError("an expression must be a string")
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"expression longer than {MAX_LENGTH} characters")
    if not text.strip():
        raise ExpressionError("empty expression")
    aliases: dict[str, str] = {}
    source = _translate(text, aliases)
    try:
        tree = ast.parse(source.strip(), mode="eval")
    except SyntaxError as exc:
        raise ExpressionError(f"syntax error: {exc.msg}") from None
    except (MemoryError, RecursionError):
        raise ExpressionError("expression nested too deeply") from None
    names = _check(tree, aliases)
    try:
        code = compile(tree, "<expect>", "eval")
    except (MemoryError, RecursionError):
        raise ExpressionError("expression nested too deeply") from None
    return Expression(text, names, code, tuple((alias, name) for name, alias in aliases.items()))


def bounds(expression: Expression) -> list[tuple[str, str, float]]:
    """Each comparison of a signal with a number in *expression*: ``(signal, operator, number)``.

    The signal is on the left as written (``30 >= speed`` is ``("speed", "<=", 30)``);
    chains give one item per link that compares a signal with a number; comparisons of
    two signals or of a function's result give none. What the run picture draws as bounds.

    >>> bounds(parse("0 <= ego.x < 5 && sim.collisions == 0 || 30 >= speed"))
    [('ego.x', '>=', 0.0), ('ego.x', '<', 5.0), ('sim.collisions', '==', 0.0), ('speed', '<=', 30.0)]
    """
    aliases: dict[str, str] = {}
    try:
        tree = ast.parse(_translate(expression.source, aliases).strip(), mode="eval")
    except (ExpressionError, SyntaxError, RecursionError, MemoryError):
        return []
    dotted = {alias: name for name, alias in aliases.items()}
    mirror = {"<": ">", "<=": ">=", ">": "<", ">=": "<=", "==": "==", "!=": "!="}
    found: list[tuple[str, str, float]] = []
    compares = sorted((n for n in ast.walk(tree) if isinstance(n, ast.Compare)), key=lambda n: n.col_offset)
    for node in compares:  # in the order written
        sides = [node.left, *node.comparators]
        for (left, right), op in zip(zip(sides, sides[1:]), node.ops):
            text = _COMPARE[type(op)]
            number = _number_of(right)
            if isinstance(left, ast.Name) and left.id not in FUNCTIONS and number is not None:
                found.append((dotted.get(left.id, left.id), text, number))
            elif isinstance(right, ast.Name) and right.id not in FUNCTIONS and _number_of(left) is not None:
                found.append((dotted.get(right.id, right.id), mirror[text], _number_of(left)))  # type: ignore[arg-type]
    return found


def _number_of(node: ast.expr) -> float | None:
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        inner = _number_of(node.operand)
        return -inner if inner is not None else None
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
        return float(node.value)
    return None


# -- why an expression is false -------------------------------------------------------------------

_COMPARE = {ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">", ast.GtE: ">=", ast.Eq: "==", ast.NotEq: "!="}
_OPS: dict[type, Callable[[Any, Any], bool]] = {
    ast.Lt: lambda a, b: a < b, ast.LtE: lambda a, b: a <= b, ast.Gt: lambda a, b: a > b,
    ast.GtE: lambda a, b: a >= b, ast.Eq: lambda a, b: a == b, ast.NotEq: lambda a, b: a != b,
}  # fmt: skip


def _number(value: float) -> str:
    return f"{value:.6g}"


def why_false(expression: Expression, values: Mapping[str, Any]) -> str:
    """Why *expression* is false for *values*: each false comparison with its margin.

    The margin of a false comparison ``a OP b`` is ``|a - b|``, the distance
    between its sides (0 for ``!=``: they are equal; for ``<``/``>`` the distance
    to the boundary). A chain ``a < b < c`` is explained by its first false link,
    ``and`` by each false operand, ``or`` by every operand; anything else is
    "false" without a margin. Returns ``""`` when the expression is not false or
    cannot be evaluated (its error says why).

    >>> why_false(parse("speed <= 30"), {"speed": 32.4})
    'speed <= 30 false by 2.4'
    >>> why_false(parse("0 <= x < 5 && brake == 0"), {"x": 7, "brake": 0})
    'x < 5 false by 2'
    >>> why_false(parse("a > 1 || b"), {"a": 0, "b": False})
    'a > 1 false by 1; b false'
    """
    try:
        if expression.evaluate(values):
            return ""
        aliases: dict[str, str] = {}
        tree = ast.parse(_translate(expression.source, aliases).strip(), mode="eval")
    except (ExpressionError, SyntaxError, RecursionError, MemoryError):
        return ""
    env = {**FUNCTIONS, **values, **{alias: values[name] for name, alias in aliases.items()}}
    dotted = {alias: name for name, alias in aliases.items()}
    try:
        parts = _explain(tree.body, env, dotted)
    except (ArithmeticError, TypeError, ValueError, RecursionError):
        return f"{expression.source} false"
    return "; ".join(parts) if parts else f"{expression.source} false"


def _value(node: ast.expr, env: Mapping[str, Any]) -> Any:
    code = compile(ast.Expression(node), "<explain>", "eval")  # a checked sub-tree of a checked expression
    return eval(code, {"__builtins__": {}}, dict(env))  # noqa: S307


def _text(node: ast.AST, dotted: Mapping[str, str]) -> str:
    text = re.sub(r"\b(True|False)\b", lambda m: m.group().lower(), ast.unparse(node))
    return re.sub(r"\b_s\d+\b", lambda m: dotted.get(m.group(), m.group()), text) if dotted else text


def _explain(node: ast.expr, env: Mapping[str, Any], dotted: Mapping[str, str]) -> list[str]:
    if isinstance(node, ast.BoolOp):
        parts: list[str] = []
        for operand in node.values:
            if not _value(operand, env):
                parts.extend(_explain(operand, env, dotted))
        return parts
    if isinstance(node, ast.Compare):
        left = _value(node.left, env)
        left_node: ast.expr = node.left
        for op, right_node in zip(node.ops, node.comparators):
            right = _value(right_node, env)
            if not _OPS[type(op)](left, right):
                link = f"{_text(left_node, dotted)} {_COMPARE[type(op)]} {_text(right_node, dotted)}"
                try:
                    margin = 0.0 if isinstance(op, ast.NotEq) else abs(float(left) - float(right))
                except (TypeError, ValueError, OverflowError):
                    return [f"{link} false"]
                return [f"{link} false by {_number(margin)}"]
            left, left_node = right, right_node
        return []
    return [f"{_text(node, dotted)} false"]
