"""Temporal criteria against record criteria: ``python -m benchmarks.temporal``.

Issue 34: 20 bounded temporal operators over a 10,000-tick run should cost at most 2x the same run with
20 ``record`` criteria. Both cases ramp one signal for 999.9 s at a 0.1 s tick (10,000 ticks) and read it
in 20 criteria: ``x <= c`` on every tick (record), or ``always[0, 999.9](x <= c)`` /
``eventually[0, 999.9](x >= c)`` anchored at 0 (temporal: the run goes on to their horizon, the same
10,000 ticks; the monitor keeps each window's extreme in a monotone deque, and ``decided`` is worked out
at the end). A third case, ``nested``, has 20 ``always[0, 990](eventually[0, 9.9](x >= c))`` (40 operators);
a fourth, ``until``, 20 ``(x >= -1) until[0, 999.9] (x >= c)`` / ``until[499.9, 999.9]`` (windows of 10,000
and 5,000 ticks).
Each run is ``run(case, record=False)`` as a sweep's or a search's job runs it, timed with the process's
CPU clock, the cases taken in turns (``--rounds``); the report is the median per case and the ratios.

Then the monitor alone (``--window-ticks``): ``until`` and ``since`` over windows of 10 and of 1,000 ticks,
``(x > c) until[w/2, w] (y > d)`` with ``w`` the window, stepped over the same 20,000 random samples, the CPU
time per tick per operator, the windows in turns. Amortised O(1) per tick: the wide window costs what the
narrow one does (ratio ~1); O(window) would be ~100x.
"""

from __future__ import annotations

import argparse
import json
import random
import statistics
import sys
import time
from typing import Any, Sequence

from btgen_pytrees import load
from btgen_pytrees.formulas import parse
from btgen_pytrees.monitor import Monitor
from btgen_pytrees.run import run

N = 20


def case(kind: str) -> dict[str, Any]:
    criteria = []
    for i in range(N):
        if kind == "record":
            criteria.append({"id": f"C{i}", "type": "record", "expect": f"x <= {2000 + i}"})
        elif kind == "temporal":
            expect = f"always[0, 999.9](x <= {2000 + i})" if i % 2 == 0 else f"eventually[0, 999.9](x >= {990 - i})"
            criteria.append({"id": f"C{i}", "type": "temporal", "expect": expect})
        elif kind == "until":
            window = "[0, 999.9]" if i % 2 == 0 else "[499.9, 999.9]"
            criteria.append({"id": f"C{i}", "type": "temporal", "expect": f"(x >= -1) until{window} (x >= {990 - i})"})
        else:
            criteria.append({"id": f"C{i}", "type": "temporal", "expect": f"always[0, 990](eventually[0, 9.9](x >= {-1 - i}))"})
    return {"name": kind, "tick": 0.1, "timeout": 1100, "signals": {"x": 0.0},
            "execute": [{"id": "Up", "kind": "behavior", "action": "ramp", "params": {"signal": "x", "to": 999.9, "duration": 999.9}}],
            "oracle": {"criteria": criteria}}  # fmt: skip


def window_cost(op: str, width: int, samples: list[tuple[float, float]], tick: float = 0.1) -> float:
    """CPU seconds per tick of one ``until``/``since`` operator with a window of *width* ticks over *samples*."""
    formula = parse(f"(x > -0.8) {op}[{width // 2 * tick:.6g}, {width * tick:.6g}] (y > 0.9)")
    monitor = Monitor(formula, tick)
    judges = [e.judge for e in monitor.expressions]
    margins = [[judge({"x": x, "y": y})[1] for judge in judges] for x, y in samples]
    start = time.process_time()
    for m in margins:
        monitor.step(m)
    monitor.finish()
    return (time.process_time() - start) / len(samples)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.temporal", description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--json", metavar="PATH")
    parser.add_argument("--window-ticks", type=int, nargs=2, default=[10, 1000], metavar=("NARROW", "WIDE"))
    parser.add_argument("--samples", type=int, default=20000)
    args = parser.parse_args(argv)
    cases = {kind: load(case(kind)) for kind in ("record", "temporal", "nested", "until")}
    times: dict[str, list[float]] = {kind: [] for kind in cases}
    ticks: dict[str, int] = {}
    for _ in range(args.rounds):
        for kind, loaded in cases.items():
            start = time.process_time()
            report = run(loaded, record=False)
            times[kind].append(time.process_time() - start)
            ticks[kind] = report.ticks
            assert report.verdict == "pass", (kind, report.verdict, report.message)
    medians = {kind: statistics.median(values) for kind, values in times.items()}
    base = medians["record"]
    print(f"{'case':10} {'ticks':>6} {'median CPU s':>13} {'vs record':>10}")
    for kind, value in medians.items():
        print(f"{kind:10} {ticks[kind]:6d} {value:13.3f} {value / base:9.2f}x")
    rng = random.Random(34)
    samples = [(rng.uniform(-1, 1), rng.uniform(-1, 1)) for _ in range(args.samples)]
    narrow, wide = args.window_ticks
    per_tick: dict[str, list[float]] = {f"{op} {w}": [] for op in ("until", "since") for w in (narrow, wide)}
    for _ in range(args.rounds):
        for op in ("until", "since"):
            for w in (narrow, wide):
                per_tick[f"{op} {w}"].append(window_cost(op, w, samples))
    windows = {key: statistics.median(values) for key, values in per_tick.items()}
    print(f"\n{'operator':16} {'window':>7} {'us/tick':>8} {'vs ' + str(narrow):>8}")
    for op in ("until", "since"):
        for w in (narrow, wide):
            value = windows[f"{op} {w}"]
            print(f"{op:16} {w:7d} {value * 1e6:8.2f} {value / windows[f'{op} {narrow}']:7.2f}x")
    if args.json:
        with open(args.json, "w", encoding="utf-8") as handle:
            json.dump({"medians": medians, "ticks": ticks, "times": times, "windows": windows}, handle, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
