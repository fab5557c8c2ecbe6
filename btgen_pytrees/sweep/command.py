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
import sys
from typing import Any, Callable, Mapping, Sequence

from ..leaves import Registry, default_registry
from ..leaves.plugins import is_path
from ..errors import ExitCode, UsageError, plural
from ..loader import system_spec
from ..output import check_target, commit, emit, on_stdout, report_outputs
from ..parallel import Interrupted, Outcome, process, progress_stream
from ..parallel.dask import DaskExecutor, check_address, scheduler_address
from ..parallel.shipping import Files, read_files
from ..contracts.system import SystemSpec
from ..run.plot import plot_format
from .case import MAX_VARIATIONS, Sweep, Variation, load_sweep
from .jobs import ChunkOutcome, RunOptions, VariationOutcome, chunk_size, job_chunk
from .plot import map_bytes
from .report import SweepReport

__all__ = ["run_sweep", "run_variations", "resolved_system", "cmd_expand", "file_name", "make_executor", "sweep_report"]

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
        raise UsageError(f"--max-variations {limit}: must be at least 1")
    registry = default_registry(args.plugin or ())
    return load_sweep(data if data is not None else source, registry=registry, max_variations=limit, source_name=source, system=system,
                      max_work=getattr(args, "max_work", None))  # fmt: skip


def cmd_expand(args: argparse.Namespace, data: Mapping[str, Any] | None = None) -> int:
    """Write every variation (or the one of *data*, chosen with ``--set``/``--params``) into ``--out-dir``:
    all of them, or none.

    Like ``run``'s outputs, every target is checked before anything is written: none
    may be the input file (named alike, through a symlink or a hard link), be a
    directory, or be named twice; ``--out-dir`` must be a directory or creatable.
    """
    out = args.out_dir
    if os.path.lexists(out) and not os.path.isdir(out):
        raise UsageError(f"--out-dir {out}: exists and is not a directory")
    sweep = _load(args, data)
    planned: list[tuple[str, str]] = []
    taken: dict[str, str] = {}
    for variation in sweep:
        doc = _moved(dict(variation.document), sweep.source, args.out_dir)
        where = f"variation {variation.label} of {os.path.basename(sweep.source)}" if variation.label else None
        if where:
            doc["description"] = f"{doc['description']} ({where})" if doc.get("description") else where.capitalize()
        name = file_name(sweep.name, variation.label, variation.index)
        if name.casefold() in taken:  # a case-insensitive disk would merge them
            raise UsageError(f"--out-dir {out}: variations [{taken[name.casefold()]}] and [{variation.label}] would both be written to {name}")
        taken[name.casefold()] = variation.label
        path = os.path.join(out, name)
        check_target(path, "--out-dir", [args.file], made_later=True)
        planned.append((path, json.dumps(doc, indent=2, ensure_ascii=False) + "\n"))
    try:
        os.makedirs(out, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"--out-dir {out}: cannot be created: {exc.strerror or exc}") from None
    commit(planned)
    emit(f"{len(planned)} case{'s' if len(planned) != 1 else ''} written to {out}\n")
    return ExitCode.OK


def _moved(document: dict[str, Any], source: str, out_dir: str) -> dict[str, Any]:
    """*document* (from the file *source*) as a file in *out_dir*: its system's ``config`` is relative to the case
    file, so it is rewritten relative to *out_dir* (absolute when no relative path leads there, e.g. another drive)."""
    spec = system_spec(document, source)
    if spec is None or spec.config is None:
        return document
    try:
        config = os.path.relpath(spec.config, os.path.abspath(out_dir))
    except ValueError:
        config = spec.config
    return {**document, "system": {**document["system"], "config": config}}


