"""Clocks that leaves read time from.

A generated tree never sleeps and never calls :func:`time.time` directly: every
leaf asks the :class:`~btgen_pytrees.contracts.environment.Environment` for the
time, and the environment asks its clock - once per tick, when the tree's root
begins the tick, so every node of a tick sees one time. Two clocks cover the
two ways a tree is ticked:

* :class:`VirtualClock` - moves only when set. The runner (``btgen_pytrees.run``)
  sets it to the system's time (``system.now()``) before each tick: with the
  simulated system tick *k* happens at ``k * tick``, so runs are fast and
  reproducible to the byte.
* :class:`WallClock` - the default of :func:`btgen_pytrees.generate`, for a host
  application that ticks the tree itself at its own pace.

A host with its own notion of time (a simulator, a ROS clock) passes any object
with a ``now() -> float`` method.

>>> c = VirtualClock()
>>> c.set(0.5); c.now()
0.5
"""

from __future__ import annotations

import time
from typing import Protocol

__all__ = ["Clock", "VirtualClock", "WallClock"]


class Clock(Protocol):
    def now(self) -> float:
        """Seconds, on any monotonic scale; leaves only use differences."""
        ...  # pragma: no cover


class VirtualClock:
    """A clock that only moves when told to."""

    def __init__(self, start: float = 0.0):
        self.time = float(start)

    def now(self) -> float:
        return self.time

    def set(self, seconds: float) -> None:
        self.time = float(seconds)


class WallClock:
    """Monotonic wall-clock time (:func:`time.monotonic`)."""

    def now(self) -> float:
        return time.monotonic()
