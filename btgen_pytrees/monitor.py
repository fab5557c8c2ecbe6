"""The online robustness monitor of a :class:`~btgen_pytrees.formulas.Formula`.

Discrete time: sample ``k`` is the run's ``k``-th tick, a window ``[a, b]`` in seconds is ``[a/tick, b/tick]``
in samples (bounds must be multiples of the tick, as rtamt requires of its sampling period). The robustness
of every sub-formula is a stream of values, one per sample, in sample order; each node of the monitor turns
its operands' streams into its own as soon as they allow:

* an atom: the expression's margin (:meth:`~btgen_pytrees.expressions.Expression.judge`), every tick;
* ``!``, ``&&``, ``||``, ``->``: pointwise ``-x``, ``min``, ``max``, ``max(-x, y)``;
* ``eventually[a,b]`` / ``always[a,b]``: the max / min of the operand over ``[t+a, t+b]``, emitted once the
  operand's value at ``t+b`` is known; ``once[a,b]`` / ``historically[a,b]`` over ``[t-b, t-a]``. A sliding
  window extreme kept in Lemire's monotone deque (Lemire 2006, as in Donzé, Ferrère and Maler's efficient
  robust monitoring): each operand value enters and leaves the deque once - amortised O(1) per tick;
* ``until[a,b]``, ``since[a,b]``: rtamt's definitions, ``max over t' in [t+a, t+b] of min(ψ(t'), min of φ over
  [t, t'))`` and ``max over t' in [t-b, t-a] of min(ψ(t'), min of φ over (t', t])``, split as Donzé, Ferrère
  and Maler split the bounded until: φ's minimum before the window (a monotone deque) capping a ``[0, b-a]``
  until over the window, itself a sliding aggregate kept in two stacks whose front is filled by the backward
  until recurrence - amortised O(1) per tick whatever the window (:meth:`Node._slide`); unbounded ``since``
  and past operators: O(1) recurrences;
* ``always`` without a window (to the end of the run): known at the end of the run only (:meth:`Monitor.finish`).

:meth:`Monitor.finish` ends the trace: values not emitted yet are computed on the windows cut at the last
sample (the maximum over an empty window is ``-inf``, the minimum ``+inf``) - what rtamt's offline
discrete-time evaluation gives on the same finite trace, so a formula's value at every sample equals
rtamt's there (``tests/test_temporal.py`` compares them on random formulas and traces).

Every node keeps its whole stream (:attr:`Node.values`): the replay page draws the sub-formulas' robustness
over time, and :func:`decided` asks what was known at an earlier tick (:func:`bound_at`).
"""

from __future__ import annotations

import math
from collections import deque
from functools import partial
from itertools import accumulate
from typing import Callable, Iterable

from .formulas import Formula

__all__ = ["Monitor", "Node", "ticks_of", "WindowError", "decided", "bound_at", "bound_streamed", "polarities", "holds"]

_INF = math.inf


class WindowError(ValueError):
    """A window bound that is not a multiple of the tick."""


def ticks_of(seconds: float, tick: float) -> int:
    """*seconds* as a whole number of ticks; :class:`WindowError` when it is not one (within 1e-9).

    >>> ticks_of(1.5, 0.1), ticks_of(0.3, 0.1)
    (15, 3)
    """
    n = seconds / tick
    k = round(n)
    if abs(n - k) > 1e-9 * max(1.0, abs(n)):
        raise WindowError(f"{seconds:g} s is not a multiple of the tick ({tick:g} s)")
    return int(k)


