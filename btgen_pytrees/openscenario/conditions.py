"""Conditions: an OpenSCENARIO ``Trigger`` as the case language's ``when``/``edge``/``delay``.

ASAM OpenSCENARIO 1.2, clause 7.6.2 "Triggers and conditions" (1.0: 8.6.2): a trigger is true
when one of its ``ConditionGroup`` s is true (OR), and a group is true when every one of its
conditions is (AND). Each condition has its own ``delay`` (its value is the value it had that
long ago) and ``conditionEdge`` (``rising``: true on the evaluation where it turns true;
``falling``; ``risingOrFalling``; ``none``: its plain value).

A trigger becomes the control-flow keys of issue 32 (docs/format.md): one condition gives its
expression, edge and delay to the element's entry directly. A trigger whose conditions all have
``edge: none`` and no delay gives one expression, the groups ORed (``||``) and their conditions
ANDed (``&&``). Otherwise each condition that has an edge or a delay becomes a helper entry of its
own (``set`` of a latch signal, with that condition's ``when``/``edge``/``delay``), and the
element waits for the OR of ANDs over the latches and the plain conditions. A latch stays true once
set: a start trigger fires once, so this differs from the standard only for a group that needs two
edges on *different* ticks to coincide - documented in docs/openscenario.md.

This module turns a condition element into an expression of the project's language on the
system's signals (:class:`ConditionWriter`); :mod:`.storyboard` places the entries.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Mapping

from .parameters import Scope
from .xmltree import Node, XmlProblem

__all__ = ["Condition", "ConditionWriter", "EDGES", "OPERATORS"]

EDGES = {"none": "none", "rising": "rising", "falling": "falling", "risingOrFalling": "any"}
"""OpenSCENARIO's ``conditionEdge`` -> the case language's ``edge``."""

OPERATORS = {"greaterThan": ">", "lessThan": "<", "equalTo": "==", "greaterOrEqual": ">=", "lessOrEqual": "<=",
             "notEqualTo": "!="}  # fmt: skip
"""A ``rule`` -> the expression language's comparison."""


def number(x: float) -> str:
    """A number as expression text (no exponent the expression language could misread)."""
    if float(x).is_integer() and abs(x) < 1e15:
        return str(int(x))
    return repr(float(x))


@dataclass
class Condition:
    """One condition: its expression, the case language's edge and its delay (seconds)."""

    name: str
    expect: str
    edge: str
    delay: float
    node: Node


