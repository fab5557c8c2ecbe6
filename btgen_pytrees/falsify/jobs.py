"""The job a worker runs for the search: the sweep's variation job, timed.

It runs where the sweep's variations run (the local process pool or a Dask
worker, through :func:`btgen_pytrees.sweep.runs.run_variations`), with the
case as data: each run is :func:`btgen_pytrees.sweep.jobs.job_variation` - so its
row carries the report's verdict and each criterion's margin, exactly as a
sweep row does - and its row gets ``wall``, the run's wall-clock seconds.
"""

from __future__ import annotations

import time
from typing import Any, Mapping, Sequence

from ..parallel import Outcome
from ..errors import InvalidTestCase, is_interrupt
from ..sweep.jobs import ChunkOutcome, RunOptions, job_variation
from ..systems.sumo import reuse_for

__all__ = ["job_probe", "timed"]


def timed(label: str, options: RunOptions, source: str, document: Mapping[str, Any], system: Any) -> Outcome:
    """One run (its sweep row plus ``wall``); an invalid case is code 2, anything else raised code 3."""
    began = time.perf_counter()
    try:
        outcome = job_variation(label, options, source, document, system)
    except InvalidTestCase as error:
        return Outcome(label, 2, "invalid: " + "; ".join(p.render(error.source) for p in error.problems[:3]))
    except BaseException as exc:  # noqa: BLE001 - one run's error is that run's, never the search's
        if is_interrupt(exc):
            raise
        return Outcome(label, 3, f"error: {type(exc).__name__}: {exc}")
    outcome.row["wall"] = time.perf_counter() - began  # type: ignore[attr-defined]
    return outcome


def job_probe(label: str, options: RunOptions, source: str,
              items: Sequence[tuple[str, Mapping[str, Any], Any]]) -> ChunkOutcome:  # fmt: skip
    """Several runs in one task (like :func:`btgen_pytrees.sweep.jobs.job_chunk`), each guarded and timed;
    SUMO is started once for them (:func:`~btgen_pytrees.systems.sumo.reuse_for`)."""
    with reuse_for(len(items)):
        parts = [timed(name, options, source, document, system) for name, document, system in items]
    return ChunkOutcome(label, max(p.code for p in parts), f"{len(parts)} runs", parts=parts)
