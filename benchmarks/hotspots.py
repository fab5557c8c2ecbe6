"""cProfile one pipeline step of one benchmark case and print its hot spots.

``python -m benchmarks.run --profile random:100000`` profiles the load, the
generation and (for sizes the tick benchmark can afford) the run of that case,
each on its own, and prints the functions with the most time of their own and
the most time below them. This is how ``docs/performance.md`` finds where a
missed target goes; keep the profiled steps those the table times.
"""

from __future__ import annotations

import cProfile
import io
import json
import os
import pstats
import tempfile
from typing import Any, Callable

import btgen_pytrees
from btgen_pytrees.clock import VirtualClock
from btgen_pytrees.run import run_tree

from . import timelines

__all__ = ["profile_case", "STEPS"]

STEPS = ("load", "generate", "run")


def _stats(func: Callable[[], Any], top: int) -> tuple[Any, str]:
    profiler = cProfile.Profile()
    result = profiler.runcall(func)
    out = io.StringIO()
    stats = pstats.Stats(profiler, stream=out).strip_dirs()
    for order in ("tottime", "cumulative"):
        out.write(f"-- by {order}\n")
        stats.sort_stats(order).print_stats(top)
    return result, out.getvalue()


def profile_case(shape: str, n: int, steps: tuple[str, ...] = STEPS, top: int = 20) -> str:
    """The profile report of *steps* for *shape* at *n* entries, as text."""
    report = []
    with tempfile.TemporaryDirectory(prefix="btgen-profile-") as directory:
        path = os.path.join(directory, "case.json")
        with open(path, "w", encoding="utf-8") as fh:
            json.dump(timelines.build(shape, n), fh)
        case, text = _stats(lambda: btgen_pytrees.load(path), top)
        if "load" in steps:
            report.append(f"==== load {shape} n={n}\n{text}")
        if "generate" in steps:
            _, text = _stats(lambda: btgen_pytrees.generate(case), top)
            report.append(f"==== generate {shape} n={n}\n{text}")
        if "run" in steps:
            clock = VirtualClock()
            root = btgen_pytrees.generate(case, clock=clock)
            result, text = _stats(lambda: run_tree(root, case, clock), top)
            report.append(f"==== run {shape} n={n}: {result.verdict} after {result.ticks} ticks\n{text}")
    return "\n".join(report)
