"""Margins: each criterion's signed robustness, and the search's objective combined from them.

The objective of a run is the test's own verdict made quantitative: each
criterion's *margin* (> 0 held with room to spare, < 0 violated by that much,
signal-temporal-logic robustness), divided by its *scale*, combined within each
oracle group by the group's relation (``&&`` -> min, ``||`` -> max) and across
the two groups (records, and periods/finals) by min, as the oracle root
combines them. A failing run's objective is at most 0.

Where the margins come from: :func:`criterion_margins` reads the report's own
``margin`` of each criterion when the report carries one; otherwise it computes
it from the run's trace with the same quantitative semantics:

* ``a <= b``, ``a < b`` -> ``b - a``; ``a >= b``, ``a > b`` -> ``a - b``;
  ``a == b`` -> ``-|a - b|``; ``a != b`` -> ``|a - b|``; a chain: the min of its links;
* ``&&`` -> min, ``||`` -> max, ``!x`` -> ``-x``; a boolean value: +1 true, -1 false;
* ``record``: the min over every tick it judged (from the first tick to its
  verdict's time); ``period``: the min over its window (``from`` to its verdict's
  time); ``final``: the value at its verdict's time;
* a tick whose values cannot be evaluated (a signal without a value): that
  criterion has no margin (``None``).
"""

from __future__ import annotations

import ast
import math
from typing import Any, Callable, Mapping, Sequence

from ..expressions import FUNCTIONS, Expression, ExpressionError, syntax_tree
from ..model import TestCase

__all__ = ["criterion_margins", "expression_margin", "combine", "groups_of"]

_Margin = Callable[[Mapping[str, Any]], float]


def _compile(expression: Expression) -> _Margin:
    """A function from signal values to the margin of *expression* (raises ExpressionError, ArithmeticError...)."""
    tree, aliases = syntax_tree(expression)
    return _node(tree, aliases)


def _value_fn(node: ast.expr, aliases: Mapping[str, str]) -> Callable[[Mapping[str, Any]], Any]:
    code = compile(ast.Expression(node), "<margin>", "eval")

    def value(values: Mapping[str, Any]) -> Any:
        scope = {**FUNCTIONS, **values, **{a: values[n] for a, n in aliases.items() if n in values}}
        return eval(code, {"__builtins__": {}}, scope)  # noqa: S307 - a sub-tree of a checked expression

    return value


def _node(node: ast.expr, aliases: Mapping[str, str]) -> _Margin:
    if isinstance(node, ast.BoolOp):
        parts = [_node(v, aliases) for v in node.values]
        pick = min if isinstance(node.op, ast.And) else max
        return lambda values: pick(p(values) for p in parts)
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.Not):
        inner = _node(node.operand, aliases)
        return lambda values: 0.0 - inner(values)
    if isinstance(node, ast.Compare):
        sides = [_value_fn(n, aliases) for n in (node.left, *node.comparators)]
        ops = [type(op) for op in node.ops]

        def compare(values: Mapping[str, Any]) -> float:
            got = [float(s(values)) for s in sides]
            return min(_link(op, a, b) for op, a, b in zip(ops, got, got[1:]))

        return compare
    value = _value_fn(node, aliases)

    def truth(values: Mapping[str, Any]) -> float:
        return 1.0 if value(values) else -1.0

    return truth


def _link(op: type, a: float, b: float) -> float:
    if op in (ast.Lt, ast.LtE):
        return b - a
    if op in (ast.Gt, ast.GtE):
        return a - b
    if op is ast.Eq:
        return 0.0 - abs(a - b)  # 0.0, not -0.0, on equality
    return abs(a - b)


