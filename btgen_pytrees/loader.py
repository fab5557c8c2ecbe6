"""Load and validate a test case: JSON text → :class:`~btgen_pytrees.model.TestCase`.

Validation runs in stages and reports *every* problem of a stage, each with the
JSON pointer of the offending value; a stage runs only if the one before found
nothing, because its checks assume what the earlier ones guarantee:

0. **values** - what no later stage could handle: lone surrogates, integers
   beyond float range, nesting deeper than :data:`MAX_NESTING` (fuzz findings).
1. **shape** - the JSON Schema ``schemas/testcase.schema.json`` (unknown keys,
   wrong types, missing keys, bad identifiers, ...).
2. **meaning** - what a schema cannot say: duplicate ids, ``after`` naming an
   unknown id or the entry itself, cycles, ``from`` ≥ ``to``, expressions,
   signal names, unknown actions and each action's own ``params`` schema, the
   ``system`` (a registered type, options from its allow-list, its own checks
   through ``SystemType.describe``; its signals are read-only).

Problems are raised together as :class:`~btgen_pytrees.errors.InvalidTestCase`.

A valid document is usually decided in one pass instead, by :mod:`btgen_pytrees.onepass`,
which builds the same :class:`TestCase`; whatever it does not accept runs through the
stages above, so every error message comes from them.

>>> case = load({"name": "t", "execute": [{"id": "A", "kind": "behavior", "action": "hold",
...                                        "params": {"duration": 1}}]})
>>> case.entries[0].id, case.tick, case.timeout
('A', 0.1, 60.0)
"""

from __future__ import annotations

import json
import math
import os
import stat
import re
from functools import lru_cache
from importlib import resources
from types import MappingProxyType
from typing import Any, Iterable, Iterator, Mapping

import networkx as nx

from .errors import InvalidTestCase, PathPart, Problem, by_place
from .expressions import RESERVED, Expression, ExpressionError, parse
from .leaves import Registry, default_registry
from .contracts.registry import LeafType
from .overlap import overlapping_writes
from .validation import SchemaValidator
from .model import DEFAULT_JOIN, DEFAULT_TICK, DEFAULT_TIMEOUT, EMPTY, Criterion, Entry, TestCase
from .order import is_acyclic
from .contracts.system import SystemInfo, SystemSpec
from .text import MAX_MESSAGE, did_you_mean, shorten

__all__ = ["load", "load_json", "validate", "schema", "schema_for", "schema_text", "MAX_FILE_BYTES", "MAX_TICKS", "MAX_MAGNITUDE", "MIN_TICK", "MAX_WORK",
           "work", "check_work", "system_spec"]

MAX_FILE_BYTES = 16 * 1024 * 1024
"""Largest test-case file accepted (16 MiB); larger files are refused before reading."""

MAX_TICKS = 10_000_000
"""Most ticks a run may take (``timeout / tick``); keeps every run bounded."""

MIN_TICK = 1e-6
"""Smallest ``tick`` (one microsecond). The run clock counts in nanoseconds (``round(k * tick, 9)``):
far below this a tick would not move it, and a run would burn its ticks at t = 0."""

MAX_WORK = 100_000_000
"""Default work budget of a run (``run --max-work`` changes it). Each tick is charged the tree's size,
``entries + criteria + 10`` (the ten: the nodes every tree ticks); a run is stopped with verdict
``error`` when its next tick would exceed the budget (so a run ending early is charged only what it
did). One unit is well under a microsecond for big trees and about 2 µs for tiny ones, so a run
within the budget takes a few minutes at most."""

MAX_NESTING = 100
"""Deepest nesting of arrays/objects accepted (fuzz finding: deeper values crashed error reporting)."""

def schema_text() -> str:
    """The test-case JSON Schema, as shipped in the package."""
    return resources.files(__package__).joinpath("schemas/testcase.schema.json").read_text(encoding="utf-8")


@lru_cache(maxsize=1)
def schema() -> Mapping[str, Any]:
    return json.loads(schema_text())


