"""The benchmark: ``python -m benchmarks.run`` (``--quick`` for 1k and 10k only).

For each synthetic timeline shape (:mod:`benchmarks.timelines`) at 1k, 10k
and 100k entries it reports load+validate, graph, construct and total time,
tracemalloc peak, and both as ratios to the *floor* - the same tree built from
stock py_trees classes (:mod:`benchmarks.floor`), the least any generator
could spend. It then compares the runner's per-tick cost with bare ticking of
the same tree, times the schema-validation alternatives, and checks the
targets of the performance issue, printing one plain-text report
(``--json PATH`` also writes every number).

Each case runs in a fresh child process with a time limit (``--timeout``), so
one pathological case (a quadratic step at 100k, a recursion limit) is
recorded as what happened and the run still finishes; a fresh interpreter per
case also keeps one case's garbage, blackboard keys and fragmented heap out of
the next one's numbers. ``--inline`` runs everything in this process instead
(no time limit), for the smoke test and for debugging.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import platform
import subprocess
import sys
import time
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any, Callable, Sequence

if __package__ in (None, ""):  # run as a file: python benchmarks/run.py
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks import hotspots, measure, schemas, timelines  # noqa: E402

__all__ = ["main", "Job", "run_jobs", "TARGETS"]

SIZES = (1_000, 10_000, 100_000)
QUICK_SIZES = (1_000, 10_000)
DEFAULT_TIMEOUT = 300.0
DEFAULT_BUDGET = 600.0
MIN_TIMEOUT = 60.0

TARGETS = {"total/floor": 2.0, "scaling": 1.3, "peak/floor": 2.0, "tick/bare": 1.5, "run scaling": 1.3,
           "run/bare": 1.5}  # fmt: skip
"""The issue's targets: at the largest size, time and memory against the floor; per-entry
time at the largest size against the size ten times smaller; run_tree per tick against bare;
for the per-shape runs, run time per entry at the largest run size against a tenth of it, and
run_tree per tick against bare ticking of the same tree (which ticks only its active part)."""


# ---------------------------------------------------------------------------
# jobs: one child process each


@dataclass
class Job:
    """One measurement in one process: ``generation`` of a shape, ``ticks`` or ``schemas``."""

    kind: str
    n: int
    shape: str = "random"
    repeats: int = 1
    memory: bool = True
    clock: str = "cpu"
    gc_on: bool = True
    result: dict[str, Any] = field(default_factory=dict)

    @property
    def label(self) -> str:
        return f"{self.shape} n={self.n}" if self.kind != "schemas" else f"random n={self.n}"


def _dispatch(job: Job, emit: measure.Emit) -> None:
    if job.kind == "generation":
        measure.measure_generation(job.shape, job.n, job.repeats, emit, memory=job.memory, clock=job.clock,
                                   gc_on=job.gc_on)  # fmt: skip
    elif job.kind == "ticks":
        measure.measure_ticks(job.n, job.repeats, emit, clock=job.clock, shape=job.shape)
    elif job.kind == "runs":
        measure.measure_ticks(job.n, job.repeats, emit, clock=job.clock, shape=job.shape,
                              contenders=("bare", "run_tree"))  # fmt: skip
    elif job.kind == "schemas":
        schemas.measure_schemas(job.n, job.repeats, emit, clock=job.clock)
    else:
        raise ValueError(f"unknown job kind {job.kind!r}")


def _merge(result: dict[str, Any], message: dict[str, Any]) -> None:
    if "row" in message:
        result.setdefault("rows", []).append(message["row"])
    else:
        result.update(message)


def _child(conn: Any, job: Job) -> None:
    """Child process body: run *job*, sending each stage's results as they come."""
    try:
        _dispatch(job, conn.send)
    except BaseException as exc:  # a RecursionError or MemoryError at 100k is a result
        conn.send({"error": f"{type(exc).__name__}: {str(exc)[:300]}"})
    conn.send({"done": True})
    conn.close()


