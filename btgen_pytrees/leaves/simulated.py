"""Built-in simulated behaviours and constraints.

They act on signals stored on the blackboard (see
:mod:`~btgen_pytrees.contracts.environment`) and measure time with the
environment's clock, so the same leaves run on the simulator's virtual clock and
in a host application on wall-clock time.

Timing rule shared by all of them: a leaf that lasts *d* seconds and starts at
time *s* succeeds on the first tick with ``now >= s + d`` (with a tolerance of a
nanosecond, so that 0.1 * 3 counts as 0.3).
"""

from __future__ import annotations

import bisect
from typing import Any, Iterator, Mapping

from py_trees.common import Status

from ..contracts.environment import Environment
from ..expressions import ExpressionError
from ..model import Entry
from .node import Node

__all__ = ["SimulatedLeaf", "Set", "Ramp", "Profile", "profile_problems", "Hold", "Wait", "Until", "reached"]

# the statuses as module constants: ``Status.SUCCESS`` is a look-up on the Enum class (~80 ns), every tick
_SUCCESS, _FAILURE, _RUNNING = Status.SUCCESS, Status.FAILURE, Status.RUNNING


def reached(elapsed: float, duration: float) -> bool:
    """Whether *elapsed* seconds cover *duration*, tolerating float rounding (a nanosecond per second of
    *duration*, at least a nanosecond).

    >>> reached(0.1 * 3, 0.3), reached(0.29, 0.3), reached(1e9 - 0.5, 1e9)
    (True, False, True)
    """
    size = abs(duration)
    return elapsed >= duration - 1e-9 * (size if size > 1.0 else 1.0)  # max(1.0, |duration|) without the call


class SimulatedLeaf(Node):
    """Base: remembers its entry, its environment and when it started.

    ``client`` is its py_trees blackboard client, with the keys of :meth:`keys`
    declared (``None`` for a leaf without any; see
    :meth:`Environment.attach <btgen_pytrees.leaves.Environment.attach>`).
    """

    def __init__(self, entry: Entry, env: Environment):
        super().__init__(entry.name)
        self.entry = entry
        self.env = env
        self.params = entry.params
        self.started = 0.0
        self.client = None
        if type(self).keys is not SimulatedLeaf.keys:  # a leaf class without keys (hold, wait) builds no lists
            reads, writes = self.keys()
            if reads or writes:
                self.client = env.attach(self, reads=reads, writes=writes)

    def keys(self) -> tuple[list[str], list[str]]:
        """The blackboard keys this leaf reads and writes (absolute); none by default."""
        return [], []

    def initialise(self) -> None:
        self.started = self.env.now()

    def elapsed(self) -> float:
        return self.env.now() - self.started

    def timed_out(self, default: float | None = None) -> float | None:
        """The leaf's ``timeout`` param (*default* when it has none) once that many seconds have
        passed since it started; ``None`` before then, and always for a leaf without a timeout."""
        timeout = self.params.get("timeout", default)
        if timeout is not None and reached(self.elapsed(), timeout):
            return timeout
        return None


class Set(SimulatedLeaf):
    """``set {signal, value, duration?}``: write *value* at start, then hold for *duration*."""

    def keys(self) -> tuple[list[str], list[str]]:
        return [], [self.env.signal_key(self.params["signal"])]

    def initialise(self) -> None:
        super().initialise()
        self.env.write(self.params["signal"], self.params["value"], self.client)
        self.feedback_message = f"{self.params['signal']} = {self.params['value']}"

    def update(self) -> Status:
        duration = self.params.get("duration")
        if duration is None or reached(self.elapsed(), duration):
            return _SUCCESS
        return _RUNNING


class Ramp(SimulatedLeaf):
    """``ramp {signal, to, duration}``: move linearly from the value at start (0 if unset) to *to*.

    A boolean signal cannot be interpolated: it takes *to* at the end of the ramp.
    """

    def keys(self) -> tuple[list[str], list[str]]:
        return [], [self.env.signal_key(self.params["signal"])]  # written, and read at the start

    def initialise(self) -> None:
        super().initialise()
        signal = self.params["signal"]
        try:
            self.origin: Any = self.env.read(signal, self.client)
        except KeyError:  # a signal without an initial value ramps from 0
            self.origin = 0

    def update(self) -> Status:
        signal, target, duration = self.params["signal"], self.params["to"], self.params["duration"]
        elapsed = self.elapsed()
        if reached(elapsed, duration):
            self.env.write(signal, target, self.client)
            self.feedback_message = f"{signal} = {target}"
            return _SUCCESS
        if isinstance(self.origin, bool):
            return _RUNNING
        value = self.origin + (target - self.origin) * (elapsed / duration)
        self.env.write(signal, value, self.client)
        self.feedback_message = f"{signal} = {value:.6g}"
        return _RUNNING


