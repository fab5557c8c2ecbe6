"""The job a worker runs for one variation: validate its concrete case, run it, return a row.

The job receives the case *data* (a concrete document), never a path to read
it from, and :class:`RunOptions` - every option of the command that changes a
run (``--plugin``, ``--max-work``, ``--require-complete``; ``--system`` and the
case's own system come as a resolved :class:`~btgen_pytrees.systems.SystemSpec`
per case) - so it runs the same in a local worker process and on a Dask worker
on another machine, in another directory. Files a run reads (a SUMO
configuration and its network, a plugin file) are named by their absolute
path on the client; on a cluster they were shipped (:mod:`btgen_pytrees.parallel.shipping`)
and each path is mapped to the worker's copy. It returns a :class:`VariationOutcome` - an
:class:`~btgen_pytrees.parallel.Outcome` carrying the row for the sweep report -
so :func:`btgen_pytrees.parallel.process` (its pool, its progress bar, its error
guard) runs sweeps and batches alike.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any, Mapping, Sequence

from ..errors import ExitCode
from ..leaves import Registry, default_registry
from ..leaves.plugins import is_path
from ..load import MAX_WORK, check_work, validate
from ..parallel import Outcome, guard
from ..parallel.shipping import local
from ..run import run
from ..contracts.system import SystemSpec
from ..systems.sumo import reuse_for

__all__ = ["VariationOutcome", "ChunkOutcome", "RunOptions", "job_variation", "job_chunk", "chunk_size",
           "registry_for", "row_of", "margin_of"]  # fmt: skip


@dataclass(frozen=True)
class RunOptions:
    """What the command line says about every run, the same for each variation and file.

    Attributes:
        plugins: ``--plugin`` modules and files (files as absolute paths on the client)
        max_work: the work budget (None: :data:`~btgen_pytrees.load.MAX_WORK`)
        require_complete: ``--require-complete``
        files: the digest of the :class:`~.shipping.Files` shipped to the workers (Dask), None when
            the runs read the client's own disk (the local pool)
    """

    plugins: tuple[str, ...] = ()
    max_work: int | None = None
    require_complete: bool = False
    files: str | None = None

    def local_plugins(self) -> tuple[str, ...]:
        return tuple(local(self.files, p) if is_path(p) else p for p in self.plugins)

    def local_system(self, system: SystemSpec | None) -> SystemSpec | None:
        if system is None or system.config is None:
            return system
        return SystemSpec(system.type, local(self.files, system.config), system.options)


@dataclass
class VariationOutcome(Outcome):
    """An :class:`Outcome` with the variation's result row (see :func:`row_of`)."""

    row: dict[str, Any] = field(default_factory=dict)


@lru_cache(maxsize=8)
def registry_for(plugins: tuple[str, ...]) -> Registry:
    """One registry per worker process and plugin list (building one imports the plugins)."""
    return default_registry(plugins)


def margin_of(oracle: Any) -> float | None:
    """A criterion's robustness margin, if the oracle reports one (> 0 passed with room, < 0 failed by)."""
    margin = oracle.get("margin") if isinstance(oracle, Mapping) else getattr(oracle, "margin", None)
    return float(margin) if isinstance(margin, (int, float)) and not isinstance(margin, bool) else None


def row_of(report: Any) -> dict[str, Any]:
    """The sweep report's row for one run: verdict, margin (the report's: the oracle's robustness),
    why, when, each criterion's verdict and margin."""
    oracles = []
    for o in report.oracles:
        oracles.append({"id": o.id, "verdict": o.verdict, "margin": margin_of(o), "at": o.at, "message": o.message})
        if o.type == "temporal":
            oracles[-1]["decided"] = o.decided
    failed = next((e for e in report.execute if e.status == "failure"), None)
    details = [f"{o.id}: {o.message}" for o in report.oracles if o.verdict == "fail" and o.message and report.decisive(o)]
    if failed is not None:
        details.insert(0, f"{failed.id} failed" + (f": {failed.message}" if failed.message else ""))
    why = "; ".join(details) if report.verdict == "fail" and details else report.message
    return {
        "verdict": report.verdict,
        "message": why,
        "duration": report.duration,
        "ticks": report.ticks,
        "margin": report.margin,
        "oracles": oracles,
    }


def job_variation(label: str, options: RunOptions, source: str, document: Mapping[str, Any],
                  system: SystemSpec | None = None) -> VariationOutcome:  # fmt: skip
    """Run one concrete case; code 0 pass, 1 fail/timeout/error (invalid input raises, as in batch jobs).

    *system*: the system to run against (``--system``, or the case's own with its configuration
    resolved on the client); None: the document's, resolved here (only for documents without files)."""
    registry = registry_for(options.local_plugins())
    case = validate(document, source, registry, options.local_system(system))
    budget = MAX_WORK if options.max_work is None else options.max_work
    check_work(case, budget)
    report = run(case, registry=registry, require_complete=options.require_complete or None, max_work=budget,
                 record=False)  # a row carries no trace: recording it would be a fifth of a short run's time
    row = row_of(report)
    line = f"{report.verdict} after {report.duration:g} s" + (f": {row['message']}" if row["message"] else "")
    return VariationOutcome(label, ExitCode.OK if report.passed else ExitCode.FAIL, line, row=row)


@dataclass
class ChunkOutcome(Outcome):
    """The outcomes of several variations run by one task (:func:`job_chunk`), in order."""

    parts: list[Outcome] = field(default_factory=list)


def job_chunk(label: str, options: RunOptions, source: str,
              items: Sequence[tuple[str, Mapping[str, Any], SystemSpec | None]]) -> ChunkOutcome:  # fmt: skip
    """Run several variations in one task, each guarded on its own (one's error is not the others').

    *items*: ``(label, document, system)`` per variation. A run takes milliseconds, about
    what handing a task to a worker process costs; a chunk pays that once for all its runs,
    and its SUMO runs start SUMO once and set it back between runs (:func:`~btgen_pytrees.systems.sumo.reuse_for`).
    """
    with reuse_for(len(items)):
        parts = [guard(job_variation, name, options, source, document, system) for name, document, system in items]
    return ChunkOutcome(label, max(p.code for p in parts), f"{len(parts)} variations", parts=parts)


def chunk_size(n: int, workers: int, per_worker: int = 8, most: int = 32) -> int:
    """Runs per task: about *per_worker* tasks per worker, at most *most* runs each (a worker that
    dies costs its task's runs a second run, one by one), at least one."""
    return max(1, min(most, -(-n // max(1, workers * per_worker))))
