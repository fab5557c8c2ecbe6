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

import os
from typing import Any, Mapping

from ..errors import InvalidTestCase, by_place
from ..leaves import Registry, default_registry
from ..model import TestCase
from ..contracts.system import SystemSpec
from .context import Checker
from .document import build_case
from .onepass import from_data, from_text
from .read import parse_json, read_file
from .template import nominal
from .values import value_problems
from .words import new_document, schema_problems

__all__ = ["load", "validate"]


def validate(data: Any, source: str = "<dict>", registry: Registry | None = None, system: SystemSpec | None = None) -> TestCase:
    """Check parsed JSON *data* and build the :class:`TestCase`; raise :class:`InvalidTestCase`.

    *system*, if given, replaces the case's own ``system`` (``run --system``; its
    ``config`` is used as given, so resolve it first). The case's ``options``
    are kept when *system* names the same type and gives none.
    """
    registry = registry if registry is not None else default_registry()
    case = from_data(data, source, registry, system)
    return case if case is not None else _validate(data, source, registry, system)


def _validate(data: Any, source: str, registry: Registry, system: SystemSpec | None) -> TestCase:
    """The detailed checks, stage by stage: every problem, each at its JSON path."""
    new_document()  # "did you mean" budget of this document
    problems = sorted(set(value_problems(data)), key=by_place)  # stage 0 (fuzz findings, see above)
    if problems:
        raise InvalidTestCase(problems, source)
    if type(data) is dict and ("parameters" in data or "variations" in data):
        data = nominal(data, source)  # '$name' -> the defaults (.template)
    problems = set(schema_problems(data))
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
    raw, where = read_file(source)
    registry = registry if registry is not None else default_registry()
    case = from_text(raw, os.fspath(source), registry, system)
    return case if case is not None else _validate(parse_json(raw, where), os.fspath(source), registry, system)