def profile_problems(params: Mapping[str, Any]) -> Iterator[tuple[tuple[str | int, ...], str]]:
    """What the schema cannot say about ``profile``'s ``points``: their times increase, and a boolean
    signal only steps.

    >>> list(profile_problems({"signal": "u", "points": [[0, 1], [5, 2], [5, 3]]}))
    [(('points', 2, 0), 'the times must increase: 5 s follows 5 s')]
    """
    points = params["points"]
    for i in range(1, len(points)):
        if not points[i][0] > points[i - 1][0]:
            yield ("points", i, 0), f"the times must increase: {points[i][0]:g} s follows {points[i - 1][0]:g} s"
    if params.get("shape", "step") != "step":
        for i, (_, value) in enumerate(points):
            if isinstance(value, bool):
                yield ("points", i, 1), f"a {params['shape']} profile interpolates numbers; {str(value).lower()} only steps"


class Profile(SimulatedLeaf):
    """``profile {signal, points, shape}``: an input signal given by control points ``[t, value]``.

    *t* is seconds from the entry's start. ``step`` holds each value from its time until the next
    point's; ``linear`` interpolates between points; ``pchip`` is SciPy's shape-preserving piecewise
    cubic through them (``scipy.interpolate.PchipInterpolator``: no overshoot between two points, so a
    throttle profile in [0, 1] stays in [0, 1]). When the first point's time is after 0, the signal's
    value at the start (0 when it has none) is the point at 0, as ``ramp`` starts from it. On the first
    tick at or after the last point's time the last value is written and the entry succeeds.

    A falsification input is such a signal: its values (and times) may be ``$parameters``, so a sweep's
    or a search's box is the input space (docs/falsify.md, the chasing-cars example).
    """

    def keys(self) -> tuple[list[str], list[str]]:
        return [], [self.env.signal_key(self.params["signal"])]  # written, and read at the start

    def initialise(self) -> None:
        super().initialise()
        points = [(float(t), v) for t, v in self.params["points"]]
        if points[0][0] > 0:
            try:
                origin = self.env.read(self.params["signal"], self.client)
            except KeyError:  # a signal without an initial value starts from 0, as a ramp does
                origin = 0
            points.insert(0, (0.0, origin))
        self.times = [t for t, _ in points]
        self.values = [v for _, v in points]
        self.shape = self.params.get("shape", "step")
        self.curve = None
        if self.shape == "pchip" and len(points) > 1:
            from scipy.interpolate import PchipInterpolator  # the 'search' extra; checked when the case is loaded

            self.curve = PchipInterpolator(self.times, [float(v) for v in self.values])

    def value(self, elapsed: float) -> Any:
        """The profile's value *elapsed* seconds after the start (before the last point's time)."""
        times, values = self.times, self.values
        i = bisect.bisect_right(times, elapsed) - 1
        while i + 1 < len(times) and reached(elapsed, times[i + 1]):  # 0.1 * 3 is at the point of 0.3
            i += 1
        if self.shape == "step" or i + 1 >= len(times):
            return values[i]
        if self.curve is not None:
            return float(self.curve(elapsed))
        t0, t1, v0, v1 = times[i], times[i + 1], values[i], values[i + 1]
        return v0 + (v1 - v0) * ((elapsed - t0) / (t1 - t0))

    def update(self) -> Status:
        signal, elapsed = self.params["signal"], self.elapsed()
        if reached(elapsed, self.times[-1]):
            self.env.write(signal, self.values[-1], self.client)
            self.feedback_message = f"{signal} = {self.values[-1]}"
            return _SUCCESS
        value = self.value(elapsed)
        self.env.write(signal, value, self.client)
        self.feedback_message = f"{signal} = {value:.6g}"
        return _RUNNING


class Hold(SimulatedLeaf):
    """``hold {duration}``: a behaviour that lets time pass."""

    def update(self) -> Status:
        if reached(self.elapsed(), self.params["duration"]):
            return _SUCCESS
        self.feedback_message = f"{self.elapsed():.6g}/{self.params['duration']} s"
        return _RUNNING


class Wait(Hold):
    """``wait {duration}``: a constraint that succeeds once *duration* has passed."""


class Until(SimulatedLeaf):
    """``until {expect, timeout?}``: succeed on the first tick *expect* holds; fail after *timeout*."""

    def keys(self) -> tuple[list[str], list[str]]:
        return [self.env.signal_key(n) for n in self.entry.expressions["expect"].ordered_names], []

    def update(self) -> Status:
        expect = self.entry.expressions["expect"]
        env = self.env
        values = env.values(expect.ordered_names, self.client)
        why = ""
        try:
            ok = bool(expect.evaluate(values))
        except ExpressionError as exc:
            ok, why = False, f": {exc}"
        if ok:
            self.feedback_message = f"{expect.source} held at {env.now():.6g} s"
            return _SUCCESS
        timeout = self.timed_out()
        if timeout is not None:
            shown = ", ".join(f"{k}={v!r}" for k, v in sorted(values.items()))
            self.feedback_message = f"{expect.source} still false after {timeout} s" + (f" ({shown})" if shown else "") + why
            return _FAILURE
        return _RUNNING