def _run_inline(job: Job) -> None:
    job.result = {}
    try:
        _dispatch(job, lambda message: _merge(job.result, message))
    except Exception as exc:  # the same report as in a child, for --inline
        job.result["error"] = f"{type(exc).__name__}: {str(exc)[:300]}"
    job.result["status"] = _status(job.result)


def _status(result: dict[str, Any]) -> str:
    return f"error in {result.get('stage')}: {result['error']}" if "error" in result else "ok"


def _run_child(job: Job, timeout: float) -> None:
    ctx = multiprocessing.get_context("spawn")
    receiver, sender = ctx.Pipe(duplex=False)
    process = ctx.Process(target=_child, args=(sender, job), daemon=True)
    job.result = {}
    deadline = time.monotonic() + timeout
    process.start()
    sender.close()
    status = ""
    while not status:
        remaining = deadline - time.monotonic()
        if remaining <= 0 or not receiver.poll(remaining):
            process.kill()
            status = f"timeout ({timeout:g} s) in {job.result.get('stage', 'start-up')}"
            break
        try:
            message = receiver.recv()
        except EOFError:
            process.join()
            status = f"died in {job.result.get('stage', 'start-up')} (exit code {process.exitcode})"
            break
        if "done" in message:
            status = _status(job.result)
        else:
            _merge(job.result, message)
    process.join()
    receiver.close()
    job.result["status"] = status


def run_jobs(jobs: Sequence[Job], *, timeout: float, budget: float | None, inline: bool,
             log: Callable[[str], None]) -> None:  # fmt: skip
    """Run *jobs* one after the other (never in parallel: they would share two cores).

    Each job may take *timeout* seconds, and at most an equal share of what is
    left of *budget* (but never less than :data:`MIN_TIMEOUT`): a run that
    meets a slow core then still ends near its budget, with the slow cases
    marked as timed out, and time a fast case leaves over goes to later ones.
    """
    started = time.monotonic()
    for i, job in enumerate(jobs, 1):
        limit = timeout
        if budget is not None:
            share = (budget - (time.monotonic() - started)) / (len(jobs) - i + 1)
            limit = max(MIN_TIMEOUT, min(timeout, share))
        log(f"[{i}/{len(jobs)}] {job.kind} {job.label} (limit {limit:.0f} s) ...")
        t0 = time.monotonic()
        if inline:
            _run_inline(job)
        else:
            _run_child(job, limit)
        job.result["wall"] = time.monotonic() - t0
        log(f"[{i}/{len(jobs)}] {job.kind} {job.label}: {job.result['status']} ({job.result['wall']:.1f} s)")


# ---------------------------------------------------------------------------
# derived numbers


def _ratio(a: float | None, b: float | None) -> float | None:
    return a / b if a is not None and b else None


def generation_rows(jobs: Sequence[Job]) -> list[dict[str, Any]]:
    """One flat row per generation job, with ratios to the floor and to the size 10× smaller."""
    rows = []
    per_entry: dict[tuple[str, int], float] = {}
    for job in jobs:
        if job.kind != "generation":
            continue
        r, g = job.result, job.result.get("generated", {})
        row: dict[str, Any] = {
            "shape": job.shape, "n": job.n, "nodes": r.get("nodes"), "depth": r.get("depth"),
            "counts": r.get("counts"), "input_bytes": r.get("input_bytes"),
            "load": g.get("load"), "graph": g.get("graph"), "construct": g.get("construct"),
            "total": g.get("total"), "floor": r.get("floor"),
            "peak": r.get("peak"), "held": r.get("held"), "floor_peak": r.get("floor_peak"),
            "floor_held": r.get("floor_held"), "repeats": job.repeats, "status": r.get("status"),
            "wall": r.get("wall"),
        }  # fmt: skip
        row["total/floor"] = _ratio(row["total"], row["floor"])
        row["peak/floor"] = _ratio(row["peak"], row["floor_peak"])
        row["us/entry"] = row["total"] / job.n * 1e6 if row["total"] is not None else None
        floor_per_entry = row["floor"] / job.n * 1e6 if row["floor"] is not None else None
        if row["us/entry"] is not None:
            per_entry[(job.shape, job.n)] = row["us/entry"]
        if floor_per_entry is not None:
            per_entry[("floor " + job.shape, job.n)] = floor_per_entry
        tenth = job.n // 10 if job.n % 10 == 0 else None
        row["scaling"] = _ratio(row["us/entry"], per_entry.get((job.shape, tenth)))
        row["floor scaling"] = _ratio(floor_per_entry, per_entry.get(("floor " + job.shape, tenth)))
        rows.append(row)
    return rows