def schema_for(registry: Registry | None = None) -> dict[str, Any]:
    """The test-case schema with each registered action's ``params`` schema, for editors.

    ``python -m btgen_pytrees schema`` prints this. Entries and criteria get one
    ``if``/``then`` per registered leaf: *if* ``kind`` and ``action`` (a criterion:
    ``type`` and ``action``, or no ``action``) match, *then* ``params`` must fit
    that leaf's schema - so an editor that knows JSON Schema flags a misspelt or
    mistyped parameter as it is typed. The loader checks the same params itself
    (with friendlier messages), so it does not validate against this larger
    schema.

    >>> s = schema_for()
    >>> rule = next(r for r in s["$defs"]["entry"]["allOf"] if r["if"]["properties"]["action"] == {"const": "hold"})
    >>> rule["then"]["properties"]["params"]["required"]
    ['duration']
    """
    registry = registry if registry is not None else default_registry()
    full = json.loads(schema_text())
    entry_rules, criterion_rules = [], []
    for kind in ("behavior", "constraint", "record", "period", "final"):
        actions: list[str | None] = list(registry.actions(kind))
        if kind in ("record", "period", "final"):
            actions.insert(0, None)
        for action in actions:
            leaf = registry.get(kind, action)
            if leaf is None or leaf.params_schema is None:
                continue
            params = {k: v for k, v in leaf.params_schema.items() if k != "$schema"}
            if leaf.description and "description" not in params:
                params["description"] = leaf.description
            then = {"properties": {"params": params}}
            if kind in ("behavior", "constraint"):
                rule_if: dict[str, Any] = {"properties": {"kind": {"const": kind}, "action": {"const": action}}, "required": ["kind", "action"]}
            elif action is None:
                rule_if = {"properties": {"type": {"const": kind}}, "required": ["type"], "not": {"required": ["action"]}}
            else:
                rule_if = {"properties": {"type": {"const": kind}, "action": {"const": action}}, "required": ["type", "action"]}
            (entry_rules if kind in ("behavior", "constraint") else criterion_rules).append({"if": rule_if, "then": then})
    full["$defs"]["entry"].setdefault("allOf", []).extend(entry_rules)
    full["$defs"]["criterion"].setdefault("allOf", []).extend(criterion_rules)
    # a sweep's "$name" stands for a number or a boolean where the loader substitutes it (docs/sweeps.md):
    # tick, timeout, signals' values, params, a criterion's from/to/at - so editors accept the project's sweeps
    full["$defs"]["parameter"] = {"type": "string", "pattern": "^[$][A-Za-z_][A-Za-z0-9_]*$",
                                  "description": "A sweep parameter, $name: replaced by its value before the case is checked."}  # fmt: skip
    for key in ("tick", "timeout", "signals"):
        full["properties"][key] = _or_parameter(full["properties"][key])
    full["$defs"]["seconds"] = _or_parameter(full["$defs"]["seconds"])
    for rule in entry_rules + criterion_rules:
        rule["then"]["properties"]["params"] = _or_parameter(rule["then"]["properties"]["params"])
    return full


_NOT_SCHEMAS = frozenset({"enum", "const", "default", "examples", "required", "description", "pattern", "$comment"})


def _or_parameter(schema: Any) -> Any:
    """*schema* where every number, integer or boolean may also be a sweep parameter ``"$name"``."""
    if isinstance(schema, list):
        return [_or_parameter(item) for item in schema]
    if not isinstance(schema, dict):
        return schema
    made = {key: value if key in _NOT_SCHEMAS else _or_parameter(value) for key, value in schema.items()}
    types = schema.get("type")
    types = [types] if isinstance(types, str) else types if isinstance(types, list) else []
    if any(t in ("number", "integer", "boolean") for t in types):
        return {"anyOf": [made, {"$ref": "#/$defs/parameter"}]}
    return made


def inline_refs(node: Any, root: Mapping[str, Any], depth: int = 0) -> Any:
    """*node* with every local ``$ref`` replaced by a copy of its target (``$defs`` dropped).

    jsonschema resolves a ``$ref`` through its referencing registry each time it
    meets one, i.e. several times per execute entry; a schema with the targets
    inlined validates the same documents with the same errors, 1.7 times faster.
    A sibling of ``$ref`` (only ``description`` in our schema) overrides the target's.

    >>> inline_refs({"$defs": {"n": {"type": "number"}}, "items": {"$ref": "#/$defs/n"}}, {"$defs": {"n": {"type": "number"}}})
    {'items': {'type': 'number'}}
    """
    if depth > 32:
        raise ValueError("recursive $ref in the schema")
    if isinstance(node, dict):
        if "$ref" in node:
            target: Any = root
            for part in node["$ref"].removeprefix("#/").split("/"):
                target = target[part]
            merged = {**target, **{k: v for k, v in node.items() if k != "$ref"}}
            return inline_refs(merged, root, depth + 1)
        return {k: inline_refs(v, root, depth + 1) for k, v in node.items() if k != "$defs"}
    if isinstance(node, list):
        return [inline_refs(v, root, depth + 1) for v in node]
    return node


