"""Parameters from the command line: ``--set NAME=VALUE`` and ``--params FILE.json``.

``run``/``show``/``expand`` of a parameterised case (a sweep or not) with
``--set limit=25 --set top_speed=30`` or ``--params chosen.json`` (a JSON object
``{"limit": 25}``) work on *one* variation: the given parameters take the given
values, every other parameter its default from the ``parameters`` block, and the
``variations`` block is left out. ``--set`` wins over ``--params`` for a name
given by both.

Each given value is checked as a sweep's values are: the name must be declared
in ``parameters`` (otherwise "did you mean"), and the value must have its
default's type - ``true``/``false`` for a boolean default, a number for a number
(``--set`` reads ``VALUE`` as JSON: ``25``, ``2.5``, ``true``). The concrete
case is then validated like the sweep's defaults, and named after the values it
ran with, ``fig1_sweep[top_speed=30,limit=25,ramp_time=2]``, so the table, the
JSON report and the JUnit XML say which parameters were used.

>>> data = {"name": "s", "parameters": {"d": 1, "on": True}, "variations": {"d": [1, 2]},
...         "execute": [{"id": "A", "kind": "behavior", "action": "hold", "params": {"duration": "$d"}}]}
>>> chosen = choose(data, "s.json", given_values({"d": 3}))
>>> chosen.document["name"], chosen.document["execute"][0]["params"]
('s[d=3,on=true]', {'duration': 3})
>>> choose(data, "s.json", given_values({"dd": 3}))
Traceback (most recent call last):
...
btgen_pytrees.sweep.overrides.ParameterError: --set dd=3: unknown parameter 'dd' (did you mean 'd'?)
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

from ..errors import InvalidTestCase, Problem, UserError, shorten
from ..leaves import Registry
from ..load.read import load_json
from ..text import closest
from ..load.sweep import load_sweep
from ..load.template import rendered
from ..load.values import value_problems
from ..load.variations import Value, format_value, label

__all__ = ["Given", "Chosen", "ParameterError", "parse_set", "given_values", "read_params", "choose", "variation_name"]

MAX_NAME = 200
"""A case name's longest (the schema's ``maxLength``); a longer ``name[label]`` has its label shortened."""


class ParameterError(UserError, ValueError):
    """Given parameters that cannot be used (unknown, wrong type, malformed): one message per line."""

    def __init__(self, lines: Sequence[str]):
        super().__init__("\n".join(lines))
        self.lines = list(lines)

    def messages(self) -> list[str]:
        return self.lines


@dataclass(frozen=True)
class Given:
    """A value given for a parameter, and where it was given (for messages)."""

    value: Any
    origin: str


@dataclass(frozen=True)
class Chosen:
    """One variation chosen on the command line.

    Attributes:
        values: every parameter's value (given or default), in the ``parameters`` block's order
        given: the parameters given, with their values
        document: the concrete case (no ``parameters``/``variations``), named ``name[label]``
    """

    values: dict[str, Value]
    given: dict[str, Value]
    document: dict[str, Any]


def variation_name(name: str, shown: str) -> str:
    """``name[label]``, the name of one variation of the case *name*: in reports, JUnit and the case files
    ``expand`` and ``falsify --out-dir`` write. A long label is shortened in its middle to fit :data:`MAX_NAME`.

    >>> variation_name("fig1_sweep", "top_speed=30,limit=25")
    'fig1_sweep[top_speed=30,limit=25]'
    """
    if not shown:
        return name
    if len(name) + len(shown) + 2 > MAX_NAME:
        shown = shorten(shown, max(MAX_NAME - len(name) - 2, 10))
    return f"{name}[{shown}]"[:MAX_NAME]


def _no_constant(name: str) -> Any:
    raise ValueError(name)


def _number(text: str) -> int | float:
    """A JSON integer; one too long for Python's ``int`` (over 4,300 digits) as a float (``inf``), which
    the magnitude check then refuses with the loader's message."""
    try:
        return int(text)
    except ValueError:
        return float(text)


MAX_SHOWN = 40
"""Most characters of a ``--set`` value echoed in a message (a 5,000-digit value is cut in its middle)."""


