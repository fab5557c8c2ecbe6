"""The command line of sweeps: ``run CASE`` on a case with variations, the ``expand`` command, and the
``--executor``/``--scheduler`` options (run and falsify) - the argparse and printing half of running
many variations; the runs themselves are :mod:`btgen_pytrees.sweep.runs`.

Everything that can be refused is refused before the first run: the file and
every variation are validated, the count is checked against the limit, the
``--plot`` suffix and extra, and the Dask scheduler is reached - so exit code 2
always means nothing ran and nothing was written.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import signal
from typing import Any, Callable, Mapping, Sequence

from ..errors import ExitCode, UsageError, plural
from ..leaves.plugins import is_path
from ..load import system_spec
from ..writing import at_home, check_target, commit, emit, report_outputs, stderr_stream
from ..parallel import Interrupted, progress_stream
from ..parallel.dask import DaskExecutor, check_address, scheduler_address
from ..run.plot import plot_format
from ..sweep import MAX_VARIATIONS, Sweep, load_sweep
from ..sweep.jobs import RunOptions
from ..sweep.plot import map_bytes
from ..sweep.overrides import variation_name
from ..sweep.runs import file_name, run_variations, sweep_report
from ..systems.sumo import keep_simulations, release_simulations
from .options import SIDECAR_NOTE, Parents, chosen, registry, whole
from .terminal import deliver

__all__ = ["add_parser", "add_executor_options", "cmd_expand", "run_sweep", "make_executor", "checked_scheduler",
           "run_options"]  # fmt: skip


def add_parser(sub: Any, parents: Parents) -> None:
    expand = sub.add_parser("expand", parents=[parents.plugin, parents.chosen], help="write each variation of a sweep as a concrete test case")
    expand.add_argument("file", metavar="FILE", help="test case file with variations, or an OpenSCENARIO ParameterValueDistribution (.xosc); " + SIDECAR_NOTE)
    expand.add_argument("--out-dir", required=True, metavar="DIR", help="write name[gap=5,...].json files into DIR")
    expand.add_argument("--max-variations", type=whole, metavar="N", help="refuse more than N variations (default 10000)")
    expand.set_defaults(func=cmd_expand)


def add_executor_options(parser: argparse.ArgumentParser) -> None:
    """``--executor`` and ``--scheduler``: where runs execute (``run``, ``falsify``)."""
    parser.add_argument("--executor", choices=("local", "dask"), default="local",
                        help="where runs execute: local worker processes (--jobs), or a Dask cluster (--scheduler)")  # fmt: skip
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="with --executor dask: the scheduler, tcp://HOST:PORT (default: $DASK_SCHEDULER_ADDRESS)")  # fmt: skip


def load(args: argparse.Namespace, data: Mapping[str, Any] | None = None, system: Any = None) -> Sweep:
    """The sweep of ``args.file`` (or *data*, the document read from it), every variation validated."""
    source = args.file
    limit = args.max_variations if args.max_variations is not None else MAX_VARIATIONS
    if limit < 1:
        raise UsageError(f"--max-variations {limit}: must be at least 1")
    return load_sweep(data if data is not None else source, registry=registry(args), max_variations=limit, source_name=source,
                      system=system, max_work=getattr(args, "max_work", None))  # fmt: skip


def cmd_expand(args: argparse.Namespace) -> int:
    """Write every variation (or the one chosen with ``--set``/``--params``) into ``--out-dir``:
    all of them, or none.

    Like ``run``'s outputs, every target is checked before anything is written: none
    may be the input file (named alike, through a symlink or a hard link), be a
    directory, or be named twice; ``--out-dir`` must be a directory or creatable.
    """
    data = chosen(args)
    out = args.out_dir
    if os.path.lexists(out) and not os.path.isdir(out):
        raise UsageError(f"--out-dir {out}: exists and is not a directory")
    sweep = load(args, data)
    planned: list[tuple[str, str]] = []
    taken: dict[str, str] = {}
    for variation in sweep:
        doc = moved(dict(variation.document), sweep.source, args.out_dir)
        where = f"variation {variation.label} of {os.path.basename(sweep.source)}" if variation.label else None
        if where:
            doc["description"] = f"{doc['description']} ({where})" if doc.get("description") else where.capitalize()
            doc["name"] = variation_name(sweep.name, variation.label)  # its reports and JUnit say which variation
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
    emit(f"{plural(len(planned), 'case')} written to {out}\n")
    return ExitCode.OK


def moved(document: dict[str, Any], source: str, out_dir: str) -> dict[str, Any]:
    """*document* (from the file *source*) as a file in *out_dir*: its system's ``config`` (and ``road``) is relative
    to the case file, so it is rewritten relative to *out_dir* (absolute when no relative path leads there, e.g.
    another drive)."""
    spec = system_spec(document, source)
    if spec is None or (spec.config is None and spec.road is None):
        return document
    system = dict(document["system"])
    for key, path in (("config", spec.config), ("road", spec.road)):  # an OpenDRIVE road is relative to the case too
        if path is None:
            continue
        try:
            system[key] = os.path.relpath(path, os.path.abspath(out_dir))
        except ValueError:
            system[key] = path
    return {**document, "system": system}


def make_executor(args: argparse.Namespace,
                  keep: tuple[Callable[[], None], Callable[[], None]] | None = None) -> DaskExecutor | None:  # fmt: skip
    """None for the local pool; a connected :class:`~btgen_pytrees.parallel.dask.DaskExecutor` for ``--executor dask``
    (*keep*: its ``keep``, what each worker process enters before its first task and leaves at the end).

    Raises:
        UsageError: no scheduler address.
        DaskUnavailable: a malformed or unsupported address, the extra is missing, or the scheduler
            cannot be reached.
    """
    address = checked_scheduler(args)
    if address is None:
        return None
    try:
        executor = DaskExecutor(address, keep=keep)
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
    sweep = load(args, data, system)
    executor = make_executor(args, keep=(keep_simulations, release_simulations))  # each worker keeps its SUMO open
    variations = list(sweep)
    try:
        outcomes = run_variations(sweep, variations, run_options(args), system, args.jobs, executor,
                                  progress_stream())  # fmt: skip
    except Interrupted as stop:
        emit(f"btgen_pytrees: interrupted by {signal.Signals(stop.signum).name} after {stop.finished} of "  # type: ignore[attr-defined]
             f"{plural(len(variations), 'variation')}; nothing written\n", stderr_stream())  # fmt: skip
        return 128 + stop.signum
    finally:
        if executor is not None:
            executor.close()
    report = sweep_report(sweep, variations, outcomes)
    outputs = report_outputs(report, args.json, args.junit, args.plot, lambda: map_bytes(report, plot_format(args.plot)))
    for path, kind in extra:
        outputs.append((path, report.to_json() if kind == "json" else report.to_junit()))
    if out_dir is not None:
        at_home()
        os.makedirs(out_dir, exist_ok=True)
    if any(o.code == ExitCode.INTERNAL for o in outcomes):
        code: int = ExitCode.INTERNAL
    else:
        code = ExitCode.OK if report.passed else ExitCode.FAIL
    deliver(outputs, report.summary(), code)  # escaped; stdout: the document only
    if executor is not None and executor.lost:
        emit(f"btgen_pytrees: {executor.lost}; the rest are reported as errors\n", stderr_stream())
    return code
