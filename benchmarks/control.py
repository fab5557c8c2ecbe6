"""What the control-flow keys cost: ``python -m benchmarks.control`` (docs/performance.md#control-flow).

Two questions of issue 32, each answered by ratios measured in one run:

* **load + generate**: a chain of *n* entries with control keys on every tenth entry
  (``when`` on a signal, ``timeout``, ``attempts``: what a real case writes, none of which
  changes the run of a one-tick ``hold``) against the same chain without them, at
  100,000 entries; the target is 1.2x. The input is the case's JSON file, written before the
  clock starts and read by :func:`btgen_pytrees.load` as the CLI reads it (the rule of
  :mod:`benchmarks.measure`); the same from the ``dict`` already in memory is reported beside it.
* **run cost per tick stays linear**: the same chains run to the end (one entry active
  per tick, so the ticks grow with *n*): run time per tick at the largest size against
  the smallest (1.0 = linear), for both, and the modified chain's run time against the plain one's.

Each ratio is the median of ``--rounds`` rounds; a round measures both variants back to back (the
order alternating from round to round), each with its own input alone in memory (the other's dict
is not held while it loads) after a full ``gc.collect()``, with the collector on, in CPU time
(``time.process_time``: the machine may be shared), so both see the same machine and a disturbance
shifts one round, not the figure.
"""

from __future__ import annotations

import argparse
import gc
import json
import statistics
import sys
import tempfile
import time
from functools import partial
from pathlib import Path
from typing import Any, Callable

if __package__ in (None, ""):  # run as a file: python benchmarks/control.py
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import btgen_pytrees  # noqa: E402
from btgen_pytrees.run import run  # noqa: E402

__all__ = ["chain", "measure", "main", "report", "TARGET"]

TARGET = 1.2
"""Load + generate of the modified chain against the plain one, at 100,000 entries (issue 32)."""

MODIFIERS = ({"when": "x >= 0"}, {"timeout": 1}, {"attempts": 2}, {"when": "x >= 0", "edge": "none", "timeout": 1, "attempts": 2})
"""The keys every tenth entry gets, in turn: a start condition that holds at once, a timeout and a retry that never
fire, and the three together (none changes the run of a one-tick ``hold``)."""

VARIANTS = ("plain", "modified")


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


Work = tuple[Callable[[], Any], Callable[[Any], Any]]
"""What one measurement does: its input made (not timed), then the work on it (timed)."""


def _cpu(work: Work) -> float:
    """CPU seconds of one call of *work* on its input, made first and followed by a full collection, so that the heap
    holds what this measurement needs and nothing of another's (the collector stays on: users run with it)."""
    made = work[0]()
    gc.collect()
    start = time.process_time()
    result = work[1](made)
    spent = time.process_time() - start
    del result, made  # (freed before the next measurement)
    return spent


def _rounds(works: dict[str, Work], rounds: int) -> dict[str, Any]:
    """Each variant's CPU seconds per round, measured back to back in an order alternating by round, and the
    median of the per-round ratios modified / plain."""
    seconds: dict[str, list[float]] = {name: [] for name in works}
    for k in range(rounds):
        for name in VARIANTS if k % 2 == 0 else VARIANTS[::-1]:
            seconds[name].append(_cpu(works[name]))
    ratios = [m / p for p, m in zip(seconds["plain"], seconds["modified"])]
    return {"s": {name: statistics.median(v) for name, v in seconds.items()}, "ratio": statistics.median(ratios),
            "ratios": ratios}  # fmt: skip


def _build(source: Callable[[], Any]) -> Work:
    """Load + generate of the case *source* makes: a path (the JSON file) or the dict itself."""
    return source, lambda made: btgen_pytrees.generate(btgen_pytrees.load(made))


def _checked_run(case: Any) -> Any:
    report = run(case, record=False)
    if report.verdict != "pass":
        raise AssertionError(f"the benchmark chain did not pass: {report.verdict} {report.message}")
    return report


def _run(case: Any) -> Work:
    return (lambda: case), _checked_run


