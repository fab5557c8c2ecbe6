"""Several files at once (``show|validate|run DIR_OR_FILES...``): the worker pool called, each file's
outputs written as its result arrives, its problems printed, and the summary table."""

from __future__ import annotations

import argparse
import os
import signal
from typing import Any, Callable

from ..batch import expand
from ..errors import InvalidTestCase, Problem, UsageError
from ..writing import WriteFailed, commit
from ..parallel import Interrupted, Outcome, process, progress_stream, summary
from .checks import make_out_dir
from .terminal import deliver, err, problems

__all__ = ["run_batch", "process_files", "expand_files", "single"]


def run_batch(args: argparse.Namespace, files: list[str], job: Callable[..., Outcome],
              job_args: Callable[[int], tuple[object, ...]], *, after: Callable[[list[Outcome]], None] | None = None,
              executor: Any = None) -> int:  # fmt: skip
    """Process *files* in worker processes; write each file's outputs as it finishes, then a summary.

    The output directory is made when the first output is written, so a batch
    of invalid files leaves none.
    """
    made: list[bool] = []

    def write(outcome: Outcome) -> None:
        outputs = [(t, d) for t, d in outcome.outputs if t != "-"]
        if not outputs:
            return
        if args.out_dir and not made:
            make_out_dir(args)
            made.append(True)
        try:
            outcome.written = commit(outputs)
        except WriteFailed as failed:  # a full disk: the environment's fault; the file's verdict stands
            outcome.summary = f"{outcome.summary}; not written: {failed}"
        outcome.outputs = [(t, d) for t, d in outcome.outputs if t == "-"]

    try:
        outcomes = process_files(args, job, [job_args(i) for i in range(len(files))], files, on_result=write,
                                 executor=executor)  # fmt: skip
    except Interrupted as stop:
        for outcome in stop.outcomes:
            problems(outcome, args.quiet)
        code = deliver([], summary(stop.outcomes), 128 + stop.signum)  # stdout full or not: 130/143 all the same
        err(f"btgen_pytrees: interrupted by {signal.Signals(stop.signum).name}; files not run are marked NOT RUN")
        return code
    failed: list[WriteFailed] = []
    if after is not None:
        try:
            after(outcomes)
        except WriteFailed as exc:
            failed.append(exc)
    code = deliver([], summary(outcomes), max(o.code for o in outcomes))
    for problem in failed:
        err(f"btgen_pytrees: {problem}")
    return code


def process_files(args: argparse.Namespace, job: Callable[..., Outcome], job_args: list[tuple[object, ...]],
                  files: list[str], on_result: Callable[[Outcome], None] | None = None,
                  executor: Any = None) -> list[Outcome]:  # fmt: skip
    """Run *job* over *files* (in worker processes when there are several, or on *executor*, a Dask
    cluster, which is closed after); print each file's problems."""
    workers = min(args.jobs, len(files))
    try:
        outcomes = process(job, job_args, files, workers=workers, progress=progress_stream(),
                           on_result=on_result, executor=executor)  # fmt: skip
    finally:
        if executor is not None:
            executor.close()
    for outcome in outcomes:
        problems(outcome, getattr(args, "quiet", False))
    return outcomes


def expand_files(args: argparse.Namespace) -> list[str]:
    """The files named, directories replaced by their *.json and *.xosc files (not catalogs); invalid input if none."""
    files = expand(args.files)
    if not files:
        raise InvalidTestCase([Problem((), "no *.json or *.xosc files found", "json")], ", ".join(args.files))
    return files


def single(args: argparse.Namespace) -> list[str] | None:
    """The expanded file list when this is a batch (several files, a directory, or --out-dir), else None."""
    if len(args.files) == 1 and not os.path.isdir(args.files[0]) and not args.out_dir:
        args.file = args.files[0]
        return None
    if args.set or args.params:
        raise UsageError("--set/--params choose one variation of one file (not a directory, several files or --out-dir)")
    return expand_files(args)
