"""Load and validate a test case: JSON text → :class:`~btgen_pytrees.model.TestCase`, on one path.

Validation reports *every* problem of a stage, each with the JSON pointer of the
offending value; a stage's problems are reported only if the one before found
nothing, because its checks assume what the earlier ones guarantee:

0. **values** - what no later stage could handle: lone surrogates, integers
   beyond float range, nesting deeper than :data:`~.limits.MAX_NESTING` (fuzz findings).
1. **shape** - the JSON Schema ``schemas/testcase.schema.json`` (unknown keys,
   wrong types, missing keys, bad identifiers, ...); with it, each entry's and
   criterion's action and ``params``, so one round of corrections fixes both.
2. **meaning** - what a schema cannot say: duplicate ids, ``after`` naming an
   unknown id or the entry itself, cycles, ``from`` ≥ ``to``, expressions,
   signal names, unknown actions and each action's own ``params`` schema, the
   ``system`` (a registered type, options from its allow-list, its own checks
   through ``SystemType.describe``; its signals are read-only).

Problems are raised together as :class:`~btgen_pytrees.errors.InvalidTestCase`.

Each rule is a cheap condition plus its wording, written once (the entries' in
:mod:`.entries`, the rest's in :mod:`.context`, :mod:`.values`, :mod:`.document`); the
wording runs only where a condition failed. A file is first read entry by entry
(:func:`~.read.stream`) with the conditions alone - each entry checked and built as it is
read, the common, valid case in one pass -; at the first failed condition it is read whole
and the same checks run again with their words. *Valid* means: no problem collected.

>>> case = load({"name": "t", "execute": [{"id": "A", "kind": "behavior", "action": "hold",
...                                        "params": {"duration": 1}}]})
>>> case.entries[0].id, case.tick, case.timeout
('A', 0.1, 60.0)
"""

from __future__ import annotations

import os
from typing import Any, Mapping

from ..errors import InvalidTestCase, Problem, by_place
from ..leaves import Registry, default_registry
from ..model import DEFAULT_JOIN, Entry, TestCase
from ..contracts.system import SystemSpec
from ..systems.simulated import SIMULATED
from .context import Checker
from .control import finish_control
from .document import build_case, rest_fits
from .entries import STAND_IN, Entries, entry_validator
from ..openscenario import is_openscenario
from .read import NotStreamed, load_json, parse_json, read_file, stream
from .template import is_parameterised, nominal
from .values import suspicious, value_problems
from .words import described, new_document, schema_problems

__all__ = ["load", "validate"]


def validate(data: Any, source: str = "<dict>", registry: Registry | None = None, system: SystemSpec | None = None) -> TestCase:
    """Check parsed JSON *data* and build the :class:`TestCase`; raise :class:`InvalidTestCase`.

    *system*, if given, replaces the case's own ``system`` (``run --system``; its
    ``config`` is used as given, so resolve it first). The case's ``options``
    are kept when *system* names the same type and gives none.
    """
    registry = registry if registry is not None else default_registry()
    return _checked(data, source, registry, system)


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
    if is_openscenario(source):  # converted to its document first (load_json)
        return validate(load_json(source), os.fspath(source), registry, system)
    raw, where = read_file(source)
    registry = registry if registry is not None else default_registry()
    name = os.fspath(source)
    try:
        return _streamed(raw, name, registry, system)
    except NotStreamed:  # a condition failed, or the text is not for reading entry by entry: read it whole
        return _checked(parse_json(raw, where), name, registry, system)


def _streamed(raw: bytes, source: str, registry: Registry, system: SystemSpec | None) -> TestCase:
    """The case of the file's bytes *raw*, read entry by entry, the conditions alone: raises
    :class:`NotStreamed` at the first that fails, or where the whole document is needed."""
    entries = Entries(registry, words=False)
    top = stream(raw, entries)
    if "execute" not in top or top["execute"] is not None or is_parameterised(top):
        raise NotStreamed  # no execute array: the schema's problem; parameters: substituted first
    rest = {k: v for k, v in top.items() if k != "execute"}
    if not entries.entries or suspicious(rest) or not rest_fits({**rest, "execute": [STAND_IN]}) or not entries.ids_valid():
        raise NotStreamed
    checker = Checker(rest, registry, source, system)
    if registry.system(checker.spec.type) is not SIMULATED:
        raise NotStreamed  # another system's describe() may read the whole document, entries included
    return _meaning(top, rest, entries, checker, registry, source)


