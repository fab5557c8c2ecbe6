"""The built-in ``temporal`` criterion: a signal temporal logic formula judged by its robustness.

Once per tick the leaf judges the formula's atoms (:meth:`~btgen_pytrees.expressions.Expression.judge`)
and steps its online monitor (:class:`~btgen_pytrees.monitor.Monitor`). The formula is evaluated at its
*anchor*: ``from`` in seconds (default 0), or the tick on which an execute entry started or ended
(``"from": "LeadBrakes.start"``). Its *horizon* is the anchor plus the formula's span (how far its
windows look ahead); ``always`` without a window reads to the end of the run, which is the tick on which
the execute subtree has finished.

The leaf stays RUNNING until the horizon has passed, even when the verdict was certain earlier: the
margin is that of the whole horizon (sweeps and ``falsify`` compare margins). Then it succeeds (the
robustness is > 0, or 0 with the formula true) or fails. :attr:`Outcome.decided` is the run time of the
earliest tick after which the verdict was certain (:func:`~btgen_pytrees.monitor.decided`). A run that ends
before the horizon leaves it ``inconclusive``.

An atom that cannot be evaluated (a signal without a value, a division by zero) fails the criterion on
that tick with an unknown margin, like the other criteria.
"""

from __future__ import annotations

from typing import Any

import py_trees
from py_trees.common import Status

from ..contracts.environment import Environment
from ..expressions import ExpressionError, format_number
from ..model import Criterion
from ..monitor import Monitor, Node, decided, holds
from .oracles import MAX_SAMPLES, Oracle, Outcome
from .simulated import reached

__all__ = ["Temporal"]

_SUCCESS, _FAILURE, _RUNNING, _INVALID = Status.SUCCESS, Status.FAILURE, Status.RUNNING, Status.INVALID