class Node:
    """One sub-formula's robustness stream: :attr:`values` (sample ``t`` at index ``t``).

    Attributes:
        formula: the sub-formula
        children: the operands' nodes
        low, high: the window in samples (``high`` None: unbounded); 0, 0 without a window
        span: how many samples past ``t`` the value at ``t`` may read (``inf``: to the end of the run)
    """

    __slots__ = ("formula", "children", "low", "high", "span", "values", "update", "_deque", "_next", "_run", "_run_state", "samples")

    def __init__(self, formula: Formula, children: list[Node], tick: float):
        self.formula = formula
        self.children = children
        window = formula.window
        self.low = ticks_of(window[0], tick) if window else 0
        self.high = (ticks_of(window[1], tick) if window[1] is not None else None) if window else 0
        inner = max((c.span for c in children), default=0)
        op = formula.op
        if op in ("always", "eventually", "until"):
            self.span: float = _INF if self.high is None else inner + self.high
        else:
            self.span = inner
        self.values: list[float] = []
        self.samples: list[float] = self.values  # the trace's samples so far (the monitor's first atom's stream)
        self._deque: deque[int] = deque()
        self._next = 0  # the next operand sample to enter the deque
        self._run = -_INF if op == "once" else _INF  # an unbounded once's / historically's running value
        self._run_state: list | None = None  # until / since: the two stacks of :meth:`_slide`
        self.update: Callable[[], None] = getattr(self, "_" + op)

    # -- one tick: append what the operands now allow ----------------------------------------------------
    def _atom(self) -> None:  # fed by Monitor.step
        pass

    def _not(self) -> None:
        out, src = self.values, self.children[0].values
        for t in range(len(out), len(src)):
            out.append(-src[t])

    def _and(self) -> None:
        out = self.values
        streams = [c.values for c in self.children]
        for t in range(len(out), min(map(len, streams))):
            out.append(min(s[t] for s in streams))

    def _or(self) -> None:
        out = self.values
        streams = [c.values for c in self.children]
        for t in range(len(out), min(map(len, streams))):
            out.append(max(s[t] for s in streams))

    def _implies(self) -> None:
        out, left, right = self.values, self.children[0].values, self.children[1].values
        for t in range(len(out), min(len(left), len(right))):
            out.append(max(-left[t], right[t]))

    def _window_future(self, larger: bool, end: int | None = None) -> None:
        """eventually (*larger*) / always over [t+a, t+b]; *end*: the trace ends at that sample (a cut window)."""
        out, src, dq = self.values, self.children[0].values, self._deque
        a, b = self.low, self.high
        assert b is not None
        known = len(src) if end is None else end + 1
        t = len(out)
        while (t + b < known) if end is None else (t <= end):
            top = min(t + b, known - 1)
            j = self._next
            while j <= top:  # enter the deque: drop the samples it makes useless (Lemire)
                v = src[j]
                if larger:
                    while dq and src[dq[-1]] <= v:
                        dq.pop()
                else:
                    while dq and src[dq[-1]] >= v:
                        dq.pop()
                dq.append(j)
                j += 1
            self._next = j
            while dq and dq[0] < t + a:
                dq.popleft()
            out.append(src[dq[0]] if dq else (-_INF if larger else _INF))
            t += 1

    def _eventually(self) -> None:
        self._window_future(True)

    def _always(self) -> None:
        if self.high is not None:
            self._window_future(False)

    def _window_past(self, larger: bool) -> None:
        """once (*larger*) / historically over [t-b, t-a] (unbounded: since sample 0)."""
        out, src, dq = self.values, self.children[0].values, self._deque
        a, b = self.low, self.high
        t = len(out)
        last = min(len(src) + a, len(self.samples))  # (a value is emitted for a sample the trace has)
        while t < last:
            if t - a >= 0:
                v = src[t - a]
                if b is None:  # a running extreme
                    run = self._run
                    self._run = run = (v if v > run else run) if larger else (v if v < run else run)
                    out.append(run)
                    t += 1
                    continue
                if larger:
                    while dq and src[dq[-1]] <= v:
                        dq.pop()
                else:
                    while dq and src[dq[-1]] >= v:
                        dq.pop()
                dq.append(t - a)
                while dq[0] < t - b:
                    dq.popleft()
                out.append(src[dq[0]])
            else:
                out.append(-_INF if larger else _INF)
            t += 1

    def _once(self) -> None:
        self._window_past(True)

    def _historically(self) -> None:
        self._window_past(False)

    def _until(self, end: int | None = None) -> None:
        """``φ until[a,b] ψ`` at t = ``min(min of φ over [t, t+a), U(t+a))``, U(s) the ``[0, b-a]`` until at s
        (the minimum over ``[t, t+a)`` caps every t' of the window alike): φ's window minimum in a monotone
        deque, U a sliding aggregate over ``[s, t+b]`` kept in two stacks (:meth:`_slide`)."""
        out, left, right = self.values, self.children[0].values, self.children[1].values
        a, b = self.low, self.high
        assert b is not None
        known = min(len(left), len(right)) if end is None else end + 1
        t = len(out)
        dq = self._deque
        while (t + b < known) if end is None else (t <= end):
            s = t + a
            if s >= known:  # the window lies past the end of the trace
                out.append(-_INF)
                t += 1
                continue
            cap = _INF
            if a:  # min of φ over [t, t+a): Lemire's deque over φ
                j = self._next
                while j < s:
                    v = left[j]
                    while dq and left[dq[-1]] >= v:
                        dq.pop()
                    dq.append(j)
                    j += 1
                self._next = j
                while dq[0] < t:
                    dq.popleft()
                cap = left[dq[0]]
            u = self._slide(s, min(t + b, known - 1), True)
            out.append(u if u < cap else cap)
            t += 1

    def _since(self) -> None:
        """``φ since[a,b] ψ`` at t = ``min(min of φ over (t-a, t], S(t-a))``, S(s) the ``[0, b-a]`` since at s:
        the mirror of :meth:`_until`; unbounded: ``s(t) = max(ψ(t), min(φ(t), s(t-1)))``."""
        out, left, right = self.values, self.children[0].values, self.children[1].values
        a, b = self.low, self.high
        known = min(len(left), len(right), len(self.samples))
        t = len(out)
        dq = self._deque
        while t < known:
            if b is None:  # s(t) = max(ψ(t), min(φ(t), s(t-1)))
                prev = out[-1] if out else -_INF
                lv, rv = left[t], right[t]
                v = lv if lv < prev else prev
                out.append(rv if rv > v else v)
                t += 1
                continue
            cap = _INF
            if a:  # min of φ over (t-a, t]
                v = left[t]
                while dq and left[dq[-1]] >= v:
                    dq.pop()
                dq.append(t)
                while dq[0] <= t - a:
                    dq.popleft()
                cap = left[dq[0]]
            if t - a < 0:
                out.append(-_INF)
            else:
                s = self._slide(max(t - b, 0), t - a, False)
                out.append(s if s < cap else cap)
            t += 1

    def _slide(self, low: int, high: int, future: bool) -> float:
        """The ``[0, w]`` until (*future*) over the window [*low*, *high*] of samples, or the ``[0, w]`` since
        whose window it is; each call's window ends at or after the last call's on both sides.

        Both are sliding aggregates of an associative operation on (value, φ's minimum) pairs, a window's
        until being ``max(U1, min(m1, U2))`` from its two halves' (since: ``max(min(S1, m2), S2)``): two
        stacks (a queue with aggregates, as Lemire's deque is one for ``min``/``max``). The back holds the
        aggregate of the samples entered since the last flip; the front, the aggregates of each suffix of
        the samples before them, worked out backwards at a flip (Donzé, Ferrère and Maler's backward until
        recurrence). Each sample enters the back once and the front once: amortised O(1) per tick.
        """
        left, right = self.children[0].values, self.children[1].values
        st = self._run_state
        if st is None:
            st = self._run_state = [low, low - 1, [], [], -_INF, _INF, low - 1]  # front lo, hi, U, m; back U, m, hi
        back_u, back_m, back_hi = st[4], st[5], st[6]
        for j in range(back_hi + 1, high + 1):  # enter the back
            r, lv = right[j], left[j]
            if future:  # U = max(U, min(m, ψ(j))), then m = min(m, φ(j))
                v = r if r < back_m else back_m
                if v > back_u:
                    back_u = v
            else:  # S = max(min(S, φ(j)), ψ(j))
                v = back_u if back_u < lv else lv
                back_u = r if r > v else v
            if lv < back_m:
                back_m = lv
        back_hi = high if high > back_hi else back_hi
        if low > st[1]:  # the front is used up: the back's samples become the front, suffix by suffix
            n = back_hi - low + 1
            us, ms = [0.0] * n, [0.0] * n
            u, m = -_INF, _INF
            for i in range(n - 1, -1, -1):
                r, lv = right[low + i], left[low + i]
                if future:  # U(i) = max(ψ(i), min(φ(i), U(i+1)))
                    v = lv if lv < u else u
                    u = r if r > v else v
                else:  # S(i) = max(min(ψ(i), m(i+1)), S(i+1))
                    v = r if r < m else m
                    if v > u:
                        u = v
                if lv < m:
                    m = lv
                us[i], ms[i] = u, m
            st[0], st[1], st[2], st[3] = low, back_hi, us, ms
            back_u, back_m = -_INF, _INF
        st[4], st[5], st[6] = back_u, back_m, back_hi
        i = low - st[0]
        fu, fm = st[2][i], st[3][i]
        if future:
            v = fm if fm < back_u else back_u
            return fu if fu > v else v
        v = fu if fu < back_m else back_m
        return back_u if back_u > v else v

    # -- the end of the trace -----------------------------------------------------------------------------
    def finish(self, end: int) -> None:
        """The trace ends at sample *end*: emit every value up to it, on windows cut there."""
        op = self.formula.op
        if op == "eventually":
            self._window_future(True, end)
        elif op == "always" and self.high is not None:
            self._window_future(False, end)
        elif op == "always":  # unbounded: the minimum of the suffix
            src, out = self.children[0].values, self.values
            low = _INF
            suffix = [0.0] * (end + 1)
            for t in range(end, -1, -1):
                if src[t] < low:
                    low = src[t]
                suffix[t] = low
            out[len(out):] = suffix[len(out):]
        elif op == "until":
            self._until(end)
        else:
            self.update()