@lru_cache(maxsize=1)
def case_validator() -> SchemaValidator:
    return SchemaValidator(inline_refs(schema(), schema()), checked=True)  # tests/test_validation_fastpath.py checks it


# ---------------------------------------------------------------------------
# reading JSON


class _DuplicateKey(ValueError):
    pass


def no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    obj = dict(pairs)  # in C; a key seen twice makes the dict shorter than the pairs
    if len(obj) != len(pairs):
        seen: set[str] = set()
        for key, _ in pairs:
            if key in seen:
                raise _DuplicateKey(key)
            seen.add(key)
    return obj


def reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not valid JSON")


def load_json(path: str | os.PathLike[str]) -> Any:
    """Read a JSON file with the limits of a test case; problems raise :class:`InvalidTestCase`."""
    return parse_json(*_read(path))


def _read(path: str | os.PathLike[str]) -> tuple[bytes, str]:
    """The bytes of a test-case file (``-``: standard input) within the size limit, and its name for errors."""
    source = os.fspath(path)
    if source == "-":  # standard input, read up to the limit
        import sys

        raw = sys.stdin.buffer.read(MAX_FILE_BYTES + 1)
        source = "<stdin>"
    else:
        try:
            info = os.stat(source)
            if not stat.S_ISREG(info.st_mode):
                # a FIFO or socket would wait for a writer, a terminal (/dev/ptmx, /dev/tty) for a
                # person, a device (/dev/zero, /dev/urandom) never ends: only regular files are read
                kind = "a directory" if stat.S_ISDIR(info.st_mode) else "a pipe or socket" if (
                    stat.S_ISFIFO(info.st_mode) or stat.S_ISSOCK(info.st_mode)) else "a device"  # fmt: skip
                raise InvalidTestCase([Problem((), f"not a regular file ({kind})", "json")], source)
            size = info.st_size
            if size > MAX_FILE_BYTES:
                raise InvalidTestCase([Problem((), f"file is {size} bytes; the limit is {MAX_FILE_BYTES}", "limit")], source)
            with open(source, "rb") as fh:
                raw = fh.read(size + 1)
                if len(raw) > size:  # it grew since stat(): read on, up to the limit
                    raw += fh.read(MAX_FILE_BYTES + 1 - len(raw))
        except OSError as exc:
            why = exc.strerror or str(exc)
            if os.path.islink(source) and not os.path.exists(source):
                why = f"dangling symbolic link to {os.readlink(source)}"
            raise InvalidTestCase([Problem((), f"cannot read file: {why}", "json")], source) from None
    if len(raw) > MAX_FILE_BYTES:  # the file grew while we looked
        raise InvalidTestCase([Problem((), f"file is larger than {MAX_FILE_BYTES} bytes", "limit")], source)
    return raw, source


def parse_json(raw: bytes | str, source: str = "<string>") -> Any:
    """Parse JSON text strictly: no NaN/Infinity, no duplicate keys, bounded nesting."""
    def fail(message: str) -> InvalidTestCase:
        return InvalidTestCase([Problem((), message, "json")], source)

    try:
        text = raw.decode("utf-8-sig") if isinstance(raw, bytes) else raw
    except UnicodeDecodeError as exc:
        raise fail(f"not UTF-8 text (byte {exc.start})") from None
    try:
        return json.loads(text, object_pairs_hook=no_duplicates, parse_constant=reject_constant)
    except json.JSONDecodeError as exc:
        raise fail(f"invalid JSON at line {exc.lineno} column {exc.colno}: {exc.msg}") from None
    except _DuplicateKey as exc:
        raise fail(f"invalid JSON: key {exc.args[0]!r} appears twice in one object") from None
    except RecursionError:
        raise fail("invalid JSON: nested too deeply") from None
    except ValueError as exc:  # NaN/Infinity, integers with too many digits
        raise fail(f"invalid JSON: {shorten(str(exc))}") from None


# ---------------------------------------------------------------------------
# stage 0: values every later stage can handle
#
# Fuzz findings (tests/test_fuzz.py), each an exit 3 before this stage existed:
# * an integer beyond float range (e.g. "timeout": 1e4000 written out as digits)
#   raised OverflowError in the timeout/tick check, or later while running;
# * a lone surrogate ("\ud800" escape) in a string reached the output streams and
#   raised UnicodeEncodeError;
# * a value nested ~1000 deep parsed, then raised RecursionError while an error
#   message showed it.

SURROGATE = re.compile("[\ud800-\udfff]")


