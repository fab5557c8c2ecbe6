"""Batch mode: validate, show or run many test cases, in parallel.

``python -m btgen_pytrees validate|show|run DIR_OR_FILES... [--jobs N] [--out-dir D]``
expands directories to the ``*.json`` and ``*.xosc`` files under them (sorted, so the order and
the output names are stable), processes each file in a worker process
(:func:`btgen_pytrees.parallel.process`), and ends with a summary table. One bad
file never stops the others: every file gets an :class:`~btgen_pytrees.parallel.Outcome`,
and the exit code is the worst of all (0 < 1 < 2 < 3).

This module holds the jobs, one per file: plain functions of a path and the
command's options that return the file's outcome (its outputs as data, which the
CLI writes), so they run alike in this process, in a local worker and on a Dask worker.
"""

from __future__ import annotations

import os
from typing import Any, Iterable, Sequence

from .construct import generate
from .errors import ExitCode, InvalidTestCase, plural
from .leaves import default_registry
from .load import MAX_WORK, check_work, load, load_json, parse_json, validate
from .writing import report_outputs
from .load.warnings import warning_lines
from .parallel import Outcome
from .render import render
from .run import run
from .run.plot import plot_bytes
from .sweep import MAX_VARIATIONS, has_variations, load_sweep
from .sweep.runs import resolved_system, sweep_report
from .sweep.jobs import RunOptions, job_chunk, registry_for
from .sweep.plot import map_bytes
from .load.variations import Variations
from .openscenario import is_catalog, is_openscenario
from .contracts.system import SystemSpec
from .timeline import timeline

__all__ = ["expand", "output_names", "job_validate", "job_show", "job_run", "job_run_shipped", "job_run_variations",
           "run_case", "defaults_only"]  # fmt: skip


def expand(paths: Iterable[str]) -> list[str]:
    """Files as given, directories replaced by the ``*.json`` and ``*.xosc`` entries under them (recursive,
    sorted; an OpenSCENARIO scenario's sidecar ``NAME.oracle.json`` and an OpenSCENARIO catalog file are
    not cases: :func:`~btgen_pytrees.openscenario.is_catalog` reads the start of each ``.xosc`` to tell).

    The walk is iterative (a tree 1,000 folders deep is fine) and does not
    follow symbolic links to directories (no loops). Every ``*.json`` entry that
    is not a directory is listed - a dangling symlink, a FIFO or a device too -
    so the loader reports it instead of it being skipped in silence.
    """
    out: list[str] = []
    for raw in paths:
        if not os.path.isdir(raw):
            out.append(raw)
            continue
        found: list[str] = []
        stack = [raw]
        while stack:
            folder = stack.pop()
            try:
                with os.scandir(folder) as listing:
                    items = list(listing)
            except OSError:
                found.append(folder)  # unreadable folder: the loader says why
                continue
            for item in items:
                try:
                    is_dir = item.is_dir(follow_symlinks=False)
                except OSError:
                    is_dir = False
                if is_dir:
                    stack.append(item.path)
                elif item.name.endswith(".json") and not _sidecar(item.path):
                    found.append(item.path)
                elif is_openscenario(item.name) and not is_catalog(item.path):
                    found.append(item.path)
        out.extend(sorted(found, key=_path_key))
    return out


def _sidecar(path: str) -> bool:
    """``NAME.oracle.json``: an OpenSCENARIO scenario's pass criteria (docs/openscenario.md), not a case."""
    return path.endswith(".oracle.json")


def _path_key(path: str) -> tuple[str, ...]:
    """Sort by path components, so ``a/b.json`` and ``a-b.json`` order as ``pathlib`` does."""
    return tuple(path.split(os.sep))


def output_names(paths: Sequence[str], suffix: str) -> list[str]:
    """``<stem><suffix>`` per path, unique over the whole batch, in input order.

    A stem used by several inputs gets ``-2``, ``-3``, ... on its second and
    later uses, skipping every name another input has (or was given), compared
    case-insensitively (a case-insensitive disk must not merge two reports):
    ``a/x.json``, ``b/x.json`` and ``x-2.json`` give ``x``, ``x-3`` and ``x-2``.
    Characters a file name cannot hold safely (control characters) are replaced.
    """
    stems = [_safe_stem(p) for p in paths]
    taken = {stem.casefold() for stem in stems}
    first: set[str] = set()
    names = []
    for stem in stems:
        key = stem.casefold()
        if key not in first:
            first.add(key)
            names.append(stem + suffix)
            continue
        n = 2
        while f"{stem}-{n}".casefold() in taken:
            n += 1
        taken.add(f"{stem}-{n}".casefold())
        names.append(f"{stem}-{n}{suffix}")
    return names