def make_executor(args: argparse.Namespace) -> Any:
    """None for the local pool; a connected :class:`DaskExecutor` for ``--executor dask``.

    Raises:
        UsageError: no scheduler address.
        DaskUnavailable: a malformed or unsupported address, the extra is missing, or the scheduler
            cannot be reached.
    """
    address = checked_scheduler(args)
    if address is None:
        return None
    import logging

    try:
        executor = DaskExecutor(address)
        executor.connect()
    finally:  # the command says itself what went wrong with the cluster, in one line; distributed's own
        # log records (tracebacks of its reconnection attempts) would bury it. Its loggers exist once it is imported.
        for name in [n for n in logging.root.manager.loggerDict if n == "distributed" or n.startswith("distributed.")]:
            logging.getLogger(name).setLevel(logging.CRITICAL + 1)
    return executor


def checked_scheduler(args: argparse.Namespace) -> str | None:
    """The scheduler address of ``--executor dask``, checked without connecting (None for the local pool).

    Raises:
        UsageError: no address.
        DaskUnavailable: a malformed or unsupported address.
    """
    if getattr(args, "executor", None) != "dask":
        return None
    address = scheduler_address(args.scheduler)
    if address is None:
        raise UsageError("--executor dask needs --scheduler tcp://HOST:PORT (or DASK_SCHEDULER_ADDRESS)")
    return check_address(address)


def run_options(args: argparse.Namespace) -> RunOptions:
    """The options of ``run`` that change each run, with plugin files as absolute paths."""
    plugins = tuple(os.path.abspath(p) if is_path(p) else p for p in (args.plugin or ()))
    return RunOptions(plugins, getattr(args, "max_work", None), bool(getattr(args, "require_complete", False)))


def resolved_system(document: Any, source: str, system: SystemSpec | None) -> SystemSpec | None:
    """The system a run of *document* uses, its configuration an absolute path on this machine:
    *system* (``--system``) or the case's own, resolved relative to *source*."""
    if system is not None:
        return system
    own = system_spec(document, source)
    return SystemSpec(own.type, own.config) if own is not None and own.config is not None else None


def needed_files(options: RunOptions, systems: Sequence[SystemSpec | None], registry: Registry) -> list[str]:
    """Every file the runs read besides their case: each system's (its type's ``files(spec)``, else
    its configuration file) and the ``--plugin`` files - absolute paths on this machine."""
    found: list[str] = [p for p in options.plugins if is_path(p) and os.path.isfile(p)]
    for spec in dict.fromkeys(s for s in systems if s is not None and s.config is not None):
        assert spec.config is not None
        system_type = registry.system(spec.type)
        lister = getattr(system_type, "files", None)
        try:
            files = tuple(lister(spec)) if callable(lister) else ()
        except Exception:  # noqa: BLE001 - a third-party system's bug: ship the configuration at least
            files = ()
        found += [os.path.abspath(f) for f in files] or ([spec.config] if os.path.isfile(spec.config) else [])
    return list(dict.fromkeys(found))


def ship(executor: Any, options: RunOptions, systems: Sequence[SystemSpec | None], registry: Registry) -> RunOptions:
    """On a cluster: send the files the runs read to the workers (once each); the options naming them."""
    if executor is None:
        return options
    files: Files = read_files(needed_files(options, systems, registry))  # ShippingError: a usage error
    if not files.items:
        return options
    executor.ship(files)
    return RunOptions(options.plugins, options.max_work, options.require_complete, files.digest)


def sweep_report(sweep: Sweep, variations: Sequence[Variation], outcomes: Sequence[Outcome]) -> SweepReport:
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


