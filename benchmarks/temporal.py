"""Temporal criteria against record criteria: ``python -m benchmarks.temporal``.

Issue 34: 20 bounded temporal operators over a 10,000-tick run should cost at most 2x the same run with
20 ``record`` criteria. Both cases ramp one signal for 999.9 s at a 0.1 s tick (10,000 ticks) and read it
in 20 criteria: ``x <= c`` on every tick (record), or ``always[0, 999.9](x <= c)`` /
``eventually[0, 999.9](x >= c)`` anchored at 0 (temporal: the run goes on to their horizon, the same
10,000 ticks; the monitor keeps each window's extreme in a monotone deque, and ``decided`` is worked out
at the end). A third case, ``nested``, has 20 ``always[0, 990](eventually[0, 9.9](x >= c))`` (40 operators).
Each run is ``run(case, record=False)`` as a sweep's or a search's job runs it, timed with the process's
CPU clock, the cases taken in turns (``--rounds``); the report is the median per case and the ratios.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from typing import Any, Sequence

from btgen_pytrees import load
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
        else:
            criteria.append({"id": f"C{i}", "type": "temporal", "expect": f"always[0, 990](eventually[0, 9.9](x >= {-1 - i}))"})
    return {"name": kind, "tick": 0.1, "timeout": 1100, "signals": {"x": 0.0},
            "execute": [{"id": "Up", "kind": "behavior", "action": "ramp", "params": {"signal": "x", "to": 999.9, "duration": 999.9}}],
            "oracle": {"criteria": criteria}}  # fmt: skip


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.temporal", description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--json", metavar="PATH")
    args = parser.parse_args(argv)
    cases = {kind: load(case(kind)) for kind in ("record", "temporal", "nested")}
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
    if args.json:
        with open(args.json, "w", encoding="utf-8") as handle:
            json.dump({"medians": medians, "ticks": ticks, "times": times}, handle, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
