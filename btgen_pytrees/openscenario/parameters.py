"""Parameters: declarations with their types and constraint groups, ``$name`` references and ``${...}`` values.

ASAM OpenSCENARIO 1.2, clause 7.4 (1.0: 8.4): a ``ParameterDeclaration`` has a name, a
``parameterType`` and a default ``value``; an attribute written ``$name`` takes the parameter's
value and one written ``${...}`` the value of the expression (:mod:`.formula`). A declaration may
refer to parameters declared before it. ``ConstraintGroup`` s (1.1+) restrict a value: the value
must satisfy every ``ValueConstraint`` of at least one group (the groups are ORed, the constraints
of a group ANDed). A value given from outside (a variation, ``--set``) replaces the default and is
checked against the same constraints.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

from .formula import FormulaError, evaluate, is_expression
from .xmltree import Node, XmlProblem

__all__ = ["Scope", "convert_value", "TYPES", "RULES"]

TYPES = ("int", "double", "string", "boolean", "unsignedInt", "unsignedShort", "dateTime", "integer")
"""The ``parameterType`` s of 1.0-1.3 (``integer`` is 1.0's spelling of ``int``)."""

RULES = {
    "equalTo": lambda a, b: a == b, "greaterThan": lambda a, b: a > b, "lessThan": lambda a, b: a < b,
    "greaterOrEqual": lambda a, b: a >= b, "lessOrEqual": lambda a, b: a <= b, "notEqualTo": lambda a, b: a != b,
}  # fmt: skip
"""The ``ValueConstraint`` rules (and the ``rule`` of conditions, the same words)."""


def convert_value(text: Any, kind: str) -> Any:
    """*text* (or an already computed value) as a value of ``parameterType`` *kind*; ValueError if it is not one."""
    if kind in ("int", "integer", "unsignedInt", "unsignedShort"):
        if isinstance(text, bool):
            raise ValueError(f"{text!r} is not an integer")
        number = float(text) if isinstance(text, str) else text
        if not isinstance(number, (int, float)) or not math.isfinite(number) or number != int(number):
            raise ValueError(f"{text!r} is not an integer")
        value = int(number)
        if kind != "int" and kind != "integer" and value < 0:
            raise ValueError(f"{text!r} is negative: {kind} is not")
        if kind == "unsignedShort" and value > 65535:
            raise ValueError(f"{text!r} is out of range for unsignedShort")
        return value
    if kind == "double":
        if isinstance(text, bool):
            raise ValueError(f"{text!r} is not a number")
        value = float(text)
        if not math.isfinite(value):
            raise ValueError(f"{text!r} is not a finite number")
        return value
    if kind == "boolean":
        if isinstance(text, bool):
            return text
        if text in ("true", "false"):
            return text == "true"
        raise ValueError(f"{text!r} is not true or false")
    return text if isinstance(text, str) else _text(text)


def _text(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and value.is_integer():
        return str(int(value))
    return str(value)


class Scope:
    """The parameters visible at a place: name -> (type, value); a catalog entry's scope is a child scope."""

    def __init__(self, parent: "Scope | None" = None):
        self.parent = parent
        self.types: dict[str, str] = {}
        self.values: dict[str, Any] = {}
        self.constraints: dict[str, list[Node]] = {}

    def all_values(self) -> dict[str, Any]:
        base = self.parent.all_values() if self.parent is not None else {}
        return {**base, **self.values}

    def value(self, node: Node, text: str) -> Any:
        """The value of attribute text *text* of *node*: a literal, ``$name`` or ``${...}``."""
        if text.startswith("${"):
            if not is_expression(text):
                raise XmlProblem(node, f"{text!r}: an expression is written ${{...}}")
            try:
                return evaluate(text, self.all_values())
            except FormulaError as exc:
                raise XmlProblem(node, f"{text!r}: {exc}") from None
        if text.startswith("$"):
            values = self.all_values()
            name = text[1:]
            if name not in values:
                raise XmlProblem(node, f"unknown parameter {text!r}" + (f" (declared: {', '.join(sorted(values))})" if values else ""))
            return values[name]
        return text

    def declare(self, declarations: Node | None, given: Mapping[str, Any] | None = None, check: bool = True) -> None:
        """Read a ``ParameterDeclarations`` element: each default (or the *given* value), typed, checked."""
        given = dict(given or {})
        if declarations is None:
            return
        for decl in declarations.all("ParameterDeclaration"):
            name = decl.need("name")
            kind = decl.need("parameterType")
            if kind not in TYPES:
                raise XmlProblem(decl, f"parameterType {kind!r} is not one of {', '.join(TYPES)}")
            default = decl.need("value")  # read even when a value is given (a variation, an assignment)
            raw: Any = given.pop(name) if name in given else self.value(decl, default)
            try:
                value = convert_value(raw, kind)
            except ValueError as exc:
                raise XmlProblem(decl, f"parameter {name!r}: {exc}") from None
            self.types[name] = kind
            self.values[name] = value
            groups = decl.all("ConstraintGroup")
            self.constraints[name] = groups
            if check and groups:
                self.check(decl, name, value, groups)

    def check(self, decl: Node, name: str, value: Any, groups: list[Node]) -> None:
        """Raise if *value* satisfies no constraint group."""
        failed, ok = [], False
        for group in groups:  # every constraint is read (a bad rule is a problem in any group)
            broken = [why for c in group.all("ValueConstraint") if (why := self._broken(c, value)) is not None]
            if not broken:
                ok = True
            failed.append(" and ".join(broken))
        if ok:
            return
        raise XmlProblem(decl, f"parameter {name!r} = {_text(value)} breaks its ConstraintGroups: {'; '.join(failed)}")

    def _broken(self, constraint: Node, value: Any) -> str | None:
        rule = constraint.need("rule")
        if rule not in RULES:
            raise XmlProblem(constraint, f"rule {rule!r} is not one of {', '.join(RULES)}")
        bound = self.value(constraint, constraint.need("value"))
        try:
            if isinstance(value, str) or isinstance(bound, str):
                left, right = _text(value), _text(bound)
                if isinstance(value, (int, float)) and not isinstance(value, bool):
                    left, right = value, float(bound)  # type: ignore[assignment]
            else:
                left, right = value, bound
            ok = RULES[rule](left, right)
        except (TypeError, ValueError):
            raise XmlProblem(constraint, f"cannot compare {_text(value)!r} with {_text(bound)!r}") from None
        return None if ok else f"not {rule} {_text(bound)}"

    def text(self, node: Node, name: str, default: str | None = None) -> str | None:
        raw = node.get(name, default)
        return None if raw is None else _text(self.value(node, raw))

    def name(self, node: Node, attr: str = "name", default: str = "") -> str:
        """An element's name (the XSD's ``String``: a ``$parameter`` or any text): ``${...}`` in it is text,
        not an expression - expressions are numbers and booleans (esmini's cut-in names a condition
        ``${BrakeCondition_HWT + _ + $HeadwayTime_Brake}``)."""
        raw = node.get(attr)
        if raw is None or raw.startswith("${"):
            return raw or default
        return _text(self.value(node, raw)) or default

    def number(self, node: Node, name: str, default: float | None = None) -> float:
        raw = node.get(name)
        if raw is None:
            if default is None:
                raise XmlProblem(node, f"{node.tag} needs the attribute {name!r}")
            return default
        value = self.value(node, raw)
        try:
            number = float(value) if not isinstance(value, bool) else math.nan
        except (TypeError, ValueError):
            number = math.nan
        if not math.isfinite(number):
            raise XmlProblem(node, f"{name}={raw!r} is not a finite number")
        return number

    def integer(self, node: Node, name: str, default: int | None = None) -> int:
        number = self.number(node, name, None if default is None else float(default))
        if number != int(number):
            raise XmlProblem(node, f"{name}={node.attrs.get(name)!r} is not an integer")
        return int(number)

    def boolean(self, node: Node, name: str, default: bool | None = None) -> bool:
        raw = node.get(name)
        if raw is None:
            if default is None:
                raise XmlProblem(node, f"{node.tag} needs the attribute {name!r}")
            return default
        value = self.value(node, raw)
        if isinstance(value, bool):
            return value
        if value in ("true", "false"):
            return value == "true"
        raise XmlProblem(node, f"{name}={raw!r} is not true or false")

    def choice(self, node: Node, name: str, options: tuple[str, ...], default: str | None = None) -> str:
        value = self.text(node, name, default)
        if value is None:
            raise XmlProblem(node, f"{node.tag} needs the attribute {name!r}")
        if value not in options:
            raise XmlProblem(node, f"{name}={value!r} is not one of {', '.join(options)}")
        return value
