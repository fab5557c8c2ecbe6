"""The execute entries' rules, written once: one loop checks each entry and builds it.

Each rule is a cheap condition in :meth:`Entries.add_all` - what most entries of most
documents pass - plus its wording, which runs only for the entries whose condition failed
(:meth:`Entries.doubt`) and only when the problems are wanted:

* **values and shape** - the entry's part of the test-case schema (keys, types, the id
  pattern, lengths, enums), read from the schema file itself (:func:`entry_rules`), and
  values a later step could not handle (lone surrogates, numbers beyond
  :data:`~btgen_pytrees.load.limits.MAX_MAGNITUDE`, nesting). Worded by
  :func:`~btgen_pytrees.load.values.value_problems` and by the entry's sub-schema through
  jsonschema (:func:`~btgen_pytrees.load.words.described`), so the messages are the schema's own;
* **ids** - each new (:meth:`Entries.duplicate_ids` words a repeated one);
* **after** - names other entries, once each, none a criterion (:meth:`Entries.after`);
* **action and params** - a registered leaf whose ``params`` schema the params fit, checked
  once per distinct value (:func:`params_key`); entries with equal params share one
  read-only mapping. An entry whose params name a signal or hold an expression, or whose
  action has a dot (a system's action), needs the whole document (``signals``,
  ``system``) and is checked after the loop (:meth:`Entries.entry`), with the same code
  that words the leaf's problems (:meth:`btgen_pytrees.load.context.Checker.check_leaf`).

With ``words=False`` (reading a file entry by entry, :func:`btgen_pytrees.load.read.stream`)
the first failed condition raises :class:`~btgen_pytrees.load.read.NotStreamed`: the file is
then read whole and the same loop runs with ``words=True`` - like jsonschema's ``is_valid``,
which is its error walk stopped at the first error.
"""

from __future__ import annotations

import re
from functools import lru_cache
from typing import Any, Iterable, Mapping

from ..errors import PathPart, Problem
from ..leaves import Registry
from ..contracts.registry import LeafType
from ..model import DEFAULT_JOIN, EMPTY, Control, Entry
from ..validator import SchemaValidator
from .context import Checker, freeze
from .control import CONTROL_KEYS, build_control, control_fits, control_key, entry_control
from ..expressions import ExpressionError
from .read import NotStreamed
from .schema import inline_refs, schema
from .values import SURROGATE, suspicious
from .words import suggest

__all__ = ["Entries", "entry_rules", "entry_validator", "params_key", "STAND_IN"]


class _Rules:
    """What the schema says about one execute entry, read from the schema file itself."""

    def __init__(self, entry: Mapping[str, Any]):
        props = entry["properties"]
        self.keys = frozenset(props)
        self.required = tuple(entry["required"])
        self.id = re.compile(props["id"]["pattern"]).search
        self.id_max = props["id"]["maxLength"]
        self.kinds = tuple(props["kind"]["enum"])
        self.action_min, self.action_max = props["action"]["minLength"], props["action"]["maxLength"]
        self.joins = tuple(props["join"]["enum"])
        self.name_min, self.name_max = props["name"]["minLength"], props["name"]["maxLength"]


_ID = {"type": "string", "pattern": "^[A-Za-z_][A-Za-z0-9_-]*(?![\\s\\S])", "maxLength": 64}
_ENTRY = {
    "type": "object",
    "required": ["id", "kind", "action"],
    "additionalProperties": False,
    "properties": {
        "id": _ID,
        "kind": {"enum": ["behavior", "constraint"]},
        "action": {"type": "string", "minLength": 1, "maxLength": 200},
        "params": {"type": "object"},
        "after": {"type": "array", "items": _ID},
        "join": {"enum": ["any", "all"]},
        "name": {"type": "string", "minLength": 1, "maxLength": 200},
        "when": {"type": "string", "minLength": 1, "maxLength": 1000},
        "edge": {"enum": ["none", "rising", "falling", "any"]},
        "delay": {"type": "number", "minimum": 0},
        "timeout": {"type": "number", "exclusiveMinimum": 0},
        "attempts": {"type": "integer", "minimum": 1, "maximum": 1000000},
        "repeat": {"type": "integer", "minimum": 1, "maximum": 1000000},
        "stops": {"type": "array", "minItems": 1, "items": _ID},
        "race": _ID,
    },
}
"""The execute entry's schema (descriptions aside) as the conditions of :meth:`Entries.add_all` implement it."""

_FIELDS = ("id", "kind", "action", "params", "after", "join", "name")

