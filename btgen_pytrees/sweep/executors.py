"""Where runs execute: the local process pool, or a Dask ``distributed`` cluster.

The default engine is :func:`btgen_pytrees.batch.process`'s local process pool
(``--jobs N``). :class:`DaskExecutor` hands the same calls to an existing Dask
cluster instead (``--executor dask --scheduler tcp://HOST:PORT``, or the
``DASK_SCHEDULER_ADDRESS`` variable); ``batch.process(..., executor=...)`` uses
it for a sweep's variations and for a batch of files alike.

What the cluster gets and gives back:

* **Data, not paths.** Each task carries its case *data* (a sweep's concrete
  documents, a batch's file contents - see docs/scaling.md), so a worker needs
  btgen_pytrees (and any plugins) installed, and no copy of the case file.
* **Chunks.** A run of a small case takes milliseconds, about what the scheduler
  spends on one task; calls are therefore grouped into chunks (about
  :data:`CHUNKS_PER_WORKER` per worker, at most :data:`MAX_CHUNK` calls each) so
  scheduling costs little, while progress still moves and the load balances.
* **Streaming, exactly once.** Results are yielded as chunks finish, each call's
  result once, tagged with its index - a chunk whose worker died is run again
  elsewhere by the scheduler (up to ``distributed.scheduler.allowed-failures``
  times) and still completes only once. A chunk that keeps killing workers comes
  back as a :class:`TaskFailed` for each of its calls (``batch.process`` records
  it as an internal error, code 3), so the final report is complete either way.
* **Cancellation.** If the consumer stops early (Ctrl-C raises
  ``KeyboardInterrupt`` in the loop, or the generator is closed), every task not
  yet finished is cancelled on the cluster before the client disconnects.

``dask`` and ``distributed`` are the optional extra ``[dask]``; this module
imports them only when a :class:`DaskExecutor` is created.
"""

from __future__ import annotations

import importlib.util
import math
import os
import uuid
from typing import Any, Callable, Iterator, Sequence

__all__ = ["Executor", "DaskExecutor", "DaskUnavailable", "TaskFailed", "scheduler_address", "run_chunk",
           "CHUNKS_PER_WORKER", "MAX_CHUNK"]  # fmt: skip

CHUNKS_PER_WORKER = 8
"""Tasks per worker a sweep is split into (more: finer progress and balance; fewer: less overhead)."""

MAX_CHUNK = 64
"""Most calls in one task (a retried task repeats at most this many runs)."""

HINT = "--executor dask needs dask and distributed: pip install 'btgen_pytrees[dask]'"


class DaskUnavailable(RuntimeError):
    """The cluster cannot be used (extra not installed, scheduler unreachable); ``str()`` says why."""


class TaskFailed(Exception):
    """The result of a call the engine could not complete (not raised: yielded in its place)."""


class Executor:
    """Runs zero-argument picklable calls somewhere; :meth:`map_unordered` yields ``(index, result)``."""

    def map_unordered(self, calls: Sequence[Callable[[], Any]]) -> Iterator[tuple[int, Any]]:
        raise NotImplementedError


def scheduler_address(given: str | None) -> str | None:
    """*given*, else ``DASK_SCHEDULER_ADDRESS``, else None."""
    return given or os.environ.get("DASK_SCHEDULER_ADDRESS") or None


def run_chunk(chunk: Sequence[tuple[int, Callable[[], Any]]]) -> list[tuple[int, Any]]:
    """The task a worker runs: every call of *chunk*, in order, with its index."""
    return [(i, call()) for i, call in chunk]


class DaskExecutor(Executor):
    """Submit calls to the Dask cluster whose scheduler is at *address*.

    Args:
        address: ``tcp://HOST:PORT`` of a running scheduler
        chunk: calls per task (default: from the number of workers, see :data:`CHUNKS_PER_WORKER`)
        timeout: seconds to wait for the scheduler when connecting
    """

    def __init__(self, address: str, *, chunk: int | None = None, timeout: float = 10.0):
        if importlib.util.find_spec("distributed") is None:
            raise DaskUnavailable(HINT)
        self.address = address
        self.chunk = chunk
        self.timeout = timeout
        self._client: Any = None

    def connect(self) -> None:
        """Reach the scheduler now (a usage problem is better found before anything runs)."""
        if self._client is not None:
            return
        from distributed import Client

        try:
            self._client = Client(self.address, timeout=self.timeout, set_as_default=False)
        except (OSError, TimeoutError, ValueError) as exc:
            raise DaskUnavailable(f"cannot reach the Dask scheduler at {self.address}: {exc}") from None

    def close(self) -> None:
        """Disconnect (the cluster itself keeps running)."""
        if self._client is not None:
            self._client.close()
            self._client = None

    def __enter__(self) -> "DaskExecutor":
        self.connect()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def map_unordered(self, calls: Sequence[Callable[[], Any]]) -> Iterator[tuple[int, Any]]:
        from distributed import as_completed

        if not calls:
            return
        self.connect()
        client = self._client
        futures: list[Any] = []
        try:
            workers = max(1, len(client.scheduler_info().get("workers", {})))
            size = self.chunk or max(1, min(MAX_CHUNK, math.ceil(len(calls) / (workers * CHUNKS_PER_WORKER))))
            pairs = list(enumerate(calls))
            chunks = [pairs[start:start + size] for start in range(0, len(pairs), size)]
            token = uuid.uuid4().hex[:12]
            futures = [client.submit(run_chunk, chunk, key=f"btgen-{token}-{j}", pure=False)
                       for j, chunk in enumerate(chunks)]  # fmt: skip
            owner = {f.key: chunk for f, chunk in zip(futures, chunks)}
            for future in as_completed(futures, loop=client.loop):
                if future.status == "finished":
                    yield from future.result()
                else:  # the scheduler gave up on it (KilledWorker) or it was lost: say so per call
                    why = f"run on the Dask cluster failed: {type(future.exception()).__name__}: {future.exception()}"
                    for i, _ in owner[future.key]:
                        yield i, TaskFailed(why)
        finally:
            pending = [f for f in futures if not f.done()]
            if pending:
                client.cancel(pending, force=True)