def expression_margin(expression: Expression, values: Mapping[str, Any]) -> float | None:
    """The margin of *expression* for one set of signal values (``None``: it cannot be evaluated).

    >>> from btgen_pytrees.expressions import parse
    >>> expression_margin(parse("speed <= 30 && brake == 0"), {"speed": 27.5, "brake": 0})
    0.0
    >>> expression_margin(parse("speed <= 30 || gap > 5"), {"speed": 32, "gap": 9})
    4.0
    """
    try:
        margin = _compile(expression)(values)
    except (ExpressionError, ArithmeticError, TypeError, ValueError, KeyError, NameError):
        return None
    return margin if math.isfinite(margin) else None


def _series_margin(trace: Any, expression: Expression, first: float, last: float) -> float | None:
    """The min of the margin over the trace's ticks whose time is in [first, last]."""
    try:
        margin_of = _compile(expression)
    except (ExpressionError, SyntaxError):
        return None
    names = expression.ordered_names
    series = {n: trace.signals.get(n) for n in names}
    if any(s is None for s in series.values()):
        return None
    position = dict.fromkeys(names, -1)
    current: dict[str, Any] = {}
    best: float | None = None
    for k, t in enumerate(trace.times):
        for n in names:
            ticks, values = series[n]
            i = position[n]
            while i + 1 < len(ticks) and ticks[i + 1] <= k:
                i += 1
            position[n] = i
            if i >= 0:
                current[n] = values[i]
        if t < first - 1e-9 or t > last + 1e-9:
            continue
        if len(current) < len(names) or any(v is None for v in current.values()):
            return None
        try:
            m = float(margin_of(current))
        except (ExpressionError, ArithmeticError, TypeError, ValueError, KeyError, NameError):
            return None
        if not math.isfinite(m):
            continue
        best = m if best is None else min(best, m)
    return best


def criterion_margins(report: Any, case: TestCase) -> dict[str, float | None]:
    """Each criterion's margin, by id: the report's own ``margin`` when it has one, else from its trace."""
    out: dict[str, float | None] = {}
    criteria = {c.id: c for c in case.criteria}
    for o in report.oracles:
        own = getattr(o, "margin", None)
        if isinstance(own, (int, float)) and not isinstance(own, bool):
            out[o.id] = float(own)
            continue
        criterion = criteria.get(o.id)
        trace = report.trace
        if criterion is None or trace is None or o.at is None or criterion.action is not None:
            out[o.id] = None
            continue
        if criterion.type == "final":
            first = o.at
        elif criterion.type == "period":
            first = criterion.start or 0.0
        else:
            first = 0.0
        out[o.id] = _series_margin(trace, criterion.expect, first, o.at)
    return out


def groups_of(oracles: Sequence[Any]) -> dict[str, tuple[str, list[str]]]:
    """``{group: (relation, [criterion ids])}`` from a report's oracle results (or their dicts)."""
    groups: dict[str, tuple[str, list[str]]] = {}
    for o in oracles:
        group = o["group"] if isinstance(o, Mapping) else o.group
        relation = o["relation"] if isinstance(o, Mapping) else o.relation
        ident = o["id"] if isinstance(o, Mapping) else o.id
        groups.setdefault(group or "record", (relation or "&&", []))[1].append(ident)
    return groups


def combine(margins: Mapping[str, float | None], groups: Mapping[str, tuple[str, Sequence[str]]],
            scales: Mapping[str, float], use: Callable[[str], bool] = lambda _: True) -> float | None:  # fmt: skip
    """The objective: scaled margins, min/max within each group by its relation, min across groups.

    Criteria for which *use* is false, without a margin or with an infinite one (a truth value: no
    distance to measure) are left out (``None`` when nothing is left).
    """
    totals = []
    for relation, ids in groups.values():
        values = [margins[i] / scales.get(i, 1.0) for i in ids  # type: ignore[operator]
                  if use(i) and margins.get(i) is not None and math.isfinite(margins[i])]  # type: ignore[arg-type]  # fmt: skip
        if values:
            totals.append(max(values) if relation == "||" else min(values))
    return min(totals) if totals else None