def tick_row(job: Job) -> dict[str, Any]:
    r = job.result
    seconds, ticks = r.get("seconds", {}), r.get("ticks", {})
    row: dict[str, Any] = {"shape": job.shape, "n": job.n, "nodes": r.get("nodes"), "verdict": r.get("verdict"),
                           "ticks": ticks.get("run_tree"), "trace_lines": r.get("trace_lines"),
                           "status": r.get("status"), "repeats": job.repeats}  # fmt: skip
    for name in ("bare", "run_tree", "traced"):
        if name in seconds and ticks.get(name):
            row[f"{name} s/tick"] = seconds[name] / ticks[name]
    row["tick/bare"] = _ratio(row.get("run_tree s/tick"), row.get("bare s/tick"))
    row["traced/bare"] = _ratio(row.get("traced s/tick"), row.get("bare s/tick"))
    if ticks and len(set(ticks.values())) > 1:
        row["status"] = f"{row['status']}; tick counts differ: {ticks}"
    return row


def run_rows(jobs: Sequence[Job]) -> list[dict[str, Any]]:
    """One row per per-shape run job: per tick and per entry, against bare, and scaling over a tenth of n."""
    rows = []
    per_entry: dict[tuple[str, int], float] = {}
    for job in jobs:
        if job.kind != "runs":
            continue
        row = tick_row(job)
        seconds = job.result.get("seconds", {})
        row["ticked/tick"] = (job.result["ticked"] / row["ticks"]
                              if job.result.get("ticked") and row.get("ticks") else None)  # fmt: skip
        row["run us/entry"] = seconds["run_tree"] / job.n * 1e6 if "run_tree" in seconds else None
        if row["run us/entry"] is not None:
            per_entry[(job.shape, job.n)] = row["run us/entry"]
        tenth = job.n // 10 if job.n % 10 == 0 else None
        row["run scaling"] = _ratio(row["run us/entry"], per_entry.get((job.shape, tenth)))
        rows.append(row)
    return rows


def run_table(rows: Sequence[dict[str, Any]]) -> str:
    headers = ["case", "nodes", "ticks", "verdict", "ticked/tick", "bare ms/tick", "run_tree ms/tick", "run/bare",
               "run s", "us/entry", "scaling"]  # fmt: skip
    body = [[f"{r['shape']} n={r['n']}", _fmt(r["nodes"]), _fmt(r["ticks"]), _fmt(r["verdict"]),
             "-" if r["ticked/tick"] is None else f"{r['ticked/tick']:.0f}",
             _fmt(r.get("bare s/tick"), "ms"), _fmt(r.get("run_tree s/tick"), "ms"), _fmt(r["tick/bare"], "x"),
             _fmt(None if r.get("run_tree s/tick") is None or not r["ticks"] else r["run_tree s/tick"] * r["ticks"], "s"),
             _fmt(r["run us/entry"], "us"), _fmt(r["run scaling"], "x")] for r in rows]  # fmt: skip
    notes = [f"  {r['shape']} n={r['n']}: {r['status']}" for r in rows if r["status"] != "ok"]
    return table(headers, body) + ("\n" + "\n".join(notes) if notes else "")