def _scalar_problem(path: tuple[PathPart, ...], value: Any) -> Problem | None:
    if isinstance(value, str):
        bad = SURROGATE.search(value)
        if bad:
            return Problem(path, f"not valid Unicode: lone surrogate {ascii(bad.group())} at character {bad.start()}", "json")
    elif isinstance(value, int) and not isinstance(value, bool):
        if not -MAX_MAGNITUDE <= value <= MAX_MAGNITUDE:
            try:
                shown = f"{float(value):.3g}"
            except OverflowError:
                shown = f"{value.bit_length()} bits"
            return Problem(path, f"number too large ({shown}; the limit is ±{MAX_MAGNITUDE:g})", "limit")
    elif isinstance(value, float):
        if not math.isfinite(value):  # 1e999 parses as inf
            return Problem(path, f"number too large (beyond float range, read as {value}; the limit is ±{MAX_MAGNITUDE:g})", "limit")
        if not -MAX_MAGNITUDE <= value <= MAX_MAGNITUDE:
            return Problem(path, f"number too large ({value:.3g}; the limit is ±{MAX_MAGNITUDE:g})", "limit")
    return None


MAX_MAGNITUDE = 1e300
"""Largest magnitude of any number in a test case. Far beyond any physical quantity, and far
enough below float's ±1.8e308 that what a run computes from such numbers stays finite: a ramp
between -1e300 and 1e300 (their difference), an integer signal times a fraction, a report's
values. ``1e999`` parses as infinity and is refused too."""

_PLAIN = (bool, type(None))
_BIG = int(MAX_MAGNITUDE)


def suspicious(data: Any, depth: int = 0) -> bool:
    """A quick pass without paths: could :func:`value_problems` find anything?

    Valid documents are the common case; for them this one cheap walk (one regex
    over all strings joined, a bound on integers, a depth count) replaces the
    detailed walk that builds a JSON path for every container. *depth*: where
    *data* sits in its document (the root is 0), for a part checked on its own.
    """
    if not isinstance(data, (dict, list)):
        return True
    strings: list[str] = []
    stack: list[tuple[Any, int]] = [(data, depth)]
    while stack:
        container, depth = stack.pop()
        if depth >= MAX_NESTING:
            return True
        if type(container) is dict:
            strings.extend(container)
            values: Any = container.values()
        else:
            values = container
        for item in values:
            kind = type(item)
            if kind is str:
                strings.append(item)
            elif kind is int:
                if not -_BIG <= item <= _BIG:
                    return True
            elif kind is float:
                if not -MAX_MAGNITUDE <= item <= MAX_MAGNITUDE:  # NaN fails every comparison
                    return True
            elif kind is dict or kind is list:
                stack.append((item, depth + 1))
            elif kind not in _PLAIN:
                return True  # a subclass or an odd type from a dict: look closely
    try:
        return SURROGATE.search("".join(strings)) is not None
    except TypeError:  # a non-string key in a dict given from Python: look closely
        return True


def value_problems(data: Any) -> Iterator[Problem]:
    if not suspicious(data):
        return
    if not isinstance(data, (dict, list)):
        problem = _scalar_problem((), data)
        if problem is not None:
            yield problem
        return
    stack: list[tuple[tuple[PathPart, ...], Any]] = [((), data)]
    while stack:  # iterative: no recursion limit to hit; paths are built for containers only
        path, container = stack.pop()
        if len(path) >= MAX_NESTING:
            yield Problem(path, f"nested more than {MAX_NESTING} levels deep", "limit")
            continue
        for key, item in container.items() if isinstance(container, dict) else enumerate(container):
            if isinstance(key, str) and SURROGATE.search(key):
                yield Problem(path, f"not valid Unicode: key {ascii(key)[:MAX_MESSAGE]} has a lone surrogate", "json")
                continue
            if isinstance(item, (dict, list)):
                stack.append(((*path, key), item))
            elif isinstance(item, (str, int, float)):
                problem = _scalar_problem((*path, key), item)
                if problem is not None:
                    yield problem


# ---------------------------------------------------------------------------
# stage 1: shape


def _shown(value: Any) -> str:
    return shorten(json.dumps(value, ensure_ascii=False) if not isinstance(value, str) else repr(value))


def _resolve(data: Any, path: tuple[PathPart, ...]) -> Any:
    for part in path:
        data = data[part]
    return data


def _schema_problems(data: Any) -> Iterator[Problem]:
    return _described(case_validator().iter_errors(data), data)


