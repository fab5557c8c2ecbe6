"""``run FILE...``: run a case against its system and print the verdicts; several files, a folder or
``--out-dir``: a batch; a case with variations: a sweep (:mod:`.sweep`)."""

from __future__ import annotations

import argparse
import fnmatch
import os
from typing import Any, Callable, Sequence

from .. import batch
from ..construct import generate
from ..errors import ExitCode, InvalidTestCase, Problem, UsageError
from ..leaves import Registry, default_registry
from ..load import MAX_WORK, check_work, load_json, parse_json, validate
from ..load.read import read_file
from ..model import TestCase
from ..writing import check_distinct, commit, is_direct, report_outputs, stderr_stream
from ..load.warnings import warning_lines
from ..parallel import Outcome, merge_junit
from ..progress import terminal_progress
from ..run import run
from ..run.btlog import BtlogError, btlog_bytes, check_btlog
from ..run.export import ExportUnavailable, export_format, require_pyarrow, table_bytes
from ..run.plot import PlotUnavailable, plot_bytes, plot_format, require_matplotlib
from ..run.replay import replay_html
from ..run.report import Report
from ..sweep import has_variations
from ..sweep.runs import resolved_system, ship
from ..systems import SystemSpec
from .checks import check_out_dir, check_output, targets
from .many import run_batch, single
from .options import SIDECAR_NOTE, Parents, chosen, non_negative, positive, registry, system, whole
from .sweep import add_executor_options, make_executor, run_options, run_sweep
from .terminal import deliver, err, stdout_text

__all__ = ["add_parser", "cmd_run"]


def add_parser(sub: Any, parents: Parents) -> None:
    parser = sub.add_parser("run", parents=[parents.plugin, parents.many, parents.chosen], help="run the tree against its system (default: the virtual-clock simulator) and print verdicts")
    parser.add_argument("files", nargs="+", metavar="FILE", help="test case file, .json or .xosc (several, or directories of them: batch mode); " + SIDECAR_NOTE)
    parser.add_argument("--json", metavar="REPORT", help="write the report as JSON (schemas/report.schema.json; a sweep's: schemas/sweep-report.schema.json)")
    parser.add_argument("--junit", metavar="XML", help="write the report as JUnit XML (several files: one file, a testsuite per case)")
    parser.add_argument("--require-complete", action="store_true",
                        help="fail a run that passes before every entry has run to success (as the case key require_complete)")
    parser.add_argument("--trace", action="store_true",
                        help="print a line per entry start/success/failure/stopped on stderr (docs/semantics.md#the-trace)")
    parser.add_argument("--system", metavar="TYPE[:CONFIG]", help="run against this system instead of the case's own (CONFIG relative to the current directory); checked like the case's 'system'")
    parser.add_argument("--plot", metavar="PATH", help="draw the run (timeline, oracles, signals) to PATH: .svg, .png or .html; several files: svg, png or html, one per file in --out-dir; needs the 'plot' extra")
    parser.add_argument("--replay", metavar="PATH", help="write a replay page of the run to PATH: one self-contained HTML file (tree, time slider, statuses, signals, verdicts, a SUMO run's scene)")
    parser.add_argument("--signals", action="append", metavar="PATTERN", help="draw/export only the signals matching this glob (repeatable: ego.*, *.speed); for --plot, --replay, --signals-out")
    parser.add_argument("--signals-out", metavar="PATH", help="write every signal on every tick, and every entry's and criterion's status, as a table: .csv, or .parquet (needs pyarrow: the 'parquet' extra)")
    parser.add_argument("--max-depth", type=non_negative, metavar="N", help="--replay: open with the subtrees below depth N collapsed (default: a tree over 100 nodes opens breadth first)")
    parser.add_argument("--max-work", type=positive, default=MAX_WORK, metavar="N",
                        help=f"work budget of a run: ticks x (entries + criteria + 10), default {MAX_WORK:.0e}; a case over it is refused before running")  # fmt: skip
    parser.add_argument("--btlog", metavar="PATH", help="write the run as a BehaviorTree.CPP .btlog (FileLogger2) for Groot2")
    parser.add_argument("--max-variations", type=whole, metavar="N", help="a sweep may have at most N variations (default 10000)")
    parser.add_argument("--variations", action="store_true",
                        help="batch mode: run every variation of each sweep file, on one worker per file (default: a sweep in a batch of several files runs its defaults, and its row says so; a sweep given alone always runs its variations)")  # fmt: skip
    add_executor_options(parser)
    parser.set_defaults(func=cmd_run)


def plot_check(path: str) -> str:
    """The plot format of *path* (or of a bare ``svg``/``png``/``html``), with matplotlib importable."""
    try:
        fmt = path.lower() if path.lower() in ("svg", "png", "html") else plot_format(path)
        require_matplotlib()
    except (ValueError, PlotUnavailable) as problem:
        raise UsageError(str(problem)) from None
    return fmt


