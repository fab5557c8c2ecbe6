"""The control-flow keys of the case language, checked and built: an entry's ``when``, ``edge``, ``delay``,
``timeout``, ``attempts``, ``repeat``, ``stops``, ``race`` and the case's top-level ``stop``
(docs/format.md#control-flow).

Like the other rules of the loader, each is a cheap condition (:func:`control_fits`, run in the entry
loop for the entries that carry a key) and its words: the schema's own for a value of the wrong shape
(``attempts: 0``, ``edge: "up"``), and here, at the key's JSON pointer, what a schema cannot say - a
``when`` naming an unknown signal (with "did you mean"), ``stops`` naming an unknown id or the entry
itself, a race of one entry, ``repeat`` on a race member (a member's success ends the race: it cannot
run again).

An entry's state reads, in a ``when`` or a ``stop``, as the boolean signal ``<id>.<state>``
(:data:`~btgen_pytrees.model.STATES`); an entry whose states are read is marked ``watched`` so its node
publishes them.
"""

from __future__ import annotations

import math
import re
from dataclasses import replace
from typing import Any, Mapping

from ..errors import PathPart
from ..expressions import Expression, ExpressionError, parse
from ..model import EDGES, STATES, Control, Entry, StopCondition
from .context import Checker
from .values import SURROGATE
from .words import shown, suggest

__all__ = ["CONTROL_KEYS", "control_fits", "control_key", "entry_control", "finish_control"]

CONTROL_KEYS = ("when", "edge", "delay", "timeout", "attempts", "repeat", "stops", "race")
"""An entry's control-flow keys, in the order docs/format.md lists them."""

_ID = re.compile(r"[A-Za-z_][A-Za-z0-9_-]{0,63}").fullmatch
_MOST = 1_000_000  # the schema's maximum of attempts and repeat


def _number(value: Any) -> bool:
    return type(value) in (int, float) and math.isfinite(value)


def _count(value: Any) -> bool:
    """An integer as JSON Schema says (``2.0`` is one), within 1 .. the schema's maximum."""
    return _number(value) and value == int(value) and 1 <= value <= _MOST


def control_fits(raw: Mapping[str, Any]) -> int:
    """How many control keys *raw* carries if each has the shape the schema gives it, else -1.

    The entry loop's cheap condition (:meth:`~.entries.Entries.add_all`): an entry that fails it is
    worded by the schema itself.
    """
    found = 0
    for key in CONTROL_KEYS:
        if key not in raw:
            continue
        value = raw[key]
        found += 1
        if key == "when":
            ok = type(value) is str and 1 <= len(value) <= 1000 and not SURROGATE.search(value)
        elif key == "edge":
            ok = type(value) is str and value in EDGES
        elif key == "delay":
            ok = _number(value) and value >= 0
        elif key == "timeout":
            ok = _number(value) and value > 0
        elif key in ("attempts", "repeat"):
            ok = _count(value)
        elif key == "stops":
            ok = type(value) is list and bool(value) and all(type(v) is str and _ID(v) for v in value)
        else:  # race
            ok = type(value) is str and bool(_ID(value))
        if not ok:
            return -1
    return found


def control_key(raw: Mapping[str, Any]) -> Any:
    """A hashable key of *raw*'s control keys and their values, for the entry loop's memo of built controls
    (:meth:`~.entries.Entries.add_all`): entries with the same keys share one :class:`Control` (it is immutable),
    checked and built once - a case writes the same few keys on many entries.

    Each value's type is part of the key, as in :func:`~.entries.params_key`: ``1``, ``1.0`` and ``True``
    are equal in Python but not to a JSON Schema. ``None`` when a value cannot be a key (a list holding a
    list or an object: checked every time).
    """
    parts = []
    for key in CONTROL_KEYS:
        if key in raw:
            value = raw[key]
            if type(value) is list:
                value = (tuple(value), tuple(map(type, value)))
            parts.append((key, type(value), value))
    found = tuple(parts)
    try:
        hash(found)
    except TypeError:
        return None
    return found


def build_control(raw: Mapping[str, Any]) -> Control | None:
    """The :class:`Control` of an entry whose control keys have the schema's shape (:func:`control_fits`); ``None``
    without any. Its ``when`` is parsed (an :class:`~btgen_pytrees.expressions.ExpressionError` if it is no
    expression); the names it reads and the ids of ``stops`` are checked with the whole document
    (:func:`finish_control`)."""
    if not any(key in raw for key in CONTROL_KEYS):
        return None
    get = raw.get
    when = get("when")
    timeout = get("timeout")
    return Control(
        when=parse(when) if when is not None else None, edge=get("edge", "none"), delay=float(get("delay", 0.0)),
        timeout=float(timeout) if timeout is not None else None, attempts=int(get("attempts", 1)),
        repeat=int(get("repeat", 1)), stops=tuple(get("stops", ())), race=get("race"),
    )  # fmt: skip


def entry_control(checker: Checker, i: int, raw: Mapping[str, Any]) -> Control | None:
    """:func:`build_control`, a bad ``when`` a problem at its pointer (the entries read with words)."""
    try:
        return build_control(raw)
    except ExpressionError as exc:
        checker.add(("execute", i, "when"), f"bad expression {shown(raw['when'])}: {exc}", "expression")
        return None