class Monitor:
    """The online monitor of one formula: :meth:`step` once per tick with the atoms' margins.

    Attributes:
        root: the formula's node; ``root.values[t]`` its robustness at sample ``t``, once known
        atoms: the atom nodes, in the order :attr:`expressions` lists their expressions
        nodes: every node, each after its operands (the order :meth:`step` updates them in)
    """

    def __init__(self, formula: Formula, tick: float):
        self.formula = formula
        self.tick = tick
        self.nodes: list[Node] = []
        self.atoms: list[Node] = []
        self.root = self._build(formula)
        for node in self.nodes:
            node.samples = self.atoms[0].values
        self.updates = [n.update for n in self.nodes if n.formula.op != "atom"]
        self.ended = False

    def _build(self, formula: Formula) -> Node:
        node = Node(formula, [self._build(c) for c in formula.children], self.tick)
        self.nodes.append(node)
        if formula.op == "atom":
            self.atoms.append(node)
        return node

    @property
    def expressions(self) -> list:
        return [n.formula.atom for n in self.atoms]

    def step(self, margins: Iterable[float]) -> None:
        """The atoms' margins at the next sample (in :attr:`atoms` order); every node emits what it can."""
        for node, margin in zip(self.atoms, margins):
            node.values.append(margin)
        for update in self.updates:
            update()

    def finish(self) -> None:
        """The trace has ended at the last sample stepped: every node emits the rest (cut windows)."""
        if self.ended or not self.atoms or not self.atoms[0].values:
            return
        self.ended = True
        end = len(self.atoms[0].values) - 1
        for node in self.nodes:
            if node.formula.op != "atom":
                node.finish(end)