def check_run_targets(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """run/bare and run scaling for each shape at the largest run size."""
    out = []
    largest = max((row["n"] for row in rows), default=0)
    for row in rows:
        if row["n"] != largest:
            continue
        for key, value in (("run scaling", row["run scaling"]), ("run/bare", row["tick/bare"])):
            out.append({"case": f"run {row['shape']} n={row['n']}", "target": key, "value": value,
                        "limit": TARGETS[key], "met": None if value is None else value <= TARGETS[key]})  # fmt: skip
    return out


def check_targets(rows: Sequence[dict[str, Any]], tick: dict[str, Any] | None) -> list[dict[str, Any]]:
    """Each target at the largest size measured: value, limit, met (None when not measured)."""
    out = []
    largest = max((row["n"] for row in rows), default=0)
    for row in rows:
        if row["n"] != largest:
            continue
        for key in ("total/floor", "scaling", "peak/floor"):
            value = row.get(key)
            out.append({"case": f"{row['shape']} n={row['n']}", "target": key, "value": value,
                        "limit": TARGETS[key], "met": None if value is None else value <= TARGETS[key]})  # fmt: skip
    if tick is not None:
        value, limit = tick.get("tick/bare"), TARGETS["tick/bare"]
        out.append({"case": f"run {tick['shape']} n={tick['n']}", "target": "tick/bare", "value": value,
                    "limit": limit, "met": None if value is None else value <= limit})  # fmt: skip
    return out


# ---------------------------------------------------------------------------
# text output


def _fmt(value: Any, kind: str = "") -> str:
    if value is None:
        return "-"
    if kind == "s":
        return f"{value:.3f}" if value < 100 else f"{value:.1f}"
    if kind == "ms":
        return f"{value * 1e3:.3f}"
    if kind == "x":
        return f"{value:.2f}"
    if kind == "MB":
        return f"{value / 1e6:.1f}"
    if kind == "us":
        return f"{value:.1f}"
    return str(value)


def table(headers: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """A plain-text table: first column left-aligned, the others right-aligned."""
    widths = [max(len(h), *(len(r[i]) for r in rows)) if rows else len(h) for i, h in enumerate(headers)]

    def line(cells: Sequence[str]) -> str:
        parts = [c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(cells, widths))]
        return "  ".join(parts).rstrip()

    return "\n".join([line(headers), line(["-" * w for w in widths]), *(line(r) for r in rows)])


def generation_table(rows: Sequence[dict[str, Any]]) -> str:
    headers = ["shape", "entries", "nodes", "load+val s", "graph s", "construct s", "total s", "floor s",
               "total/floor", "us/entry", "scaling", "floor scaling", "peak MB", "floor MB", "peak/floor"]  # fmt: skip
    body = [[r["shape"], str(r["n"]), _fmt(r["nodes"]), _fmt(r["load"], "s"), _fmt(r["graph"], "s"),
             _fmt(r["construct"], "s"), _fmt(r["total"], "s"), _fmt(r["floor"], "s"), _fmt(r["total/floor"], "x"),
             _fmt(r["us/entry"], "us"), _fmt(r["scaling"], "x"), _fmt(r["floor scaling"], "x"),
             _fmt(r["peak"], "MB"), _fmt(r["floor_peak"], "MB"),
             _fmt(r["peak/floor"], "x")] for r in rows]  # fmt: skip
    notes = [f"  {r['shape']} n={r['n']}: {r['status']}" for r in rows if r["status"] != "ok"]
    return table(headers, body) + ("\n" + "\n".join(notes) if notes else "")


def shape_table(rows: Sequence[dict[str, Any]]) -> str:
    headers = ["shape", "entries", "sequence", "parallel", "decorator", "leaf", "depth"]
    body = []
    for r in rows:
        c = r["counts"] or {}
        body.append([r["shape"], str(r["n"]), *(_fmt(c.get(k)) for k in ("sequence", "parallel", "decorator", "leaf")),
                     _fmt(r["depth"])])  # fmt: skip
    return table(headers, body)


def tick_table(row: dict[str, Any]) -> str:
    headers = ["case", "nodes", "ticks", "verdict", "bare ms/tick", "run_tree ms/tick", "run/bare",
               "traced ms/tick", "traced/bare"]  # fmt: skip
    body = [[f"{row['shape']} n={row['n']}", _fmt(row["nodes"]), _fmt(row["ticks"]), _fmt(row["verdict"]),
             _fmt(row.get("bare s/tick"), "ms"), _fmt(row.get("run_tree s/tick"), "ms"), _fmt(row["tick/bare"], "x"),
             _fmt(row.get("traced s/tick"), "ms"), _fmt(row["traced/bare"], "x")]]  # fmt: skip
    note = f"\n  {row['status']}" if row["status"] != "ok" else ""
    return table(headers, body) + note


def schema_table(job: Job) -> str:
    rows = job.result.get("rows", [])
    base = next((r for r in rows if r["candidate"] == schemas.LOADER and "unavailable" not in r), None)
    base_total = (base["document"] + base.get("params", 0.0)) if base else None
    headers = ["validator", "document s", "params s", "both s", "speed-up", "agrees"]
    body = []
    for r in rows:
        if "unavailable" in r:
            body.append([r["candidate"], "-", "-", "-", "-", r["unavailable"]])
            continue
        both = r["document"] + r["params"] if "params" in r else None
        body.append([r["candidate"], _fmt(r["document"], "s"), _fmt(r.get("params"), "s"), _fmt(both, "s"),
                     _fmt(_ratio(base_total, both), "x"), "yes" if r["agrees"] else "NO"])  # fmt: skip
    note = f"\n  {job.result['status']}" if job.result.get("status") != "ok" else ""
    return f"schema validation of the random case, n={job.n} (best of {job.repeats})\n" + table(headers, body) + note


def targets_text(targets: Sequence[dict[str, Any]]) -> str:
    body = [[t["case"], t["target"], _fmt(t["value"], "x"), f"<= {t['limit']:g}",
             "-" if t["met"] is None else ("met" if t["met"] else "MISSED")] for t in targets]  # fmt: skip
    return table(["case", "target", "value", "limit", "result"], body)


# ---------------------------------------------------------------------------
# machine


def commit() -> str | None:
    """The checked-out commit (read-only ``git rev-parse``), or ``None`` outside a git checkout."""
    try:
        out = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, timeout=10,
                             cwd=Path(__file__).resolve().parent).stdout.strip()  # fmt: skip
    except (OSError, subprocess.SubprocessError):
        return None
    return out or None