def _described(errors: Iterable[Any], data: Any, prefix: tuple[PathPart, ...] = (), cause: str = "schema") -> Iterator[Problem]:
    """jsonschema's *errors* about *data* (found at *prefix* in the document) in words a test author reads.

    The same wording serves the test-case schema and every action's ``params`` schema:
    unknown keys with "did you mean", missing keys, values outside an enumeration with
    "did you mean", negative durations, and a schema's ``description`` where it says
    what was expected.
    """
    for error in errors:
        path = (*prefix, *error.absolute_path)
        keyword = error.validator
        if keyword == "additionalProperties" and isinstance(error.instance, dict):
            allowed = sorted(error.schema.get("properties", {}))
            for key in error.instance:
                if key not in allowed:
                    tip = did_you_mean(key, allowed) or f" (allowed: {', '.join(allowed) or 'none'})"
                    yield Problem((*path, key), f"unknown key {_shown(key)}{tip}", cause)
            continue
        if error.schema is False:  # from/to/at on a criterion of another type (if/else branches)
            criterion = _resolve(data, tuple(error.absolute_path))
            allowed = {"from": "period", "to": "period", "at": "final"}
            for key, where in allowed.items():
                if isinstance(criterion, dict) and key in criterion and criterion.get("type") != where:
                    yield Problem((*path, key), f"{key!r} is only allowed on {where} criteria", cause)
            continue
        if keyword == "required":
            missing = error.message.split("'")[1] if "'" in error.message else error.message
            yield Problem(path, f"missing required key {missing!r}", cause)
            continue
        if keyword == "enum" and isinstance(error.instance, str):
            options = [v for v in error.validator_value if isinstance(v, str)]
            shown = ", ".join(repr(v) for v in options)
            yield Problem(path, f"{_shown(error.instance)} is not one of {shown}{_suggest(error.instance, options)}", cause)
            continue
        if keyword == "minimum" and error.validator_value == 0 and isinstance(error.instance, (int, float)):
            yield Problem(path, f"must not be negative (got {error.instance})", cause)
            continue
        description = error.schema.get("description") if isinstance(error.schema, dict) else None
        if keyword in ("pattern", "anyOf") and description:
            yield Problem(path, f"{_shown(error.instance)} is not valid: expected {description}", cause)
            continue
        if keyword == "type" and description:
            yield Problem(path, f"{shorten(error.message)}: expected {description}", cause)
            continue
        yield Problem(path, shorten(error.message), cause)


# ---------------------------------------------------------------------------
# stage 2: meaning


MAX_SUGGESTIONS = 20
"""Unknown names (ids, signals, actions, keys) that get a "did you mean" per document; later ones get
none. Each suggestion compares the name with every known one: 20,000 unknown ids against 20,000
known ones took ten minutes before this bound."""

_suggestions = __import__("threading").local()


