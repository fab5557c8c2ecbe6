"""The job a worker runs for the search: a sweep's variation job, plus each criterion's margin.

It runs where the sweep's variations run (the local process pool or a Dask
worker, through :func:`btgen_pytrees.sweep.command.run_variations`), with the
case as data; it returns the sweep row (:func:`btgen_pytrees.sweep.jobs.row_of`)
with ``margins`` (criterion id -> margin, :func:`.margins.criterion_margins`)
and ``groups`` (the oracle groups and their relations) added, so the client
computes the objective without the run's trace.
"""

from __future__ import annotations

import time
from functools import lru_cache
from typing import Any, Mapping, Sequence

from ..batch import Outcome
from ..errors import InvalidTestCase, is_interrupt
from ..leaves import Registry, default_registry
from ..loader import validate
from ..run import run
from ..sweep.jobs import ChunkOutcome, VariationOutcome, row_of
from .margins import criterion_margins, groups_of

__all__ = ["job_probe", "probe"]


@lru_cache(maxsize=8)
def _registry(plugins: tuple[str, ...]) -> Registry:
    return default_registry(plugins)


def probe(label: str, plugins: Sequence[str], source: str, document: Mapping[str, Any], system: Any = None) -> VariationOutcome:
    """Run one concrete case: its sweep row, with ``margins`` and ``groups``."""
    began = time.perf_counter()
    registry = _registry(tuple(plugins))
    case = validate(document, source, registry, system)
    report = run(case, registry=registry)
    row = row_of(report)
    row["wall"] = time.perf_counter() - began
    row["margins"] = criterion_margins(report, case)
    row["groups"] = {g: [relation, ids] for g, (relation, ids) in groups_of(report.oracles).items()}
    line = f"{report.verdict} after {report.duration:g} s"
    return VariationOutcome(label, 0 if report.passed else 1, line, row=row)


def _guarded(label: str, plugins: Sequence[str], source: str, document: Mapping[str, Any], system: Any) -> Outcome:
    try:
        return probe(label, plugins, source, document, system)
    except InvalidTestCase as error:
        return Outcome(label, 2, "invalid: " + "; ".join(p.render(error.source) for p in error.problems[:3]))
    except BaseException as exc:  # noqa: BLE001 - one run's error is that run's, never the search's
        if is_interrupt(exc):
            raise
        return Outcome(label, 3, f"error: {type(exc).__name__}: {exc}")


def job_probe(label: str, plugins: Sequence[str], source: str, items: Sequence[tuple[str, Mapping[str, Any]]],
              system: Any = None) -> ChunkOutcome:  # fmt: skip
    """Several runs in one task (like :func:`btgen_pytrees.sweep.jobs.job_chunk`), each guarded on its own."""
    parts = [_guarded(name, plugins, source, document, system) for name, document in items]
    return ChunkOutcome(label, max(p.code for p in parts), f"{len(parts)} runs", parts=parts)
