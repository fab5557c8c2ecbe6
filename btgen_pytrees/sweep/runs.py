"""A sweep's variations run: in chunks on the local worker pool or one by one on a Dask cluster (the
files they read shipped there first), and their outcomes made into the sweep's report.

The command line's half (the options, the checks before anything runs, the printing) is
:mod:`btgen_pytrees.cli.sweep`; this module takes plain values and prints nothing.
"""

from __future__ import annotations

import hashlib
import os
import re
from typing import Any, Callable, Sequence

from ..leaves import Registry, default_registry
from ..leaves.plugins import is_path
from ..errors import ExitCode
from ..load import system_spec
from ..parallel import Interrupted, Outcome, Workers, process
from ..parallel.shipping import Files, read_files
from ..contracts.system import SystemSpec
from ..load.template import Sweep, Variation
from .jobs import ChunkOutcome, RunOptions, VariationOutcome, chunk_size, job_chunk
from .report import SweepReport
from .objective import document_groups

__all__ = ["run_variations", "resolved_system", "needed_files", "ship", "file_name", "sweep_report"]

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
    report = SweepReport(sweep.name, sweep.source, dict(sweep.defaults), sweep.varied, groups=document_groups(sweep.template))
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
                   job: Callable[..., ChunkOutcome] = job_chunk, pool: Workers | None = None) -> list[Outcome]:  # fmt: skip
    """Run *variations*; one outcome per variation, in order.

    *job* runs a chunk (default :func:`~.jobs.job_chunk`; ``falsify`` passes its own, which
    also times each run).

    Every variation's job gets *options* and its system (*system*, ``--system``, or its own
    with the configuration resolved here). On a cluster the files the runs read are sent to
    the workers first (:func:`ship`). On the local pool, variations go to the workers in chunks
    (:func:`~.jobs.chunk_size`: about 8 per worker, at most 32 runs each), so the cost of
    handing a task to a process is paid once per chunk; a worker that dies takes its chunk with it,
    and the chunk's variations run again one per job (only one that kills its worker alone is an
    error). A :class:`~btgen_pytrees.parallel.dask.DaskExecutor` chunks by itself (and does the same).
    *pool* (a :class:`~btgen_pytrees.parallel.Workers`) runs the chunks in workers kept across calls (a search's batches).

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
        done = process(job, job_args, names, workers=workers, progress=progress, executor=executor, pool=pool)
    except Interrupted as stop:
        stop.finished = sum(len(c) for c, o in zip(chunks, stop.outcomes) if o.code != ExitCode.INTERRUPTED)  # type: ignore[attr-defined]
        raise
    # a chunk whose worker died with it: its variations run again one per job, so that only the one that kills
    # its worker is an error (the others had run beside it, or had yet to), as on a Dask cluster
    dead = [(k, j) for k, (c, o) in enumerate(zip(chunks, done)) if len(c) > 1 and o.died
            for j in range(len(c))]  # fmt: skip
    alone: dict[tuple[int, int], Outcome] = {}
    if dead:
        try:
            again = process(job, [(options, sweep.source, [job_args[k][2][j]]) for k, j in dead],
                            [chunks[k][j].label for k, j in dead], workers=workers, progress=None, pool=pool,
                            isolate=True)  # fmt: skip  (never in this process: one of them kills its process)
        except Interrupted as stop:
            stop.finished = (sum(len(c) for c, o in zip(chunks, done) if not o.died)  # type: ignore[attr-defined]
                             + sum(1 for o in stop.outcomes if o.code != ExitCode.INTERRUPTED))  # fmt: skip
            raise
        alone = dict(zip(dead, (o.parts[0] if isinstance(o, ChunkOutcome) else o for o in again)))
    return [alone.get((k, j), part) for k, (c, o) in enumerate(zip(chunks, done))
            for j, part in enumerate(o.parts if isinstance(o, ChunkOutcome) else [o] * len(c))]  # a lost chunk: each its error
