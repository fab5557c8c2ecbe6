"""Every bound a test case is checked against, and the work a run of a case may take."""

from __future__ import annotations

from ..errors import InvalidTestCase, Problem
from ..model import TestCase

__all__ = ["MAX_FILE_BYTES", "MAX_TICKS", "MIN_TICK", "MAX_WORK", "MAX_NESTING", "MAX_MAGNITUDE", "work", "check_work"]

MAX_FILE_BYTES = 16 * 1024 * 1024
"""Largest test-case file accepted (16 MiB); larger files are refused before reading."""

MAX_TICKS = 10_000_000
"""Most ticks a run may take (``timeout / tick``); keeps every run bounded."""

MIN_TICK = 1e-6
"""Smallest ``tick`` (one microsecond). The run clock counts in nanoseconds (``round(k * tick, 9)``):
far below this a tick would not move it, and a run would burn its ticks at t = 0."""

MAX_WORK = 100_000_000
"""Default work budget of a run (``run --max-work`` changes it). Each tick is charged the tree's size,
``entries + criteria + 10`` (the ten: the nodes every tree ticks); a run is stopped with verdict
``error`` when its next tick would exceed the budget (so a run ending early is charged only what it
did). One unit is well under a microsecond for big trees and about 2 µs for tiny ones, so a run
within the budget takes a few minutes at most."""

MAX_NESTING = 100
"""Deepest nesting of arrays/objects accepted (fuzz finding: deeper values crashed error reporting)."""
MAX_MAGNITUDE = 1e300
"""Largest magnitude of any number in a test case. Far beyond any physical quantity, and far
enough below float's ±1.8e308 that what a run computes from such numbers stays finite: a ramp
between -1e300 and 1e300 (their difference), an integer signal times a fraction, a report's
values. ``1e999`` parses as infinity and is refused too."""


def work(case: TestCase) -> int:
    """The most work units a run of *case* can take: ``(timeout / tick + 1) x (entries + criteria + 10)``
    (a run that ends before its timeout is charged less; see :data:`MAX_WORK`)."""
    return case.ticks * (len(case.entries) + len(case.criteria) + 10)


def check_work(case: TestCase, max_work: int = MAX_WORK) -> None:
    """Raise :class:`InvalidTestCase` (at ``/timeout``, cause ``limit``) if a run of *case* is certain to exceed
    *max_work*: when even its first tick would. Anything else runs, and is stopped when its budget is spent
    (``run(..., max_work=...)``)."""
    size = len(case.entries) + len(case.criteria) + 10
    if size > max_work:
        message = (f"one tick of this tree is {size} units of work (entries + criteria + 10), more than the whole "
                   f"budget, {max_work:.3g}: raise it with run --max-work N")  # fmt: skip
        raise InvalidTestCase([Problem(("execute",), message, "limit")], case.source)

