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
import operator
import re
from dataclasses import dataclass, field
from functools import cached_property, lru_cache
from typing import Any, Callable, Iterable, Mapping

__all__ = ["Expression", "ExpressionError", "parse", "why_false", "format_number", "bounds", "conjunction",
           "disjunction", "RESERVED", "MAX_LENGTH"]  # fmt: skip

MAX_LENGTH = 1000
"""Longest accepted expression, in characters (keeps parsing and products bounded)."""

FUNCTIONS: dict[str, Any] = {"abs": abs, "min": min, "max": max}
_EVAL_GLOBALS: dict[str, Any] = {"__builtins__": {}, **FUNCTIONS}
"""The globals :meth:`Expression.evaluate` runs its code with: no builtins, the functions (a name is looked up
in the values first - no signal can be named as a function: :data:`RESERVED`). A checked expression stores no
name, so the one dict serves every call."""
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
        if not (values.keys() >= self.names if type(values) is dict else all(n in values for n in self.names)):
            raise ExpressionError(f"signal {self._missing(values)!r} has no value")
        scope: Mapping[str, Any] = values  # the functions are the globals': no dict of them made per call
        aliases = self._aliases
        if aliases:
            scope = dict(values)
            for alias, name in aliases:
                scope[alias] = values[name]
        try:
            return eval(self._code, _EVAL_GLOBALS, scope)  # noqa: S307 - checked AST
        except (ArithmeticError, TypeError, ValueError) as exc:
            raise ExpressionError(f"{exc} in {self.source!r}") from None

    def judge(self, values: Mapping[str, Any]) -> tuple[bool, float]:
        """Whether the expression holds for *values*, and by how much: ``(truth, margin)``.

        *truth* is ``bool(evaluate(values))``, raising exactly when :meth:`evaluate` raises.
        *margin* is the expression's robustness in the quantitative semantics of signal
        temporal logic: > 0 it holds with room to spare, < 0 it is false by that much, 0 on
        the boundary; its sign never contradicts *truth* (0 may go either way):

        * ``a <= b``, ``a < b``: ``b - a``; ``a >= b``, ``a > b``: ``a - b``;
          ``a == b``: ``-|a - b|`` (0 when it holds, never positive); ``a != b``: ``|a - b|``
          (0 when it is false); a chain ``a < b < c``: the smallest of its links;
        * ``&&``: the smallest operand margin, ``||``: the largest, ``!``: the negation;
        * anything else used as a truth value (a bare signal, ``true``, a function's result):
          ``+inf`` when truthy, ``-inf`` when not - a boolean has no distance to the boundary;
        * booleans count as 0 and 1 in a comparison; a comparison whose sides have no
          finite difference (a NaN side, ``inf - inf``) is 0 when the sides are equal,
          else ``+inf``/``-inf`` by its truth;
        * an operand that ``&&``/``||`` skips (Python's short-circuit) and that cannot be
          evaluated (``x > 0 && 1/x > 2`` with ``x = 0``) is left out: the margin is that of
          the operands that decided.

        >>> parse("speed <= 30").judge({"speed": 32.5})
        (False, -2.5)
        >>> parse("0 <= x < 5 && brake == 0").judge({"x": 1, "brake": 0})
        (True, 0.0)
        >>> parse("a > 1 || !flag").judge({"a": 3, "flag": True})
        (True, 2.0)
        """
        if not (values.keys() >= self.names if type(values) is dict else all(n in values for n in self.names)):
            raise ExpressionError(f"signal {self._missing(values)!r} has no value")
        judge, scoped = self._judge
        scope = None
        if scoped:
            scope = {**FUNCTIONS, **values}
            for alias, name in self._aliases:
                scope[alias] = values[name]
        truth, margin = judge(values, scope)
        return truth, margin + 0.0  # -0.0 is 0

    def _missing(self, values: Mapping[str, Any]) -> str:
        """The first name (in sorted order) that has no value in *values*."""
        return sorted(n for n in self.names if n not in values)[0]

    @cached_property
    def _judge(self) -> tuple[_Judge, bool]:
        """The robustness evaluator of this expression (built on first use) and whether it needs a scope."""
        aliases: dict[str, str] = {}
        tree = ast.parse(_translate(self.source, aliases).strip(), mode="eval")
        plan = _Plan(self.source, {alias: name for name, alias in aliases.items()})
        return plan.logic(tree.body), plan.scoped


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


PARSED = 1024
"""Expressions :func:`parse` keeps by their text (the least recently used forgotten first)."""


