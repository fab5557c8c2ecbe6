"""One pass over a valid test case: decide validity and build the :class:`TestCase` together.

The loader's detailed checks (:func:`btgen_pytrees.loader.validate`) run in stages, each a
walk over the whole document: a JSON parse with a duplicate-key hook, a walk for values no
later stage could handle, the JSON Schema, then each entry's meaning, a cycle check, and
finally the model. For a valid document - the common case - that is five passes over
data that is only read, and the parsed document (two containers per entry) stays alive
through all of them while the model is built next to it. On a 100,000-entry timeline
the parsed document's containers made the cyclic garbage collector's full collections
(which walk every live container) the largest cost of loading.

This module decides the same question in one pass and answers only *valid* - with the
very :class:`TestCase` the detailed checks build - or *not decided here* (``None``): then
the caller runs the detailed checks from the start, so every error message, path and
order is theirs, unchanged. It is therefore conservative: anything outside what it
checks itself (a ``system`` other than the built-in simulated one, whose ``describe``
may read the whole document; ``parameters``/``variations``; a value of an unexpected
type) is left to the detailed checks.

* **Reading** (:func:`from_text`): the top-level object is read key by key with the
  ``json`` module's own scanner (the one ``json.loads`` uses, with the same
  duplicate-key hook and constants rule), and the ``execute`` array element by
  element: each entry is checked and turned into an :class:`~btgen_pytrees.model.Entry`
  as soon as it is read, and its parsed dict is freed at once. Anything the scanner or
  this reader does not accept (invalid JSON, a duplicate key, a trailing comma, extra
  data) is left to the detailed checks, which report it.
* **Each entry** gets, in one go, what the stages check: values (strings without lone
  surrogates, numbers within :data:`~btgen_pytrees.loader.MAX_MAGNITUDE`, nesting), the
  entry's part of the schema (keys, types, the id pattern, lengths, enums: read from
  the schema file itself, see :func:`_entry_rules`), the id is new, ``after`` names
  other entries once each, the action is registered and its ``params`` fit its schema.
  Params are checked once per distinct value, as the detailed checks do, and entries
  with equal params share one read-only mapping. An entry whose params name a signal or
  hold an expression (``set``, ``ramp``, ``until``), or whose action has a dot (a
  system's action), needs the whole document (``signals``, ``system``) and is checked
  at the end, with the detailed checks' own code.
* **At the end**: the rest of the document (everything but ``execute``) through the
  same value walk and the schema (with ``execute``'s items left out: they were checked
  one by one), then the system, signals, limits, criteria and the ids they share with
  entries, ``after`` items naming entries further down the file, and acyclicity (one
  pass when every ``after`` points up the file, as usual).

``tests/test_onepass.py`` checks that this path builds the same case as the detailed
checks for every example and for generated and mutated documents, and that it leaves
every document the detailed checks reject to them.
"""

from __future__ import annotations

import json
import re
from dataclasses import replace
from functools import lru_cache
from typing import Any, Callable, Iterable, Iterator, Mapping

from ..leaves import Registry
from ..contracts.registry import LeafType
from ..model import DEFAULT_JOIN, EMPTY, Criterion, Entry, TestCase
from ..order import is_acyclic
from ..contracts.system import SystemSpec
from ..systems.simulated import SIMULATED
from ..validation import SchemaValidator
from .context import Checker, freeze
from .document import build_case
from .read import no_duplicates, reject_constant
from .schema import case_validator, inline_refs, schema
from .values import SURROGATE, suspicious

__all__ = ["from_text", "from_data"]

_WHITESPACE = re.compile(r"[ \t\n\r]*")  # what json's scanner skips between tokens
_SPACE = " \t\n\r"
_SPACED_KEY = re.compile(r'"[ \t\n\r]+:')  # a string, white space, a colon: a key written "key" : value


class _NotHere(Exception):
    """Not decided by the one pass: run the detailed checks."""


def from_text(raw: bytes | str, source: str, registry: Registry, system: SystemSpec | None = None) -> TestCase | None:
    """The case in *raw* (a file's bytes) if it is valid and within this pass's reach, else ``None``."""
    try:
        text = raw.decode("utf-8-sig") if isinstance(raw, bytes) else raw
        builder = _Builder(registry)
        top = _read(text, builder)
    except (_NotHere, ValueError, TypeError, RecursionError, StopIteration, IndexError):
        # not JSON the detailed reader accepts (ValueError: invalid JSON, a duplicate key, NaN),
        # or an entry this pass does not accept (TypeError: an unhashable item in 'after'): they say why
        return None
    return builder.finish(top, source, system)


