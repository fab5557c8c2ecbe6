"""Measurements of one benchmark case, run inside one process.

Everything here reports through an ``emit`` callback, one small ``dict`` per
finished stage, instead of returning at the end: the driver
(:mod:`benchmarks.run`) runs each case in a child process with a time limit,
and a case killed half-way must still report what it had measured (a 100k-entry
case that finishes its timing but not its memory pass is a finding, not a
blank line).

Timing rules, the same for the generator and for its floor:

* the input is JSON text on disk, written before the clock starts, and read
  through :func:`btgen_pytrees.load` exactly as the CLI reads a file;
* each repeat starts after a full ``gc.collect()`` with the previous tree
  already freed; the garbage collector stays *on* during a repeat, because
  users run with it on and its cost grows with the number of live objects
  (``gc_on=False`` switches it off, to see the algorithms' own growth);
* the best repeat is kept for each column (``min`` is the estimate least
  disturbed by the rest of the machine);
* the clock is the process's CPU time by default (``clock="cpu"``): on a
  machine shared with test runs, wall time mostly measures the queue for a
  core, while the ratios the issue sets are about work done. On an idle
  machine both clocks agree; ``clock="wall"`` uses :func:`time.perf_counter`;
* memory is a separate pass under :mod:`tracemalloc` (which slows allocation
  several-fold, so its run is never timed): the peak of Python allocations
  from reading the file to the returned tree.
"""

from __future__ import annotations

import gc
import json
import os
import tempfile
import time
import tracemalloc
from contextlib import contextmanager
from typing import Any, Callable, Iterator

import btgen_pytrees
from btgen_pytrees.clock import VirtualClock
from btgen_pytrees.run import run_tree
from py_trees.common import Status

from . import floor, timelines

__all__ = ["Emit", "CLOCKS", "measure_generation", "measure_ticks", "default_repeats"]

Emit = Callable[[dict[str, Any]], None]
"""Receives each stage's results as soon as the stage is done."""

_DONE = (Status.SUCCESS, Status.FAILURE)

CLOCKS: dict[str, Callable[[], float]] = {"cpu": time.process_time, "wall": time.perf_counter}
"""The clocks a measurement can read, by the name the command line uses."""


def default_repeats(n: int) -> int:
    """Repeats per measurement: more where one run is short and noisy, one at 100k."""
    if n <= 2_000:
        return 5
    if n <= 20_000:
        return 3
    return 1


def _write(data: dict[str, Any], directory: str) -> str:
    path = os.path.join(directory, f"{data['name']}.json")
    with open(path, "w", encoding="utf-8") as fh:
        json.dump(data, fh, separators=(",", ":"))
    return path


def _fresh() -> None:
    gc.collect()


@contextmanager
def _collector(on: bool) -> Iterator[None]:
    """Leave the garbage collector as it is (*on*), or switch it off for the block."""
    was = gc.isenabled()
    if not on:
        gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


def measure_generation(
    shape: str, n: int, repeats: int, emit: Emit, *, memory: bool = True, clock: str = "cpu", gc_on: bool = True
) -> None:
    """Time load / graph / construct for *shape* at *n* entries, then its floor, then memory.

    Emits, in order (a stage only once the one before it has finished):

    * ``stage``: the name of the stage about to start (so a killed run says where);
    * ``generated``: seconds per phase, node counts by kind, tree depth;
    * ``floor``: seconds to build the same shape from stock py_trees classes;
    * ``memory``: tracemalloc peak (and what the tree still holds) for the
      generator, then for the floor.

    With *gc_on* false the garbage collector is off during each timed repeat
    (for the generator and the floor alike): CPython's cyclic collector makes
    the cost per object grow with the number of live objects, so this is how to
    tell an algorithm's own growth from the collector's.

    ``construct`` is the time of :func:`btgen_pytrees.generate`, which reads the
    timeline from the entries; ``graph`` is :func:`btgen_pytrees.timeline` (the
    networkx graph the views and ``--format matrix`` build), measured on its own
    and not part of ``total`` (load + construct). The benchmark only uses public
    entry points so that it keeps measuring whatever the core becomes.
    """
    now = CLOCKS[clock]
    with tempfile.TemporaryDirectory(prefix="btgen-bench-") as directory:
        emit({"stage": "input"})
        path = _write(timelines.build(shape, n), directory)
        emit({"input_bytes": os.path.getsize(path)})

        emit({"stage": "generate"})
        best: dict[str, float] = {}
        shape_of_tree: floor.Shape | None = None
        for _ in range(repeats):
            _fresh()
            with _collector(gc_on):
                t0 = now()
                case = btgen_pytrees.load(path)
                t1 = now()
                graph = btgen_pytrees.timeline(case)
                t2 = now()
                del graph
                t3 = now()
                root = btgen_pytrees.generate(case)
                t4 = now()
            sample = {"load": t1 - t0, "graph": t2 - t1, "construct": t4 - t3,
                      "total": (t1 - t0) + (t4 - t3)}  # fmt: skip
            for key, value in sample.items():
                best[key] = min(best.get(key, value), value)
            if shape_of_tree is None:
                shape_of_tree = floor.capture(root)
                emit({"depth": floor.depth(root)})
            del case, root
        assert shape_of_tree is not None
        emit({"generated": best, "nodes": len(shape_of_tree), "counts": shape_of_tree.counts()})

        emit({"stage": "floor"})
        floor_best = float("inf")
        for _ in range(repeats):
            _fresh()
            with _collector(gc_on):
                t0 = now()
                tree = floor.build(shape_of_tree)
                floor_best = min(floor_best, now() - t0)
            del tree
        emit({"floor": floor_best})

        if not memory:
            return
        emit({"stage": "memory"})
        _fresh()
        tracemalloc.start()
        try:
            root = btgen_pytrees.generate(btgen_pytrees.load(path))
            held, peak = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
        del root
        emit({"peak": peak, "held": held})

        emit({"stage": "floor memory"})
        _fresh()
        tracemalloc.start()
        try:
            tree = floor.build(shape_of_tree)
            held, peak = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
        del tree
        emit({"floor_peak": peak, "floor_held": held})


