"""Built-in oracle leaves: ``record``, ``period`` and ``final`` criteria.

Each oracle keeps its own :class:`Outcome` (verdict, time, message, the values it
read), because the tree's statuses do not survive the end of a run: when the
exit condition succeeds, py_trees stops every still-running sibling and resets
its status. Reports read the outcome instead.

Semantics (times are seconds since the run's first tick):

* ``record`` - ``expect`` holds on every tick; fails at the first violation,
  otherwise stays RUNNING (its verdict is *pass* when the run ends).
* ``period`` - ``expect`` holds on every tick in [``from``, ``to``]; ``from``
  defaults to 0, ``to`` to the tick on which the execute subtree has finished;
  succeeds at the end of the window, fails at the first violation.
* ``final`` - evaluated once, at ``at`` or, without it, when the execute
  subtree has finished.

Each also keeps its *margin* (:attr:`Outcome.margin`), the robustness of
signal temporal logic: the expression's margin on each tick it judged
(:meth:`~btgen_pytrees.expressions.Expression.judge`), and for ``record`` and
``period`` the minimum over those ticks (``always``); ``final`` judges one tick.
A tick on which the expression could not be evaluated (a signal without a
value) has no margin: the criterion fails on it, and its margin is unknown
(None) unless an earlier tick had already gone below 0.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from py_trees.common import Status

from ..contracts.environment import Environment
from ..expressions import ExpressionError, format_number, why_false
from ..model import Criterion
from .node import Node
from .simulated import reached

__all__ = ["Outcome", "Oracle", "Record", "Period", "Final", "always"]

# the statuses as module constants: ``Status.SUCCESS`` is a look-up on the Enum class (~80 ns), every tick
_SUCCESS, _FAILURE, _RUNNING = Status.SUCCESS, Status.FAILURE, Status.RUNNING


@dataclass
class Outcome:
    """What an oracle concluded.

    Attributes:
        verdict: ``pass``, ``fail`` or ``inconclusive`` (still undecided)
        at: run time of the verdict (or of the last evaluation)
        message: why, for people
        values: the signal values it read at that time
        margin: the robustness over the ticks judged so far (None: none judged, or unknown)
    """

    verdict: str = "inconclusive"
    at: float | None = None
    message: str = ""
    values: dict[str, Any] = field(default_factory=dict)
    margin: float | None = None
    decided: float | None = None
    """A temporal criterion's: the run time of the tick after which its verdict was certain."""
    violation: tuple[float, dict[str, Any]] | None = None
    """A failed temporal criterion's: the run time of the tick its explanation names and the values read there."""


MAX_SAMPLES = 1000
"""Most value changes an oracle keeps (``samples``, a fallback for plots; the run's trace has the
full signal history). What the reports need is kept apart and always: the first violation and the
last values read (:class:`Outcome`). Unbounded, a 485-byte case reached 3 GB."""


def always(before: float | None, margin: float | None) -> float | None:
    """The margin of "always" over the ticks judged before (*before*) and one more (*margin*):
    ``expressions.conjunction((before, margin))`` - their minimum, an unknown (None) part unknown
    unless the known one is below 0 - for two parts, without the lists it makes (every tick of
    every ``record`` and ``period`` calls it).

    >>> always(2.0, -1.0), always(2.0, None), always(None, -1.0), always(None, None)
    (-1.0, None, -1.0, None)
    """
    if before is None:
        return None if margin is None or margin >= 0 else margin
    if margin is None:
        return None if before >= 0 else before
    return margin if margin < before else before


class Oracle(Node):
    """Base: evaluates its criterion's expression against the blackboard signals."""

    def __init__(self, criterion: Criterion, env: Environment):
        super().__init__(name=criterion.name)
        self.criterion = criterion
        self.env = env
        self.outcome = Outcome()
        self.samples: list[tuple[float, dict[str, Any]]] = []
        self.judged = 0  # ticks judged in this run
        reads = [env.signal_key(n) for n in criterion.expect.ordered_names]
        self.client = env.attach(self, reads=reads + ([env.execute_done_key] if self.waits_for_execute() else []))

    def waits_for_execute(self) -> bool:
        """Whether it reads ``execute_done`` (a period without ``to``, a final without ``at``)."""
        return False

    def initialise(self) -> None:
        self.outcome = Outcome()
        self.samples = []
        self.judged = 0

    def check(self, now: float) -> bool:
        """Evaluate ``expect`` now; remember the values; on failure record the outcome."""
        expect = self.criterion.expect
        values = self.env.values(expect.ordered_names, self.client)
        samples = self.samples
        if (not samples or samples[-1][1] != values) and len(samples) < MAX_SAMPLES:
            samples.append((now, values))
        margin: float | None
        try:
            ok, margin = expect.judge(values)
            message = "" if ok else why_false(expect, values) or f"{expect.source} is false"
        except ExpressionError as exc:
            ok, margin, message = False, None, str(exc)
        judged = self.judged
        if judged:  # always: the minimum over the ticks judged (always(), inline for two known margins)
            before = self.outcome.margin
            if before is None or margin is None:
                margin = always(before, margin)
            elif not margin < before:  # as always(): a NaN or an equal margin keeps the one before
                margin = before
        self.judged = judged + 1
        self.outcome = Outcome("inconclusive" if ok else "fail", now, message, values, margin)
        if not ok:
            shown = ", ".join(f"{k}={format_number(v)}" for k, v in sorted(values.items()))  # rounded like the margin
            self.outcome.message = f"{message} at {now:.6g} s ({shown})" if shown else f"{message} at {now:.6g} s"
            self.feedback_message = self.outcome.message
        return ok

    def succeed(self, now: float, why: str) -> Status:
        self.outcome.verdict, self.outcome.at, self.outcome.message = "pass", now, why
        self.feedback_message = why
        return _SUCCESS


class Record(Oracle):
    def update(self) -> Status:
        now = self.env.now()
        return _RUNNING if self.check(now) else _FAILURE

    def conclude(self, now: float) -> None:
        """The run ended without a violation: the record passes."""
        if self.outcome.verdict != "fail":
            self.outcome.verdict, self.outcome.at = "pass", now
            self.outcome.message = f"{self.criterion.expect.source} held on every tick"


class Period(Oracle):
    def waits_for_execute(self) -> bool:
        return self.criterion.end is None

    def update(self) -> Status:
        now = self.env.now()
        start = self.criterion.start or 0.0
        if not reached(now, start):
            self.feedback_message = f"window opens at {start} s"
            return _RUNNING
        self.feedback_message = f"checked since {start:g} s"
        if not self.check(now):
            return _FAILURE
        end = self.criterion.end
        if end is not None and reached(now, end):
            return self.succeed(now, f"held from {start:g} s to {end:g} s")
        if end is None and self.env.execute_done(self.client):
            return self.succeed(now, f"held from {start:g} s to {now:.6g} s (the execute subtree had finished)")
        return _RUNNING


class Final(Oracle):
    def waits_for_execute(self) -> bool:
        return self.criterion.at is None

    def update(self) -> Status:
        now = self.env.now()
        at = self.criterion.at
        due = reached(now, at) if at is not None else self.env.execute_done(self.client)
        if not due:
            return _RUNNING
        if not self.check(now):
            return _FAILURE
        return self.succeed(now, f"{self.criterion.expect.source} held at {now:.6g} s")