# -- what was known at an earlier tick --------------------------------------------------------------------

def polarities(formula: Formula, positive: bool = True, out: dict[int, bool] | None = None) -> dict[int, bool]:
    """Each sub-formula's polarity, by ``id``: whether the root's robustness grows with it (an even number
    of negations above it - ``!`` and the premise of ``->`` negate) or shrinks."""
    out = {} if out is None else out
    out[id(formula)] = positive
    for i, child in enumerate(formula.children):
        flip = formula.op == "not" or formula.op == "implies" and i == 0
        polarities(child, positive != flip, out)
    return out


def bound_at(monitor: Monitor, anchor: int, k: int, lower: bool, known: dict | None = None) -> float:
    """The lowest (*lower*) or highest robustness at *anchor* that any continuation of the first *k* + 1
    samples can give (the trace not ended): each atom's later samples at the extreme that pushes the root
    that way (``-inf`` or ``inf`` by the atom's polarity, :func:`polarities`), every window whole, and
    ``always`` without a window over the known samples and an unknown rest.

    min, max and negation are monotone, so this is the interval's end. A sub-formula's value whose window
    lies within the known samples is the monitor's own (read, not worked out again); a window's known
    part is one built-in ``min``/``max`` over a slice of its operand's values; only the values still open
    at *k* are worked out, each once.

    *known*: kept across calls on the same monitor (:func:`decided`'s search): an until's settled part as
    running minima and best values, one slice pass per value whatever the prefixes asked about.
    """
    signs = polarities(monitor.formula)
    memo: dict[tuple[int, int], float] = {}
    known = {} if known is None else known

    def value(node: Node, t: int) -> float:
        if t + node.span <= k and t < len(node.values):
            return node.values[t]
        key = (id(node), t)
        found = memo.get(key)
        if found is not None:
            return found
        low_end = lower == signs[id(node.formula)]  # this node's lower end is wanted (else its upper)
        op, kids = node.formula.op, node.children
        if op == "atom":
            v = -_INF if low_end else _INF
        elif op == "not":
            v = -value(kids[0], t)
        elif op == "and":
            v = min(value(c, t) for c in kids)
        elif op == "or":
            v = max(value(c, t) for c in kids)
        elif op == "implies":
            v = max(-value(kids[0], t), value(kids[1], t))
        elif op in ("always", "eventually", "once", "historically"):
            larger = op in ("eventually", "once")
            a, b = node.low, node.high
            if op in ("always", "eventually"):
                first, top = t + a, (t + b if b is not None else k)
            else:
                first, top = (0 if b is None else max(t - b, 0)), t - a
            v = _extreme(kids[0], first, top, k, larger, value)
            if b is None and op == "always" and low_end:
                v = -_INF  # the unknown rest of the run may hold anything
        elif op == "until":
            a, b = node.low, node.high
            assert b is not None
            left, right = kids
            top = t + b
            done = min(top, _settled(left, k), _settled(right, k))  # [t, done]: the monitor's own values
            v, run = -_INF, _INF
            if done >= t:  # min(ψ(u), min of φ over [t, u)) for the settled u: running minima in C
                first = t + a
                key = (id(node), t)
                if key not in known:  # over every value the monitor has: a later prefix reads further
                    end = min(top, len(left.values) - 1, len(right.values) - 1)
                    runs = list(accumulate(left.values[t : end + 1], min))
                    before = runs[first - t - 1 : end - t] if first > t else [_INF, *runs[: end - t]]
                    known[key] = runs, list(accumulate(map(min, right.values[first : end + 1], before), max))
                runs, best = known[key]
                if first <= done:
                    v = best[done - first]
                run = runs[done - t]
            for u in range(max(t, done + 1), top + 1):
                if u >= t + a:
                    v = max(v, min(value(right, u), run))
                    if u > k and right.formula.op == "atom":
                        break  # ψ's later samples: the same extreme under a running minimum no larger
                run = min(run, value(left, u))
        else:  # since
            a, b = node.low, node.high
            left, right = kids
            first = 0 if b is None else max(t - b, 0)
            done = min(t, _settled(left, k), _settled(right, k))
            v, run = -_INF, _INF
            for u in range(t, max(done, first - 1), -1):  # the open samples, nearest first
                if u <= t - a:
                    v = max(v, min(value(right, u), run))
                run = min(run, value(left, u))
            top = min(done, t - a)
            if top >= first:  # the settled ones: min(ψ(u), run, min of φ over (u, done]), suffix minima in C
                after = list(accumulate(reversed(left.values[first + 1 : done + 1]), min))[::-1]
                after.append(_INF)
                v = max(v, min(run, max(map(min, right.values[first : top + 1], after))))
        memo[key] = v
        return v

    return value(monitor.root, anchor)


