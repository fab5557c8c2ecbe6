"""Stage 0 of the checks: values every later stage can handle (surrogates, magnitudes, nesting)."""

from __future__ import annotations

import math
import re
from typing import Any, Iterator

from ..errors import PathPart, Problem
from ..text import MAX_MESSAGE
from .limits import MAX_MAGNITUDE, MAX_NESTING

__all__ = ["SURROGATE", "suspicious", "value_problems"]

# stage 0: values every later stage can handle
#
# Fuzz findings (tests/test_fuzz.py), each an exit 3 before this stage existed:
# * an integer beyond float range (e.g. "timeout": 1e4000 written out as digits)
#   raised OverflowError in the timeout/tick check, or later while running;
# * a lone surrogate ("\ud800" escape) in a string reached the output streams and
#   raised UnicodeEncodeError;
# * a value nested ~1000 deep parsed, then raised RecursionError while an error
#   message showed it.

SURROGATE = re.compile("[\ud800-\udfff]")


def _scalar_problem(path: tuple[PathPart, ...], value: Any) -> Problem | None:
    if isinstance(value, str):
        bad = SURROGATE.search(value)
        if bad:
            return Problem(path, f"not valid Unicode: lone surrogate {ascii(bad.group())} at character {bad.start()}", "json")
    elif isinstance(value, int) and not isinstance(value, bool):
        if not -MAX_MAGNITUDE <= value <= MAX_MAGNITUDE:
            try:
                shown = f"{float(value):.3g}"
            except OverflowError:
                shown = f"{value.bit_length()} bits"
            return Problem(path, f"number too large ({shown}; the limit is ±{MAX_MAGNITUDE:g})", "limit")
    elif isinstance(value, float):
        if not math.isfinite(value):  # 1e999 parses as inf
            return Problem(path, f"number too large (beyond float range, read as {value}; the limit is ±{MAX_MAGNITUDE:g})", "limit")
        if not -MAX_MAGNITUDE <= value <= MAX_MAGNITUDE:
            return Problem(path, f"number too large ({value:.3g}; the limit is ±{MAX_MAGNITUDE:g})", "limit")
    return None


_PLAIN = (bool, type(None))
_BIG = int(MAX_MAGNITUDE)


def suspicious(data: Any, depth: int = 0) -> bool:
    """A quick pass without paths: could :func:`value_problems` find anything?

    Valid documents are the common case; for them this one cheap walk (one regex
    over all strings joined, a bound on integers, a depth count) replaces the
    detailed walk that builds a JSON path for every container. *depth*: where
    *data* sits in its document (the root is 0), for a part checked on its own.
    """
    if not isinstance(data, (dict, list)):
        return True
    strings: list[str] = []
    stack: list[tuple[Any, int]] = [(data, depth)]
    while stack:
        container, depth = stack.pop()
        if depth >= MAX_NESTING:
            return True
        if type(container) is dict:
            strings.extend(container)
            values: Any = container.values()
        else:
            values = container
        for item in values:
            kind = type(item)
            if kind is str:
                strings.append(item)
            elif kind is int:
                if not -_BIG <= item <= _BIG:
                    return True
            elif kind is float:
                if not -MAX_MAGNITUDE <= item <= MAX_MAGNITUDE:  # NaN fails every comparison
                    return True
            elif kind is dict or kind is list:
                stack.append((item, depth + 1))
            elif kind not in _PLAIN:
                return True  # a subclass or an odd type from a dict: look closely
    try:
        return SURROGATE.search("".join(strings)) is not None
    except TypeError:  # a non-string key in a dict given from Python: look closely
        return True


def value_problems(data: Any, prefix: tuple[PathPart, ...] = ()) -> Iterator[Problem]:
    """The stage-0 problems of *data*, found at *prefix* in its document (the root: ``()``)."""
    if not suspicious(data, len(prefix)):
        return
    if not isinstance(data, (dict, list)):
        problem = _scalar_problem(prefix, data)
        if problem is not None:
            yield problem
        return
    stack: list[tuple[tuple[PathPart, ...], Any]] = [(prefix, data)]
    while stack:  # iterative: no recursion limit to hit; paths are built for containers only
        path, container = stack.pop()
        if len(path) >= MAX_NESTING:
            yield Problem(path, f"nested more than {MAX_NESTING} levels deep", "limit")
            continue
        for key, item in container.items() if isinstance(container, dict) else enumerate(container):
            if isinstance(key, str) and SURROGATE.search(key):
                yield Problem(path, f"not valid Unicode: key {ascii(key)[:MAX_MESSAGE]} has a lone surrogate", "json")
                continue
            if isinstance(item, (dict, list)):
                stack.append(((*path, key), item))
            elif isinstance(item, (str, int, float)):
                problem = _scalar_problem((*path, key), item)
                if problem is not None:
                    yield problem