_IDS = re.compile(r"[A-Za-z_][A-Za-z0-9_-]{0,63}(?:\n[A-Za-z_][A-Za-z0-9_-]{0,63})*").fullmatch
"""Ids joined by newlines, each matching ``_ID`` (its pattern, at most its maxLength characters)."""

STAND_IN = {"id": "_", "kind": "behavior", "action": "_"}
"""An entry the schema accepts: stands for the entries that passed the loop when the rest of a document is checked."""


def _plain_schema(node: Any) -> Any:
    if isinstance(node, dict):
        return {k: _plain_schema(v) for k, v in node.items() if k != "description"}
    if isinstance(node, list):
        return [_plain_schema(v) for v in node]
    return node


@lru_cache(maxsize=1)
def entry_rules() -> _Rules:
    """The entry rules; an error when the schema's entry is not the one :meth:`Entries.add_all` implements
    (``tests/test_entries.py`` says so first)."""
    entry = _plain_schema(_entry_schema())
    if entry != _ENTRY or frozenset(_FIELDS + CONTROL_KEYS) != frozenset(entry["properties"]):
        raise RuntimeError("the schema's execute entry changed: update load/entries.py (_ENTRY and Entries.add_all)")
    return _Rules(entry)


def _entry_schema() -> Any:
    return inline_refs(schema(), schema())["properties"]["execute"]["items"]


@lru_cache(maxsize=1)
def entry_validator() -> SchemaValidator:
    """The execute entry's part of the schema, for the words of an entry's shape problems."""
    return SchemaValidator(_entry_schema(), checked=True)


def params_key(params: Mapping[str, Any] | None) -> Any:
    """A hashable key for *params* made of scalars (``None`` otherwise), for the memo of checked params.

    Each value's type is part of the key: ``1``, ``1.0`` and ``True`` are equal in Python
    but not to a JSON Schema.
    """
    if not params:
        return ()
    if len(params) == 1:
        ((k, v),) = params.items()
        key: Any = (k, type(v), v)
    else:
        key = (tuple(params.items()), tuple(map(type, params.values())))
    try:
        hash(key)
    except TypeError:  # a list or object value: checked every time
        return None
    return key


class _Leaf:
    """What the loop knows about one registered (kind, action): the leaf, and params already checked."""

    __slots__ = ("leaf", "validator", "special", "later", "checked")

    def __init__(self, leaf: LeafType, action: str):
        self.leaf = leaf
        self.validator = leaf.params_validator
        self.special = (*leaf.signals, *leaf.expressions)  # params that need the whole document
        self.later = "." in action  # a system's action: whose system is decided by the whole document
        self.checked: dict[Any, Mapping[str, Any]] = {}  # params key -> the shared read-only params