def _suggest(word: str, candidates: Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` for the closest of *candidates*, within the document's budget.

    Only candidates of about the same length are compared (:func:`~btgen_pytrees.text.closest`).
    """
    left = getattr(_suggestions, "left", MAX_SUGGESTIONS)
    if left <= 0:
        return ""
    _suggestions.left = left - 1
    return did_you_mean(word, candidates, similar_length=True)


class Checker:
    """Collects meaning-level problems of one schema-valid document."""

    def __init__(self, data: Mapping[str, Any], registry: Registry, source: str = "<dict>", system: SystemSpec | None = None):
        self.data = data
        self.registry = registry
        self.problems: list[Problem] = []
        self.declares_signals = "signals" in data
        self.signals: Mapping[str, Any] = data.get("signals", {})
        self.source = source
        own = _spec(data.get("system"), source)
        if system is not None and not system.options and system.type == own.type:
            system = SystemSpec(system.type, system.config, own.options)  # options written for this type still apply
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
            self.add(("system", "type"), f"unknown system {_shown(spec.type)}{_suggest(spec.type, installed)}; installed: "
                     f"{', '.join(installed) or 'none'} (a plugin may add it: --plugin MODULE or FILE.py)", "system")  # fmt: skip
            return
        problems = _option_problems(spec.options, system_type)
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
            self.add(path, f"bad expression {_shown(text)}: {exc}", "expression")
            return None
        for name in sorted(expr.names - self.known):
            if self._checked(name):
                self.add(path, f"unknown signal {name!r} in {_shown(text)}{_suggest(name, self.known)}", "signal")
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
            self.add(path, f"unknown signal {name!r}{_suggest(name, self.known)}", "signal")

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

    def entries(self) -> list[Entry]:
        raw_entries = self.data["execute"]
        raw_criteria = self.data.get("oracle", {}).get("criteria", [])
        first: dict[str, tuple[PathPart, ...]] = {}
        for where, items in (("execute", raw_entries), ("criteria", raw_criteria)):
            for i, item in enumerate(items):
                path = ("execute", i, "id") if where == "execute" else ("oracle", "criteria", i, "id")
                if item["id"] in first:
                    self.add(path, f"duplicate id {item['id']!r} (first used at {_pointer(first[item['id']])})", "id")
                else:
                    first[item["id"]] = path
        execute_ids = {e["id"] for e in raw_entries}
        criteria_ids = {c["id"] for c in raw_criteria}
        default_join = self.data.get("join", DEFAULT_JOIN)
        entries = []
        # (kind, action, params) -> the frozen params, for leaves whose check of those params was
        # path-independent and clean: entries sharing params (most: {"duration": 0.1}) are checked
        # once and share one read-only mapping
        checked: dict[Any, Mapping[str, Any]] = {}
        for i, raw in enumerate(raw_entries):
            after = self._after(i, raw, execute_ids, criteria_ids)
            entries.append(self.entry(i, raw, after, default_join, checked))
        return entries

    def entry(self, i: int, raw: Mapping[str, Any], after: tuple[str, ...], join: str,
              checked: dict[Any, Mapping[str, Any]]) -> Entry:  # fmt: skip
        """Execute entry *i* (*after* already checked): its leaf's params checked, or shared from *checked*."""
        kind, action, params = raw["kind"], raw["action"], raw.get("params")
        key = _params_key(kind, action, params)
        frozen = checked.get(key) if key is not None else None
        if frozen is not None:
            expressions = EMPTY
        else:
            before = len(self.problems)
            compiled = self._leaf(("execute", i), kind, action, params if params is not None else {})
            frozen = freeze(params)
            expressions = freeze(compiled)
            if key is not None and not compiled and len(self.problems) == before and self._plain(kind, action, params):
                checked[key] = frozen
        return Entry(
            id=raw["id"], kind=kind, action=action, params=frozen, after=after,
            join=raw.get("join", join), name=raw.get("name", raw["id"]), index=i,
            expressions=expressions,
        )  # fmt: skip

    def _plain(self, kind: str, action: str | None, params: Mapping[str, Any] | None) -> bool:
        """Whether *params* of this leaf hold no signal name or expression (so its check is path-independent)."""
        leaf = self.registry.get(kind, action)
        return leaf is not None and not any(name in (params or {}) for name in (*leaf.signals, *leaf.expressions))

    def _after(self, i: int, raw: Mapping[str, Any], execute_ids: set[str], criteria_ids: set[str]) -> tuple[str, ...]:
        listed = raw.get("after")
        if not listed:
            return ()
        preds = tuple(listed)
        if raw["id"] not in preds and len(set(preds)) == len(preds) and execute_ids.issuperset(preds):
            return preds  # the common case: every item names another execute entry, once
        seen: dict[str, None] = {}  # ordered, O(1) membership
        for k, pred in enumerate(preds):
            path = ("execute", i, "after", k)
            if pred == raw["id"]:
                self.add(path, f"{pred!r} cannot come after itself", "graph")
            elif pred in seen:
                self.add(path, f"{pred!r} is listed twice", "graph")
            elif pred not in execute_ids and pred in criteria_ids:
                self.add(path, f"{pred!r} is an oracle criterion, not an execute entry", "graph")
            elif pred not in execute_ids:
                self.add(path, f"unknown id {pred!r}{_suggest(pred, execute_ids)}", "graph")
            else:
                seen[pred] = None
        return tuple(seen)

    def params(self, leaf: LeafType, path: tuple[PathPart, ...], params: Mapping[str, Any]) -> bool:
        """Check *params* against the leaf's own schema; whether they fit."""
        validator = leaf.params_validator
        if validator is None:
            return True
        before = len(self.problems)
        self.problems.extend(_described(validator.iter_errors(params), params, (*path, "params"), "action"))
        return len(self.problems) == before

    def leaves_alongside_shape(self) -> None:
        """Registration and ``params`` of every entry and criterion whose own shape is right.

        Runs with stage 1 when the schema found problems, so that a document needs
        one round of corrections, not one for the shape and one for the params.
        """
        data = self.data
        entries = data.get("execute")
        for i, raw in enumerate(entries if isinstance(entries, list) else ()):
            if not isinstance(raw, dict) or raw.get("kind") not in ("behavior", "constraint"):
                continue
            action, params = raw.get("action"), raw.get("params", {})
            if isinstance(action, str) and action and isinstance(params, dict):
                self._registered(("execute", i), raw["kind"], action, params)
        oracle = data.get("oracle")
        criteria = oracle.get("criteria") if isinstance(oracle, dict) else None
        for i, raw in enumerate(criteria if isinstance(criteria, list) else ()):
            if not isinstance(raw, dict) or raw.get("type") not in ("record", "period", "final"):
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
        hint = hint or _suggest(action, known)
        listed = ", ".join(known) if known else "none"
        self.add((*path, "action"), f"unknown {kind} action {_shown(action)}{hint}; known: {listed}{self._plugin_hint(action)}", "action")
        return None

    def _leaf(self, path: tuple[PathPart, ...], kind: str, action: str | None, params: Mapping[str, Any]) -> dict[str, Expression]:
        """Check that a leaf is registered for (kind, action) and that its params fit; parse its expressions."""
        leaf = self.registry.get(kind, action)
        owner = self._other_system(action)
        if leaf is not None and owner is not None:
            self.add((*path, "action"), f"{_shown(action)} is an action of the {owner!r} system; this case's system is "
                     f"{self.spec.type!r} (set \"system\": {{\"type\": \"{owner}\", ...}})", "action")  # fmt: skip
            return {}
        leaf = self._lookup(path, kind, action)
        if leaf is None:
            return {}
        if not self.params(leaf, path, params):
            return {}
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
            expressions = self._leaf(path, raw["type"], raw.get("action"), params)
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
            shown = " -> ".join(cycle)
            self.add(("execute", index[first].index, "after", k), f"cycle: {shown}", "graph")


def _cycle_through(graph: nx.DiGraph, start: str) -> list[str]:
    """A cycle through *start* in a strongly connected *graph*, written pred -> succ."""
    path = nx.shortest_path(graph, start, next(iter(graph.pred[start])))
    return [*path, start]


def _params_key(kind: str, action: str | None, params: Mapping[str, Any] | None) -> Any:
    """A hashable key for a leaf's *params* made of scalars (``None`` otherwise).

    Each value's type is part of the key: ``1``, ``1.0`` and ``True`` are equal
    in Python but not to a JSON Schema.
    """
    if not params:
        return (kind, action)
    try:
        key = (kind, action, *((k, v.__class__, v) for k, v in params.items()))
        hash(key)
    except TypeError:  # a list or object value
        return None
    return key


def freeze(mapping: Mapping[str, Any] | None) -> Mapping[str, Any]:
    """A read-only copy; every empty one is the same shared object (most entries have no expressions)."""
    return MappingProxyType(dict(mapping)) if mapping else EMPTY


def _pointer(path: tuple[PathPart, ...]) -> str:
    return Problem(path, "").pointer


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
    return _spec({**raw, "options": options}, source)


def _spec(raw: Mapping[str, Any] | None, source: str) -> SystemSpec:
    """The case's ``system`` key as a :class:`SystemSpec`, ``config`` resolved relative to the case file."""
    if raw is None:
        return SystemSpec()
    config = raw.get("config")
    if config is not None:
        base = os.path.dirname(os.path.abspath(source)) if source != "<dict>" else os.getcwd()
        config = os.path.normpath(os.path.join(base, config))
    return SystemSpec(raw["type"], config, tuple(raw.get("options", ())))


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _option_problems(options: tuple[str, ...], system_type: Any) -> list[tuple[int, str]]:
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
            problems.append((index, f"{_shown(item)} is not an option (options start with '-', each followed by at most one value)"))
            continue
        name, eq, _ = item.partition("=")
        value_may_follow = not eq
        if name not in allowed:
            if not allowed:
                problems.append((index, f"the {system_type.name!r} system takes no options"))
            else:
                tip = _suggest(name, allowed) or f" (allowed: {', '.join(allowed)})"
                problems.append((index, f"option {_shown(name)} is not allowed for the {system_type.name!r} system{tip}"))
    return problems


def work(case: TestCase) -> int:
    """The most work units a run of *case* can take: ``(timeout / tick + 1) x (entries + criteria + 10)``
    (a run that ends before its timeout is charged less; see :data:`MAX_WORK`)."""
    return case.ticks * (len(case.entries) + len(case.criteria) + 10)


def check_work(case: TestCase, max_work: int = MAX_WORK) -> None:
    """Raise :class:`InvalidTestCase` (at ``/timeout``, cause ``limit``) if a run of *case* is certain to exceed
    *max_work*: when even its first tick would. Anything else runs, and is stopped when its budget is spent
    (``run(..., max_work=...)``)."""
    size = len(case.entries) + len(case.criteria) + 10
    if size > max_work:
        message = (f"one tick of this tree is {size} units of work (entries + criteria + 10), more than the whole "
                   f"budget, {max_work:.3g}: raise it with run --max-work N")  # fmt: skip
        raise InvalidTestCase([Problem(("execute",), message, "limit")], case.source)


def validate(data: Any, source: str = "<dict>", registry: Registry | None = None, system: SystemSpec | None = None) -> TestCase:
    """Check parsed JSON *data* and build the :class:`TestCase`; raise :class:`InvalidTestCase`.

    *system*, if given, replaces the case's own ``system`` (``run --system``; its
    ``config`` is used as given, so resolve it first). The case's ``options``
    are kept when *system* names the same type and gives none.
    """
    registry = registry if registry is not None else default_registry()
    from .onepass import from_data  # the one pass for valid documents (imports this module)

    case = from_data(data, source, registry, system)
    return case if case is not None else _validate(data, source, registry, system)


def _validate(data: Any, source: str, registry: Registry, system: SystemSpec | None) -> TestCase:
    """The detailed checks, stage by stage: every problem, each at its JSON path."""
    _suggestions.left = MAX_SUGGESTIONS  # "did you mean" budget of this document
    problems = sorted(set(value_problems(data)), key=by_place)  # stage 0 (fuzz findings, see above)
    if problems:
        raise InvalidTestCase(problems, source)
    if type(data) is dict and ("parameters" in data or "variations" in data):
        data = _parameterised(data, source)  # '$name' -> the defaults (btgen_pytrees.sweep)
    problems = set(_schema_problems(data))
    if problems:
        if isinstance(data, dict):  # the params of well-formed entries in the same round
            # only the parts it reads: the rest of the document may have any shape now (fuzz finding:
            # "signals" as a list crashed the checker's set-up)
            early = Checker({k: data[k] for k in ("execute", "oracle") if k in data}, registry, source)
            early.leaves_alongside_shape()
            problems.update(early.problems)
        raise InvalidTestCase(sorted(problems, key=by_place), source)
    checker = Checker(data, registry, source, system)
    checker.check_system()
    checker.check_signals()
    checker.check_limits()
    entries = checker.entries()
    criteria = checker.criteria()
    if not any(p.cause == "graph" for p in checker.problems):
        checker.cycles(entries)
    if checker.problems:
        raise InvalidTestCase(sorted(set(checker.problems), key=by_place), source)
    return build_case(data, entries, criteria, checker.spec, registry, source)


def build_case(data: Mapping[str, Any], entries: list[Entry], criteria: list[Criterion], spec: SystemSpec,
          registry: Registry, source: str) -> TestCase:  # fmt: skip
    """The :class:`TestCase` of a valid document, from its checked entries and criteria."""
    relation = data.get("oracle", {}).get("relation", "&&")
    if isinstance(relation, str):
        relation = {"record": relation, "others": relation}
    return TestCase(
        name=data["name"],
        description=data.get("description", ""),
        signals=MappingProxyType(dict(data.get("signals", {}))),
        declares_signals="signals" in data,
        tick=float(data.get("tick", DEFAULT_TICK)),
        timeout=float(data.get("timeout", DEFAULT_TIMEOUT)),
        join=data.get("join", DEFAULT_JOIN),
        entries=tuple(entries),
        criteria=tuple(criteria),
        relation=MappingProxyType({"record": relation.get("record", "&&"), "others": relation.get("others", "&&")}),
        source=source,
        system=spec,
        require_complete=bool(data.get("require_complete", False)),
        warnings=tuple(overlapping_writes(entries, registry)),
    )


def _parameterised(data: dict[str, Any], source: str) -> dict[str, Any]:
    """A case with ``parameters``/``variations``: check those blocks, substitute the defaults.

    Kept out of the fast path: a case without them never imports :mod:`btgen_pytrees.sweep`.
    """
    from .sweep.case import nominal

    return nominal(data, source)


def load(source: str | os.PathLike[str] | Mapping[str, Any], *, registry: Registry | None = None,
         system: SystemSpec | None = None) -> TestCase:  # fmt: skip
    """Load a test case from a file path or an already parsed ``dict``.

    Args:
        system: replaces the case's ``system`` key (``run --system``), checked the same way

    Raises:
        InvalidTestCase: with every problem found (see :mod:`btgen_pytrees.errors`).
    """
    if isinstance(source, Mapping):
        return validate(source, "<dict>", registry, system)
    from .onepass import from_text  # the one pass for valid documents (imports this module)

    raw, where = _read(source)
    registry = registry if registry is not None else default_registry()
    case = from_text(raw, os.fspath(source), registry, system)
    return case if case is not None else _validate(parse_json(raw, where), os.fspath(source), registry, system)