class Temporal(Oracle):
    """A ``temporal`` criterion (see the module notes)."""

    def __init__(self, criterion: Criterion, env: Environment):
        super().__init__(criterion, env)
        self.monitor = Monitor(criterion.expect, criterion.tick)  # type: ignore[arg-type]
        self.judges = [e.judge for e in self.monitor.expressions]  # type: ignore[union-attr]
        self.entry: py_trees.behaviour.Behaviour | None = None  # the node an entry anchor watches
        self.anchor: int | None = None  # the anchor's sample, once known
        self.anchor_known = 0  # the sample on which the anchor became known
        self.history: list[dict[str, Any]] = []  # the values read on each tick (what the explanation names)
        self.waiting = ""  # the feedback while the horizon has not passed (worked out once the anchor is known)

    def waits_for_execute(self) -> bool:
        return self.criterion.expect.span == float("inf")  # type: ignore[union-attr]

    def setup(self, **kwargs: Any) -> None:
        anchor = self.criterion.anchor
        if anchor is not None and anchor[1] == "start":
            root: py_trees.behaviour.Behaviour = self
            while root.parent is not None:
                root = root.parent
            self.entry = next((n for n in root.iterate() if getattr(getattr(n, "btgen_entry", None), "id", None) == anchor[0]), None)

    def initialise(self) -> None:
        super().initialise()
        self.monitor = Monitor(self.criterion.expect, self.criterion.tick)  # type: ignore[arg-type]
        self.anchor = None
        self.history = []
        span = self.monitor.root.span
        self.outcome.message = "the run ended before the anchor" if self.criterion.anchor else (
            f"the run ended before its horizon ({self.horizon_text(ticks_of_anchor(self.criterion))})"
            if span != float("inf") else "the run ended before the execute subtree finished")

    def terms(self) -> list[tuple[str, list[float]]]:
        """The formula and its sub-formulas with their robustness on each tick so far (at most 8, outermost
        first): what the replay page draws."""
        nodes = self.monitor.nodes[::-1]
        return [(n.formula.source, n.values) for n in nodes[:8]]  # (a re-run makes new lists: no copy)

    def window(self) -> tuple[float, float | None] | None:
        """The run times of the anchor and the horizon (None: the end of the run), once the anchor is known:
        the window the views draw."""
        if self.anchor is None:
            return None
        tick, span = self.criterion.tick, self.monitor.root.span
        start = round(self.anchor * tick, 9)
        return start, (round((self.anchor + span) * tick, 9) if span != float("inf") else None)

    def horizon_text(self, anchor: int) -> str:
        span = self.monitor.root.span
        if span == float("inf"):
            return "the end of the run"
        return f"{(anchor + span) * self.criterion.tick:.6g} s"

    def update(self) -> Status:
        now = self.env.now()
        k = self.judged
        self.judged = k + 1
        expect = self.criterion.expect
        values = self.env.values(expect.ordered_names, self.client)
        self.history.append(values)
        samples = self.samples
        if (not samples or samples[-1][1] != values) and len(samples) < MAX_SAMPLES:
            samples.append((now, values))
        margins = []
        try:
            for judge in self.judges:
                truth, margin = judge(values)
                margins.append(margin if margin else (0.0 if truth else -0.0))  # a held boundary +0, a failed one -0
        except ExpressionError as exc:
            shown = ", ".join(f"{n}={format_number(v)}" for n, v in sorted(values.items()))
            message = f"{exc} at {now:.6g} s" + (f" ({shown})" if shown else "")
            self.outcome = Outcome("fail", now, message, values, None)
            self.feedback_message = message
            return _FAILURE
        monitor = self.monitor
        monitor.step(margins)
        if self.anchor is None:
            self.anchor = self.find_anchor(now, k)
            if self.anchor is None:
                self.feedback_message = "waits for its anchor"
                return _RUNNING
            self.anchor_known = k
            self.outcome.message = f"the run ended before its horizon ({self.horizon_text(self.anchor)})"
            self.waiting = f"horizon {self.horizon_text(self.anchor)}"
        anchor = self.anchor
        root = monitor.root
        ended = False
        if len(root.values) <= anchor:
            if root.span != float("inf") or not self.env.execute_done(self.client):
                self.feedback_message = self.waiting
                return _RUNNING
            monitor.finish()  # always without a window: the run ends with the execute subtree
            ended = True
        margin = root.values[anchor] + 0.0
        ok = margin > 0 or margin == 0 and holds(root, anchor)
        tick = self.criterion.tick
        first = decided(monitor, anchor, max(self.anchor_known, 0), k, ended)
        at = now
        self.outcome = Outcome("pass" if ok else "fail", at, "", values, margin)
        self.outcome.decided = round(first * tick, 9)
        self.outcome.message, self.outcome.violation = self.why(ok, margin, anchor, first)
        self.feedback_message = self.outcome.message
        return _SUCCESS if ok else _FAILURE

    def find_anchor(self, now: float, k: int) -> int | None:
        """The anchor's sample, if it is known on sample *k* (at run time *now*)."""
        criterion = self.criterion
        if criterion.anchor is None:
            start = criterion.start or 0.0
            return ticks_of_anchor(criterion) if reached(now, start) or k >= ticks_of_anchor(criterion) else None
        entry, edge = criterion.anchor
        if edge == "end":
            return k if self.env.is_done(entry) else None
        node = self.entry
        return k if node is not None and node.status != _INVALID else None

    def why(self, ok: bool, margin: float, anchor: int, first: int) -> tuple[str, tuple[float, dict[str, Any]] | None]:
        """The message, and for a violation the tick its explanation names with the values read there."""
        tick = self.criterion.tick
        head = f"{self.criterion.expect.source} {'held' if ok else 'violated'} at {anchor * tick:.6g} s (margin {format_number(margin)})"
        reason, violation = "", None
        if not ok:
            reason, u = explain(self.monitor.root, anchor, tick, self.history)
            violation = (round(u * tick, 9), dict(self.history[u]) if u < len(self.history) else {})
        return f"{head}{': ' + reason if reason else ''}; certain after the tick at {first * tick:.6g} s", violation