def replay_check(args: argparse.Namespace) -> None:
    """--replay/--btlog need a file name, --btlog a .btlog one: found out before the run, not after it."""
    for option in ("replay", "btlog"):
        if getattr(args, option) == "-":  # stdout carries the verdict table
            raise UsageError(f"--{option} -: give a file name (stdout carries the verdict table)")
    if args.btlog and os.path.splitext(args.btlog)[1].lower() != ".btlog" and not is_direct(args.btlog):
        raise UsageError(f"--btlog {args.btlog}: the file name must end in .btlog (Groot2 opens only those)")


def btlog_tree(args: argparse.Namespace, case: TestCase, known: Registry) -> Any:
    """For --btlog: the tree to log (generated like the run's), checked before the run: at most 65,535 nodes."""
    if not args.btlog:
        return None
    root = generate(case, registry=known)
    try:
        check_btlog(root, case.timeout + case.tick)
    except BtlogError as problem:
        raise UsageError(f"--btlog {args.btlog}: {problem}") from None
    return root


def replay_outputs(args: argparse.Namespace, report: Report, case: TestCase, known: Registry,
                   logged: Any) -> list[tuple[str, bytes]]:  # fmt: skip
    """The --replay page and the --btlog file, drawn from the run's trace on a tree generated alike."""
    if not (args.replay or args.btlog):
        return []
    outputs = []
    if args.replay:
        outputs.append((args.replay, replay_html(report, case, generate(case, registry=known), max_depth=args.max_depth,
                                                 signals=args.signals)))  # fmt: skip
    if args.btlog:
        outputs.append((args.btlog, btlog_bytes(report.trace, logged)))
    return outputs


def is_sweep(path: str) -> bool:
    """Whether *path* holds a sweep (a readable test case with ``variations``); a file that cannot be read is not."""
    try:
        return has_variations(load_json(path))
    except InvalidTestCase:
        return False


def sweep_alone(args: argparse.Namespace, path: str, target: str | None, plot: str | None, spec: SystemSpec | None) -> int:
    """A batch of one sweep file (``run S.json --out-dir D``, a folder holding only S.json): the sweep's
    variations, as ``run S.json`` runs them, with the sweep's report, JUnit and map as its ``--out-dir`` files."""
    alone = argparse.Namespace(**vars(args))
    alone.file = path
    alone.json = alone.junit = alone.plot = None
    extra: list[tuple[str, str]] = []
    if target is not None:
        alone.json, alone.junit = target + ".report.json", target + ".junit.xml"
        alone.plot = f"{target}.{plot}" if plot else None
        if args.junit:
            extra.append((args.junit, "junit"))
    else:
        alone.junit = args.junit
    return run_sweep(alone, load_json(path), spec, extra=extra, out_dir=args.out_dir)


def cmd_run(args: argparse.Namespace) -> int:
    if args.scheduler and args.executor != "dask":
        raise UsageError("--scheduler applies to --executor dask only; add --executor dask to run there")

    files = single(args)
    if files is not None:
        return run_many(args, files)
    outputs_named = ("json", "junit", "plot", "replay", "btlog", "signals_out")
    for option in outputs_named:
        check_output(getattr(args, option), f"--{option.replace('_', '-')}", [args.file])
    check_distinct([(f"--{option.replace('_', '-')}", getattr(args, option)) for option in outputs_named])
    replay_check(args)
    if args.signals_out:  # a bad suffix or a missing pyarrow: found out before the run
        try:
            if export_format(args.signals_out) == "parquet":
                require_pyarrow()
        except (ValueError, ExportUnavailable) as exc:
            raise UsageError(str(exc)) from None
    if args.plot:  # check before running: a missing extra or a bad suffix should not cost a run
        plot_check(args.plot)
        plot_format(args.plot)
    data = chosen(args) or load_json(args.file)
    if has_variations(data):  # a sweep: every variation (btgen_pytrees.sweep)
        if args.replay or args.btlog or args.signals_out or args.signals:
            raise UsageError("--replay/--btlog/--signals-out/--signals take one case, not a sweep's variations")

        return run_sweep(args, data, system(args))
    if args.executor == "dask":  # accepted and ignored, it would run here while the user believes it ran there
        raise UsageError(f"--executor dask runs a sweep's variations or a batch's files on a cluster; {args.file} is one case"
                         f"{' (one variation, chosen with --set/--params)' if args.set or args.params else ''}, "
                         "which runs here: leave --executor out")  # fmt: skip
    known = registry(args)
    case = validate(data, args.file, registry=known, system=system(args))
    check_work(case, args.max_work)  # before anything runs: a tree whose one tick exceeds the budget
    for line in [] if args.quiet else warning_lines(case):
        err(line)
    logged = btlog_tree(args, case, known)
    trace = (lambda line: err(line)) if args.trace else None
    progress = None if args.trace else terminal_progress(case.name, case.timeout, stderr_stream())  # a terminal's line only
    try:
        report = run(case, registry=known, trace=trace, require_complete=args.require_complete or None,
                     progress=progress, max_work=args.max_work)  # fmt: skip
    finally:
        if progress is not None:
            progress.done()
    if args.signals and report.trace is not None:  # a typo would quietly draw nothing (globs as run.export.select)
        for pattern in args.signals:
            if not any(fnmatch.fnmatchcase(name, pattern) for name in report.trace.signals):
                err(f"btgen_pytrees: warning: --signals {pattern!r} matches no signal of the run")
    outputs = report_outputs(report, args.json, args.junit, args.plot,
                             lambda: plot_bytes(report, case, plot_format(args.plot), args.signals))  # fmt: skip
    if args.signals_out:
        outputs.append((args.signals_out, table_bytes(report, case, export_format(args.signals_out), args.signals)))
    outputs += replay_outputs(args, report, case, known, logged)
    shown = {args.json: "json", args.junit: "btcpp"}  # '-': printed like any view, escaped for a terminal
    outputs = [(t, stdout_text(d, shown.get(t, "")).encode("utf-8") if t == "-" and isinstance(d, str) else d)
               for t, d in outputs]  # fmt: skip
    # all together, after everything was made (a failure leaves none); then the table (stdout: the document only)
    return deliver(outputs, report.table(), ExitCode.OK if report.passed else ExitCode.FAIL)


