"""A parameterised test case: a template, its parameters and its variations.

Two entry points:

* :func:`nominal` - what :func:`btgen_pytrees.load` does with a file that has
  ``parameters`` or ``variations``: check both blocks and every ``$name``,
  substitute the *defaults*, and return a concrete document for the usual
  checks. So ``show``/``validate``/``run`` of such a file with its defaults
  behave as for any case, and the defaults must themselves make a valid case.
* :func:`load_sweep` - for ``run``/``expand``/``validate`` of a sweep: the
  above, then the variation count against the limit (by arithmetic, before
  anything is built), then *every* variation substituted and validated.
  A problem that several variations share is reported once, naming how many
  variations have it and the first one.

>>> sweep = load_sweep({"name": "s", "parameters": {"d": 1},
...     "variations": {"d": {"from": 1, "to": 3, "step": 1}},
...     "execute": [{"id": "A", "kind": "behavior", "action": "hold", "params": {"duration": "$d"}}]})
>>> [(v.label, v.document["execute"][0]["params"]) for v in sweep]
[('d=1', {'duration': 1}), ('d=2', {'duration': 2}), ('d=3', {'duration': 3})]
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any, Iterator, Mapping

from ..errors import InvalidTestCase, Problem, by_place
from ..leaves import Registry, default_registry
from .check import collision_problems, count_problem, meaning_problems, shape_problems
from .parameters import REFERENCE, find_sites, substitute
from .variations import Point, Value, Variations, label

__all__ = ["MAX_VARIATIONS", "Sweep", "Variation", "is_parameterised", "has_variations", "nominal", "load_sweep"]

MAX_VARIATIONS = 10_000
"""Most variations one sweep may have unless raised (``--max-variations``); checked before any run."""


def is_parameterised(data: Any) -> bool:
    """Whether *data* needs this module: it has ``parameters`` or ``variations``."""
    return type(data) is dict and ("parameters" in data or "variations" in data)


def has_variations(data: Any) -> bool:
    """Whether *data* is a sweep (a ``variations`` block), i.e. ``run`` runs many cases."""
    return type(data) is dict and "variations" in data


@dataclass(frozen=True)
class Variation:
    """One concrete case of a sweep.

    Attributes:
        index: position in the sweep's order (0-based)
        point: the varied parameters' values, as ``((name, value), ...)``
        values: every parameter's value (defaults overridden by *point*)
        document: the concrete test case (see :meth:`Sweep.document`)
    """

    index: int
    point: Point
    values: Mapping[str, Value]
    document: Mapping[str, Any]

    @property
    def label(self) -> str:
        """``gap=5,speed=10``."""
        return label(self.point)


class Sweep:
    """A checked parameterised case; iterating gives its :class:`Variation` objects in order."""

    def __init__(self, data: Mapping[str, Any], source: str):
        self.source = source
        self.name: str = data["name"] if isinstance(data.get("name"), str) else ""
        self.defaults: dict[str, Value] = dict(data.get("parameters", {}))
        self.variations = Variations.parse(data.get("variations"))
        self.template = {k: v for k, v in data.items() if k not in ("variations", "search")}
        self.search: Mapping[str, Any] | None = data.get("search")
        """The ``search`` block (``falsify``'s settings), kept out of every variation's document."""
        # a case without parameters keeps every '$' as written, as it always has
        self.sites, self.problems = find_sites(self.template, self.defaults) if is_parameterised(data) else ([], [])

    @property
    def count(self) -> int:
        return self.variations.count

    @property
    def varied(self) -> tuple[str, ...]:
        """The varied parameters, in label order (``sample`` included for random sweeps)."""
        grid = tuple(a.name for a in self.variations.grid)
        randoms = tuple(a.name for a in self.variations.randoms)
        return grid + (("sample",) + randoms if randoms else ())

    def document(self, values: Mapping[str, Value]) -> dict[str, Any]:
        """The concrete case for *values*: no ``$name`` left, no ``parameters``/``variations`` block.

        Without ``parameters`` the result is a plain case, so a literal ``$`` (written ``$$``)
        stays literal when it is loaded again.
        """
        doc = substitute(self.template, self.sites, values)
        doc.pop("parameters", None)
        return doc

    def __iter__(self) -> Iterator[Variation]:
        for index, point in enumerate(self.variations.points()):
            values = {**self.defaults, **{k: v for k, v in point if k != "sample"}}
            yield Variation(index, point, values, self.document(values))


def _prepare(data: Mapping[str, Any], source: str) -> Sweep:
    problems = shape_problems(data)
    if problems:
        raise InvalidTestCase(problems, source)
    sweep = Sweep(data, source)
    used = {name for site in sweep.sites for name in _names(site.text)}
    problems = sorted(set(sweep.problems) | set(meaning_problems(data, used)), key=by_place)
    if problems:
        raise InvalidTestCase(problems, source)
    return sweep


def _names(text: str) -> set[str]:
    return {m.group(1) for m in REFERENCE.finditer(text)}


def nominal(data: dict[str, Any], source: str) -> dict[str, Any]:
    """The concrete document for the defaults; raises :class:`InvalidTestCase` for the blocks' problems."""
    sweep = _prepare(data, source)
    return sweep.document(sweep.defaults)


def load_sweep(source: str | os.PathLike[str] | Mapping[str, Any], *, registry: Registry | None = None,
               max_variations: int = MAX_VARIATIONS, check_all: bool = True, source_name: str | None = None,
               system: Any = None, max_work: int | None = None) -> Sweep:  # fmt: skip
    """Load a sweep and check it completely before anything runs.

    Args:
        max_variations: the limit (:data:`MAX_VARIATIONS` by default)
        check_all: validate every variation (else only the template and the defaults)
        source_name: the file name for messages when *source* is already parsed data
        system: replaces the case's ``system`` (``run --system``), as for :func:`btgen_pytrees.load`
        max_work: the work budget each variation's run must fit (default :data:`~btgen_pytrees.loader.MAX_WORK`)

    Raises:
        InvalidTestCase: the template's, the limit's and every variation's problems.
    """
    from ..loader import load_json, value_problems

    if isinstance(source, Mapping):
        data, name = source, source_name or "<dict>"
    else:
        name = os.fspath(source)
        data = load_json(name)
    registry = registry if registry is not None else default_registry()
    if not isinstance(data, dict):
        from ..loader import validate

        validate(data, name, registry, system)  # raises: not an object
    problems = sorted(set(value_problems(data)), key=by_place)  # the loader's stage 0
    if problems:
        raise InvalidTestCase(problems, name)
    sweep = _prepare(data, name) if is_parameterised(data) else Sweep(data, name)
    too_many = count_problem(data, max_variations)
    if too_many is not None:
        raise InvalidTestCase([too_many], name)
    collisions = list(collision_problems(data)) if has_variations(data) else []
    if collisions:
        raise InvalidTestCase(collisions, name)
    _check_variations(sweep, registry, check_all, system, max_work)
    return sweep


_MAX_DISTINCT = 1000
"""Most distinct problems :func:`load_sweep` collects over all variations."""


def _check_variations(sweep: Sweep, registry: Registry, every: bool, system: Any = None,
                      max_work: int | None = None) -> None:  # fmt: skip
    """Validate the defaults' case and every variation; each distinct problem once.

    A problem all variations share is reported as it is; one that only some have
    (or only the defaults) says how many and names the first.
    """
    from ..loader import MAX_WORK, check_work, validate

    seen: dict[Problem, tuple[int, str | None, bool]] = {}  # problem -> (variations with it, the first, the defaults too)
    defaults = sweep.document(sweep.defaults) if sweep.sites or "parameters" in sweep.template else sweep.template
    budget = MAX_WORK if max_work is None else max_work

    def check(document: Mapping[str, Any], label_: str | None) -> None:
        try:
            check_work(validate(document, sweep.source, registry, system), budget)
        except InvalidTestCase as error:
            for problem in error.problems:
                if problem not in seen and len(seen) >= _MAX_DISTINCT:
                    continue  # the CLI prints at most 100; a problem naming each variation's value stays bounded
                count, first, with_defaults = seen.get(problem, (0, None, False))
                if label_ is None:
                    seen[problem] = (count, first, True)
                else:
                    seen[problem] = (count + 1, first if first is not None else label_, with_defaults)

    check(defaults, None)
    if every:  # one variation at a time: a million of them never live at once (issue 20 item 13)
        for variation in sweep:
            check(variation.document, variation.label)
    if not seen:
        return
    problems = []
    for problem, (count, first, _) in seen.items():
        if every and count < sweep.count:
            if not count:
                where = "with the defaults"
            elif count == 1:
                where = f"in variation: [{first}]"
            else:
                where = f"in {count} of {sweep.count} variations: [{first}], ..."
            problem = Problem(problem.path, f"{problem.message} ({where})", problem.cause)
        problems.append(problem)
    raise InvalidTestCase(sorted(problems, key=by_place), sweep.source)
