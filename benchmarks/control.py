"""What the control-flow keys cost: ``python -m benchmarks.control`` (docs/performance.md#control-flow).

Two questions of issue 32, each answered by ratios measured in one run:

* **load + generate**: a chain of *n* entries with control keys on every tenth entry
  (``when`` on a signal, ``timeout``, ``attempts``: what a real case writes, none of which
  changes the run of a one-tick ``hold``) against the same chain without them, at
  100,000 entries; the target is 1.2x.
* **run cost per tick stays linear**: the same chains run to the end (one entry active
  per tick, so the ticks grow with *n*): run time per tick at 100,000 entries against
  10,000 (1.0 = linear), for both, and the modified chain's run time against the plain one's.

Each figure is the best of ``--repeat`` alternating measurements (plain, modified, plain, ...)
in this process, the garbage collected before each, so both variants see the same machine.
"""

from __future__ import annotations

import argparse
import gc
import json
import sys
import time
from pathlib import Path
from typing import Any, Callable

if __package__ in (None, ""):  # run as a file: python benchmarks/control.py
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import btgen_pytrees  # noqa: E402
from btgen_pytrees.run import run  # noqa: E402

__all__ = ["chain", "measure", "main", "TARGET"]

TARGET = 1.2
"""Load + generate of the modified chain against the plain one, at 100,000 entries (issue 32)."""

MODIFIERS = ({"when": "x >= 0"}, {"timeout": 1}, {"attempts": 2}, {"when": "x >= 0", "edge": "none", "timeout": 1, "attempts": 2})
"""The keys every tenth entry gets, in turn: a start condition that holds at once, a timeout and a retry that never
fire, and the three together (none changes the run of a one-tick ``hold``)."""


def chain(n: int, modified: bool) -> dict[str, Any]:
    """A chain of *n* one-tick ``hold`` entries; with *modified*, every tenth carries :data:`MODIFIERS`."""
    execute = []
    for i in range(n):
        entry: dict[str, Any] = {"id": f"S{i}", "kind": "behavior", "action": "hold", "params": {"duration": 0.1}}
        if i:
            entry["after"] = [f"S{i - 1}"]
        if modified and i % 10 == 9:
            entry.update(MODIFIERS[i // 10 % len(MODIFIERS)])
        execute.append(entry)
    return {"name": "chain", "signals": {"x": 0}, "tick": 0.1, "timeout": n * 0.1 + 10, "execute": execute}


def _best(work: Callable[[], Any], repeat: int) -> float:
    """The least CPU time (``time.process_time``: the machine may be shared) of *repeat* calls of *work*."""
    best = float("inf")
    for _ in range(repeat):
        gc.collect()
        start = time.process_time()
        work()
        best = min(best, time.process_time() - start)
    return best


def _build(data: dict[str, Any]) -> Callable[[], Any]:
    def work() -> Any:
        return btgen_pytrees.generate(btgen_pytrees.load(data))

    return work


def _run(case: Any) -> Callable[[], Any]:
    def work() -> Any:
        report = run(case, record=False)
        if report.verdict != "pass":
            raise AssertionError(f"the benchmark chain did not pass: {report.verdict} {report.message}")
        return report

    return work


def measure(sizes: tuple[int, ...] = (10_000, 100_000), repeat: int = 3, runs: bool = True) -> dict[str, Any]:
    """Every figure, by size: ``build`` (load + generate) and ``run`` seconds of both variants, and the ratios."""
    out: dict[str, Any] = {"sizes": {}, "modifiers": list(MODIFIERS), "repeat": repeat}
    for n in sizes:
        plain, modified = chain(n, False), chain(n, True)
        build = {"plain": float("inf"), "modified": float("inf")}
        for _ in range(repeat):  # alternating, so both see the same machine
            build["plain"] = min(build["plain"], _best(_build(plain), 1))
            build["modified"] = min(build["modified"], _best(_build(modified), 1))
        if not runs:
            out["sizes"][n] = {"build_s": build, "build_ratio": build["modified"] / build["plain"]}
            continue
        cases = {"plain": btgen_pytrees.load(plain), "modified": btgen_pytrees.load(modified)}
        ran = {"plain": float("inf"), "modified": float("inf")}
        for _ in range(repeat):
            for name in ran:
                ran[name] = min(ran[name], _best(_run(cases[name]), 1))
        ticks = cases["plain"].ticks  # (the run ends after n ticks: the same for both)
        ended = run(cases["modified"], record=False).ticks
        out["sizes"][n] = {
            "build_s": build, "build_ratio": build["modified"] / build["plain"],
            "run_s": ran, "run_ratio": ran["modified"] / ran["plain"], "ticks": ended,
            "run_us_per_tick": {k: v / ended * 1e6 for k, v in ran.items()}, "timeout_ticks": ticks,
        }  # fmt: skip
    if len(sizes) > 1 and runs:
        small, large = out["sizes"][sizes[0]], out["sizes"][sizes[-1]]
        out["run_scaling"] = {k: large["run_us_per_tick"][k] / small["run_us_per_tick"][k] for k in ("plain", "modified")}
    return out


def report(figures: dict[str, Any]) -> str:
    keys = sorted({k for m in figures["modifiers"] for k in m})
    lines = [f"control-flow keys on every tenth entry of a chain (in turn: {', '.join(keys)}); best of {figures['repeat']}"]
    for n, f in figures["sizes"].items():
        lines.append(f"  n={n:>7,}: load+generate {f['build_s']['plain']:.2f} s plain, {f['build_s']['modified']:.2f} s "
                     f"modified = {f['build_ratio']:.2f}x (target {TARGET}x)" + ("" if "run_s" not in f else
                     f"; run {f['run_s']['plain']:.2f} s plain, "
                     f"{f['run_s']['modified']:.2f} s modified = {f['run_ratio']:.2f}x, {f['ticks']:,} ticks, "
                     f"{f['run_us_per_tick']['plain']:.1f} / {f['run_us_per_tick']['modified']:.1f} us per tick"))  # fmt: skip
    if "run_scaling" in figures:
        s = figures["run_scaling"]
        lines.append(f"  run time per tick, largest size against smallest: plain {s['plain']:.2f}x, modified "
                     f"{s['modified']:.2f}x (1.0 = linear)")  # fmt: skip
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.control", description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[10_000, 100_000])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--build-only", action="store_true", help="load + generate only, no runs")
    parser.add_argument("--json", help="also write every figure to this file")
    args = parser.parse_args(argv)
    figures = measure(tuple(args.sizes), args.repeat, runs=not args.build_only)
    print(report(figures))
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