def _settled(child: Node, k: int) -> int:
    """The last sample at which *child*'s value is the monitor's own at *k* (it reads no sample after *k*)."""
    return min(k - int(child.span), len(child.values) - 1) if child.span != _INF else -1


def _extreme(child: Node, first: int, top: int, k: int, larger: bool, value: Callable[[Node, int], float]) -> float:
    """The max (*larger*) or min of *child*'s values over [*first*, *top*] as :func:`bound_at` sees them at *k*:
    the final ones sliced from the monitor, the open ones from *value*."""
    if top < first:
        return -_INF if larger else _INF
    pick = max if larger else min
    done = min(top, k - int(child.span) if child.span != _INF else first - 1, len(child.values) - 1)
    best = pick(child.values[first : done + 1], default=-_INF if larger else _INF) if done >= first else (-_INF if larger else _INF)
    rest = range(max(first, done + 1), top + 1)
    if child.formula.op == "atom" and rest:  # an atom's samples after k: one extreme
        rest = rest[:1]
    for u in rest:
        v = value(child, u)
        best = v if (v > best if larger else v < best) else best
    return best


def bound_streamed(monitor: Monitor, anchor: int, k: int, lower: bool) -> float:
    """:func:`bound_at` worked out as the monitor works: a fresh monitor over the known samples and the
    extremes after them (amortised O(1) per sample per operator) - cheaper than :func:`bound_at`'s
    recursion where windows nest (ARCH-COMP's CC4: three), dearer for one long window over a long run."""
    fresh = Monitor(monitor.formula, monitor.tick)
    signs = polarities(monitor.formula)
    reach = sum(n.high or 0 for n in fresh.nodes if n.formula.op in ("always", "eventually", "until"))
    last = max(anchor, k) + reach + 1
    feeds = []
    for real, node in zip(monitor.atoms, fresh.atoms):
        extreme = -_INF if lower == signs[id(node.formula)] else _INF
        node.values.extend(real.values[: k + 1])
        node.values.extend([extreme] * (last + 1 - len(node.values)))
        feeds.append(node)
    for node in fresh.nodes:
        if node.formula.op == "atom":
            continue
        if node.formula.op == "always" and node.high is None:
            src = node.children[0].values
            if lower == signs[id(node.formula)]:  # the unknown rest can be anything: no lower end
                node.values[:] = [-_INF] * (last + 1)
            else:  # the known part's minimum; the rest may be +inf
                low, out = _INF, [_INF] * (last + 1)
                for t in range(min(k, last), -1, -1):
                    if src[t] < low:
                        low = src[t]
                    out[t] = low
                node.values[:] = out
            continue
        node.update()
        node.finish(last)
    return fresh.root.values[anchor]


