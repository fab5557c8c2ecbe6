"""Sweep throughput: ``python -m benchmarks.sweep`` (issue 12).

A 1,000-variation sweep of the fig1 case (``examples/fig1_sweep.json`` with the
ramp's top speed swept over 1,000 values) is run

* in this process, one variation after the other (the floor: no pool at all);
* on the local process pool (:func:`btgen_pytrees.parallel.process`) with 1 and 2 workers;
* on a 2-worker ``distributed.LocalCluster`` (worker processes, one thread each)
  through :class:`~btgen_pytrees.parallel.dask.DaskExecutor`;

and reports runs per second for each, the speed-up from 1 to 2 local workers
(goal ≥ 1.8) and the Dask overhead over the local pool at 2 workers (goal ≤ 15 %).
Only the runs are timed: validating the sweep, starting the cluster and a
warm-up sweep that lets each Dask worker import the package are not (a real
cluster is long-lived). Each configuration runs ``--repeats`` times (default 3)
and the best time counts, since the machine is shared.

``--sumo`` also sweeps the SUMO cut-in case (examples/sumo/cut_in_sweep.json, as
written); it needs the ``sumo`` extra.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path
from typing import Any, Callable

if __package__ in (None, ""):  # run as a file
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

ROOT = Path(__file__).resolve().parent.parent
GOALS = {"speedup_1_to_2": 1.8, "dask_overhead": 0.15}


def fig1_sweep(n: int) -> dict[str, Any]:
    """fig1_sweep with *n* variations: the top speed from 0.05 in steps of 0.05 (limit 30: some fail)."""
    data = json.loads((ROOT / "examples" / "fig1_sweep.json").read_text())
    data["variations"] = {"top_speed": {"from": 0.05, "to": round(0.05 * n, 10), "step": 0.05}}
    return data


def sumo_sweep() -> dict[str, Any]:
    """The SUMO cut-in sweep as written (examples/sumo/cut_in_sweep.json: gap × ego speed)."""
    return json.loads((ROOT / "examples" / "sumo" / "cut_in_sweep.json").read_text())  # type: ignore[no-any-return]


def _time(run: Callable[[], Any], repeats: int) -> tuple[float, Any]:
    best, result = float("inf"), None
    for _ in range(repeats):
        start = time.perf_counter()
        result = run()
        best = min(best, time.perf_counter() - start)
    return best, result


def measure(data: dict[str, Any], source: str, repeats: int, dask: bool = True) -> dict[str, Any]:
    from btgen_pytrees.sweep import load_sweep
    from btgen_pytrees.sweep.runs import run_variations
    from btgen_pytrees.sweep.jobs import RunOptions

    start = time.perf_counter()
    sweep = load_sweep(data, source_name=source, max_variations=10**6)
    check = time.perf_counter() - start
    variations = list(sweep)
    n = len(variations)
    plugins = RunOptions()

    def engine(workers: int, executor: Any = None) -> Callable[[], Any]:
        return lambda: run_variations(sweep, variations, plugins, None, workers, executor)  # what `run` does

    def in_process() -> Any:
        from btgen_pytrees.sweep.jobs import job_variation

        return [job_variation(v.label, plugins, source, v.document) for v in variations]

    results: dict[str, Any] = {"variations": n, "validate_all_s": round(check, 3)}
    configs: list[tuple[str, Callable[[], Any]]] = [
        ("in-process", in_process),
        ("local --jobs 1", engine(1)),
        ("local --jobs 2", engine(2)),
    ]
    cluster = None
    if dask:
        try:
            from distributed import LocalCluster

            from btgen_pytrees.parallel.dask import DaskExecutor
        except ImportError:
            results["dask"] = "skipped: distributed is not installed (pip install -e '.[dask]')"
        else:
            import logging

            cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                   silence_logs=logging.CRITICAL)  # fmt: skip
            executor = DaskExecutor(cluster.scheduler_address)
            executor.connect()
            run_variations(sweep, variations[:20], plugins, None, 2, executor)  # warm-up: imports on the workers
            configs.append(("dask LocalCluster 2 workers", engine(2, executor)))
    rows = []
    verdicts = None
    try:
        for name, run in configs:
            seconds, outcomes = _time(run, repeats)
            summary = [(o.path, o.code) for o in outcomes]
            verdicts = verdicts or summary
            assert summary == verdicts, f"{name} gave other verdicts"  # the same results whatever the engine
            rows.append({"config": name, "seconds": round(seconds, 3), "runs_per_s": round(n / seconds, 1)})
    finally:
        if cluster is not None:
            executor.close()
            cluster.close()
    results["rows"] = rows
    by = {r["config"]: r["seconds"] for r in rows}
    results["speedup_1_to_2"] = round(by["local --jobs 1"] / by["local --jobs 2"], 2)
    if "dask LocalCluster 2 workers" in by:
        results["dask_overhead"] = round(by["dask LocalCluster 2 workers"] / by["local --jobs 2"] - 1, 3)
    return results


def report(name: str, results: dict[str, Any]) -> str:
    lines = [f"{name}: {results['variations']} variations (validating all of them: {results['validate_all_s']} s)"]
    lines.append(f"  {'engine':30s} {'seconds':>8s} {'runs/s':>8s}")
    for row in results["rows"]:
        lines.append(f"  {row['config']:30s} {row['seconds']:8.2f} {row['runs_per_s']:8.1f}")
    speedup = results["speedup_1_to_2"]
    lines.append(f"  speed-up 1 -> 2 local workers: {speedup:.2f}x (goal >= {GOALS['speedup_1_to_2']}x: "
                 f"{'met' if speedup >= GOALS['speedup_1_to_2'] else 'NOT met'})")  # fmt: skip
    if "dask_overhead" in results:
        over = results["dask_overhead"]
        lines.append(f"  Dask overhead over the local pool at 2 workers: {over:+.1%} (goal <= {GOALS['dask_overhead']:.0%}: "
                     f"{'met' if over <= GOALS['dask_overhead'] else 'NOT met'})")  # fmt: skip
    elif "dask" in results:
        lines.append(f"  dask: {results['dask']}")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.sweep", description=__doc__.splitlines()[0])
    parser.add_argument("--variations", type=int, default=1000, help="variations of the fig1 sweep (default 1000)")
    parser.add_argument("--sumo", action="store_true", help="also the SUMO cut-in sweep (needs the sumo extra)")
    parser.add_argument("--repeats", type=int, default=3, help="runs per configuration; the best counts (default 3)")
    parser.add_argument("--no-dask", action="store_true", help="skip the LocalCluster")
    parser.add_argument("--json", metavar="PATH", help="also write every number as JSON")
    args = parser.parse_args(argv)
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    print(f"python {platform.python_version()} on {platform.machine()}, {os.cpu_count()} CPUs, load average {load} "
          f"(shared with other work: the best of {args.repeats} runs counts)\n")  # fmt: skip
    everything: dict[str, Any] = {"load_average_before": os.getloadavg()}
    everything["fig1"] = measure(fig1_sweep(args.variations), "examples/fig1_sweep.json", args.repeats, not args.no_dask)
    print(report("fig1 sweep", everything["fig1"]))
    if args.sumo:
        everything["sumo"] = measure(sumo_sweep(), str(ROOT / "examples" / "sumo" / "cut_in_sweep.json"),
                                     args.repeats, not args.no_dask)  # fmt: skip
        print(report("SUMO cut-in sweep", everything["sumo"]))
    if args.json:
        Path(args.json).write_text(json.dumps(everything, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