def run_many(args: argparse.Namespace, files: list[str]) -> int:
    """``run`` of several files, a folder or ``--out-dir``: a batch (a sweep given alone: its variations)."""
    if args.json or args.trace:
        raise UsageError("--json/--trace take one file; with several use --out-dir (a report per file)")
    if args.replay or args.btlog or args.signals_out or args.signals:
        raise UsageError("--replay/--btlog/--signals-out/--signals take one file")
    plot = None
    if args.plot:
        if not args.out_dir:
            raise UsageError("--plot with several files needs --out-dir (one picture per file)")
        plot = plot_check(args.plot)
    if args.junit:
        check_output(args.junit, "--junit", files)
    if args.out_dir:
        check_out_dir(args, files, writes_json=True)
    suffixes = [".report.json", ".junit.xml"] + ([f".{plot}"] if plot else [])
    bases = targets(args, files, suffixes)
    check_distinct([("--junit", args.junit)] + [("--out-dir", t + x) for t in bases if t for x in suffixes])

    def junit(outcomes: list[Outcome]) -> None:
        if args.junit:
            commit([(args.junit, merge_junit(outcomes))])

    spec = system(args)
    if len(files) == 1 and is_sweep(files[0]):  # a sweep given alone runs its variations, in any form
        return sweep_alone(args, files[0], bases[0], plot, spec)
    if args.variations:
        if args.executor == "dask":
            raise UsageError("--variations runs each sweep on one local worker; with --executor dask run each sweep alone")
        return run_batch(args, files, batch.job_run_variations,
                         lambda i: (tuple(args.plugin or ()), bases[i], plot, bool(args.junit), spec, args.max_work,
                                    args.require_complete, args.max_variations),
                         after=junit)  # fmt: skip
    if args.executor == "dask":  # on a Dask cluster
        executor, job, job_args = dask_batch_args(args, files, bases, plot, spec)
        return run_batch(args, files, job, job_args, after=junit, executor=executor)
    return run_batch(args, files, batch.job_run,
                     lambda i: (tuple(args.plugin or ()), bases[i], plot, bool(args.junit), spec, args.max_work,
                                args.require_complete),
                     after=junit)  # fmt: skip


def dask_batch_args(args: argparse.Namespace, files: list[str], targets: Sequence[str | None],
                    plot: str | None, system: Any = None) -> tuple[Any, Callable[..., Outcome], Callable[[int], tuple[object, ...]]]:  # fmt: skip
    """``run FILE... --executor dask``: the cluster, the job and its arguments for the CLI's batch.

    Each file is read here (:func:`~btgen_pytrees.load.read.read_file`, as the local workers read it) and its bytes travel with
    its task, so workers need no copy of the files; the files the cases name
    (SUMO configurations and their networks and routes) and the ``--plugin``
    files are sent to every worker once. The outputs come back as data and the
    CLI writes them here, never on a worker.
    """
    executor = make_executor(args)
    shipped: list[tuple[bytes | None, list[Problem], SystemSpec | None]] = []
    for path in files:
        try:
            raw: bytes | None = read_file(path)[0]
            problems: list[Problem] = []
        except InvalidTestCase as error:
            raw, problems = None, list(error.problems)
        shipped.append((raw, problems, _system_of(raw, path, system)))
    options = ship(executor, run_options(args), [s for _, _, s in shipped], default_registry(()))

    def job_args(i: int) -> tuple[object, ...]:
        raw, problems, spec = shipped[i]
        return (options, raw, problems, targets[i], plot, bool(args.junit), spec)

    return executor, batch.job_run_shipped, job_args


def _system_of(raw: bytes | None, path: str, system: SystemSpec | None) -> SystemSpec | None:
    """The system of the file *path* holding *raw*, resolved here (None if it cannot be read: the worker says why)."""
    if system is not None or raw is None:
        return system
    try:
        document = parse_json(raw, path)
    except InvalidTestCase:
        return None
    return resolved_system(document, path, None)
