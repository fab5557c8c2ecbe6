"""A long single run shows how far it got, on a terminal only (``run``; docs/limits.md).

A run of 360,000 SUMO ticks takes most of a minute and used to print nothing
until its table. :class:`Progress` is the callback the runner calls after every
tick (``run(case, progress=...)``); it writes one line on stderr, rewritten in
place, at most four times a second and not before the run has taken half a
second (a short run shows nothing)::

    cut_in: t = 12.3 / 300 s · tick 124 · 8,412 ticks/s

and erases it when the run ends, so the table follows on a clean screen. It is
made only when stderr is a terminal and ``CI`` is not set (:func:`terminal_progress`):
never on a pipe, in a file or in a CI log, so the output of a run is the same
bytes whoever runs it. The run itself does not change: wall time is only shown.
"""

from __future__ import annotations

import os
import time
from typing import Callable, TextIO

__all__ = ["Progress", "terminal_progress", "FIRST", "EVERY"]

FIRST = 0.5
"""Seconds of wall time before the line first shows."""

EVERY = 0.25
"""Seconds of wall time between two updates of the line."""


class Progress:
    """Call with ``(ticks done, run time now)``; :meth:`done` erases the line (if one was written)."""

    def __init__(self, name: str, timeout: float, stream: TextIO, clock: Callable[[], float] = time.monotonic):
        self.name, self.timeout, self.stream, self.clock = name, timeout, stream, clock
        self.start = clock()
        self.next = self.start + FIRST
        self.shown = False

    def __call__(self, ticks: int, now: float) -> None:
        wall = self.clock()
        if wall < self.next:
            return
        self.next = wall + EVERY
        rate = ticks / max(wall - self.start, 1e-9)
        self.stream.write(f"\r{self.name}: t = {now:.1f} / {self.timeout:g} s \u00b7 tick {ticks:,} \u00b7 "
                          f"{rate:,.0f} ticks/s\x1b[K")  # fmt: skip
        self.stream.flush()
        self.shown = True

    def done(self) -> None:
        if self.shown:
            self.stream.write("\r\x1b[K")
            self.stream.flush()
            self.shown = False


def terminal_progress(name: str, timeout: float, stream: TextIO) -> Progress | None:
    """A :class:`Progress` on *stream* when it is a terminal and ``CI`` is not set, else ``None``."""
    if os.environ.get("CI"):
        return None
    try:
        if not stream.isatty():
            return None
    except (AttributeError, ValueError):  # a replaced or closed stream
        return None
    return Progress(name, timeout, stream)
