"""One small run taken apart in CPU time: ``python -m benchmarks.small_run`` (needs the ``sumo`` extra).

Issue 22 asks that a SUMO run inside a search cost at most 1.5x the same run in a bare libsumo loop
(``python -m benchmarks.falsify --sumo-loop``). Its ``cut_in_3d`` case at 20 random settings is taken
apart here as the search's job runs it (validate the concrete case, create the system, generate the
tree, ``run_tree`` without a trace), with the process's CPU clock (``time.process_time``; SUMO runs
in the process, so it counts) rather than the wall clock, which on a machine shared with other work
mostly measures the queue for a core:

* the parts of a run, medians over ``--rounds`` x 20 runs: validating, the system and the tree, SUMO's
  start (or its restore, on a simulation kept open between runs) and close, SUMO's steps, the adapter,
  and the rest: the tree's ticks through py_trees, the leaves, the oracles and the collector;
  once with the simulation kept open (``reuse_simulations``, as a search's worker runs them) and once
  started per run;
* the *steady tick*: the same tree ticked in place (the runner's loop: the clock, the system's signals
  published, the tick and the collector's visit) ``--ticks`` times at one moment of a run, without SUMO
  stepping between the ticks - the tick's own cost, without the cache misses a SUMO step leaves.

The figures are in docs/performance.md ("A SUMO run inside a search"), how they came about in
docs/performance-history.md ("A small run inside a search").
"""

from __future__ import annotations

import argparse
import contextlib
import json
import random
import statistics
import sys
import time
from typing import Any, Callable, Sequence

from btgen_pytrees.clock import VirtualClock
from btgen_pytrees.construct import generate
from btgen_pytrees.falsify import Space
from btgen_pytrees.leaves import default_registry
from btgen_pytrees.load import validate
from btgen_pytrees.run import Collector, create_system, run_tree
from btgen_pytrees.run import runner
from btgen_pytrees.systems.sumo import reuse_simulations

from .falsify import _row, _sweep

PARTS = ("validate", "system and tree", "SUMO start+close", "SUMO steps", "adapter", "tree, collector")
PYTHON = ("validate", "system and tree", "tree, collector")
"""The parts that are the package's Python, not SUMO's nor the adapter's."""


def parts(sweep: Any, values: dict[str, Any], clock: Callable[[], float] = time.process_time) -> dict[str, float]:
    """One run at *values* taken apart (seconds of *clock*), as ``benchmarks.falsify`` does with the wall clock."""
    registry = default_registry()
    t0 = clock()
    case = validate(sweep.document({**sweep.defaults, **values}), sweep.source, registry)
    t1 = clock()
    system = create_system(case, registry)
    system.timer = clock  # type: ignore[attr-defined]
    root = generate(case, registry=registry, clock=system)
    t2 = clock()
    run_tree(root, case, system=system, record=False)  # as the sweep's job
    t3 = clock()
    _drop(root)
    timing = system.timing  # type: ignore[attr-defined]
    return {"validate": t1 - t0, "system and tree": t2 - t1, "SUMO start+close": timing["start"] + timing["close"],
            "SUMO steps": timing["sumo"], "adapter": timing["adapter"],
            "tree, collector": t3 - t2 - sum(timing.values())}  # fmt: skip


def steady_tick(sweep: Any, ticks: int, at: int = 20) -> float:
    """Seconds of CPU per tick of the ``cut_in_3d`` tree ticked in place *ticks* times after *at* real ticks
    (the gap is not reached yet: the cut-in waits, both records judge, every tick alike)."""
    registry = default_registry()
    case = validate(sweep.document({**sweep.defaults, "gap": 1.5}), sweep.source, registry)
    system = create_system(case, registry)
    root = generate(case, registry=registry, clock=system)
    env = root.btgen_env
    clock = VirtualClock()
    env.clock, env.system = clock, system
    root.setup_with_descendants()
    system.start(env)
    collector = Collector(root)
    visit = getattr(collector, "visit", None)
    try:
        for k in range(at + ticks):
            if k == at:
                t0 = time.process_time()
            clock.set(system.now())
            system.publish(env)
            collector.initialise()
            if visit is not None:
                visit(root.tick())
            else:  # the code before Collector.visit
                for node in root.tick():
                    collector.run(node)
            collector.finalise()
            if k < at:
                system.tick()
        spent = time.process_time() - t0
        assert root.status.name == "RUNNING", "the tree finished while ticked in place"
    finally:
        system.close()
        _drop(root)
    return spent / ticks


def _drop(root: Any) -> None:
    """What ``run()`` does with the tree it made (``take_apart``; code before it: the environment's release and
    clear, or release only)."""
    take_apart = getattr(runner, "take_apart", None)
    if take_apart is not None:
        take_apart(root)
        return
    env = root.btgen_env
    env.release()
    if hasattr(env, "clear"):
        env.clear()


def measure(points: int = 20, rounds: int = 5, ticks: int = 20_000) -> dict[str, Any]:
    sweep = _sweep("cut_in_3d")
    space = Space.of(sweep.variations)
    rng = random.Random(1)
    settings = [space.values([rng.random() for _ in space.dimensions]) for _ in range(points)]
    _row(sweep, settings[0])  # warm-up (imports, caches)
    found: dict[str, dict[str, list[float]]] = {"kept": {}, "fresh": {}}
    for _ in range(rounds):
        for name, block in (("kept", reuse_simulations), ("fresh", contextlib.nullcontext)):
            with block():
                if name == "kept":
                    parts(sweep, settings[0])  # the block's first run starts SUMO
                for values in settings:
                    for part, seconds in parts(sweep, values).items():
                        found[name].setdefault(part, []).append(seconds)
    out: dict[str, Any] = {"points": points, "rounds": rounds}
    for name, table in found.items():
        ms = {part: 1000 * statistics.median(table[part]) for part in PARTS}
        out[name] = {**ms, "python": sum(ms[p] for p in PYTHON)}
    out["steady_tick_us"] = 1e6 * min(steady_tick(sweep, ticks) for _ in range(3))
    return out


def text(result: dict[str, Any]) -> str:
    lines = [f"cut_in_3d, {result['points']} settings x {result['rounds']} rounds; CPU time, medians, ms per run"]
    labels = {**{part: part for part in PARTS}, "python": "the package's Python (" + " + ".join(PYTHON) + ")"}
    width = max(map(len, labels.values()))
    lines.append(f"{'SUMO:':<{width}}  {'kept':>7}  {'fresh':>7}")
    for part, shown in labels.items():
        lines.append(f"{shown:<{width}}  {result['kept'][part]:7.2f}  {result['fresh'][part]:7.2f}")
    lines.append(f"steady tick (the tree ticked in place, best of 3): {result['steady_tick_us']:.1f} us")
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.small_run", description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=5, help="rounds of the 20 settings (default 5)")
    parser.add_argument("--ticks", type=int, default=20_000, help="ticks of the steady-tick measurement")
    parser.add_argument("--json", metavar="PATH", help="also write the figures as JSON")
    args = parser.parse_args(argv)
    result = measure(rounds=args.rounds, ticks=args.ticks)
    sys.stdout.write(text(result))
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            f.write(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