def _costs(monitor: Monitor, anchor: int, k: int) -> tuple[float, float]:
    """Rough costs of :func:`bound_at` (its recursion: the windows' sizes multiplied down the nesting) and of
    :func:`bound_streamed` (samples times nodes), to pick the cheaper."""

    def rec(node: Node) -> float:
        op = node.formula.op
        if op == "atom":
            return 0.0
        inner = sum(rec(c) for c in node.children)
        if op in ("not", "and", "or", "implies"):
            return inner + 1
        width = (node.high if node.high is not None else k) - node.low + 1
        return width * (1 + inner) if op in ("until", "since") or inner else 1 + inner

    reach = sum(n.high or 0 for n in monitor.nodes if n.formula.op in ("always", "eventually", "until"))
    return rec(monitor.root), (max(anchor, k) + reach + 2) * len(monitor.nodes) * 4.0


def decided(monitor: Monitor, anchor: int, known_from: int, last: int, ended: bool) -> int:
    """The earliest sample after which the verdict at *anchor* was certain: the robustness's interval
    (:func:`bound_at`) lay above 0 or below 0; *last* (where the value became known) when it never did.

    Certainty only grows with the samples known, so this is a binary search over [*known_from*, *last*].
    *ended*: the trace ended at *last* (a formula that reads to the end of the run).
    """
    value = monitor.root.values[anchor]
    known: dict = {}  # bound_at's settled until parts, shared by the search's steps

    def certain(k: int) -> bool:
        if k >= last:
            return value != 0
        recursive, streamed = _costs(monitor, anchor, k)
        bound = partial(bound_at, known=known) if recursive <= streamed else bound_streamed
        return bound(monitor, anchor, k, True) > 0 or bound(monitor, anchor, k, False) < 0

    low, high = known_from, last
    if not certain(high):
        return last
    while low < high:
        mid = (low + high) // 2
        if certain(mid):
            high = mid
        else:
            low = mid + 1
    return low


def holds(node: Node, t: int) -> bool:
    """The formula's truth at sample *t*, from its atoms' truth (a margin of 0 is true when its atom held:
    the atoms' streams keep ``0.0`` for a held boundary and ``-0.0`` for a failed one). What the verdict of
    a robustness of exactly 0 is (its sign does not say). Needs the whole trace the value reads."""
    op = node.formula.op
    if op == "atom":
        v = node.values[t]
        return v > 0 or v == 0 and math.copysign(1.0, v) > 0
    kids = node.children
    if op == "not":
        return not holds(kids[0], t)
    if op == "and":
        return all(holds(c, t) for c in kids)
    if op == "or":
        return any(holds(c, t) for c in kids)
    if op == "implies":
        return not holds(kids[0], t) or holds(kids[1], t)
    end = len(kids[0].values) - 1
    a, b = node.low, node.high
    if op in ("eventually", "always"):
        top = end if b is None else min(t + b, end)
        test = any if op == "eventually" else all
        return test(holds(kids[0], u) for u in range(t + a, top + 1))
    if op in ("once", "historically"):
        first = 0 if b is None else max(t - b, 0)
        test = any if op == "once" else all
        return test(holds(kids[0], u) for u in range(first, t - a + 1))
    if op == "until":
        assert b is not None
        for u in range(t + a, min(t + b, end) + 1):
            if holds(kids[1], u) and all(holds(kids[0], w) for w in range(t, u)):
                return True
        return False
    first = 0 if b is None else max(t - b, 0)
    for u in range(first, t - a + 1):
        if holds(kids[1], u) and all(holds(kids[0], w) for w in range(u + 1, t + 1)):
            return True
    return False