def parse(text: str) -> Expression:
    """Parse and check *text*; raise :class:`ExpressionError` if it is not in the language.

    An :class:`Expression` is immutable and depends on its text alone, so the same text gives the same
    object, parsed, checked and compiled once (and its robustness evaluator built once) for all the
    cases of a process that hold it: the runs of a sweep or a search validate a concrete case each,
    most of whose expressions are those of the one before (:data:`PARSED` are kept).
    """
    if not isinstance(text, str):
        raise ExpressionError("an expression must be a string")
    return _parse(text)


@lru_cache(maxsize=PARSED)
def _parse(text: str) -> Expression:
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


# -- robustness (Expression.judge) ----------------------------------------------------------------

_Judge = Callable[[Mapping[str, Any], Any], "tuple[bool, float]"]
_Get = Callable[[Mapping[str, Any], Any], Any]
_INF = math.inf
_LINKS: dict[type, tuple[Callable[[Any, Any], Any], Callable[[Any, Any], Any]]] = {
    ast.Lt: (operator.lt, lambda a, b: b - a), ast.LtE: (operator.le, lambda a, b: b - a),
    ast.Gt: (operator.gt, lambda a, b: a - b), ast.GtE: (operator.ge, lambda a, b: a - b),
    ast.Eq: (operator.eq, lambda a, b: -abs(a - b)), ast.NotEq: (operator.ne, lambda a, b: abs(a - b)),
}  # fmt: skip
"""Per comparison operator: its truth, and its robustness (signed distance to the boundary)."""


def _link_margin(distance: Callable[[Any, Any], Any], holds: bool, a: Any, b: Any) -> float:
    """The margin of one comparison ``a OP b`` whose truth is *holds*."""
    try:
        d = float(distance(a, b))
    except (ArithmeticError, TypeError, ValueError):  # no difference (not numbers, or too large for a float)
        return _INF if holds else -_INF
    if d != d:  # NaN: inf - inf, or a side that is NaN
        try:
            return 0.0 if a == b else _INF if holds else -_INF
        except (ArithmeticError, TypeError, ValueError):
            return _INF if holds else -_INF
    if (d < 0.0) if holds else (d > 0.0):  # rounding never flips a sign; keep it so whatever the numbers
        return 0.0
    return d


class _Plan:
    """Builds an expression's robustness evaluator from its checked tree: a closure per node.

    The logical layer (``and``/``or``/``not``, comparisons) becomes closures that return
    ``(truth, margin)``; every other node (an operand, an atom) is evaluated as Python
    evaluates it - a signal read straight from the values, a constant folded, anything
    else compiled - so the truth is the one :meth:`Expression.evaluate` gives.
    """

    def __init__(self, source: str, dotted: Mapping[str, str]):
        self.source = source
        self.dotted = dotted
        self.scoped = False

    def logic(self, node: ast.expr) -> _Judge:
        if isinstance(node, ast.BoolOp):
            return self._boolean([self.logic(v) for v in node.values], isinstance(node.op, ast.And))
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.Not):
            inner = self.logic(node.operand)

            def negation(values: Mapping[str, Any], scope: Any) -> tuple[bool, float]:
                truth, margin = inner(values, scope)
                return not truth, -margin

            return negation
        if isinstance(node, ast.Compare):
            return self._compare(node)
        get = self.value(node)

        def atom(values: Mapping[str, Any], scope: Any) -> tuple[bool, float]:
            truth = bool(get(values, scope))
            return truth, _INF if truth else -_INF

        return atom

    @staticmethod
    def _boolean(parts: list[_Judge], conjunctive: bool) -> _Judge:
        pick = min if conjunctive else max

        def judge(values: Mapping[str, Any], scope: Any) -> tuple[bool, float]:
            decided = False  # the truth is known: the operands left are evaluated for their margins only
            truth = conjunctive
            margins = []
            for part in parts:
                if not decided:
                    truth, margin = part(values, scope)
                    decided = truth is not conjunctive
                else:
                    try:
                        margin = part(values, scope)[1]
                    except ExpressionError:  # Python would not have evaluated it
                        continue
                margins.append(margin)
            return truth, pick(margins)

        return judge

    def _compare(self, node: ast.Compare) -> _Judge:
        gets = [self.value(node.left), *(self.value(c) for c in node.comparators)]
        links = [_LINKS[type(op)] for op in node.ops]
        source = self.source
        if len(links) == 1:  # the usual case, e.g. speed <= 30: no loop
            (get_a, get_b), (test, distance) = gets, links[0]

            def single(values: Mapping[str, Any], scope: Any) -> tuple[bool, float]:
                a, b = get_a(values, scope), get_b(values, scope)
                try:
                    holds = bool(test(a, b))
                except (ArithmeticError, TypeError, ValueError) as exc:
                    raise ExpressionError(f"{exc} in {source!r}") from None
                return holds, _link_margin(distance, holds, a, b)

            return single

        def chain(values: Mapping[str, Any], scope: Any) -> tuple[bool, float]:
            truth = True
            low = _INF
            a = gets[0](values, scope)
            for get, (test, distance) in zip(gets[1:], links):
                if truth:
                    b = get(values, scope)
                    try:
                        holds = bool(test(a, b))
                    except (ArithmeticError, TypeError, ValueError) as exc:
                        raise ExpressionError(f"{exc} in {source!r}") from None
                    truth = holds
                else:  # Python stopped at the first false link: the rest only for the margin
                    try:
                        b = get(values, scope)
                        holds = bool(test(a, b))
                    except (ExpressionError, ArithmeticError, TypeError, ValueError):
                        break
                low = min(low, _link_margin(distance, holds, a, b))
                a = b
            return truth, low

        return chain

    def value(self, node: ast.expr) -> _Get:
        """A function giving *node*'s value as Python computes it."""
        if isinstance(node, ast.Name) and node.id not in FUNCTIONS:
            name = self.dotted.get(node.id, node.id)
            return lambda values, scope: values[name]
        code = compile(ast.Expression(node), "<expect>", "eval")
        if not any(isinstance(n, ast.Name) and n.id not in FUNCTIONS for n in ast.walk(node)):
            try:  # a constant (-5, 2 * 3, max(1, 2)): computed once
                constant = eval(code, {"__builtins__": {}}, dict(FUNCTIONS))  # noqa: S307 - checked AST
            except (ArithmeticError, TypeError, ValueError, RecursionError):
                pass  # 1 / 0: raises at every evaluation, as evaluate() does
            else:
                return lambda values, scope: constant
        self.scoped = True
        source = self.source

        def computed(values: Mapping[str, Any], scope: Any) -> Any:
            try:
                return eval(code, {"__builtins__": {}}, scope)  # noqa: S307 - a checked sub-tree
            except (ArithmeticError, TypeError, ValueError) as exc:
                raise ExpressionError(f"{exc} in {source!r}") from None

        return computed


