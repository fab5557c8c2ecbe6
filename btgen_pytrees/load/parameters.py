"""Parameters: ``$name`` in a test case, replaced by a value before validation.

A case declares named defaults, ``"parameters": {"gap": 20, "cautious": true}``,
and refers to them as ``$gap``:

* a string that is exactly ``"$gap"`` stands for the value itself (a number or
  a boolean) - in ``tick``, ``timeout``, ``signals`` values, anywhere inside an
  entry's or a criterion's ``params``, and in a criterion's ``from``/``to``/``at``;
* inside a longer string of those places, and in a criterion's ``expect``,
  ``$gap`` is replaced by the value's text (``ego_gap > $gap`` becomes
  ``ego_gap > 20``; a negative value is parenthesised, ``(-5)``, so
  ``a - $x`` stays ``a - (-5)``); ``$$`` is a literal ``$``.

Elsewhere (``name``, ``id``, ``description``, ...) a ``$`` is just a character.
The reference *sites* are found once per file (:func:`find_sites`), so an
undeclared name is one problem at one JSON path however many variations there
are; each variation then only rebuilds the containers on the way to its sites
(:func:`substitute`), sharing everything else with the template.

Substitution does not check types: the substituted document goes through the
loader like any test case, so ``"duration": "$flag"`` with a boolean ``flag``
is the loader's "true is not of type 'number'" at ``/execute/0/params/duration``.

>>> doc = {"tick": "$dt", "execute": [{"id": "A", "kind": "constraint", "action": "until",
...        "params": {"expect": "gap > $min_gap && $$ok", "timeout": "$t"}}]}
>>> sites, problems = find_sites(doc, {"dt": 0.1, "min_gap": -5, "t": 2})
>>> problems
[]
>>> substitute(doc, sites, {"dt": 0.1, "min_gap": -5, "t": 2})["execute"][0]["params"]
{'expect': 'gap > (-5) && $ok', 'timeout': 2}
>>> find_sites({"timeout": "$tmeout"}, {"timeout_s": 5})[1][0].message
"undeclared parameter '$tmeout' (did you mean '$timeout_s'?)"
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any, Iterator, Mapping

from ..errors import PathPart, Problem
from ..text import closest
from .variations import Value, format_value

__all__ = ["Site", "find_sites", "substitute", "REFERENCE"]

REFERENCE = re.compile(r"\$(\$|[A-Za-z_][A-Za-z0-9_]*)")
"""``$name``, or ``$$`` for a literal ``$``."""

_WHOLE = re.compile(r"\$([A-Za-z_][A-Za-z0-9_]*)")


@dataclass(frozen=True)
class Site:
    """A string in the document that refers to parameters.

    Attributes:
        path: where, from the document root
        text: the string as written
        whole: the string is exactly ``$name`` (replaced by the typed value)
    """

    path: tuple[PathPart, ...]
    text: str
    whole: bool


def _strings(node: Any, path: tuple[PathPart, ...]) -> Iterator[tuple[tuple[PathPart, ...], str]]:
    """Every string under *node* (values only, not keys), with its path; iterative."""
    stack = [(path, node)]
    while stack:
        where, item = stack.pop()
        if isinstance(item, str):
            yield where, item
        elif isinstance(item, dict):
            stack.extend(((*where, k), v) for k, v in reversed(list(item.items())))
        elif isinstance(item, list):
            stack.extend(((*where, i), v) for i, v in reversed(list(enumerate(item))))


def _candidates(doc: Mapping[str, Any]) -> Iterator[tuple[tuple[PathPart, ...], str, bool]]:
    """``(path, string, typed)`` for each string where a reference is allowed.

    *typed*: a whole ``$name`` there becomes the value; otherwise (``expect``) always text.
    """
    for key in ("tick", "timeout"):
        if isinstance(doc.get(key), str):
            yield (key,), doc[key], True
    signals = doc.get("signals")
    if isinstance(signals, dict):
        for name, value in signals.items():
            if isinstance(value, str):
                yield ("signals", name), value, True
    execute = doc.get("execute")
    for i, entry in enumerate(execute if isinstance(execute, list) else ()):
        if isinstance(entry, dict) and "params" in entry:
            for path, text in _strings(entry["params"], ("execute", i, "params")):
                yield path, text, True
        if isinstance(entry, dict):  # the control keys (docs/format.md#control-flow): numbers, and a when's text
            for key in ("delay", "timeout", "attempts", "repeat"):
                if isinstance(entry.get(key), str):
                    yield ("execute", i, key), entry[key], True
            if isinstance(entry.get("when"), str):
                yield ("execute", i, "when"), entry["when"], False
    stop = doc.get("stop")
    for i, item in enumerate(stop if isinstance(stop, list) else ()):
        if isinstance(item, dict):
            if isinstance(item.get("delay"), str):
                yield ("stop", i, "delay"), item["delay"], True
            if isinstance(item.get("when"), str):
                yield ("stop", i, "when"), item["when"], False
    oracle = doc.get("oracle")
    criteria = oracle.get("criteria") if isinstance(oracle, dict) else None
    for i, crit in enumerate(criteria if isinstance(criteria, list) else ()):
        if not isinstance(crit, dict):
            continue
        for key in ("from", "to", "at"):
            if isinstance(crit.get(key), str):
                yield ("oracle", "criteria", i, key), crit[key], True
        if isinstance(crit.get("expect"), str):
            yield ("oracle", "criteria", i, "expect"), crit["expect"], False
        if "params" in crit:
            for path, text in _strings(crit["params"], ("oracle", "criteria", i, "params")):
                yield path, text, True


def find_sites(doc: Mapping[str, Any], declared: Mapping[str, Any]) -> tuple[list[Site], list[Problem]]:
    """The strings of *doc* that refer to parameters, and a problem per undeclared reference."""
    sites, problems = [], []
    for path, text, typed in _candidates(doc):
        if "$" not in text:
            continue
        names = [m.group(1) for m in REFERENCE.finditer(text)]
        if not names:
            continue
        for name in dict.fromkeys(n for n in names if n != "$" and n not in declared):
            hint = closest(name, declared)
            tip = f" (did you mean '${hint}'?)" if hint is not None else (
                f" (declared: {', '.join('$' + d for d in declared)})" if declared else " (no parameters are declared)")
            problems.append(Problem(path, f"undeclared parameter '${name}'{tip}", "parameter"))
        sites.append(Site(path, text, typed and _WHOLE.fullmatch(text) is not None))
    return sites, problems


def _text(value: Value) -> str:
    shown = format_value(value)
    return f"({shown})" if shown.startswith("-") else shown


def _replace(site: Site, values: Mapping[str, Value]) -> Any:
    if site.whole:
        return values[site.text[1:]]
    return REFERENCE.sub(lambda m: "$" if m.group(1) == "$" else _text(values[m.group(1)]), site.text)


def substitute(doc: Mapping[str, Any], sites: list[Site], values: Mapping[str, Value]) -> dict[str, Any]:
    """A copy of *doc* with every site replaced; containers off the sites' paths are shared."""
    out: dict[str, Any] = dict(doc)
    copied: set[tuple[PathPart, ...]] = {()}
    for site in sites:
        node: Any = out
        for depth, part in enumerate(site.path[:-1]):
            prefix = site.path[: depth + 1]
            child = node[part]
            if prefix not in copied:
                child = dict(child) if isinstance(child, dict) else list(child)
                node[part] = child
                copied.add(prefix)
            node = child
        node[site.path[-1]] = _replace(site, values)
    return out