def parse_set(text: str) -> tuple[str, Given]:
    """``NAME=VALUE`` (VALUE as JSON: a number, ``true`` or ``false``) as ``(name, given)``; messages echo
    the option as it was typed (``--set x=1e400``, not the float it reads as), shortened."""
    name, equals, raw = text.partition("=")
    name = name.strip()
    if not equals or not name:
        raise ParameterError([f"--set {shorten(text, MAX_SHOWN)}: expected NAME=VALUE, e.g. --set gap=4"])
    origin = f"--set {shorten(name, MAX_SHOWN)}={shorten(raw.strip(), MAX_SHOWN)}"
    try:
        value = json.loads(raw, parse_constant=_no_constant, parse_int=_number)
    except (ValueError, RecursionError):
        raise ParameterError([f"{origin}: {shorten(raw.strip(), MAX_SHOWN)!r} is not a number, true or false"]) from None
    return name, Given(value, origin)


def given_values(values: Mapping[str, Any], origin: str = "--set") -> dict[str, Given]:
    """*values* as given on the command line (``--set name=value`` in messages) or in a file."""
    return {name: Given(value, f"{origin} {name}={json.dumps(value)}" if origin == "--set" else f"{origin}: /{name}")
            for name, value in values.items()}  # fmt: skip


def read_params(path: str) -> dict[str, Given]:
    """``--params FILE.json``: a JSON object of parameter values (read with the loader's limits)."""
    data = load_json(path)
    if not isinstance(data, dict):
        raise InvalidTestCase([Problem((), "expected a JSON object of parameter values, e.g. {\"gap\": 4}", "json")], path)
    return given_values(data, path)


def _type_problem(value: Any, default: Value) -> str | None:
    if isinstance(default, bool):
        return None if isinstance(value, bool) else f"must be true or false, like its default ({format_value(default)})"
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        return f"must be a number, like its default ({format_value(default)})"
    return None


def check_given(given: Mapping[str, Given], defaults: Mapping[str, Value]) -> list[str]:
    """A line per given parameter that is not declared or has the wrong type."""
    lines = []
    for name, item in given.items():
        if name not in defaults:
            hint = closest(name, defaults)
            tip = (f" (did you mean '{hint}'?)" if hint is not None else f" (declared: {', '.join(defaults)})") if defaults else (
                " (the case declares no parameters)")  # fmt: skip
            lines.append(f"{item.origin}: unknown parameter '{name}'{tip}")
            continue
        bad = next(value_problems(item.value), None)  # 1e400, 1e301: the loader's bound, said at the option
        if bad is not None and not isinstance(defaults[name], bool):
            lines.append(f"{item.origin}: parameter '{name}': {bad.message}")
            continue
        problem = _type_problem(item.value, defaults[name])
        if problem:
            lines.append(f"{item.origin}: parameter '{name}' {problem}")
    return lines


def choose(data: Any, source: str, given: Mapping[str, Given], *, registry: Registry | None = None,
           system: Any = None) -> Chosen:  # fmt: skip
    """The variation of the case *data* (read from *source*) with the *given* values, validated.

    Raises:
        ParameterError: a given name is not declared or its value has the wrong type
        InvalidTestCase: the case (with those values) is not valid
    """
    front = rendered(data)
    if front is not None:  # an OpenSCENARIO distribution: its varied parameters, the scenario converted with them
        defaults: dict[str, Value] = dict(data.defaults)
        problems = check_given(given, defaults)
        if problems:
            raise ParameterError(problems)
        values = {**defaults, **{name: item.value for name, item in given.items()}}
        document = front(values)
        load_sweep(document, registry=registry, source_name=source, system=system, check_all=False)  # valid, or raises
        document["name"] = variation_name(os.path.splitext(os.path.basename(source))[0],
                                          label(tuple((k, v) for k, v in values.items() if k in given)))  # fmt: skip
        return Chosen(values, {name: item.value for name, item in given.items()}, document)
    declared = data.get("parameters") if isinstance(data, dict) else None
    defaults = dict(declared) if isinstance(declared, dict) else {}
    problems = check_given(given, defaults)
    if problems:
        raise ParameterError(problems)
    values = {**defaults, **{name: item.value for name, item in given.items()}}
    single = {k: v for k, v in data.items() if k != "variations"}
    single["parameters"] = values
    sweep = load_sweep(single, registry=registry, source_name=source, system=system, check_all=False)
    document = sweep.document(values)
    name = document.get("name") if isinstance(document.get("name"), str) else os.path.basename(source)
    document["name"] = variation_name(name, label(tuple(values.items())))
    return Chosen(values, {name: item.value for name, item in given.items()}, document)