def _checked(data: Any, source: str, registry: Registry, system: SystemSpec | None) -> TestCase:
    """The case of parsed JSON *data*, or every problem, stage by stage, each at its JSON path."""
    new_document()  # "did you mean" budget of this document
    if is_parameterised(data):
        problems = sorted(set(value_problems(data)), key=by_place)  # stage 0 of the template
        if problems:
            raise InvalidTestCase(problems, source)
        data = nominal(data, source)  # '$name' -> the defaults (.template)
    entries = Entries(registry, words=True)
    execute = data.get("execute") if type(data) is dict else None
    if type(execute) is not list:  # no entry loop: the stages over the whole document
        problems = sorted(set(value_problems(data)), key=by_place)
        if problems:
            raise InvalidTestCase(problems, source)
        _raise_shape(data, source, registry, entries, rest=None, items=[])  # no execute array: the schema says why
        raise AssertionError("unreachable: a document without an execute array breaks the schema")
    entries.default_join = data.get("join", DEFAULT_JOIN)
    entries.add_all(execute)
    rest = {k: v for k, v in data.items() if k != "execute"}
    if not entries.ids_valid():  # an id breaking the pattern, or naming one that does: words needed
        unsure = entries.unsure()
        entries.later = [(i, raw) for i, raw in entries.later if i not in unsure]
        entries.doubtful.extend((i, execute[i]) for i in sorted(unsure))
        for i in unsure:
            entries.entries[i] = None
    if entries.doubtful or suspicious(rest):  # stage 0, where its condition failed (the other entries passed it in the loop)
        problems = [*value_problems(rest), *(p for i, raw in entries.doubtful for p in value_problems(raw, ("execute", i)))]
        if problems:
            raise InvalidTestCase(sorted(set(problems), key=by_place), source)
    if not execute or not rest_fits({**rest, "execute": [STAND_IN]}):
        _raise_shape(data, source, registry, entries, rest, execute)
    problems = [p for i, raw in sorted(entries.doubtful, key=_first) for p in _entry_shape(i, raw)]
    if problems:  # stage 1, the entries only
        _raise_with_leaves(problems, data, source, registry, entries)
    checker = Checker(data, registry, source, system)
    return _meaning(data, rest, entries, checker, registry, source, execute)


def _first(item: tuple[int, Any]) -> int:
    return item[0]


def _entry_shape(i: int, raw: Any) -> list[Problem]:
    """Entry *i*'s shape problems: its sub-schema's errors, in the words of the whole schema's."""
    return list(described(entry_validator().iter_errors(raw), raw, ("execute", i)))


def _raise_shape(data: Any, source: str, registry: Registry, entries: Entries, rest: dict[str, Any] | None,
                 items: list[Any]) -> None:  # fmt: skip
    """Stage 1 over the whole document (the entries that passed the loop replaced by a stand-in); raises
    if it finds a problem."""
    if rest is not None and items:
        left = {i for i, _ in [*entries.doubtful, *entries.later]}
        data = {**data, "execute": [raw if i in left else STAND_IN for i, raw in enumerate(items)]}
    problems = list(schema_problems(data))
    if problems:
        _raise_with_leaves(problems, data, source, registry, entries)


def _raise_with_leaves(problems: list[Problem], data: Any, source: str, registry: Registry, entries: Entries) -> None:
    """Raise the shape *problems* with the params problems of the well-formed entries and criteria."""
    found = set(problems)
    if isinstance(data, dict):  # the params of well-formed entries in the same round
        # only the parts it reads: the rest of the document may have any shape now (fuzz finding:
        # "signals" as a list crashed the checker's set-up)
        early = Checker({k: data[k] for k in ("execute", "oracle") if k in data}, registry, source)
        early.leaves_alongside_shape(sorted([*entries.doubtful, *entries.later], key=_first))
        found.update(early.problems)
    raise InvalidTestCase(sorted(found, key=by_place), source)


def _meaning(data: Mapping[str, Any], rest: Mapping[str, Any], entries: Entries, checker: Checker, registry: Registry,
             source: str, items: list[Any] | None = None) -> TestCase:  # fmt: skip
    """Stage 2, and the case. *items*: the raw entries (with words), or None (read entry by entry: no words,
    every problem raises :class:`NotStreamed`)."""
    checker.check_system()
    checker.check_signals()
    checker.check_limits()
    raw_criteria = rest.get("oracle", {}).get("criteria", [])
    criteria_ids = [c["id"] for c in raw_criteria]
    shared = len(set(criteria_ids)) != len(criteria_ids) or not entries.ids.isdisjoint(criteria_ids)
    join = data.get("join", DEFAULT_JOIN)
    entries.set_join(join)
    built = entries.entries
    if items is None:
        if checker.problems or shared or not entries.after_known():
            raise NotStreamed
        todo = entries.later
    else:
        if entries.doubtful or shared:
            entries.duplicate_ids(checker, items, raw_criteria)
        left = {i for i, _ in [*entries.doubtful, *entries.later]}
        if not entries.after_known():  # an 'after' naming an entry further down the file that is not there
            ids = entries.ids
            left.update(e.index for e in built if e is not None and e.after and not ids.issuperset(e.after))
        todo = [(i, items[i]) for i in sorted(left)]
    execute_ids = {raw["id"] for raw in items} if items is not None and todo else set()
    for i, raw in todo:  # entries the loop left to the end: checked and built with words
        after = entries.after(checker, i, raw, execute_ids, set(criteria_ids)) if items is not None else (
            tuple(raw["after"]) if raw.get("after") else ())  # fmt: skip
        built[i] = entries.entry(checker, i, raw, after, join)
    criteria = checker.criteria()
    done: list[Entry] = built  # type: ignore[assignment]
    if items is None:
        if checker.problems:
            raise NotStreamed
        if entries.forward:
            checker.cycles(done)
            if checker.problems:
                raise NotStreamed
    elif (entries.forward or todo) and not any(p.cause == "graph" for p in checker.problems):
        checker.cycles(done)  # (entries built in the loop whose 'after' points up the file make no cycle)
    if not checker.problems:
        done, stop = finish_control(checker, done, data)
        if checker.problems and items is None:
            raise NotStreamed
    if checker.problems:
        raise InvalidTestCase(sorted(set(checker.problems), key=by_place), source)
    return build_case(data, done, criteria, checker.spec, registry, source, stop)
