"""What one document's checks share: the registry, the system and its signals, the known names, the problems."""

from __future__ import annotations

import json
import itertools
import math
import os
from dataclasses import replace
from types import MappingProxyType
from typing import Any, Iterable, Mapping

import networkx as nx

from ..errors import PathPart, Problem
from ..expressions import RESERVED, Expression, ExpressionError, parse
from ..formulas import Formula, FormulaError
from ..formulas import parse as parse_formula
from ..monitor import WindowError, ticks_of
from ..leaves import Registry
from ..contracts.registry import LeafType
from ..model import DEFAULT_TICK, DEFAULT_TIMEOUT, EMPTY, Criterion, Entry
from ..order import is_acyclic
from ..contracts.system import SystemInfo, SystemSpec
from .limits import MAX_TICKS, MIN_TICK
from .words import described, shown, suggest

__all__ = ["Checker", "freeze", "system_spec", "spec_of"]

class Checker:
    """Collects meaning-level problems of one schema-valid document."""

    def __init__(self, data: Mapping[str, Any], registry: Registry, source: str = "<dict>", system: SystemSpec | None = None):
        self.data = data
        self.registry = registry
        self.problems: list[Problem] = []
        self.declares_signals = "signals" in data
        self.signals: Mapping[str, Any] = data.get("signals", {})
        self.source = source
        own = spec_of(data.get("system"), source)
        if system is not None and not system.options and system.type == own.type:
            system = replace(system, options=own.options)  # options written for this type still apply
        self.spec = system if system is not None else own
        self.owned: frozenset[str] = frozenset()  # signals the system owns (read-only for the test)
        self.writers: Mapping[str, str] = {}
        self.known: frozenset[str] = frozenset(self.signals)  # names expressions may read, when checked
        self.system_checked = False  # the system's own checks passed: its signal list is complete

    def check_system(self) -> None:
        """The system's type, options and configuration; learn the signals it owns."""
        spec = self.spec
        system_type = self.registry.system(spec.type)
        if system_type is None:
            installed = self.registry.systems()
            self.add(("system", "type"), f"unknown system {shown(spec.type)}{suggest(spec.type, installed)}; installed: "
                     f"{', '.join(installed) or 'none'} (a plugin may add it: --plugin MODULE or FILE.py)", "system")  # fmt: skip
            return
        problems = option_problems(spec.options, system_type)
        for index, message in problems:
            self.add(("system", "options", index), message, "system")
        try:
            info = system_type.describe(spec, self.data)
        except Exception as exc:  # noqa: BLE001 - a third-party system's bug is a problem, not a traceback
            self.add(("system",), f"system {spec.type!r} could not check the case: {type(exc).__name__}: {exc}", "system")
            return
        if not isinstance(info, SystemInfo):
            self.add(("system",), f"system {spec.type!r}: describe() returned {type(info).__name__}, not SystemInfo", "system")
            return
        reported = {("system", "options", index) for index, _ in problems}
        for problem in info.problems:
            if tuple(problem.path) not in reported:
                self.problems.append(problem)
        self.owned = frozenset(info.signals)
        self.writers = dict(info.writers)
        self.known = frozenset(self.signals) | self.owned
        self.system_checked = not info.problems

    def add(self, path: tuple[PathPart, ...], message: str, cause: str) -> None:
        self.problems.append(Problem(path, message, cause))

    def expression(self, text: str, path: tuple[PathPart, ...]) -> Expression | None:
        try:
            expr = parse(text)
        except ExpressionError as exc:
            self.add(path, f"bad expression {shown(text)}: {exc}", "expression")
            return None
        for name in sorted(expr.names - self.known):
            if self._checked(name):
                self.add(path, f"unknown signal {name!r} in {shown(text)}{suggest(name, self.known)}", "signal")
        return expr

    def _checked(self, name: str) -> bool:
        """Whether *name* must be a known signal: all names once ``signals`` is declared;
        dotted names always (only a system has them), unless the system's own checks failed."""
        if "." in name:
            return self.system_checked
        return self.declares_signals

    def signal(self, name: str, path: tuple[PathPart, ...], action: str | None = None) -> None:
        if name in RESERVED:
            self.add(path, f"{name!r} is a reserved word of expressions, not a signal name", "signal")
        elif name in self.owned and not (action or "").startswith(self.spec.type + "."):
            writer = self.writers.get(name)
            how = f"use the action {writer!r} instead" if writer else f"use an action of the {self.spec.type!r} system to change it"
            self.add(path, f"signal {name!r} belongs to the {self.spec.type!r} system and is read-only for the test; {how}", "signal")
        elif name not in self.known and self._checked(name):
            self.add(path, f"unknown signal {name!r}{suggest(name, self.known)}", "signal")

    def check_signals(self) -> None:
        for name in self.signals:
            if name in RESERVED:
                self.add(("signals", name), f"{name!r} is a reserved word of expressions", "signal")

    def check_limits(self) -> None:
        tick, timeout = self.data.get("tick", DEFAULT_TICK), self.data.get("timeout", DEFAULT_TIMEOUT)
        if not (math.isfinite(tick) and math.isfinite(timeout)):
            self.add(("timeout",) if not math.isfinite(timeout) else ("tick",), "must be a finite number", "limit")
        elif tick < MIN_TICK:
            self.add(("tick",), f"{tick:g} s is below the smallest tick, {MIN_TICK:g} s (the run clock counts in "
                     "nanoseconds; a smaller tick would not advance it)", "limit")  # fmt: skip
        elif timeout / tick > MAX_TICKS:
            self.add(("timeout",), f"timeout/tick is {timeout / tick:.3g} ticks; the limit is {MAX_TICKS}", "limit")

    def params(self, leaf: LeafType, path: tuple[PathPart, ...], params: Mapping[str, Any]) -> bool:
        """Check *params* against the leaf's own schema; whether they fit."""
        validator = leaf.params_validator
        if validator is None:
            return True
        errors = iter(validator.iter_errors(params))
        first = next(errors, None)
        if first is None:  # the condition: they fit (the compiled check, when there is one)
            return True
        before = len(self.problems)
        self.problems.extend(described(itertools.chain((first,), errors), params, (*path, "params"), "action"))
        return len(self.problems) == before

    def leaves_alongside_shape(self, entries: Iterable[tuple[int, Any]]) -> None:
        """Registration and ``params`` of the *entries* ``(index, raw)`` and of every criterion whose own shape is right.

        Runs with stage 1 when the schema found problems, so that a document needs
        one round of corrections, not one for the shape and one for the params.
        (The entries not given passed these checks in the entry loop.)
        """
        data = self.data
        for i, raw in entries:
            if not isinstance(raw, dict) or raw.get("kind") not in ("behavior", "constraint"):
                continue
            action, params = raw.get("action"), raw.get("params", {})
            if isinstance(action, str) and action and isinstance(params, dict):
                self._registered(("execute", i), raw["kind"], action, params)
        oracle = data.get("oracle")
        criteria = oracle.get("criteria") if isinstance(oracle, dict) else None
        for i, raw in enumerate(criteria if isinstance(criteria, list) else ()):
            if not isinstance(raw, dict) or raw.get("type") not in ("record", "period", "final", "temporal"):
                continue
            action, params = raw.get("action"), raw.get("params", {})
            if (action is None or isinstance(action, str) and action) and isinstance(params, dict):
                self._registered(("oracle", "criteria", i), raw["type"], action, params)

    def _registered(self, path: tuple[PathPart, ...], kind: str, action: str | None, params: Mapping[str, Any]) -> None:
        leaf = self._lookup(path, kind, action)
        if leaf is not None:
            self.params(leaf, path, params)

    def _lookup(self, path: tuple[PathPart, ...], kind: str, action: str | None) -> LeafType | None:
        """The leaf registered for (kind, action), or None with a problem."""
        leaf = self.registry.get(kind, action)
        if leaf is not None:
            return leaf
        if action is None:
            self.add((*path, "type"), f"no leaf is registered for {kind!r} criteria", "action")
            return None
        known = [a for a in self.registry.actions(kind) if self._other_system(a) is None]
        other = {"behavior": "constraint", "constraint": "behavior"}.get(kind)
        hint = f" ({action!r} is a {other} action)" if other and action in self.registry.actions(other) else ""
        hint = hint or suggest(action, known)
        listed = ", ".join(known) if known else "none"
        self.add((*path, "action"), f"unknown {kind} action {shown(action)}{hint}; known: {listed}{self._plugin_hint(action)}", "action")
        return None

    def check_leaf(self, path: tuple[PathPart, ...], kind: str, action: str | None, params: Mapping[str, Any]) -> dict[str, Expression]:
        """Check that a leaf is registered for (kind, action) and that its params fit; parse its expressions."""
        leaf = self.registry.get(kind, action)
        owner = self._other_system(action)
        if leaf is not None and owner is not None:
            self.add((*path, "action"), f"{shown(action)} is an action of the {owner!r} system; this case's system is "
                     f"{self.spec.type!r} (set \"system\": {{\"type\": \"{owner}\", ...}})", "action")  # fmt: skip
            return {}
        leaf = self._lookup(path, kind, action)
        if leaf is None:
            return {}
        if not self.params(leaf, path, params):
            return {}
        if leaf.check is not None:
            for where, message in leaf.check(params):
                self.add((*path, "params", *where), message, "action")
        for name in leaf.signals:
            if isinstance(params.get(name), str):
                self.signal(params[name], (*path, "params", name), action)
        compiled = {}
        for name in leaf.expressions:
            if isinstance(params.get(name), str):
                expr = self.expression(params[name], (*path, "params", name))
                if expr is not None:
                    compiled[name] = expr
        return compiled

    def _other_system(self, action: str | None) -> str | None:
        """The registered system whose action *action* is (``sumo`` for ``sumo.speed``), if not the case's."""
        prefix = action.partition(".")[0] if action and "." in action else None
        if prefix is None or prefix == self.spec.type or self.registry.system(prefix) is None:
            return None
        return prefix

    def _plugin_hint(self, action: str) -> str:
        """Where an unknown action may come from: a system that is not installed, or a plugin."""
        prefix = action.partition(".")[0] if "." in action else None
        if prefix is not None and self.registry.system(prefix) is None:
            installed = ", ".join(self.registry.systems()) or "none"
            return f" (system {prefix!r} is not installed; installed: {installed}; a plugin may add it: --plugin MODULE or FILE.py)"
        return " (a plugin may add it: --plugin MODULE or FILE.py)"

    def criteria(self) -> list[Criterion]:
        out = []
        for i, raw in enumerate(self.data.get("oracle", {}).get("criteria", [])):
            path = ("oracle", "criteria", i)
            params = raw.get("params", {})
            expressions = self.check_leaf(path, raw["type"], raw.get("action"), params)
            if raw["type"] == "temporal":
                formula, anchor = self.formula(raw, path)
                if formula is not None:
                    start = raw.get("from") if anchor is None else None
                    out.append(Criterion(
                        raw["id"], "temporal", formula, raw.get("name", raw["id"]), i, start,
                        action=raw.get("action"), params=freeze(params), expressions=freeze(expressions), anchor=anchor,
                        tick=self.data.get("tick", DEFAULT_TICK),
                    ))  # fmt: skip
                continue
            expr = self.expression(raw["expect"], (*path, "expect"))
            start, end = raw.get("from"), raw.get("to")
            if start is not None and end is not None and start >= end:
                self.add((*path, "from"), f"'from' ({start}) must be less than 'to' ({end})", "limit")
            if expr is not None:
                out.append(Criterion(
                    raw["id"], raw["type"], expr, raw.get("name", raw["id"]), i, start, end, raw.get("at"),
                    action=raw.get("action"), params=freeze(params), expressions=freeze(expressions),
                ))  # fmt: skip
        return out

    def formula(self, raw: Mapping[str, Any], path: tuple[PathPart, ...]) -> tuple[Formula | None, tuple[str, str] | None]:
        """A temporal criterion's formula (its atoms' signals known, its windows whole ticks) and anchor."""
        text = raw["expect"]
        anchor = None
        where = raw.get("from")
        if isinstance(where, str):
            entry, _, edge = where.rpartition(".")
            ids = [e.get("id") for e in self.data.get("execute", []) if isinstance(e, dict) and isinstance(e.get("id"), str)]
            if entry not in ids:
                self.add((*path, "from"), f"unknown entry {entry!r} in {shown(where)}{suggest(entry, ids)}", "graph")
            anchor = (entry, edge)
        try:
            formula = parse_formula(text)
        except FormulaError as exc:
            self.add((*path, "expect"), f"bad formula {shown(text)}: {exc}", "expression")
            return None, anchor
        for name in sorted(formula.names - self.known):
            if self._checked(name):
                self.add((*path, "expect"), f"unknown signal {name!r} in {shown(text)}{suggest(name, self.known)}", "signal")
        tick = self.data.get("tick", DEFAULT_TICK)
        for node in formula.walk():
            for bound in node.window or ():
                if bound is not None and isinstance(tick, (int, float)) and tick > 0:
                    try:
                        ticks_of(bound, tick)
                    except WindowError as exc:
                        self.add((*path, "expect"), f"window of {node.op!r} in {shown(node.source)}: {exc} (windows count whole ticks)", "expression")
                        return None, anchor
        return formula, anchor

    def cycles(self, entries: list[Entry]) -> None:
        if is_acyclic({e.id: e.after for e in entries}):  # the common case, without building a graph
            return
        graph = nx.DiGraph()
        graph.add_nodes_from(e.id for e in entries)
        graph.add_edges_from((p, e.id) for e in entries for p in e.after)
        index = {e.id: e for e in entries}
        found = []
        for component in nx.strongly_connected_components(graph):
            if len(component) < 2:
                continue
            start = min(component, key=lambda v: index[v].index)
            cycle = _cycle_through(graph.subgraph(component), start)
            found.append((index[start].index, cycle))
        for _, cycle in sorted(found):
            # report at the 'after' item of the cycle's first node that names its predecessor
            first, pred = cycle[0], cycle[-2]
            k = index[first].after.index(pred)
            self.add(("execute", index[first].index, "after", k), f"cycle: {' -> '.join(cycle)}", "graph")


