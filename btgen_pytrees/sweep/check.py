"""Checks of the ``parameters`` and ``variations`` blocks, before anything is substituted.

Like the loader, these come in two stages: the blocks' *shape* (the
``parameters``/``variations`` parts of the test-case schema) and then their
*meaning* - a varied parameter is declared and used, list values are unique
and of the default's type (boolean or number), a range runs upwards, a random
draw has ``samples``, the count is within the limit. Problems carry the JSON
path and the cause ``parameter`` (``limit`` for the count).
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Any, Iterator, Mapping

from ..errors import PathPart, Problem
from ..text import did_you_mean, shorten
from ..validation import SchemaValidator
from .variations import BLOCK_KEYS, RANGE_EPSILON, Variations, format_value

__all__ = ["shape_problems", "meaning_problems", "count_problem", "collision_problems", "axis_size"]


@lru_cache(maxsize=1)
def _validator() -> SchemaValidator:
    from ..loader import inline_refs, schema

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
