"""A sweep checked whole before anything runs: the template, the count, every variation.

:func:`load_sweep` - for ``run``/``expand``/``validate`` of a sweep: the blocks
checked (:mod:`.template`), then the variation count against the limit (by
arithmetic, before anything is built), then *every* variation substituted and
validated. A problem that several variations share is reported once, naming how
many variations have it and the first one.

>>> sweep = load_sweep({"name": "s", "parameters": {"d": 1},
...     "variations": {"d": {"from": 1, "to": 3, "step": 1}},
...     "execute": [{"id": "A", "kind": "behavior", "action": "hold", "params": {"duration": "$d"}}]})
>>> [(v.label, v.document["execute"][0]["params"]) for v in sweep]
[('d=1', {'duration': 1}), ('d=2', {'duration': 2}), ('d=3', {'duration': 3})]
"""

from __future__ import annotations

import os
from typing import Any, Mapping

from ..errors import InvalidTestCase, Problem, by_place
from ..leaves import Registry, default_registry
from .case import validate
from .limits import MAX_WORK, check_work
from .read import load_json
from .template import MAX_VARIATIONS, Sweep, collision_problems, count_problem, has_variations, is_parameterised, prepare
from .values import value_problems

__all__ = ["load_sweep"]


def load_sweep(source: str | os.PathLike[str] | Mapping[str, Any], *, registry: Registry | None = None,
               max_variations: int = MAX_VARIATIONS, check_all: bool = True, source_name: str | None = None,
               system: Any = None, max_work: int | None = None) -> Sweep:  # fmt: skip
    """Load a sweep and check it completely before anything runs.

    Args:
        max_variations: the limit (:data:`MAX_VARIATIONS` by default)
        check_all: validate every variation (else only the template and the defaults)
        source_name: the file name for messages when *source* is already parsed data
        system: replaces the case's ``system`` (``run --system``), as for :func:`btgen_pytrees.load`
        max_work: the work budget each variation's run must fit (default :data:`~btgen_pytrees.load.MAX_WORK`)

    Raises:
        InvalidTestCase: the template's, the limit's and every variation's problems.
    """
    if isinstance(source, Mapping):
        data, name = source, source_name or "<dict>"
    else:
        name = os.fspath(source)
        data = load_json(name)
    registry = registry if registry is not None else default_registry()
    if not isinstance(data, dict):
        validate(data, name, registry, system)  # raises: not an object
    problems = sorted(set(value_problems(data)), key=by_place)  # the loader's stage 0
    if problems:
        raise InvalidTestCase(problems, name)
    sweep = prepare(data, name) if is_parameterised(data) else Sweep(data, name)
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