def run_variations(sweep: Sweep, variations: Sequence[Variation], options: RunOptions, system: SystemSpec | None,
                   workers: int, executor: Any = None, progress: Any = None,
                   job: Callable[..., ChunkOutcome] = job_chunk) -> list[Outcome]:  # fmt: skip
    """Run *variations*; one outcome per variation, in order.

    *job* runs a chunk (default :func:`~.jobs.job_chunk`; ``falsify`` passes its own, which
    also times each run).

    Every variation's job gets *options* and its system (*system*, ``--system``, or its own
    with the configuration resolved here). On a cluster the files the runs read are sent to
    the workers first (:func:`ship`). On the local pool, variations go to the workers in chunks
    (:func:`~.jobs.chunk_size`: about 8 per worker, at most 32 runs each), so the cost of
    handing a task to a process is paid once per chunk; a worker that dies costs its chunk
    (each of its variations gets the error). A :class:`~btgen_pytrees.parallel.dask.DaskExecutor` chunks by itself.

    Raises:
        Interrupted: Ctrl-C; its ``finished`` tells how many variations had run.
    """
    systems = [resolved_system(v.document, sweep.source, system) for v in variations]
    options = ship(executor, options, systems, default_registry(options.plugins) if executor is not None else Registry())
    size = chunk_size(len(variations), workers) if executor is None else 1
    starts = range(0, len(variations), size)
    chunks = [variations[k:k + size] for k in starts]
    names = [c[0].label if len(c) == 1 else f"variations {c[0].index + 1}-{c[-1].index + 1}" for c in chunks]
    job_args = [(options, sweep.source, [(v.label, v.document, s) for v, s in zip(c, systems[k:k + size])])
                for k, c in zip(starts, chunks)]  # fmt: skip
    try:
        done = process(job, job_args, names, workers=workers, progress=progress, executor=executor)
    except Interrupted as stop:
        stop.finished = sum(len(c) for c, o in zip(chunks, stop.outcomes) if o.code != ExitCode.INTERRUPTED)  # type: ignore[attr-defined]
        raise
    return [part for c, o in zip(chunks, done)
            for part in (o.parts if isinstance(o, ChunkOutcome) else [o] * len(c))]  # a lost chunk: each its error


def run_sweep(args: argparse.Namespace, data: Mapping[str, Any], system: Any = None, *,
              extra: Sequence[tuple[str, str]] = (), out_dir: str | None = None) -> int:  # fmt: skip
    """``run CASE`` for a case with variations; exit 0 all pass, 1 any did not, 2 invalid (nothing ran).

    The CLI has checked the output paths and the plot suffix; the outputs are
    written together at the end (all or none), after every variation ran.
    *system* (``run --system``) replaces the case's system in every variation.
    *extra*: more ``(path, "json"|"junit")`` outputs (a batch's ``--junit`` beside
    its ``--out-dir`` files); *out_dir* is made just before they are written.
    """
    for option in ("trace", "replay"):
        if getattr(args, option, None):
            raise UsageError(f"--{option} shows a single run; a sweep has many (run one variation from 'expand')")
    checked_scheduler(args)  # a malformed address is refused before the variations are validated
    sweep = _load(args, data, system)
    executor = make_executor(args)
    variations = list(sweep)
    try:
        outcomes = run_variations(sweep, variations, run_options(args), system, args.jobs, executor,
                                  progress_stream())  # fmt: skip
    except Interrupted as stop:
        emit(f"btgen_pytrees: interrupted by {signal.Signals(stop.signum).name} after {stop.finished} of "
             f"{plural(len(variations), 'variation')}; nothing written\n", sys.stderr)  # fmt: skip
        return 128 + stop.signum
    finally:
        if executor is not None:
            executor.close()
    report = sweep_report(sweep, variations, outcomes)
    outputs = report_outputs(report, args.json, args.junit, args.plot, lambda: map_bytes(report, plot_format(args.plot)))
    for path, kind in extra:
        outputs.append((path, report.to_json() if kind == "json" else report.to_junit()))
    if out_dir is not None:
        os.makedirs(out_dir, exist_ok=True)
    commit(outputs)
    emit(report.summary(), sys.stderr if on_stdout(t for t, _ in outputs) else None)  # escaped; stdout: the document only
    if executor is not None and executor.lost:
        emit(f"btgen_pytrees: {executor.lost}; the rest are reported as errors\n", sys.stderr)
    if any(o.code == ExitCode.INTERNAL for o in outcomes):
        return ExitCode.INTERNAL
    return ExitCode.OK if report.passed else ExitCode.FAIL