def from_data(data: Any, source: str, registry: Registry, system: SystemSpec | None = None) -> TestCase | None:
    """The case of parsed JSON *data* if it is valid and within this pass's reach, else ``None``."""
    if type(data) is not dict or type(data.get("execute")) is not list:
        return None
    builder = _Builder(registry)
    builder.default_join = data.get("join", DEFAULT_JOIN)
    try:
        builder.add_all(data["execute"])
    except (_NotHere, TypeError):  # TypeError: an unhashable item in 'after'
        return None
    return builder.finish(data, source, system)


def _read(text: str, builder: "_Builder") -> dict[str, Any]:
    """Parse the top-level object of *text*, feeding ``execute``'s items to *builder* one by one.

    Returns the top-level dict with ``execute`` mapped to ``None`` (its entries are in the
    builder). Raises what the scanner raises (``StopIteration``: no value where one must
    be), or :class:`_NotHere` for anything else ``json.loads`` would reject.
    """
    scan = _scanner()
    skip = _WHITESPACE.match
    end = len(text)
    i = skip(text, 0).end()
    if text[i : i + 1] != "{":
        raise _NotHere
    top: dict[str, Any] = {}
    i = skip(text, i + 1).end()
    if text[i : i + 1] == "}":
        raise _NotHere  # {} is not a test case
    while True:
        if text[i : i + 1] != '"':
            raise _NotHere
        key, i = scan(text, i)
        i = skip(text, i).end()
        if text[i : i + 1] != ":" or key in top:
            raise _NotHere
        i = skip(text, i + 1).end()
        if key == "execute" and text[i : i + 1] == "[":
            builder.default_join = top.get("join", DEFAULT_JOIN)
            builder.join_known = "join" in top
            start, stop = i, []
            if _SPACED_KEY.search(text, i) is None:  # every key is written "key": - count them instead of hooking
                builder.count_keys = True
                builder.add_all(_items(text, skip(text, i + 1).end(), _scanner(hook=False), skip, stop))
                i = stop[0]
                if text.count('":', start, i) != builder.keys:
                    raise _NotHere  # a key twice in one object (or '":' inside a string): the detailed reader decides
            else:
                builder.add_all(_items(text, skip(text, i + 1).end(), scan, skip, stop))
                i = stop[0]
            top[key] = None
        else:
            top[key], i = scan(text, i)
        i = skip(text, i).end()
        c = text[i : i + 1]
        if c == "}":
            break
        if c != ",":
            raise _NotHere
        i = skip(text, i + 1).end()
    if skip(text, i + 1).end() != end:
        raise _NotHere  # extra data after the object
    return top


def _items(text: str, i: int, scan: Callable[[str, int], Any], skip: Callable[..., Any], end: list[int]) -> Iterator[Any]:
    """The items of the array whose first item starts at *i*; *end* receives the index after its ``]``."""
    if text[i] == "]":
        end.append(i + 1)
        return
    while True:
        try:
            raw, i = scan(text, i)
        except StopIteration:  # no value here (inside a generator it would become a RuntimeError)
            raise _NotHere from None
        yield raw
        c = text[i]
        if c in _SPACE:
            i = skip(text, i).end()
            c = text[i]
        if c == ",":
            i += 1
            if text[i] in _SPACE:
                i = skip(text, i).end()
        elif c == "]":
            end.append(i + 1)
            return
        else:
            raise _NotHere


def _scanner(hook: bool = True) -> Callable[[str, int], Any]:
    """``json.loads``' scanner with the loader's hooks: ``scan(text, index) -> (value, end)``.

    A new one per document: the scanner keeps a memo of keys between the hook's calls.
    Without *hook*, objects are built in C and a key written twice is not detected:
    the entries are read so (the duplicate-key hook was a third of reading them) and
    their keys counted instead. Where no key is followed by white space before its
    colon, every key written ends in ``":``, so the execute array holds at least as
    many ``":`` as keys written; when that count equals the number of keys of the
    dicts read (:attr:`_Builder.keys`), no object had a key twice.
    """
    if not hook:
        return json.JSONDecoder(parse_constant=reject_constant).scan_once
    return json.JSONDecoder(object_pairs_hook=no_duplicates, parse_constant=reject_constant).scan_once


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
    },
}
"""The execute entry's schema (descriptions aside) as this pass implements it."""

_FIELDS = ("id", "kind", "action", "params", "after", "join", "name")

_IDS = re.compile(r"[A-Za-z_][A-Za-z0-9_-]{0,63}(?:\n[A-Za-z_][A-Za-z0-9_-]{0,63})*").fullmatch
"""Ids joined by newlines, each matching ``_ID`` (its pattern, at most its maxLength characters)."""


def _plain_schema(node: Any) -> Any:
    if isinstance(node, dict):
        return {k: _plain_schema(v) for k, v in node.items() if k != "description"}
    if isinstance(node, list):
        return [_plain_schema(v) for v in node]
    return node