def condition(checker: Checker, text: str, path: tuple[PathPart, ...], ids: set[str]) -> Expression | None:
    """A ``when`` of an entry or a ``stop``: an expression whose names are signals a criterion may read, or an
    entry's state ``<id>.<state>``."""
    known = checker.known
    states = {name for name in _names(text) if _state_of(name, ids) is not None}
    checker.known = known | states
    try:
        return checker.expression(text, path)
    finally:
        checker.known = known


def _names(text: str) -> list[str]:
    return re.findall(r"[A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)+", text)


def _state_of(name: str, ids: set[str]) -> str | None:
    """The entry id whose state *name* reads (``A1.ended`` -> ``A1``), or None."""
    entry, dot, state = name.rpartition(".")
    return entry if dot and state in STATES and entry in ids else None


def _own_problems(checker: Checker, control: Control, path: tuple[PathPart, ...], ids: set[str],
                  by_text: dict[str, list[tuple[str, str]]]) -> list[tuple[str, str, str]]:  # fmt: skip
    """The problems of *control*'s ``when`` and ``edge`` (the same for every entry that holds it), as ``(key, message,
    cause)``; a ``when``'s text is checked once (*by_text*), at the first entry's *path*."""
    found: list[tuple[str, str, str]] = []
    if control.when is not None:
        source = control.when.source
        words = by_text.get(source)
        if words is None:
            before = len(checker.problems)
            condition(checker, source, (*path, "when"), ids)
            words = by_text[source] = [(p.message, p.cause) for p in checker.problems[before:]]
            del checker.problems[before:]
        found.extend(("when", message, cause) for message, cause in words)
    elif control.edge != "none":
        found.append(("edge", "an edge needs a 'when' to watch", "expression"))
    return found


def finish_control(checker: Checker, entries: list[Entry], data: Mapping[str, Any]) -> tuple[list[Entry], tuple[StopCondition, ...]]:
    """The checks over all entries (races), the top-level ``stop``, and the entries whose states are read marked
    ``watched``. Returns the entries (the same list when no entry has a control key) and the stop conditions."""
    raw_stop = data.get("stop") or ()
    controlled = [e for e in entries if e.control is not None]
    if not controlled and not raw_stop:
        return entries, ()
    ids = {e.id for e in entries}
    by_text: dict[str, list[tuple[str, str]]] = {}  # a when's text -> its problems (message, cause): each text once
    by_control: dict[int, list[tuple[str, str, str]]] = {}  # id of a Control -> its problems (key, message, cause)
    distinct: list[Control] = []  # each Control once (the loader shares one between entries with the same keys)
    for e in controlled:
        control = e.control
        found = by_control.get(id(control))  # type: ignore[arg-type]
        if found is None:
            distinct.append(control)  # type: ignore[arg-type]
            found = by_control[id(control)] = _own_problems(checker, control, e.path, ids, by_text)  # type: ignore[arg-type]
        for key, message, cause in found:
            checker.add((*e.path, key), message, cause)
        if control.stops:  # type: ignore[union-attr]
            seen: set[str] = set()
            for k, target in enumerate(control.stops):  # type: ignore[union-attr]
                where = (*e.path, "stops", k)
                if target == e.id:
                    checker.add(where, f"{target!r} cannot stop itself", "graph")
                elif target in seen:
                    checker.add(where, f"{target!r} is listed twice", "graph")
                elif target not in ids:
                    checker.add(where, f"unknown id {target!r}{suggest(target, ids)}", "graph")
                seen.add(target)
    stop = []
    for k, item in enumerate(raw_stop):
        when = condition(checker, item["when"], ("stop", k, "when"), ids)
        if when is not None:
            stop.append(StopCondition(when, item.get("edge", "none"), float(item.get("delay", 0.0)), k))
    races: dict[str, list[Entry]] = {}
    for e in controlled:
        if e.control.race is not None:  # type: ignore[union-attr]
            races.setdefault(e.control.race, []).append(e)  # type: ignore[union-attr]
    for name, members in races.items():
        if len(members) == 1:
            checker.add((*members[0].path, "race"), f"race {name!r} has one entry; a race needs two or more "
                        f"(entries with the same 'race'){suggest(name, races)}", "graph")  # fmt: skip
        for e in members:
            if e.control.repeat > 1:  # type: ignore[union-attr]
                checker.add((*e.path, "repeat"), f"{e.id!r} runs in race {name!r}: its success ends the race, so it "
                            "cannot repeat (use 'attempts' to retry a failure)", "graph")  # fmt: skip
    watched = {_state_of(name, ids) for c in distinct if c.when is not None for name in c.when.names} | {
        _state_of(name, ids) for s in stop for name in s.when.names}  # fmt: skip
    watched.discard(None)
    stopped = {target for c in distinct for target in c.stops}
    if watched or stopped:  # they need the node that publishes states and honours stop requests
        entries = [replace(e, control=replace(e.control or Control(), watched=e.id in watched or (e.control is not None and e.control.watched)))
                   if e.id in watched or e.id in stopped else e for e in entries]  # fmt: skip
    return entries, tuple(stop)