def _cycle_through(graph: nx.DiGraph, start: str) -> list[str]:
    """A cycle through *start* in a strongly connected *graph*, written pred -> succ."""
    path = nx.shortest_path(graph, start, next(iter(graph.pred[start])))
    return [*path, start]


def freeze(mapping: Mapping[str, Any] | None) -> Mapping[str, Any]:
    """A read-only copy; every empty one is the same shared object (most entries have no expressions)."""
    return MappingProxyType(dict(mapping)) if mapping else EMPTY


def system_spec(data: Any, source: str) -> SystemSpec | None:
    """The system a case document names, its ``config`` resolved relative to the file *source*
    (absolute), or None when it names none or not in a usable shape (validation says why)."""
    raw = data.get("system") if isinstance(data, dict) else None
    if not isinstance(raw, dict) or not isinstance(raw.get("type"), str):
        return None
    if raw.get("config") is not None and not isinstance(raw["config"], str):
        return None
    options = raw.get("options", ())
    options = tuple(options) if isinstance(options, list) and all(isinstance(o, str) for o in options) else ()
    return spec_of({**raw, "options": options}, source)


def spec_of(raw: Mapping[str, Any] | None, source: str) -> SystemSpec:
    """The case's ``system`` key as a :class:`SystemSpec`, ``config`` resolved relative to the case file."""
    if raw is None:
        return SystemSpec()
    base = os.path.dirname(os.path.abspath(source)) if source != "<dict>" else os.getcwd()
    config, road = raw.get("config"), raw.get("road")
    if config is not None:
        config = os.path.normpath(os.path.join(base, config))
    if isinstance(road, str):
        road = os.path.normpath(os.path.join(base, road))
    entities = raw.get("entities")
    text = json.dumps(entities, separators=(",", ":"), allow_nan=False) if isinstance(entities, dict) else None
    return SystemSpec(raw["type"], config, tuple(raw.get("options", ())), road if isinstance(road, str) else None, text)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def option_problems(options: tuple[str, ...], system_type: Any) -> list[tuple[int, str]]:
    """Options not on *system_type*'s allow-list, as ``(index, message)``.

    An item starting with ``-`` is an option: its name (before any ``=``) must be
    on the list. Any other item is the value of the option just before it (at
    most one value per option; a negative number counts as a value), so a stray
    item - a file name, say - can never slip through as a positional argument.
    """
    allowed = sorted(getattr(system_type, "options", ()) or ())
    problems: list[tuple[int, str]] = []
    value_may_follow = False
    for index, item in enumerate(options):
        if value_may_follow and (not item.startswith("-") or _is_number(item)):
            value_may_follow = False
            continue
        if not item.startswith("-"):
            problems.append((index, f"{shown(item)} is not an option (options start with '-', each followed by at most one value)"))
            continue
        name, eq, _ = item.partition("=")
        value_may_follow = not eq
        if name not in allowed:
            if not allowed:
                problems.append((index, f"the {system_type.name!r} system takes no options"))
            else:
                tip = suggest(name, allowed) or f" (allowed: {', '.join(allowed)})"
                problems.append((index, f"option {shown(name)} is not allowed for the {system_type.name!r} system{tip}"))
    return problems