class ConditionWriter:
    """Expressions for conditions, given the storyboard's element states and the entities.

    Args:
        scope: the parameters
        entities: the ScenarioObject names -> the names their signals carry (:func:`.scenario.signal_names`)
        state: ``(element type, name, state, node) -> expression`` for StoryboardElementStateCondition
        variable: ``(name, node) -> signal`` for VariableCondition
        position: ``(Position node) -> (x, y)`` world coordinates, for ReachPosition/Distance
        clock: ``() -> signal`` of the run's time, for SimulationTimeCondition
    """

    def __init__(self, scope: Scope, entities: Mapping[str, str], state: Callable[[str, str, str, Node], str],
                 variable: Callable[[str, Node], str], position: Callable[[Node], tuple[float, float]] | None = None,
                 clock: Callable[[], str] = lambda: "sim.time"):  # fmt: skip
        self.scope, self.entities, self.state, self.variable, self.position = scope, entities, state, variable, position
        self.clock = clock

    def condition(self, node: Node) -> Condition:
        name = self.scope.name(node)
        delay = self.scope.number(node, "delay", 0.0)
        if delay < 0:
            raise XmlProblem(node, f"delay {delay:g} must not be negative")
        edge = self.scope.choice(node, "conditionEdge", tuple(EDGES))
        body = node.only()
        if body.tag == "ByValueCondition":
            expect = self.by_value(body.only())
        elif body.tag == "ByEntityCondition":
            expect = self.by_entity(body)
        else:
            raise XmlProblem(body, f"unknown condition {body.tag}")
        return Condition(name, expect, EDGES[edge], delay, node)

    def rule(self, node: Node) -> str:
        return OPERATORS[self.scope.choice(node, "rule", tuple(OPERATORS))]

    def entity(self, node: Node, attr: str = "entityRef") -> str:
        name = self.scope.text(node, attr) or ""
        if name not in self.entities:
            raise XmlProblem(node, f"{attr}={name!r} names no entity (entities: {', '.join(self.entities)})")
        return self.entities[name]

    def by_value(self, c: Node) -> str:
        tag = c.tag
        if tag == "SimulationTimeCondition":
            return f"{self.clock()} {self.rule(c)} {number(self.scope.number(c, 'value'))}"
        if tag == "StoryboardElementStateCondition":
            kind = self.scope.text(c, "storyboardElementType") or ""
            ref = self.scope.text(c, "storyboardElementRef") or ""
            state = self.scope.text(c, "state") or ""
            return self.state(kind, ref, state, c)
        if tag == "ParameterCondition":
            ref = self.scope.text(c, "parameterRef") or ""
            values = self.scope.all_values()
            if ref not in values:
                raise XmlProblem(c, f"unknown parameter {ref!r}")
            left, right = values[ref], self.scope.value(c, c.need("value"))
            op = self.rule(c)
            return "true" if _compare(left, right, op) else "false"
        if tag == "VariableCondition":
            signal = self.variable(self.scope.text(c, "variableRef") or "", c)
            return f"{signal} {self.rule(c)} {_literal(self.scope.value(c, c.need('value')), c)}"
        raise XmlProblem(c, f"unsupported condition {tag}")

    def by_entity(self, body: Node) -> str:
        triggering = body.need_child("TriggeringEntities")
        rule = self.scope.choice(triggering, "triggeringEntitiesRule", ("any", "all"))
        names = [self.entity(r) for r in triggering.all("EntityRef")]
        if not names:
            raise XmlProblem(triggering, "TriggeringEntities names no entity")
        condition = body.need_child("EntityCondition").only()
        parts = [self.entity_condition(condition, name) for name in names]
        if len(parts) == 1:
            return parts[0]
        return f" {'||' if rule == 'any' else '&&'} ".join(f"({p})" for p in parts)

    def entity_condition(self, c: Node, t: str) -> str:
        tag, s = c.tag, self.scope
        if tag in ("TimeHeadwayCondition", "TimeToCollisionCondition"):
            free = "_free" if s.boolean(c, "freespace") else ""
            s.text(c, "alongRoute")  # 1.0: deprecated; the road's longitudinal measure is used either way
            s.text(c, "coordinateSystem")
            s.text(c, "relativeDistanceType")
            if tag == "TimeHeadwayCondition":
                ref = self.entity(c)
                return f"{t}.{ref}.headway{free} {self.rule(c)} {number(s.number(c, 'value'))}"
            target = c.need_child("TimeToCollisionConditionTarget").only()
            if target.tag != "EntityRef":
                raise XmlProblem(target, "TimeToCollisionCondition to a Position is not supported; name an entity")
            ref = self.entity(target)
            return f"{t}.{ref}.ttc{free} {self.rule(c)} {number(s.number(c, 'value'))}"
        if tag == "RelativeDistanceCondition":
            ref = self.entity(c)
            free = "_free" if s.boolean(c, "freespace") else ""
            kind = s.choice(c, "relativeDistanceType", ("longitudinal", "lateral", "cartesianDistance", "euclidianDistance"))
            system = s.choice(c, "coordinateSystem", ("entity", "road", "lane", "trajectory"), "entity")
            if system == "trajectory":
                raise XmlProblem(c, "coordinateSystem 'trajectory' is not supported")
            if kind in ("cartesianDistance", "euclidianDistance"):
                signal = f"{t}.{ref}.distance{free}"
            elif kind == "longitudinal":
                signal = f"abs({t}.{ref}.{'dx' if system == 'entity' else 'ds'}{free})"
            else:
                signal = f"abs({t}.{ref}.{'dy' if system == 'entity' else 'dt'}{free})"
            return f"{signal} {self.rule(c)} {number(s.number(c, 'value'))}"
        if tag == "RelativeSpeedCondition":
            ref = self.entity(c)
            return f"{t}.speed - {ref}.speed {self.rule(c)} {number(s.number(c, 'value'))}"
        if tag == "SpeedCondition":
            if c.get("direction") not in (None, "longitudinal"):
                raise XmlProblem(c, "SpeedCondition's direction other than longitudinal is not supported")
            return f"{t}.speed {self.rule(c)} {number(s.number(c, 'value'))}"
        if tag == "AccelerationCondition":
            if c.get("direction") not in (None, "longitudinal"):
                raise XmlProblem(c, "AccelerationCondition's direction other than longitudinal is not supported")
            return f"{t}.accel {self.rule(c)} {number(s.number(c, 'value'))}"
        if tag == "StandStillCondition":
            return f"{t}.still >= {number(s.number(c, 'duration'))}"
        if tag == "TraveledDistanceCondition":
            return f"{t}.distance >= {number(s.number(c, 'value'))}"
        if tag == "EndOfRoadCondition":
            duration = s.number(c, "duration")
            if duration != 0:
                raise XmlProblem(c, "EndOfRoadCondition with a duration other than 0 is not supported")
            return f"{t}.end_of_road"
        if tag == "CollisionCondition":
            target = c.only()
            if target.tag == "EntityRef":
                ref = self.entity(target)
                return f"{t}.collided && {ref}.collided"
            if target.tag == "ByType":
                raise XmlProblem(target, "CollisionCondition ByType is not supported; name an entity")
            raise XmlProblem(target, f"unknown collision target {target.tag}")
        if tag in ("ReachPositionCondition", "DistanceCondition") and _relative_object(c) is not None:
            return self.to_entity_point(c, _relative_object(c), t)  # type: ignore[arg-type]
        if tag in ("ReachPositionCondition", "DistanceCondition") and self.position is not None:
            x, y = self.position(c.need_child("Position"))
            dx, dy = f"({t}.ref_x {'-' if x >= 0 else '+'} {number(abs(x))})", f"({t}.ref_y {'-' if y >= 0 else '+'} {number(abs(y))})"
            if tag == "ReachPositionCondition":
                tol = s.number(c, "tolerance")
                return f"{dx} * {dx} + {dy} * {dy} <= {number(tol * tol)}"
            if s.boolean(c, "freespace"):
                raise XmlProblem(c, "DistanceCondition with freespace to a position is not supported")
            s.text(c, "alongRoute")
            s.choice(c, "coordinateSystem", ("entity",), "entity")
            s.choice(c, "relativeDistanceType", ("cartesianDistance", "euclidianDistance"), "euclidianDistance")
            value = s.number(c, "value")
            op = self.rule(c)
            return f"{dx} * {dx} + {dy} * {dy} {op} {number(value * value)}"
        raise XmlProblem(c, f"unsupported condition {tag}")


    def to_entity_point(self, c: Node, position: Node, t: str) -> str:
        """ReachPosition/Distance to a ``RelativeObjectPosition`` (entity R, ``dx``, ``dy`` in R's own axes):
        the distance from the triggering entity's reference point to that point moves with R, so it is read
        from R's own view of the entity, ``R.E.dx``/``R.E.dy`` (a distance does not depend on the axes it is
        measured in). In ``road``/``lane`` coordinates it is ``sqrt(ds² + dt²)`` to R's reference point itself."""
        s = self.scope
        ref = self.entity(position)
        dx, dy = s.number(position, "dx"), s.number(position, "dy")
        s.number(position, "dz", 0.0)  # a height: distances are measured in the road plane
        orientation = position.child("Orientation")
        if orientation is not None:  # the point's heading: no part of a distance to it
            orientation.use_all()
        if c.tag == "ReachPositionCondition":
            system, value, op = "entity", s.number(c, "tolerance"), "<="
        else:
            if s.boolean(c, "freespace"):
                raise XmlProblem(c, "DistanceCondition with freespace to a position is not supported")
            s.text(c, "alongRoute")
            system = s.choice(c, "coordinateSystem", ("entity", "road", "lane"), "entity")
            s.choice(c, "relativeDistanceType", ("cartesianDistance", "euclidianDistance"), "euclidianDistance")
            value, op = s.number(c, "value"), self.rule(c)
        if t == ref:
            raise XmlProblem(position, f"the triggering entity {t!r} measured against a point of its own: not supported")
        if system != "entity":
            if dx != 0 or dy != 0:
                raise XmlProblem(position, f"a RelativeObjectPosition with dx or dy in {system} coordinates is not supported (dx=0, dy=0 is)")
            return f"{t}.{ref}.ds * {t}.{ref}.ds + {t}.{ref}.dt * {t}.{ref}.dt {op} {number(value * value)}"
        ex = f"({ref}.{t}.dx {'-' if dx >= 0 else '+'} {number(abs(dx))})"
        ey = f"({ref}.{t}.dy {'-' if dy >= 0 else '+'} {number(abs(dy))})"
        return f"{ex} * {ex} + {ey} * {ey} {op} {number(value * value)}"


def _relative_object(c: Node) -> Node | None:
    """The ``RelativeObjectPosition`` a ReachPosition/Distance condition measures to, if it is one."""
    position = c.child("Position")
    if position is None or len(position.children) != 1 or position.children[0].tag != "RelativeObjectPosition":
        return None
    return position.children[0].use()


def _compare(left: object, right: object, op: str) -> bool:
    try:
        a, b = float(left), float(right)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        a, b = str(left), str(right)  # type: ignore[assignment]
    return {">": a > b, "<": a < b, "==": a == b, ">=": a >= b, "<=": a <= b, "!=": a != b}[op]  # type: ignore[operator]


def _literal(value: object, node: Node) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    try:
        return number(float(value))  # type: ignore[arg-type]
    except (TypeError, ValueError):
        if value in ("true", "false"):
            return str(value)
        raise XmlProblem(node, f"{value!r}: only number and boolean variables are supported") from None