def explain(node: Node, t: int, tick: float, history: list[dict[str, Any]], depth: int = 0) -> tuple[str, int]:
    """Why *node* is false (its robustness < 0, or 0 and false) at sample *t*: the sub-formula and the tick
    that decided it, followed down to an atom and the values it read; and that tick (the sample whose values
    the explanation names: ``--plot`` puts the violation's marker there).

    For ``always``, the tick of the worst value; for ``eventually``, that it never held in its window and
    its best value; for ``until``/``since``, which side gave out; for ``->``, the premise that held and
    the consequence that failed.
    """
    if depth > 8:
        return "", t
    op, kids, source = node.formula.op, node.children, node.formula.source
    at = f"{t * tick:.6g} s"
    if op == "atom":
        values = history[t] if t < len(history) else {}
        names = node.formula.atom.ordered_names if node.formula.atom is not None else ()
        shown = ", ".join(f"{n}={format_number(values[n])}" for n in names if n in values)
        return f"{source} false at {at}" + (f" ({shown})" if shown else ""), t
    deeper = lambda child, u: explain(child, u, tick, history, depth + 1)  # noqa: E731
    if op == "not":
        return f"{kids[0].formula.source} held at {at} (margin {format_number(kids[0].values[t])})", t
    if op == "and":
        worst = min(kids, key=lambda c: c.values[t])
        return deeper(worst, t)
    if op == "or":
        sides = [deeper(c, t) for c in kids]
        nearest = max(range(len(kids)), key=lambda i: kids[i].values[t])  # the side closest to holding
        return "no side held: " + "; ".join(text for text, _ in sides), sides[nearest][1]
    if op == "implies":
        premise, consequence = kids
        why, u = deeper(consequence, t)
        return (f"the premise {premise.formula.source} held at {at} (margin {format_number(premise.values[t])}) "
                f"and the consequence failed: {why}"), u  # fmt: skip
    child = kids[0]
    a, b = node.low, node.high
    end = len(child.values) - 1
    if op in ("always", "eventually"):
        window = range(t + a, (end if b is None else min(t + b, end)) + 1)
    elif op in ("once", "historically"):
        window = range(0 if b is None else max(t - b, 0), t - a + 1)
    else:
        window = range(0)
    if op in ("always", "historically"):
        u = min(window, key=lambda v: child.values[v])
        why, w = deeper(child, u)
        return f"{op} failed at {u * tick:.6g} s: {why}", w
    if op in ("eventually", "once"):
        span = f"[{window.start * tick:.6g}, {(window.stop - 1) * tick:.6g}] s" if window else "an empty window"
        if not window:
            return f"{source}: {span}", t
        u = max(window, key=lambda v: child.values[v])
        return f"{child.formula.source} never held in {span}; its best value {format_number(child.values[u])} at {u * tick:.6g} s", u
    left, right = kids
    if op == "until":
        top = min(t + (b or 0), len(right.values) - 1)
        candidates = range(t + a, top + 1)
        if not candidates or all(right.values[u] < 0 or right.values[u] == 0 and not holds(right, u) for u in candidates):
            best = max(candidates, key=lambda v: right.values[v]) if candidates else t
            return f"{right.formula.source} never held in [{(t + a) * tick:.6g}, {top * tick:.6g}] s (its best value " \
                f"{format_number(right.values[best])} at {best * tick:.6g} s)", best
        first = next(u for u in candidates if right.values[u] > 0 or holds(right, u))
        gave = next((w for w in range(t, first) if left.values[w] < 0 or not holds(left, w)), t)
        return f"{left.formula.source} gave out at {gave * tick:.6g} s, before {right.formula.source} held at {first * tick:.6g} s", gave
    low = 0 if b is None else max(t - b, 0)
    return f"{right.formula.source} did not hold in [{low * tick:.6g}, {(t - a) * tick:.6g}] s with {left.formula.source} since", max(t - a, 0)


def ticks_of_anchor(criterion: Criterion) -> int:
    """A criterion's ``from`` in seconds as a sample (the first tick at or after it)."""
    start = criterion.start or 0.0
    n = start / criterion.tick
    k = round(n)
    return int(k) if abs(n - k) <= 1e-9 * max(1.0, n) else int(n) + 1