def _safe_stem(path: str) -> str:
    name = os.path.basename(path.rstrip(os.sep))
    suffix = next((x for x in (".json", ".xosc") if name.endswith(x) and len(name) > len(x)), "")
    stem = name[: -len(suffix)] if suffix else name
    stem = "".join("_" if ord(c) < 32 or ord(c) == 127 else c for c in stem)
    return stem if stem not in ("", ".", "..") else "case"


def job_validate(path: str, plugins: Sequence[str], max_variations: int | None = None) -> Outcome:
    registry = default_registry(plugins)
    data = load_json(path)
    case = validate(data, path, registry)
    found = f"ok: {plural(len(case.entries), 'entry', 'entries')}, {plural(len(case.criteria), 'criterion', 'criteria')}"
    if has_variations(data):  # a sweep: every variation is checked
        limit = max_variations if max_variations is not None else MAX_VARIATIONS
        sweep = load_sweep(data, registry=registry, max_variations=limit, source_name=path)
        found += f", {plural(sweep.count, 'variation')}"
        discarded = getattr(sweep.variations, "discarded", 0)  # an OpenSCENARIO distribution's (docs/openscenario.md)
        if discarded:
            found += f" (of {sweep.variations.total:,} the file defines: {discarded:,} {'breaks' if discarded == 1 else 'break'} the parameters' constraints)"
    return Outcome(path, ExitCode.OK, found, warnings=warning_lines(case))


def job_show(path: str, plugins: Sequence[str], fmt: str, target: str | None, max_depth: int | None,
             indent: int | None | str = "auto") -> Outcome:  # fmt: skip
    """Render one tree; with a *target* it is an output to write, else the text to print (*indent*: json only)."""
    registry = default_registry(plugins)
    case = load(path, registry=registry)
    text = render(generate(case, registry=registry), timeline(case), fmt, max_depth=max_depth, indent=indent)
    if target is None:
        return Outcome(path, ExitCode.OK, fmt, outputs=[("-", text)], warnings=warning_lines(case))
    return Outcome(path, ExitCode.OK, fmt, outputs=[(target, text)], warnings=warning_lines(case))


def job_run(path: str, plugins: Sequence[str], target: str | None, plot: str | None = None,
            junit: bool = False, system: Any = None, max_work: int | None = None,
            require_complete: bool = False) -> Outcome:  # fmt: skip
    """Run one case; outputs: ``<target>.report.json``, ``<target>.junit.xml`` and, with *plot*
    (``svg``/``png``/``html``), ``<target>.<plot>``. With *junit* the JUnit text also comes back
    (``Outcome.junit``) for one batch-wide file. *system* (a ``SystemSpec``) replaces the case's
    (``run --system``). *max_work* is the work budget (default :data:`~.load.MAX_WORK`)."""
    registry = default_registry(plugins)
    case = load(path, registry=registry, system=system)
    with open(path, "rb") as fh:  # read again only to tell a sweep, whose defaults alone ran; before the run,
        raw = fh.read()  # whose leaves may change directory
    return defaults_only(run_case(path, case, registry, target, plot, junit, max_work, require_complete), raw)


def defaults_only(outcome: Outcome, raw: bytes) -> Outcome:
    """*outcome* of a file of a batch; if the file (its bytes *raw*) is a sweep, its row says that only its
    defaults ran, and how many variations it has (``run`` of that file alone, or ``--variations``, runs them)."""
    if b'"variations"' not in raw:
        return outcome
    data = parse_json(raw, outcome.path)
    if has_variations(data):
        count = Variations.parse(data["variations"]).count
        outcome.summary += f"; sweep: defaults only; run it alone or with --variations for its {plural(count, 'variation')}"
    return outcome


