"""A parameterised test case: the ``parameters`` and ``variations`` blocks checked, the template, its variations.

The blocks are checked before anything is substituted, like a test case in two stages: their
*shape* (the ``parameters``/``variations`` parts of the test-case schema) and then their
*meaning* - a varied parameter is declared and used, list values are unique
and of the default's type (boolean or number), a range runs upwards, a random
draw has ``samples``, the count is within the limit. Problems carry the JSON
path and the cause ``parameter`` (``limit`` for the count).

:func:`nominal` is what :func:`btgen_pytrees.load` does with a file that has
``parameters`` or ``variations``: check both blocks and every ``$name``,
substitute the *defaults*, and return a concrete document for the usual
checks. So ``show``/``validate``/``run`` of such a file with its defaults
behave as for any case, and the defaults must themselves make a valid case.
:func:`btgen_pytrees.load.sweep.load_sweep` checks every variation too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Iterator, Mapping

from ..errors import InvalidTestCase, PathPart, Problem, by_place
from ..text import did_you_mean, shorten
from ..validator import SchemaValidator
from .parameters import REFERENCE, find_sites, substitute
from .schema import inline_refs, schema
from .variations import BLOCK_KEYS, RANGE_EPSILON, Point, Value, Variations, format_value, label

__all__ = ["shape_problems", "meaning_problems", "count_problem", "collision_problems", "axis_size",
           "MAX_VARIATIONS", "Sweep", "Variation", "is_parameterised", "has_variations", "prepare", "nominal", "rendered"]



@lru_cache(maxsize=1)
def _validator() -> SchemaValidator:
    root = schema()
    blocks = {"type": "object", "properties": {k: root["properties"][k] for k in ("parameters", "variations", "search")}}
    return SchemaValidator(inline_refs(blocks, root))


def shape_problems(doc: Mapping[str, Any]) -> list[Problem]:
    """Schema problems of the three blocks (``search`` is falsify's; the rest of the document is checked after substitution)."""
    blocks = {k: doc[k] for k in ("parameters", "variations", "search") if k in doc}
    problems = []
    for error in _validator().iter_errors(blocks):
        path: tuple[PathPart, ...] = tuple(error.absolute_path)
        description = error.schema.get("description") if isinstance(error.schema, dict) else None
        if error.validator in ("not", "pattern") and isinstance(error.instance, str) and path[:1] == ("parameters",):
            # propertyNames: jsonschema points at the object; point at the bad key
            problems.append(Problem((*path, error.instance), shorten(f"{error.instance!r} is not valid: expected {description}", keep_end=False), "parameter"))
        elif error.validator == "anyOf" and description:
            problems.append(Problem(path, shorten(f"not valid: expected {description}", keep_end=False), "parameter"))
        else:
            problems.append(Problem(path, shorten(error.message, keep_end=False), "parameter"))
    return list(dict.fromkeys(problems))


def axis_size(spec: Any) -> float:
    """Values of a list or range (``inf`` if the range is too long to count; 1 for a random draw)."""
    if isinstance(spec, list):
        return len(spec)
    if "step" not in spec:
        return 1
    steps = (spec["to"] - spec["from"]) / spec["step"]
    return math.floor(steps + RANGE_EPSILON) + 1 if math.isfinite(steps) else math.inf


def meaning_problems(doc: Mapping[str, Any], used: set[str]) -> Iterator[Problem]:
    """What the schema cannot say about a shape-valid ``variations`` block.

    *used*: the parameter names some ``$name`` in the document refers to.
    """
    declared: Mapping[str, Any] = doc.get("parameters", {})
    block: Mapping[str, Any] | None = doc.get("variations")
    if block is None:
        return
    axes = {k: v for k, v in block.items() if k not in BLOCK_KEYS}
    if not axes:
        yield Problem(("variations",), "names no parameter to vary", "parameter")
    randoms = [k for k, v in axes.items() if isinstance(v, dict) and ("uniform" in v or "normal" in v)]
    for name, spec in axes.items():
        path: tuple[PathPart, ...] = ("variations", name)
        if name not in declared:
            yield Problem(path, f"{name!r} is not a declared parameter{did_you_mean(name, declared)}; "
                                f"declare it with its default under 'parameters'", "parameter")  # fmt: skip
            continue
        if name not in used:
            yield Problem(path, f"'${name}' is used nowhere, so varying it changes nothing", "parameter")
        boolean = isinstance(declared[name], bool)
        kind = "a boolean" if boolean else "a number"
        if isinstance(spec, list):
            seen: set[Any] = set()
            for i, value in enumerate(spec):
                if isinstance(value, bool) != boolean:
                    yield Problem((*path, i), f"{value!r} is not {kind} like the default of {name!r}", "parameter")
                elif (type(value) is bool, value) in seen:
                    yield Problem((*path, i), f"{value!r} is listed twice", "parameter")
                seen.add((type(value) is bool, value))
            continue
        if boolean:
            yield Problem(path, f"{name!r} is a boolean: vary it with a list, e.g. [false, true]", "parameter")
        elif "step" in spec and spec["to"] < spec["from"]:
            yield Problem((*path, "to"), f"'to' ({spec['to']}) is less than 'from' ({spec['from']})", "parameter")
        elif "uniform" in spec and not spec["uniform"][0] < spec["uniform"][1]:
            yield Problem((*path, "uniform"), "the lower bound must be less than the upper bound", "parameter")
        elif "normal" in spec and spec["normal"][1] < 0:
            yield Problem((*path, "normal", 1), "the standard deviation must not be negative", "parameter")
    if randoms and "samples" not in block:
        yield Problem(("variations",), f"random parameters ({', '.join(randoms)}) need \"samples\": N", "parameter")
    for key in BLOCK_KEYS:
        if key in block and not randoms:
            yield Problem(("variations", key), f"{key!r} applies to random parameters (uniform/normal) only; there are none", "parameter")


def count_problem(doc: Mapping[str, Any], limit: int) -> Problem | None:
    """The variation count against *limit*, by arithmetic on a meaning-valid block."""
    if rendered(doc) is not None:  # the product the front end's file defines, before anything is filtered
        total = doc.scenario_variations.total  # type: ignore[attr-defined]
        if total > limit:
            return Problem(("variations",), f"{total:,} variations; the limit is {limit:,} (raise it with --max-variations)", "limit")
        return None
    variations = Variations.parse(doc.get("variations"))
    sizes = [axis_size(a.spec) for a in variations.grid]
    count = math.prod(sizes) * (variations.samples if variations.randoms else 1)
    if count > limit:
        shown = "too many" if not math.isfinite(count) else f"{count:,}" if count < 10**15 else f"about {float(count):.3g}"
        return Problem(("variations",), f"{shown} variations; the limit is {limit:,} (raise it with --max-variations)", "limit")
    return None


def collision_problems(doc: Mapping[str, Any]) -> Iterator[Problem]:
    """Ranges whose step is finer than their values keep (a count-checked block).

    Range values are computed as ``round(from + k * step, 12)`` in floating point, so a step
    below about 1e-12, or below the floating-point spacing at the range's magnitude (``from:
    1e20, step: 1``), gives equal values for different *k*: several variations would run the
    same case under different labels. Such a range is refused, naming the first two values
    that collide. A step well above both spacings cannot collide and is not scanned.
    """
    if rendered(doc) is not None:
        return
    for axis in Variations.parse(doc.get("variations")).grid:
        if axis.kind != "range" or all(isinstance(axis.spec[k], int) for k in ("from", "step")):
            continue
        step = axis.spec["step"]
        reach = 2 * max(abs(axis.spec["from"]), abs(axis.spec["to"])) + step
        if step > 8 * math.ulp(reach) + 2e-12:
            continue
        previous = axis.value(0)
        for k in range(1, axis.size()):
            value = axis.value(k)
            if value == previous:
                yield Problem(("variations", axis.name, "step"),
                              f"step {step!r} is finer than the range's values keep: values {k} and {k + 1} are both "
                              f"{format_value(value)} (values are rounded to 12 decimal places); use a larger step",
                              "parameter")  # fmt: skip
                break
            previous = value


MAX_VARIATIONS = 10_000
"""Most variations one sweep may have unless raised (``--max-variations``); checked before any run."""


def is_parameterised(data: Any) -> bool:
    """Whether *data* needs this module: it has ``parameters`` or ``variations``."""
    return (type(data) is dict or rendered(data) is not None) and ("parameters" in data or "variations" in data)


def has_variations(data: Any) -> bool:
    """Whether *data* is a sweep (a ``variations`` block), i.e. ``run`` runs many cases."""
    return (type(data) is dict or rendered(data) is not None) and "variations" in data


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
        self.render = rendered(data)
        """A front end's document of given values (an OpenSCENARIO distribution), or None."""
        if self.render is not None:  # the front end gives the defaults, the variations and each document
            self.defaults: dict[str, Value] = dict(data.defaults)  # type: ignore[attr-defined]
            self.variations: Any = data.scenario_variations  # type: ignore[attr-defined]
            self.template = {k: v for k, v in data.items() if k not in ("variations", "search")}
            self.search: Mapping[str, Any] | None = data.get("search")
            self.sites, self.problems = [], []
            return
        self.defaults = dict(data.get("parameters", {}))
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
        if self.render is not None:
            return self.render(values)  # type: ignore[no-any-return]
        doc = substitute(self.template, self.sites, values)
        doc.pop("parameters", None)
        return doc

    def __iter__(self) -> Iterator[Variation]:
        for index, point in enumerate(self.variations.points()):
            values = {**self.defaults, **{k: v for k, v in point if k != "sample"}}
            yield Variation(index, point, values, self.document(values))


def rendered(data: Any) -> Any:
    """The document-maker of a front end's sweep (``render(values) -> document``: an OpenSCENARIO
    distribution converts its scenario again for each variation), or None for a JSON template."""
    return getattr(data, "render", None)


def prepare(data: Mapping[str, Any], source: str) -> Sweep:
    if rendered(data) is not None:
        return Sweep(data, source)
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
    sweep = prepare(data, source)
    return sweep.document(sweep.defaults)