def measure(sizes: tuple[int, ...] = (10_000, 100_000), rounds: int = 7, runs: bool = True,
            dicts: bool = True) -> dict[str, Any]:  # fmt: skip
    """Every figure, by size: ``build`` (load + generate from the JSON file), ``build_dict`` (from the dict) and
    ``run`` seconds of both variants (medians) with the median ratios, and the run's per-tick scaling."""
    out: dict[str, Any] = {"sizes": {}, "modifiers": list(MODIFIERS), "rounds": rounds}
    with tempfile.TemporaryDirectory(prefix="btgen-control-") as tmp:
        for n in sizes:
            paths = {name: Path(tmp) / f"{name}-{n}.json" for name in VARIANTS}
            for name, path in paths.items():
                path.write_text(json.dumps(chain(n, name == "modified")), encoding="utf-8")
            figures: dict[str, Any] = {"build": _rounds({name: _build(partial(str, p)) for name, p in paths.items()}, rounds)}
            if dicts:  # each dict made before its measurement, as a caller holds the one it loads
                figures["build_dict"] = _rounds({name: _build(partial(chain, n, name == "modified")) for name in VARIANTS},
                                                rounds)  # fmt: skip
            if runs:
                cases = {name: btgen_pytrees.load(str(p)) for name, p in paths.items()}
                ticks = {name: run(case, record=False).ticks for name, case in cases.items()}
                if ticks["plain"] != ticks["modified"]:
                    raise AssertionError(f"the chains ran {ticks} ticks: the keys changed the run")
                ran = _rounds({name: _run(case) for name, case in cases.items()}, rounds)
                ran["us_per_tick"] = {name: s / ticks["plain"] * 1e6 for name, s in ran["s"].items()}
                figures.update(run=ran, ticks=ticks["plain"])
                del cases
            out["sizes"][n] = figures
    if len(sizes) > 1 and runs:
        small, large = out["sizes"][sizes[0]]["run"], out["sizes"][sizes[-1]]["run"]
        out["run_scaling"] = {k: large["us_per_tick"][k] / small["us_per_tick"][k] for k in VARIANTS}
    return out


def _spread(ratios: list[float]) -> str:
    return f"{min(ratios):.2f}-{max(ratios):.2f}"


def report(figures: dict[str, Any]) -> str:
    keys = sorted({k for m in figures["modifiers"] for k in m})
    lines = [f"control-flow keys on every tenth entry of a chain (in turn: {', '.join(keys)}); CPU time, "
             f"median of {figures['rounds']} interleaved rounds (the rounds' ratios from-to)"]  # fmt: skip
    for n, f in figures["sizes"].items():
        b = f["build"]
        lines.append(f"  n={n:>7,}: load+generate from the file {b['s']['plain']:.2f} s plain, {b['s']['modified']:.2f} s "
                     f"modified = {b['ratio']:.2f}x ({_spread(b['ratios'])}; target {TARGET}x)")  # fmt: skip
        if "build_dict" in f:
            d = f["build_dict"]
            lines.append(f"             load+generate from the dict {d['s']['plain']:.2f} s plain, {d['s']['modified']:.2f} s "
                         f"modified = {d['ratio']:.2f}x ({_spread(d['ratios'])})")  # fmt: skip
        if "run" in f:
            r = f["run"]
            lines.append(f"             run {r['s']['plain']:.2f} s plain, {r['s']['modified']:.2f} s modified = "
                         f"{r['ratio']:.2f}x ({_spread(r['ratios'])}), {f['ticks']:,} ticks, "
                         f"{r['us_per_tick']['plain']:.1f} / {r['us_per_tick']['modified']:.1f} us per tick")  # fmt: skip
    if "run_scaling" in figures:
        s = figures["run_scaling"]
        sizes = list(figures["sizes"])
        lines.append(f"  run time per tick at {sizes[-1]:,} against {sizes[0]:,} entries: plain {s['plain']:.2f}x, "
                     f"modified {s['modified']:.2f}x (1.0 = linear)")  # fmt: skip
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.control", description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[10_000, 100_000])
    parser.add_argument("--rounds", type=int, default=7, help="interleaved rounds per figure (the median is reported)")
    parser.add_argument("--build-only", action="store_true", help="load + generate only, no runs")
    parser.add_argument("--no-dict", action="store_true", help="load from the JSON file only, not also from the dict")
    parser.add_argument("--json", help="also write every figure to this file")
    args = parser.parse_args(argv)
    figures = measure(tuple(args.sizes), args.rounds, runs=not args.build_only, dicts=not args.no_dict)
    print(report(figures))
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
