"""The sweep commands: ``run CASE`` on a case with variations, and ``expand CASE --out-dir D``.

Everything that can be refused is refused before the first run: the file and
every variation are validated, the count is checked against the limit, the
``--plot`` suffix and extra, and the Dask scheduler is reached - so exit code 2
always means nothing ran and nothing was written.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import signal
import stat
import sys
from typing import Any, Callable, Mapping, Sequence

from .. import batch
from ..leaves import default_registry
from ..errors import InvalidTestCase, Problem
from ..output import commit, write_file
from .case import MAX_VARIATIONS, Sweep, Variation, load_sweep
from .jobs import ChunkOutcome, VariationOutcome, chunk_size, job_chunk, job_run_shipped
from .report import SweepReport

__all__ = ["run_sweep", "run_variations", "dask_batch_args", "cmd_expand", "file_name", "make_executor", "sweep_report", "Refused"]

EXIT_OK, EXIT_FAIL, EXIT_INVALID = 0, 1, 2
_UNSAFE = re.compile(r"[^A-Za-z0-9._=,+\-\[\]]")
_MAX_NAME = 200


def file_name(name: str, label: str, index: int) -> str:
    """``name[gap=5,speed=10].json`` with anything but ``A-Za-z0-9._=,+-[]`` replaced by ``_``.

    Safe on Linux, macOS and Windows file systems. A name longer than 200 characters
    keeps its first 120 and gets the variation's number and a hash of its label instead.
    """
    stem = _UNSAFE.sub("_", name).lstrip(".") or "case"
    full = f"{stem}[{_UNSAFE.sub('_', label)}].json" if label else f"{stem}.json"
    if len(full) <= _MAX_NAME:
        return full
    digest = hashlib.sha1(label.encode("utf-8")).hexdigest()[:10]
    return f"{stem[:120]}[{index}-{digest}].json"


def _load(args: argparse.Namespace, data: Mapping[str, Any] | None = None, system: Any = None) -> Sweep:
    source = args.file
    limit = args.max_variations if args.max_variations is not None else MAX_VARIATIONS
    if limit < 1:
        raise Refused(f"--max-variations {limit}: must be at least 1")
    registry = default_registry(args.plugin or ())
    return load_sweep(data if data is not None else source, registry=registry, max_variations=limit, source_name=source, system=system,
                      max_work=getattr(args, "max_work", None))  # fmt: skip


def cmd_expand(args: argparse.Namespace) -> int:
    """Write every variation as a concrete case file into ``--out-dir``."""
    sweep = _load(args)
    os.makedirs(args.out_dir, exist_ok=True)
    count = 0
    for variation in sweep:
        doc = dict(variation.document)
        where = f"variation {variation.label} of {os.path.basename(sweep.source)}" if variation.label else None
        if where:
            doc["description"] = f"{doc['description']} ({where})" if doc.get("description") else where.capitalize()
        path = os.path.join(args.out_dir, file_name(sweep.name, variation.label, variation.index))
        write_file(path, json.dumps(doc, indent=2, ensure_ascii=False) + "\n")
        count += 1
    print(f"{count} case{'s' if count != 1 else ''} written to {args.out_dir}")
    return EXIT_OK


class Refused(Exception):
    """A usage problem found before anything ran (exit 2); ``str()`` is the message."""


def make_executor(args: argparse.Namespace) -> Any:
    """None for the local pool; a connected :class:`DaskExecutor` for ``--executor dask``.

    Raises:
        Refused: no scheduler address, the extra is missing, or the scheduler cannot be reached.
    """
    if getattr(args, "executor", None) != "dask":
        return None
    from .executors import DaskExecutor, DaskUnavailable, scheduler_address

    address = scheduler_address(args.scheduler)
    if address is None:
        raise Refused("--executor dask needs --scheduler tcp://HOST:PORT (or DASK_SCHEDULER_ADDRESS)")
    try:
        executor = DaskExecutor(address)
        executor.connect()
    except DaskUnavailable as problem:
        raise Refused(str(problem)) from None
    return executor


def sweep_report(sweep: Sweep, variations: Sequence[Variation], outcomes: Sequence[batch.Outcome]) -> SweepReport:
    """The report from the runs' outcomes (both in the sweep's order)."""
    report = SweepReport(sweep.name, sweep.source, dict(sweep.defaults), sweep.varied)
    for variation, outcome in zip(variations, outcomes):
        if isinstance(outcome, VariationOutcome):
            row = dict(outcome.row)
        else:  # the job raised (code 3) or, validated beforehand, cannot be invalid: an error row
            message = outcome.summary if not outcome.problems else "; ".join(outcome.problems)
            row = {"verdict": "error", "message": message, "duration": 0.0, "ticks": 0, "margin": None, "oracles": []}
        parameters = {name: value for name, value in variation.point}
        report.rows.append({"index": variation.index, "label": variation.label, "parameters": parameters, **row})
    return report


def run_variations(sweep: Sweep, variations: Sequence[Variation], plugins: tuple[str, ...], system: Any,
                   workers: int, executor: Any = None, progress: Any = None) -> list[batch.Outcome]:  # fmt: skip
    """Run *variations*; one outcome per variation, in order.

    On the local pool, variations go to the workers in chunks (:func:`~.jobs.chunk_size`:
    about 8 per worker, at most 32 runs each), so the cost of handing a task to a
    process is paid once per chunk; a worker that dies costs its chunk (each of its
    variations gets the error). A :class:`~.executors.DaskExecutor` chunks by itself.

    Raises:
        batch.Interrupted: Ctrl-C; its ``finished`` tells how many variations had run.
    """
    size = chunk_size(len(variations), workers) if executor is None else 1
    chunks = [variations[k:k + size] for k in range(0, len(variations), size)]
    names = [c[0].label if len(c) == 1 else f"variations {c[0].index + 1}-{c[-1].index + 1}" for c in chunks]
    job_args = [(plugins, sweep.source, [(v.label, v.document) for v in c], system) for c in chunks]
    try:
        done = batch.process(job_chunk, job_args, names, workers=workers, progress=progress, executor=executor)
    except batch.Interrupted as stop:
        stop.finished = sum(len(c) for c, o in zip(chunks, stop.outcomes) if o.code != batch.NOT_RUN)  # type: ignore[attr-defined]
        raise
    return [part for c, o in zip(chunks, done)
            for part in (o.parts if isinstance(o, ChunkOutcome) else [o] * len(c))]  # a lost chunk: each its error


def run_sweep(args: argparse.Namespace, data: Mapping[str, Any], system: Any = None) -> int:
    """``run CASE`` for a case with variations; exit 0 all pass, 1 any did not, 2 invalid (nothing ran).

    The CLI has checked the output paths and the plot suffix; the outputs are
    written together at the end (all or none), after every variation ran.
    *system* (``run --system``) replaces the case's system in every variation.
    """
    for option in ("trace", "replay"):
        if getattr(args, option, None):
            raise Refused(f"--{option} shows a single run; a sweep has many (run one variation from 'expand')")
    sweep = _load(args, data, system)
    executor = make_executor(args)
    variations = list(sweep)
    try:
        outcomes = run_variations(sweep, variations, tuple(args.plugin or ()), system, args.jobs, executor,
                                  batch.progress_stream())  # fmt: skip
    except batch.Interrupted as stop:
        print(f"btgen_pytrees: interrupted by {signal.Signals(stop.signum).name} after {stop.finished} of "
              f"{len(variations)} variations; nothing written", file=sys.stderr)  # fmt: skip
        return 128 + stop.signum
    finally:
        if executor is not None:
            executor.close()
    report = sweep_report(sweep, variations, outcomes)
    outputs: list[tuple[str, str | bytes]] = []
    if args.json:
        outputs.append((args.json, report.to_json()))
    if args.junit:
        outputs.append((args.junit, report.to_junit()))
    if args.plot:
        from ..run.plot import plot_format
        from .plot import map_bytes

        outputs.append((args.plot, map_bytes(report, plot_format(args.plot))))
    commit(outputs)
    sys.stdout.write(report.summary())
    if any(o.code == 3 for o in outcomes):
        return 3
    return EXIT_OK if report.passed else EXIT_FAIL


def dask_batch_args(args: argparse.Namespace, files: list[str], targets: Sequence[str | None],
                    plot: str | None, system: Any = None) -> tuple[Any, Callable[..., batch.Outcome], Callable[[int], tuple[object, ...]]]:  # fmt: skip
    """``run FILE... --executor dask``: the cluster, the job and its arguments for the CLI's batch.

    Each file is read here (with the loader's limits) and its bytes travel with
    its task, so workers need no copy of the files; the outputs come back as
    data and the CLI writes them here, never on a worker.
    """
    executor = make_executor(args)
    plugins = tuple(args.plugin or ())

    def job_args(i: int) -> tuple[object, ...]:
        try:
            raw: bytes | None = _read(files[i])
            problems: list[Problem] = []
        except InvalidTestCase as error:
            raw, problems = None, list(error.problems)
        return (plugins, raw, problems, targets[i], plot, bool(args.junit), system, getattr(args, "max_work", None),
                getattr(args, "require_complete", False))

    return executor, job_run_shipped, job_args


def _read(path: str) -> bytes:
    """The file's bytes, with the loader's checks (size limit, no FIFOs) - read once, here."""
    from ..loader import MAX_FILE_BYTES

    try:
        if not stat.S_ISREG(os.stat(path).st_mode):  # a FIFO would block the open
            raise InvalidTestCase([Problem((), "not a regular file", "json")], path)
        with open(path, "rb") as fh:
            raw = fh.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise InvalidTestCase([Problem((), f"cannot read file: {exc.strerror or exc}", "json")], path) from None
    if len(raw) > MAX_FILE_BYTES:
        raise InvalidTestCase([Problem((), f"file is larger than {MAX_FILE_BYTES} bytes", "limit")], path)
    return raw