def conjunction(margins: Iterable[float | None]) -> float | None:
    """The margin of an AND of parts with these margins: their minimum; None (unknown) stays unknown
    unless a known part already decides (is below 0). None when there are no parts.

    >>> conjunction([2.0, -1.0]), conjunction([2.0, None]), conjunction([-1.0, None]), conjunction([])
    (-1.0, None, -1.0, None)
    """
    seen = list(margins)
    known = [m for m in seen if m is not None]
    if not known:
        return None
    low = min(known)
    return None if len(known) < len(seen) and low >= 0 else low


def disjunction(margins: Iterable[float | None]) -> float | None:
    """The margin of an OR of parts with these margins: their maximum; None (unknown) stays unknown
    unless a known part already decides (is above 0). None when there are no parts.

    >>> disjunction([2.0, -1.0]), disjunction([-1.0, None]), disjunction([2.0, None]), disjunction([])
    (2.0, None, 2.0, None)
    """
    seen = list(margins)
    known = [m for m in seen if m is not None]
    if not known:
        return None
    high = max(known)
    return None if len(known) < len(seen) and high <= 0 else high


# -- why an expression is false -------------------------------------------------------------------

_COMPARE = {ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">", ast.GtE: ">=", ast.Eq: "==", ast.NotEq: "!="}
_OPS: dict[type, Callable[[Any, Any], bool]] = {
    ast.Lt: lambda a, b: a < b, ast.LtE: lambda a, b: a <= b, ast.Gt: lambda a, b: a > b,
    ast.GtE: lambda a, b: a >= b, ast.Eq: lambda a, b: a == b, ast.NotEq: lambda a, b: a != b,
}  # fmt: skip


def format_number(value: Any) -> str:
    """A value as messages show it: numbers to 6 significant digits, like a margin (``1.635`` for
    ``1.6350000000000051``); booleans and whole numbers as they are, anything else as ``repr``.

    >>> format_number(1.6350000000000051), format_number(True), format_number(12), format_number("a")
    ('1.635', 'True', '12', "'a'")
    """
    if isinstance(value, float):
        return f"{value:.6g}"
    return repr(value)


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
                return [f"{link} false by {format_number(margin)}"]
            left, left_node = right, right_node
        return []
    return [f"{_text(node, dotted)} false"]
