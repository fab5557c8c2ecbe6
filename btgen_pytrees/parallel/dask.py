"""Runs on a Dask ``distributed`` cluster instead of the local process pool.

The default engine is :func:`btgen_pytrees.parallel.process`'s local process pool
(``--jobs N``). :class:`DaskExecutor` hands the same calls to an existing Dask
cluster instead (``--executor dask --scheduler tcp://HOST:PORT``, or the
``DASK_SCHEDULER_ADDRESS`` variable); ``process(..., executor=...)`` uses
it for a sweep's variations and for a batch of files alike.

What the cluster gets and gives back:

* **Data, not paths.** Each task carries its case *data* (a sweep's concrete
  documents, a batch's file contents - see docs/scaling.md); the files the runs
  read besides (a SUMO configuration, its network and routes, ``--plugin``
  files) are sent once to every worker (:meth:`DaskExecutor.ship`,
  :mod:`.shipping`). So a worker needs btgen_pytrees (and any plugin
  *modules*) installed, and neither the client's files nor its working directory.
* **One run at a time per worker process.** A run ticks a py_trees tree and may
  drive a simulator that allows one simulation per process (libsumo); a worker
  process with several threads therefore runs its tasks one after the other
  (:func:`run_chunk` holds a process-wide lock), so every verdict is the one
  the local pool gives, whatever ``--nthreads`` the workers were started with.
* **Chunks.** A run of a small case takes milliseconds, about what the scheduler
  spends on one task; calls are therefore grouped into chunks (about
  :data:`CHUNKS_PER_WORKER` per worker, at most :data:`MAX_CHUNK` calls each) so
  scheduling costs little, while progress still moves and the load balances.
* **Streaming, exactly once.** Results are yielded as chunks finish, each call's
  result once, tagged with its index - a chunk whose worker died is run again
  elsewhere by the scheduler (up to ``distributed.scheduler.allowed-failures``
  times) and still completes only once. A chunk that keeps killing workers comes
  back as a :class:`TaskFailed` for each of its calls (``process`` records
  it as an internal error, code 3), so the final report is complete either way.
* **Kept between tasks.** An executor made with ``keep=(enter, leave)`` calls
  ``enter()`` in each worker process before the first of its tasks there, and
  ``leave()`` in each such process when it closes (a sweep and a search pass
  :func:`~btgen_pytrees.systems.sumo.keep_simulations` and
  :func:`~btgen_pytrees.systems.sumo.release_simulations`: a worker keeps its SUMO
  open from one task to the next, and lets it go when the command ends).
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
import re
import threading
import time
import uuid
from concurrent.futures import CancelledError
from typing import Any, Callable, Iterator, Sequence

from ..errors import UserError
from .shipping import Files, install

__all__ = ["Executor", "DaskExecutor", "DaskUnavailable", "TaskFailed", "scheduler_address",
           "check_address", "run_chunk", "CHUNKS_PER_WORKER", "MAX_CHUNK"]  # fmt: skip

CHUNKS_PER_WORKER = 8
"""Tasks per worker a sweep is split into (more: finer progress and balance; fewer: less overhead)."""

MAX_CHUNK = 64
"""Most calls in one task (a retried task repeats at most this many runs)."""

RESUBMIT = 2
"""Times a task the cluster cancelled (not failed) is sent again, with the shipped files in the task itself: the
files it needed (:meth:`DaskExecutor.ship`) were lost with every worker that held them, or its result with its
worker. A task that kills its worker every time still ends as ``KilledWorker``."""

HINT = "--executor dask needs dask and distributed: pip install 'btgen_pytrees[dask]'"


class DaskUnavailable(UserError, RuntimeError):
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


_ADDRESS = re.compile(r"(?:(?P<protocol>[A-Za-z][A-Za-z0-9+.-]*)://)?(?P<host>\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9._-]+)"
                      r":(?P<port>[0-9]{1,5})")  # fmt: skip


def check_address(address: str) -> str:
    """*address* if it is a scheduler address this client can use, else :class:`DaskUnavailable` at once.

    Accepted: ``tcp://HOST:PORT`` (``HOST:PORT`` is the same), and ``tls://HOST:PORT``
    when Dask's TLS settings name a CA file (``distributed.comm.tls.ca-file``). Nothing
    is connected here: a malformed or unsupported address never waits for a timeout.
    """
    shown = address if len(address) <= 120 else address[:117] + "..."
    match = _ADDRESS.fullmatch(address.strip())
    if match is None:
        raise DaskUnavailable(f"--scheduler {shown!r}: not a scheduler address; expected tcp://HOST:PORT")
    protocol = (match["protocol"] or "tcp").lower()
    port = int(match["port"])
    if not 0 < port < 65536:
        raise DaskUnavailable(f"--scheduler {shown!r}: port {port} is out of range (1-65535)")
    if protocol == "tls":
        import dask.config

        if not dask.config.get("distributed.comm.tls.ca-file", None):
            raise DaskUnavailable(f"--scheduler {shown!r}: tls:// needs Dask's TLS settings (distributed.comm.tls.ca-file, "
                                  ".client.cert and .client.key in a Dask configuration file or DASK_ variables)")  # fmt: skip
    elif protocol != "tcp":
        raise DaskUnavailable(f"--scheduler {shown!r}: the {protocol}:// protocol is not supported; use tcp://HOST:PORT "
                              "(or tls:// with Dask's TLS settings)")  # fmt: skip
    return address.strip()


_one_run = threading.Lock()
"""Held while a task runs: one run at a time in a worker process, whatever its number of threads."""
_entered: set[str] = set()
"""The executors (their tokens) whose ``keep`` entered this worker process (changed under :data:`_one_run`)."""
_LEAVE_WAIT = 1.0
"""Seconds a worker waits for the task it is running before it gives up leaving (a task cancelled by Ctrl-C runs on
to its end, or another client's task: the process keeps what it kept until its next task or its end). The wait
holds the worker's event loop (``Client.run``), so it is short."""


def _scratch() -> str | None:
    """The Dask worker's own directory (removed with the worker), or None outside a worker."""
    try:
        from distributed import get_worker

        return str(get_worker().local_directory)
    except (ImportError, ValueError):
        return None


def run_chunk(chunk: Sequence[tuple[int, Callable[[], Any]]], files: Files | None = None,
              keep: tuple[str, Callable[[], None]] | None = None) -> list[tuple[int, Any]]:  # fmt: skip
    """The task a worker runs: every call of *chunk*, in order, with its index, one task at a time
    per process; *files* (sent once per worker) are installed first; *keep* (an executor's token and
    its ``enter``) is entered first if this process has not entered it yet."""
    if files is not None:
        install(files, _scratch())
    with _one_run:
        if keep is not None and keep[0] not in _entered:
            keep[1]()
            _entered.add(keep[0])
        return [(i, call()) for i, call in chunk]


def _leave_kept(token: str, leave: Callable[[], None]) -> bool:
    """In a worker process: ``leave()`` if the executor *token* entered it (between two tasks); whether it did."""
    if not _one_run.acquire(timeout=_LEAVE_WAIT):
        return False
    try:
        if token not in _entered:
            return False
        _entered.discard(token)
        leave()
        return True
    finally:
        _one_run.release()


class DaskExecutor(Executor):
    """Submit calls to the Dask cluster whose scheduler is at *address*.

    Args:
        address: ``tcp://HOST:PORT`` of a running scheduler
        chunk: calls per task (default: from the number of workers, see :data:`CHUNKS_PER_WORKER`)
        timeout: seconds to wait for the scheduler when connecting
        keep: ``(enter, leave)``: called in each worker process before its first task of this executor,
            and when the executor closes (module-level functions: they are sent to the workers)
    """

    def __init__(self, address: str, *, chunk: int | None = None, timeout: float = 10.0,
                 keep: tuple[Callable[[], None], Callable[[], None]] | None = None):  # fmt: skip
        if importlib.util.find_spec("distributed") is None:
            raise DaskUnavailable(HINT)
        self.address = check_address(address)
        self.chunk = chunk
        self.timeout = timeout
        self._client: Any = None
        self._files: Any = None  # the future of the shipped Files, on the cluster
        self._shipped: Files | None = None  # the same Files here, to send again when the cluster lost them
        self.lost: str | None = None
        """Set when the scheduler was lost during :meth:`map_unordered`: what happened, in words."""
        self._keep = (uuid.uuid4().hex, keep[0]) if keep is not None else None
        self._leave = keep[1] if keep is not None else None

    def ship(self, files: Files) -> None:
        """Send *files* to every worker once (workers that join later fetch them from the others);
        every task of :meth:`map_unordered` then installs them before it runs. The same files shipped
        before (a search ships its files for every batch) are not sent again while the cluster holds them.

        Every worker may be restarting when this is called (a run's user code killed each of them, and
        their nannies start them again): the files are sent once one is back, within ``max(timeout, 30)`` s."""
        self.connect()
        if not files.items:
            self._files = self._shipped = None
            return
        if self._files is not None and self._shipped is not None and self._shipped.digest == files.digest \
                and self._files.status == "finished":
            return
        self._shipped = files
        deadline = time.monotonic() + max(self.timeout, 30.0)
        while True:
            try:
                self._files = self._client.scatter(files, broadcast=True, hash=False)
                return
            except (TimeoutError, OSError) as exc:  # "No valid workers found": none is running yet
                if time.monotonic() > deadline or self._client.status != "running":
                    raise DaskUnavailable(f"cannot send the runs' files to the Dask workers at {self.address}: {exc}") from None
                time.sleep(0.5)

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
        """Disconnect (the cluster itself keeps running); the workers this executor's ``keep`` entered leave it."""
        if self._client is not None:
            self._files = self._shipped = None
            try:
                if self._keep is not None and self._client.status == "running":
                    self._client.run(_leave_kept, self._keep[0], self._leave)
            except Exception:  # noqa: BLE001 - a worker or the scheduler gone: what it kept ends with its process
                pass
            try:
                self._client.close()
            except (OSError, TimeoutError, RuntimeError):  # the scheduler is gone already
                pass
            self._client = None

    def __enter__(self) -> "DaskExecutor":
        self.connect()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def workers(self) -> int:
        """How many runs the cluster runs at once: its worker processes now (each runs one task at a
        time, whatever its threads; at least 1)."""
        self.connect()
        return max(1, len(self._client.scheduler_info().get("workers", {})))

    def map_unordered(self, calls: Sequence[Callable[[], Any]]) -> Iterator[tuple[int, Any]]:
        from distributed import as_completed

        if not calls:
            return
        self.connect()
        client = self._client
        futures: list[Any] = []
        try:
            workers = self.workers()
            size = self.chunk or max(1, min(MAX_CHUNK, math.ceil(len(calls) / (workers * CHUNKS_PER_WORKER))))
            pairs = list(enumerate(calls))
            chunks = [pairs[start:start + size] for start in range(0, len(pairs), size)]
            token = uuid.uuid4().hex[:12]
            futures = [client.submit(run_chunk, chunk, self._files, self._keep, key=f"btgen-{token}-{j}", pure=False)
                       for j, chunk in enumerate(chunks)]  # fmt: skip
            owner = {f.key: chunk for f, chunk in zip(futures, chunks)}
            again = dict.fromkeys(owner, 0)  # how many times each chunk was sent again
            finished: set[int] = set()
            lost = False
            try:
                stream = as_completed(futures, loop=client.loop)
                for future in stream:
                    results = None
                    if future.status == "finished":
                        try:
                            results = future.result()  # fetched from a worker: the connection may break here
                        except CancelledError:  # its result was on a worker that died, and cannot be made again
                            results = None
                    if results is not None:
                        for i, result in results:
                            finished.add(i)
                            yield i, result
                    elif client.status != "running":  # the scheduler is gone: no task of this run will finish now
                        lost = True
                        break
                    elif future.status != "error" and again[future.key] < RESUBMIT:
                        # cancelled by the cluster, not failed: the shipped files it needs were lost with the
                        # workers that held them (a run's user code killed them all, or the result with its
                        # worker); sent again carrying the files themselves, so no later loss can cancel it
                        chunk = owner[future.key]
                        retry = client.submit(run_chunk, chunk, self._shipped, self._keep, pure=False,
                                              key=f"{future.key}-again{again[future.key] + 1}")  # fmt: skip
                        owner[retry.key], again[retry.key] = chunk, again[future.key] + 1
                        futures.append(retry)
                        stream.add(retry)
                    else:  # the scheduler gave up on it (KilledWorker) or it was lost: say so per call
                        why = f"run on the Dask cluster failed: {_failure(future)}"
                        for i, _ in owner[future.key]:
                            finished.add(i)
                            yield i, TaskFailed(why)
            except OSError:  # CommClosedError, a refused connection: the scheduler (or this link to it) is gone
                lost = True
            if lost:
                self.lost = (f"the connection to the Dask scheduler at {self.address} was lost after "
                             f"{len(finished)} of {len(calls)} runs had finished")  # fmt: skip
                why = f"not run: the connection to the Dask scheduler at {self.address} was lost"
                for i in range(len(calls)):
                    if i not in finished:
                        yield i, TaskFailed(why)
        finally:
            pending = [f for f in futures if not f.done()]
            if pending and client.status == "running":
                try:
                    client.cancel(pending, force=True)
                except OSError:
                    pass


def _failure(future: Any) -> str:
    """``KilledWorker: ...``: why the cluster gave up on *future*."""
    try:
        exc = future.exception(timeout=5)
    except Exception as problem:  # noqa: BLE001 - the client cannot tell any more (cancelled, disconnected)
        exc = problem
    if exc is None:
        return f"the task was {future.status}"
    return f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__