def machine() -> dict[str, Any]:
    """What the numbers were measured on (versions, processor, commit)."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            cpu = next((line.split(":", 1)[1].strip() for line in fh if line.startswith("model name")), cpu)
    except OSError:
        pass
    versions = {}
    for package in ("py_trees", "networkx", "jsonschema", "fastjsonschema", "jsonschema-rs"):
        try:
            versions[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            versions[package] = None
    return {"python": platform.python_version(), "implementation": platform.python_implementation(),
            "platform": platform.platform(), "cpu": cpu, "cores": os.cpu_count(), "versions": versions,
            "commit": commit()}  # fmt: skip


def machine_text(info: dict[str, Any]) -> str:
    versions = ", ".join(f"{k} {v}" for k, v in info["versions"].items() if v)
    text = (f"{info['implementation']} {info['python']} on {info['platform']}; {info['cpu']}, {info['cores']} cores\n"
            f"{versions}; commit {info['commit'] or 'unknown'}")  # fmt: skip
    if info.get("commit_at_end") != info["commit"]:
        text += f"\nWARNING: the commit changed to {info.get('commit_at_end')} during the run; rows differ in code"
    return text


# ---------------------------------------------------------------------------
# command line


def _profile_spec(text: str) -> tuple[str, int]:
    shape, _, n = text.partition(":")
    if shape not in timelines.SHAPES or not n.isdigit():
        raise argparse.ArgumentTypeError(f"expected SHAPE:N with SHAPE one of {', '.join(timelines.SHAPES)}")
    return shape, int(n)


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.run", description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="1k and 10k entries only")
    parser.add_argument("--sizes", type=int, nargs="+", metavar="N",
                        help=f"entry counts (default {' '.join(map(str, SIZES))})")  # fmt: skip
    parser.add_argument("--shapes", nargs="+", choices=list(timelines.SHAPES), help="shapes to generate (default: all)")
    parser.add_argument("--repeats", type=int, metavar="R",
                        help="repeats per measurement (default: 5 up to 2k, 3 up to 20k, then 1; runs: 2 at every size)")  # fmt: skip
    parser.add_argument("--timeout", type=float, default=DEFAULT_TIMEOUT, metavar="S",
                        help=f"seconds allowed per case (default {DEFAULT_TIMEOUT:g})")  # fmt: skip
    parser.add_argument("--budget", type=float, default=DEFAULT_BUDGET, metavar="S",
                        help=f"seconds the whole run aims for; each case gets at most an equal share of what is left "
                             f"(default {DEFAULT_BUDGET:g}; 0: no budget)")
    parser.add_argument("--clock", choices=list(measure.CLOCKS), default="cpu",
                        help="cpu: process CPU time (default; steady on a shared machine), wall: perf_counter")
    parser.add_argument("--gc", choices=["on", "off"], default="on",
                        help="garbage collector during timed generation repeats (default on, as users run)")
    parser.add_argument("--tick-n", type=int, default=10_000, metavar="N",
                        help="entries of the case for the run-vs-bare tick benchmark (0: skip)")  # fmt: skip
    parser.add_argument("--tick-shape", choices=list(timelines.SHAPES), default="random",
                        help="shape of that case (default random, as the issue's target)")
    parser.add_argument("--run-sizes", type=int, nargs="+", metavar="N",
                        help="entry counts of the per-shape run jobs (default: the sizes of 10,000 and more; 0: none)")
    parser.add_argument("--schema-n", type=int, default=10_000, metavar="N",
                        help="entries of the random case for the schema-validator comparison (0: skip)")  # fmt: skip
    parser.add_argument("--no-memory", action="store_true", help="skip the tracemalloc passes")
    parser.add_argument("--inline", action="store_true", help="run in this process, without time limits")
    parser.add_argument("--json", metavar="PATH", help="also write every number as JSON")
    parser.add_argument("--profile", type=_profile_spec, metavar="SHAPE:N",
                        help="instead: cProfile load, generate and run of one case; print the hot spots")  # fmt: skip
    parser.add_argument("--profile-steps", default=",".join(hotspots.STEPS), help="with --profile: steps to profile")
    parser.add_argument("--sumo", action="store_true",
                        help="instead: the SUMO examples' speed-up and time shares (benchmarks/sumo.py; needs the sumo extra)")  # fmt: skip
    args = parser.parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)
    if args.sizes is None:
        args.sizes = list(QUICK_SIZES if args.quick else SIZES)
    if any(n < 3 for n in args.sizes):
        parser.error("sizes must be at least 3")
    if args.run_sizes is None:
        args.run_sizes = [n for n in args.sizes if n >= 10_000]
    args.run_sizes = sorted({n for n in args.run_sizes if n > 0})
    return args


def plan(args: argparse.Namespace) -> list[Job]:
    """Jobs in the order they run: small sizes first, the tick and schema jobs before the largest size.

    The largest size is the likeliest to hit a time limit; running it last
    means everything else is already measured when it does.
    """
    sizes = sorted(set(args.sizes))
    shapes = args.shapes or list(timelines.SHAPES)

    def repeats(n: int) -> int:
        return args.repeats or measure.default_repeats(n)

    def generation(n: int) -> list[Job]:
        memory = not args.no_memory
        return [Job("generation", n, shape, repeats(n), memory=memory, clock=args.clock, gc_on=args.gc == "on")
                for shape in shapes]  # fmt: skip

    def runs(n: int) -> list[Job]:
        return [Job("runs", n, shape, repeats=args.repeats or 2, clock=args.clock) for shape in shapes]  # best of 2 at every size

    jobs = [job for n in sizes[:-1] for job in generation(n)]
    jobs += [job for n in args.run_sizes[:-1] for job in runs(n)]
    if args.tick_n:
        tick_repeats = min(2, repeats(args.tick_n))
        jobs.append(Job("ticks", args.tick_n, args.tick_shape, repeats=tick_repeats, clock=args.clock))
    if args.schema_n:
        jobs.append(Job("schemas", args.schema_n, repeats=min(2, repeats(args.schema_n)), clock=args.clock))
    jobs += generation(sizes[-1])
    return jobs + [job for n in args.run_sizes[-1:] for job in runs(n)]


def document_command(args: argparse.Namespace) -> str:
    return " ".join(["python -m benchmarks.run", *args.argv]).strip()


def report(
    jobs: Sequence[Job], args: argparse.Namespace, info: dict[str, Any], wall: float
) -> tuple[str, dict[str, Any]]:
    """The text report and the JSON document of finished *jobs*."""
    rows = generation_rows(jobs)
    tick_job = next((j for j in jobs if j.kind == "ticks"), None)
    schema_job = next((j for j in jobs if j.kind == "schemas"), None)
    tick = tick_row(tick_job) if tick_job else None
    runs = run_rows(jobs)
    targets = check_targets(rows, tick) + check_run_targets(runs)
    clock = "CPU" if args.clock == "cpu" else "wall"
    collector = "" if args.gc == "on" else ", garbage collector off"
    parts = [machine_text(info), f"command: {document_command(args)}", "",
             f"generation (seconds of {clock} time{collector}, best of the repeats; floor: the same tree from stock",
             "py_trees classes; scaling: us/entry over us/entry at a tenth of the entries, for the generator and",
             "for the floor; MB: tracemalloc peak)",
             generation_table(rows), "", "generated trees (nodes by kind)", shape_table(rows)]  # fmt: skip
    if tick is not None:
        heading = "run: run_tree (recorder, clock, report) against bare tick_once on the same tree"
        parts += ["", heading, tick_table(tick)]
    if runs:
        parts += ["", "runs: run_tree per shape against bare ticking of the same tree (ticked/tick: nodes a bare tick",
                  "yields, the active part; us/entry: the whole run_tree per entry; scaling: over a tenth of the entries)",
                  run_table(runs)]  # fmt: skip
    if schema_job is not None:
        parts += ["", schema_table(schema_job)]
    parts += ["", "targets", targets_text(targets), "", f"finished in {wall:.0f} s"]
    document = {"command": document_command(args), "machine": info,
                "generation": rows, "ticks": tick, "runs": runs, "schemas": schema_job.result if schema_job else None,
                "targets": targets, "wall": wall}  # fmt: skip
    return "\n".join(parts), document


def _progress(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    if args.sumo:
        from benchmarks import sumo

        return sumo.main([])
    if args.profile:
        shape, n = args.profile
        steps = tuple(s.strip() for s in args.profile_steps.split(",") if s.strip())
        unknown = set(steps) - set(hotspots.STEPS)
        if unknown:
            print(f"unknown --profile-steps {', '.join(sorted(unknown))}; known: {', '.join(hotspots.STEPS)}",
                  file=sys.stderr)  # fmt: skip
            return 2
        print(hotspots.profile_case(shape, n, steps))
        return 0
    started = time.monotonic()
    info = machine()  # before the jobs: each job imports the working tree as it is when the job starts
    jobs = plan(args)
    run_jobs(jobs, timeout=args.timeout, budget=args.budget or None, inline=args.inline, log=_progress)
    info["commit_at_end"] = commit()
    text, document = report(jobs, args, info, time.monotonic() - started)
    print(text)
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(document, fh, indent=2)
            fh.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