@lru_cache(maxsize=1)
def _entry_rules() -> _Rules | None:
    """The entry rules, or ``None`` when the schema's entry is not the one this pass implements.

    Then every document goes through the detailed checks, and ``tests/test_onepass.py``
    fails, saying this pass needs updating.
    """
    full = inline_refs(schema(), schema())
    entry = _plain_schema(full["properties"]["execute"]["items"])
    return _Rules(entry) if entry == _ENTRY and frozenset(_FIELDS) == frozenset(entry["properties"]) else None


class _Leaf:
    """What the pass knows about one registered (kind, action): the leaf, and params already checked."""

    __slots__ = ("leaf", "validator", "special", "later", "checked")

    def __init__(self, leaf: LeafType, action: str):
        self.leaf = leaf
        self.validator = leaf.params_validator
        self.special = (*leaf.signals, *leaf.expressions)  # params that need the whole document
        self.later = "." in action  # a system's action: whose system is decided by the whole document
        self.checked: dict[Any, Mapping[str, Any]] = {}  # params key -> the shared read-only params


class _Builder:
    """Checks entries as they are read and builds them; :meth:`finish` checks the rest."""

    def __init__(self, registry: Registry):
        rules = _entry_rules()
        if rules is None:
            raise _NotHere
        self.rules = rules
        self.registry = registry
        self.entries: list[Entry | None] = []
        self.ids: set[str] = set()
        self.leaves: dict[tuple[str, str], _Leaf] = {}
        self.default_join: Any = DEFAULT_JOIN
        self.join_known = True  # whether default_join is the document's (a 'join' after 'execute': not yet)
        self.defaulted: list[int] = []  # entries given default_join while it was not known
        self.forward: list[tuple[str, ...]] = []  # 'after' lists naming entries not read yet
        self.later: list[tuple[int, dict[str, Any]]] = []  # entries checked by finish()
        self.first: Any = None  # the first entry as read
        self.count_keys = False  # count the keys of the dicts read (entries read without the duplicate-key hook)
        self.keys = 0

    def add_all(self, items: Iterable[Any]) -> None:
        """Check the execute entries *items* (raise :class:`_NotHere` on anything unusual) and build them.

        One loop with everything it reads bound to locals: at 100,000 entries each attribute
        lookup or call saved per entry is a few milliseconds.
        """
        rules, ids, entries, leaves = self.rules, self.ids, self.entries, self.leaves
        joins, name_min, name_max = rules.joins, rules.name_min, rules.name_max
        default_join, join_known, count_keys = self.default_join, self.join_known, self.count_keys
        surrogate, new_id, new_entry = SURROGATE.search, ids.add, entries.append
        keys = self.keys
        for raw in items:
            if type(raw) is not dict:
                raise _NotHere
            id_, kind, action, params, listed, join, name = map(raw.get, _FIELDS)
            # null is no valid value of any field, so this says: no other key, none null
            if len(raw) != 3 + (params is not None) + (listed is not None) + (join is not None) + (name is not None):
                raise _NotHere
            if type(id_) is not str or type(action) is not str or id_ in ids:
                raise _NotHere  # (the ids' pattern and length: all at once, in finish())
            leaf = leaves.get((kind, action)) if type(kind) is str else None
            if leaf is None:
                leaf = self._leaf(kind, action)
            i = len(entries)
            if not i:
                self.first = raw
            new_id(id_)
            if listed:
                if type(listed) is not list:
                    raise _NotHere
                after = tuple(listed)
                if not ids.issuperset(after):
                    self._forward(after)
                if id_ in after or len(after) > 1 and len(set(after)) != len(after):
                    raise _NotHere
            elif listed is not None and type(listed) is not list:
                raise _NotHere
            else:
                after = ()
            if join is None:
                join = default_join
                if not join_known:
                    self.defaulted.append(i)
            elif type(join) is not str or join not in joins:
                raise _NotHere
            if name is None:
                name = id_
            elif type(name) is not str or not name_min <= len(name) <= name_max or surrogate(name):
                raise _NotHere
            if params is not None and type(params) is not dict:
                raise _NotHere
            if count_keys:
                keys += len(raw) + (len(params) if params else 0)
            if leaf.later:
                if params and count_keys:
                    keys += _nested_keys(params)
                self._later(i, raw)
                continue
            if not params:
                key: Any = ()
            else:  # 1, 1.0 and True are equal in Python but not to a schema: the types are part of the key
                if len(params) == 1:
                    ((k, v),) = params.items()
                    key = (k, type(v), v)
                else:
                    key = (tuple(params.items()), tuple(map(type, params.values())))
                try:
                    hash(key)
                except TypeError:  # a list or object value: checked every time, as the detailed checks do
                    key = None
            frozen = leaf.checked.get(key) if key is not None else None
            if frozen is None:
                if params:
                    if key is None and count_keys:
                        keys += _nested_keys(params)
                    if suspicious(params, 3) or leaf.validator is not None and not _fits(leaf.validator, params):
                        raise _NotHere
                    if leaf.special and any(k in params for k in leaf.special):
                        self._later(i, raw)  # a signal name or an expression: needs the whole document
                        continue
                elif leaf.validator is not None and not _fits(leaf.validator, {}):
                    raise _NotHere
                frozen = freeze(params)
                if key is not None:
                    leaf.checked[key] = frozen
            new_entry(Entry(id_, kind, action, frozen, after, join, name, i, EMPTY))
        self.keys = keys

    def _later(self, i: int, raw: dict[str, Any]) -> None:
        """Leave entry *i* to :meth:`finish` (its place is kept)."""
        self.later.append((i, raw))
        self.entries.append(None)

    def _leaf(self, kind: str, action: str) -> _Leaf:
        """The registered leaf of a (kind, action) seen for the first time (checked as a schema would)."""
        rules = self.rules
        if kind not in rules.kinds or not rules.action_min <= len(action) <= rules.action_max or SURROGATE.search(action):
            raise _NotHere
        leaf_type = self.registry.get(kind, action)
        if leaf_type is None:
            raise _NotHere
        leaf = self.leaves[(kind, action)] = _Leaf(leaf_type, action)
        return leaf

    def _forward(self, after: tuple[str, ...]) -> None:
        """*after* names entries not read yet: check that they are ids; finish() checks they exist."""
        rules = self.rules
        for p in after:
            if type(p) is not str or len(p) > rules.id_max or not rules.id(p):
                raise _NotHere
        self.forward.append(after)

    def finish(self, data: Mapping[str, Any], source: str, system: SystemSpec | None) -> TestCase | None:
        """Check everything but the entries read; the case, or ``None`` for the detailed checks."""
        if not self.entries or "parameters" in data or "variations" in data:
            return None  # none: the schema's error; parameters: substituted by btgen_pytrees.sweep first
        try:
            joined = "\n".join(self.ids)  # the ids' pattern and length, in one regex call
            if joined.count("\n") != len(self.ids) - 1 or not _IDS(joined):  # (an id with a newline would pass as two)
                return None
        except TypeError:  # a str subclass with an odd join (from Python): the detailed checks decide
            return None
        rest = {k: v for k, v in data.items() if k != "execute"}
        # the schema over the rest, with the first entry standing for all of them (each was checked as it came)
        if suspicious(rest) or not _small_fits({**rest, "execute": [self.first]}):
            return None
        checker = Checker(rest, self.registry, source, system)
        if self.registry.system(checker.spec.type) is not SIMULATED:
            return None  # another system's describe() may read the whole document, entries included
        checker.check_system()
        checker.check_signals()
        checker.check_limits()
        criteria_ids = [c["id"] for c in rest.get("oracle", {}).get("criteria", [])]
        if len(set(criteria_ids)) != len(criteria_ids) or not self.ids.isdisjoint(criteria_ids):
            return None
        if any(not self.ids.issuperset(after) for after in self.forward):
            return None
        entries = self.entries
        join = data.get("join", DEFAULT_JOIN)
        if self.defaulted and join != self.default_join:  # 'join' came after 'execute'
            for i in self.defaulted:
                if entries[i] is not None:  # (the entries checked below take the document's join themselves)
                    entries[i] = replace(entries[i], join=join)  # type: ignore[arg-type]
        checked: dict[Any, Mapping[str, Any]] = {}
        for i, raw in self.later:  # entries that needed the whole document: checked and built as the detailed checks do
            entries[i] = checker.entry(i, raw, tuple(raw["after"]) if raw.get("after") else (), join, checked)
        criteria: list[Criterion] = checker.criteria()
        if checker.problems:
            return None
        done: list[Entry] = entries  # type: ignore[assignment]
        if self.forward and not is_acyclic({e.id: e.after for e in done}):
            return None
        return build_case(data, done, criteria, checker.spec, self.registry, source)


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


SMALL = 100
"""Criteria and signals up to which the rest of a document is checked by jsonschema itself (about a
millisecond) rather than by the compiled check, whose compilation (40 ms, once per process) would
cost more than it saves."""


def _small_fits(doc: dict[str, Any]) -> bool:
    validator = case_validator()
    oracle, signals = doc.get("oracle"), doc.get("signals")
    criteria = oracle.get("criteria") if type(oracle) is dict else None
    size = (len(criteria) if type(criteria) is list else 0) + (len(signals) if type(signals) is dict else 0)
    if size <= SMALL and "fast" not in validator.__dict__:  # not compiled yet: jsonschema's own walk is cheaper
        return bool(validator.full.is_valid(doc))
    return _fits(validator, doc)


def _fits(validator: SchemaValidator, value: Any) -> bool:
    return next(iter(validator.iter_errors(value)), None) is None