def _bare_run(root: Any, case: Any, clock: VirtualClock, yields: list[int] | None = None) -> int:
    """Tick *root* the way :func:`~btgen_pytrees.run.run_tree` does, minus recorder and report.

    Same set-up call, same clock steps (``round(k * tick, 9)``), same stop
    rule; the loop body is py_trees' own ``tick_once`` (iterating the root's
    ``tick()``), counting the nodes ticked into *yields* (one number per run)
    when given. Returns the tick count.
    """
    root.setup_with_descendants()
    last = int(case.timeout / case.tick + 1e-9)
    ticks = 0
    ticked = 0
    for k in range(last + 1):
        clock.set(round(k * case.tick, 9))
        ticks = k + 1
        for _ in root.tick():
            ticked += 1
        if root.status in _DONE:
            break
    if root.status == Status.RUNNING:
        root.stop(Status.INVALID)
    if yields is not None:
        yields.append(ticked)
    return ticks


def measure_ticks(n: int, repeats: int, emit: Emit, *, clock: str = "cpu", shape: str = "random",
                  contenders: tuple[str, ...] = ("bare", "run_tree", "traced")) -> None:  # fmt: skip
    """Per-tick cost of ``run_tree`` against bare ticking of identically generated trees.

    The case of *shape* (the issue's target is on ``random``) with *n* entries
    is loaded once; each repeat generates a fresh tree for each contender (a
    tree runs once), alternating which goes first so neither always inherits
    the other's garbage. ``run_tree`` is timed whole - recorder set-up, ticks
    and report - because that is what a user waits for; ``traced`` adds a
    trace callback that keeps every line. *contenders* picks among the three
    (the per-shape run jobs leave ``traced`` out).

    Emits ``nodes`` and ``ticked`` (nodes ticked in the whole bare run: the
    active part), then after every contender's run the best ``seconds`` and
    the ``ticks`` of each contender so far (a long run that hits its time
    limit still reports the contenders that finished), and the ``verdict``.
    """
    now = CLOCKS[clock]
    emit({"stage": "load"})
    case = btgen_pytrees.load(timelines.build(shape, n))
    best: dict[str, float] = {}
    ticks: dict[str, int] = {}
    lines: list[str] = []
    yields: list[int] = []
    order = list(contenders)
    for r in range(repeats):
        for name in order if r % 2 == 0 else reversed(order):
            emit({"stage": name})
            virtual = VirtualClock()
            root = btgen_pytrees.generate(case, clock=virtual)
            if not best and not ticks:
                emit({"nodes": floor.count(root)})
            _fresh()
            t0 = now()
            if name == "bare":
                ticks[name] = _bare_run(root, case, virtual, yields)
            else:
                lines.clear()
                report = run_tree(root, case, virtual, trace=lines.append if name == "traced" else None)
                ticks[name] = report.ticks
                emit({"verdict": report.verdict})
                if name == "traced":
                    emit({"trace_lines": len(lines)})
            elapsed = now() - t0
            best[name] = min(best.get(name, elapsed), elapsed)
            del root
            if yields:
                emit({"ticked": yields[-1]})
            emit({"seconds": dict(best), "ticks": dict(ticks)})