class Entries:
    """The execute entries of one document, checked and built as they are read.

    After :meth:`add_all`, :attr:`entries` holds an :class:`Entry` per entry, or ``None``
    for the entries left to the end: :attr:`doubtful` (a condition failed; with *words*
    only) and :attr:`later` (they need the whole document).
    """

    def __init__(self, registry: Registry, words: bool):
        self.rules = entry_rules()
        self.registry = registry
        self.words = words
        self.entries: list[Entry | None] = []
        self.ids: set[str] = set()
        self.leaves: dict[tuple[str, str], _Leaf] = {}
        self.default_join: Any = DEFAULT_JOIN
        self.join_known = True  # whether default_join is the document's (a 'join' after 'execute': not yet)
        self.defaulted: list[int] = []  # entries given default_join while it was not known
        self.forward: list[tuple[str, ...]] = []  # 'after' lists naming entries not read yet
        self.later: list[tuple[int, Any]] = []  # entries that need the whole document
        self.doubtful: list[tuple[int, Any]] = []  # entries whose conditions failed (with words)
        self.count_keys = False  # count the keys of the dicts read (entries read without the duplicate-key hook)
        self.keys = 0
        self.controls: dict[Any, Control] = {}  # control_key -> the Control built for it (shared: it is immutable)

    def doubt(self, i: int, raw: Any) -> None:
        """A condition failed for entry *i*: its problems are worded after the loop (or, without words, read whole)."""
        if not self.words:
            raise NotStreamed
        self.doubtful.append((i, raw))
        self.entries.append(None)

    def add_all(self, items: Iterable[Any]) -> None:
        """Check the execute entries *items* and build them.

        One loop with everything it reads bound to locals: at 100,000 entries each attribute
        lookup or call saved per entry is a few milliseconds.
        """
        rules, ids, entries, leaves = self.rules, self.ids, self.entries, self.leaves
        joins, name_min, name_max = rules.joins, rules.name_min, rules.name_max
        default_join, join_known, count_keys = self.default_join, self.join_known, self.count_keys
        surrogate, new_id, new_entry, doubt = SURROGATE.search, ids.add, entries.append, self.doubt
        keys, controls = self.keys, self.controls
        for raw in items:
            i = len(entries)
            if type(raw) is not dict:
                doubt(i, raw)
                continue
            id_, kind, action, params, listed, join, name = map(raw.get, _FIELDS)
            # null is no valid value of any field, so this says: no other key, none null
            controlled = len(raw) - 3 - (params is not None) - (listed is not None) - (join is not None) - (name is not None)
            control = None
            if controlled:  # other keys: control keys of the right shape only - or the very keys of an entry built before
                control_seen = control_key(raw)
                control = controls.get(control_seen) if control_seen is not None and len(control_seen) == controlled else None
                if control is None and control_fits(raw) != controlled:
                    doubt(i, raw)
                    continue
            if type(id_) is not str or type(action) is not str or id_ in ids:
                doubt(i, raw)  # (the ids' pattern and length: all at once, in check_ids())
                continue
            leaf = leaves.get((kind, action)) if type(kind) is str else None
            if leaf is None:
                leaf = self._leaf(kind, action)
                if leaf is None:
                    doubt(i, raw)
                    continue
            if listed:
                if type(listed) is not list:
                    doubt(i, raw)
                    continue
                after = tuple(listed)
                try:
                    known = ids.issuperset(after)
                except TypeError:  # an unhashable item
                    known = False
                if not known and not self._forward(after):
                    doubt(i, raw)
                    continue
                if id_ in after or len(after) > 1 and len(set(after)) != len(after):
                    doubt(i, raw)
                    continue
            elif listed is not None and type(listed) is not list:
                doubt(i, raw)
                continue
            else:
                after = ()
            if join is None:
                join = default_join
                if not join_known:
                    self.defaulted.append(i)
            elif type(join) is not str or join not in joins:
                doubt(i, raw)
                continue
            if name is None:
                name = id_
            elif type(name) is not str or not name_min <= len(name) <= name_max or surrogate(name):
                doubt(i, raw)
                continue
            if params is not None and type(params) is not dict:
                doubt(i, raw)
                continue
            new_id(id_)
            if count_keys:
                keys += len(raw) + (len(params) if params else 0)
            if controlled and control is None:  # its control keys, built here; their names are checked with the whole document (finish_control)
                try:
                    control = build_control(raw)
                except ExpressionError:
                    doubt(i, raw)
                    continue
                if control_seen is not None:
                    controls[control_seen] = control
            if leaf.later:
                if params:
                    if count_keys:
                        keys += _nested_keys(params)
                    if suspicious(params, 3):
                        doubt(i, raw)
                        continue
                self.later.append((i, raw))
                new_entry(None)
                continue
            key = params_key(params)
            frozen = leaf.checked.get(key) if key is not None else None
            if frozen is None:
                if params:
                    if key is None and count_keys:
                        keys += _nested_keys(params)
                    if suspicious(params, 3) or leaf.validator is not None and not _fits(leaf.validator, params):
                        doubt(i, raw)
                        continue
                    if leaf.special and any(k in params for k in leaf.special):
                        self.later.append((i, raw))  # a signal name or an expression: needs the whole document
                        new_entry(None)
                        continue
                elif leaf.validator is not None and not _fits(leaf.validator, {}):
                    doubt(i, raw)
                    continue
                frozen = freeze(params)
                if key is not None:
                    leaf.checked[key] = frozen
            new_entry(Entry(id_, kind, action, frozen, after, join, name, i, EMPTY, control))
        self.keys = keys

    def _leaf(self, kind: Any, action: str) -> _Leaf | None:
        """The registered leaf of a (kind, action) seen for the first time (checked as the schema would), or None."""
        rules = self.rules
        if kind not in rules.kinds or not rules.action_min <= len(action) <= rules.action_max or SURROGATE.search(action):
            return None
        leaf_type = self.registry.get(kind, action)
        if leaf_type is None:
            return None
        leaf = self.leaves[(kind, action)] = _Leaf(leaf_type, action)
        return leaf

    def _forward(self, after: tuple[Any, ...]) -> bool:
        """*after* names entries not read yet: whether they are ids (:meth:`after_known` checks they exist)."""
        rules = self.rules
        for p in after:
            if type(p) is not str or len(p) > rules.id_max or not rules.id(p):
                return False
        self.forward.append(after)
        return True

    def ids_valid(self) -> bool:
        """The ids' pattern and length, for every entry at once (in one regex call)."""
        try:
            joined = "\n".join(self.ids)
            return joined.count("\n") == len(self.ids) - 1 and bool(_IDS(joined))  # (an id with a newline would pass as two)
        except TypeError:  # a str subclass with an odd join (from Python)
            return False

    def after_known(self) -> bool:
        """Every ``after`` naming an entry further down the file names one."""
        return all(self.ids.issuperset(after) for after in self.forward)

    def set_join(self, join: Any) -> None:
        """The document's ``join``, for the entries given the default before it was read (a 'join' after 'execute')."""
        if self.defaulted and join != self.default_join:
            entries = self.entries
            for i in self.defaulted:
                old = entries[i]
                if old is not None:  # (the entries built at the end take the document's join themselves)
                    entries[i] = Entry(old.id, old.kind, old.action, old.params, old.after, join, old.name, old.index,
                                       old.expressions, old.control)  # fmt: skip

    def unsure(self) -> set[int]:
        """When the ids' pattern failed (:meth:`ids_valid`): the entries built or left for later whose id, or an
        item of whose ``after``, breaks it."""
        bad = {id_ for id_ in self.ids if not ("\n" not in id_ and _IDS(id_))}
        found = {e.index for e in self.entries if e is not None and (e.id in bad or bad.intersection(e.after))}
        found.update(i for i, raw in self.later if raw["id"] in bad or bad.intersection(raw.get("after") or ()))
        return found

    # -- the words, for the entries left to the end ------------------------------------------------------

    def duplicate_ids(self, checker: Checker, raw_entries: list[Any], raw_criteria: list[Any]) -> None:
        """An id used twice, among the entries and criteria: at the later use, naming the first."""
        first: dict[str, tuple[PathPart, ...]] = {}
        for where, items in (("execute", raw_entries), ("criteria", raw_criteria)):
            for i, item in enumerate(items):
                path = ("execute", i, "id") if where == "execute" else ("oracle", "criteria", i, "id")
                if item["id"] in first:
                    checker.add(path, f"duplicate id {item['id']!r} (first used at {Problem(first[item['id']], '').pointer})", "id")
                else:
                    first[item["id"]] = path

    def after(self, checker: Checker, i: int, raw: Mapping[str, Any], execute_ids: set[str],
              criteria_ids: set[str]) -> tuple[str, ...]:  # fmt: skip
        """Entry *i*'s ``after``: the items that name another execute entry once, each other item a problem."""
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
                checker.add(path, f"{pred!r} cannot come after itself", "graph")
            elif pred in seen:
                checker.add(path, f"{pred!r} is listed twice", "graph")
            elif pred not in execute_ids and pred in criteria_ids:
                checker.add(path, f"{pred!r} is an oracle criterion, not an execute entry", "graph")
            elif pred not in execute_ids:
                checker.add(path, f"unknown id {pred!r}{suggest(pred, execute_ids)}", "graph")
            else:
                seen[pred] = None
        return tuple(seen)

    def entry(self, checker: Checker, i: int, raw: Mapping[str, Any], after: tuple[str, ...], join: str) -> Entry:
        """Execute entry *i* (*after* already checked): its leaf's params checked, or shared with equal ones; its
        control keys built (their names are checked with every entry's: :func:`~.control.finish_control`)."""
        kind, action, params = raw["kind"], raw["action"], raw.get("params")
        leaf = self.leaves.get((kind, action)) or self._leaf(kind, action)
        key = params_key(params) if leaf is not None else None
        frozen = leaf.checked.get(key) if leaf is not None and key is not None else None
        if frozen is not None:
            expressions = EMPTY
        else:
            before = len(checker.problems)
            compiled = checker.check_leaf(("execute", i), kind, action, params if params is not None else {})
            frozen = freeze(params)
            expressions = freeze(compiled)
            plain = leaf is not None and not any(name in (params or {}) for name in leaf.special)
            if key is not None and not compiled and len(checker.problems) == before and plain:
                leaf.checked[key] = frozen  # type: ignore[union-attr]
        return Entry(
            id=raw["id"], kind=kind, action=action, params=frozen, after=after,
            join=raw.get("join", join), name=raw.get("name", raw["id"]), index=i,
            expressions=expressions, control=entry_control(checker, i, raw),
        )  # fmt: skip


def _nested_keys(value: Any) -> int:
    """Keys of the dicts nested in *value*'s values (its own keys not counted)."""
    count, stack = 0, list(value.values()) if type(value) is dict else list(value)
    while stack:
        item = stack.pop()
        if type(item) is dict:
            count += len(item)
            stack.extend(item.values())
        elif type(item) is list:
            stack.extend(item)
    return count


def _fits(validator: SchemaValidator, value: Any) -> bool:
    return next(iter(validator.iter_errors(value)), None) is None