def run_case(path: str, case: Any, registry: Any, target: str | None, plot: str | None = None,
             junit: bool = False, max_work: int | None = None, require_complete: bool = False) -> Outcome:  # fmt: skip
    """Check the work budget, run a loaded *case* and make *path*'s :class:`Outcome`.

    The one piece behind every engine's ``run`` of a file (:func:`job_run` on the
    local workers, ``job_run_shipped`` on a Dask cluster), so the outputs, the
    summary line, the warnings and ``--require-complete`` are the same wherever it ran.
    """
    budget = MAX_WORK if max_work is None else max_work
    check_work(case, budget)
    report = run(case, registry=registry, require_complete=require_complete or None, max_work=budget)
    outputs = [] if target is None else report_outputs(report, f"{target}.report.json", f"{target}.junit.xml",
                                                       plot and f"{target}.{plot}", lambda: plot_bytes(report, case, plot))  # fmt: skip
    line = f"{report.verdict} after {report.duration:g} s" + (f": {report.message}" if report.message else "")
    word = "" if report.verdict in ("pass", "fail") else report.verdict.upper()
    outcome = Outcome(path, ExitCode.OK if report.passed else ExitCode.FAIL, line, result=word, outputs=outputs, warnings=warning_lines(case))
    if junit:
        outcome.junit = report.to_junit()
    return outcome


def job_run_shipped(path: str, options: RunOptions, raw: bytes | None, problems: Sequence[Any],
                    target: str | None, plot: str | None = None, junit: bool = False,
                    system: SystemSpec | None = None) -> Outcome:  # fmt: skip
    """``run`` of one file of a batch on a cluster: the file's bytes travel with the task.

    Only the reading differs from :func:`job_run`: both end
    in :func:`run_case`, whose outputs (report, JUnit, plot)
    come back as data for the client to write; *problems* are what reading the
    file found on the client (then *raw* is None). *system* as for :func:`~btgen_pytrees.sweep.jobs.job_variation`.
    """
    if raw is None:
        raise InvalidTestCase(problems, path)
    registry = registry_for(options.local_plugins())
    case = validate(parse_json(raw, path), path, registry, options.local_system(system))
    return defaults_only(run_case(path, case, registry, target, plot, junit, options.max_work, options.require_complete), raw)


def job_run_variations(path: str, plugins: Sequence[str], target: str | None, plot: str | None = None,
                       junit: bool = False, system: Any = None, max_work: int | None = None,
                       require_complete: bool = False, max_variations: int | None = None) -> Outcome:  # fmt: skip
    """``run FILE... --variations``: a sweep runs every variation here, one after the other; any other file
    as :func:`job_run`.

    A sweep's outputs are its sweep report (``<target>.report.json``), its JUnit
    (a testcase per variation) and, with *plot*, its verdict map; its row counts
    the verdicts. The variations run in this worker process, one at a time (a
    worker starts no workers of its own); each is guarded on its own.
    """
    data = load_json(path)
    if not has_variations(data):
        return job_run(path, plugins, target, plot, junit, system, max_work, require_complete)
    registry = default_registry(plugins)
    limit = max_variations if max_variations is not None else MAX_VARIATIONS
    sweep = load_sweep(data, registry=registry, max_variations=limit, source_name=path, system=system, max_work=max_work)
    variations = list(sweep)
    options = RunOptions(tuple(plugins), max_work, require_complete)  # every run option, as for the sweep run alone
    items = [(v.label, v.document, resolved_system(v.document, path, system)) for v in variations]
    done = job_chunk(path, options, path, items)
    report = sweep_report(sweep, variations, done.parts)
    outputs = [] if target is None else report_outputs(report, f"{target}.report.json", f"{target}.junit.xml",
                                                       plot and f"{target}.{plot}", lambda: map_bytes(report, plot))  # fmt: skip
    counts = ", ".join(f"{n} {v}" for v, n in report.counts.items())
    code = ExitCode.INTERNAL if any(p.code == ExitCode.INTERNAL for p in done.parts) else ExitCode.OK if report.passed else ExitCode.FAIL
    outcome = Outcome(path, code, f"{plural(len(variations), 'variation')}: {counts}", outputs=outputs,
                            result="" if code != ExitCode.INTERNAL else "ERROR")  # fmt: skip
    if junit:
        outcome.junit = report.to_junit()
    return outcome
