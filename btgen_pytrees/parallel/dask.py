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
  files) are sent once, as a Dask worker plugin that writes them in each worker
  when it starts - a worker restarted later included (:meth:`DaskExecutor.ship`,
  :mod:`.shipping`). A task therefore depends on no data the cluster can lose:
  a result lost with its worker is simply computed again. So a worker needs
  btgen_pytrees (and any plugin *modules*) installed, and neither the client's
  files nor its working directory.
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
  times) and still completes only once. The scheduler gives up on (``KilledWorker``)
  every task that was on a worker each time it died, the task that killed it and
  those queued beside it alike; so each call of such a chunk is run again *alone*
  (nothing else on the cluster), one after the other, and only a call that still
  kills its workers comes back as a :class:`~.outcome.WorkerDied` (``process``
  records it as that run's error, code 1, as the local pool does a worker that
  died with its job): the report is complete, and only the killing run is an error.
  A chunk the cluster could not run otherwise comes back as a :class:`TaskFailed`
  for each call (an internal error, code 3).
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
import uuid
from concurrent.futures import CancelledError
from typing import Any, Callable, Iterator, Sequence

from ..errors import UserError
from .outcome import WorkerDied
from .shipping import Files, install

__all__ = ["Executor", "DaskExecutor", "DaskUnavailable", "TaskFailed", "scheduler_address",
           "check_address", "run_chunk", "CHUNKS_PER_WORKER", "MAX_CHUNK", "KILLED"]  # fmt: skip

CHUNKS_PER_WORKER = 8
"""Tasks per worker a sweep is split into (more: finer progress and balance; fewer: less overhead)."""

MAX_CHUNK = 64
"""Most calls in one task (a retried task repeats at most this many runs)."""

RESUBMIT = 2
"""Times a task is sent again when the cluster cancelled it rather than failed it (its result was lost with
a worker as the client fetched it, and Dask then cancels the task instead of computing it again)."""

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


def _files_plugin(files: Files) -> Any:
    """A Dask worker plugin that installs *files* in each worker's own directory (removed with the worker)
    as the worker starts: the scheduler keeps it and gives it to every worker that joins later, a worker
    restarted after a run killed it included, before that worker gets a task."""
    from distributed import WorkerPlugin

    class ShippedFiles(WorkerPlugin):  # defined here: distributed is imported only when it is used
        def __init__(self, files: Files):
            self.files = files

        def setup(self, worker: Any) -> None:
            install(self.files, str(worker.local_directory))

    return ShippedFiles(files)


def run_chunk(chunk: Sequence[tuple[int, Callable[[], Any]]],
              keep: tuple[str, Callable[[], None]] | None = None) -> list[tuple[int, Any]]:  # fmt: skip
    """The task a worker runs: every call of *chunk*, in order, with its index, one task at a time
    per process; *keep* (an executor's token and its ``enter``) is entered first if this process
    has not entered it yet."""
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
        self._token = uuid.uuid4().hex
        self._shipped: tuple[str, str] | None = None  # (plugin name, digest) of the files the workers install
        self.lost: str | None = None
        """Set when the scheduler was lost during :meth:`map_unordered`: what happened, in words."""
        self._keep = (self._token, keep[0]) if keep is not None else None
        self._leave = keep[1] if keep is not None else None

    def ship(self, files: Files) -> None:
        """Have every worker install *files* - those running now and any that starts later, a worker
        restarted after a run killed it included - before it runs a task of :meth:`map_unordered`
        (a Dask worker plugin, held by the scheduler until :meth:`close`). The same files shipped
        before (a search ships its files for every batch) are not sent again."""
        self.connect()
        if self._shipped is not None and self._shipped[1] == files.digest:
            return
        self._unship()
        if files.items:
            name = f"btgen-files-{self._token[:12]}-{files.digest[:12]}"
            # recorded first: the scheduler holds the plugin as soon as it gets it, while the workers still install
            # the files - a Ctrl-C in that wait (long for big files) must still let close() remove it
            self._shipped = (name, files.digest)
            self._client.register_plugin(_files_plugin(files), name=name)

    def _unship(self) -> None:
        """Let the scheduler forget the files of :meth:`ship` (the workers keep their copies until they end)."""
        if self._shipped is not None:
            name, self._shipped = self._shipped[0], None
            self._client.unregister_worker_plugin(name)

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
            try:
                if self._client.status == "running":
                    self._unship()
            except Exception:  # noqa: BLE001 - the scheduler gone, or it never got the plugin (interrupted as it was sent)
                pass
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
        from distributed import KilledWorker, as_completed

        if not calls:
            return
        self.connect()
        client = self._client
        futures: list[Any] = []
        owner: dict[str, list[tuple[int, Callable[[], Any]]]] = {}  # each task's calls
        again: dict[str, int] = {}  # how many times each task was sent again
        alone: set[str] = set()  # the tasks that run one call with nothing else on the cluster
        suspects: list[tuple[int, Callable[[], Any]]] = []  # calls of tasks the cluster gave up on
        finished: set[int] = set()

        def submit(chunk: list[tuple[int, Callable[[], Any]]], key: str) -> Any:
            future = client.submit(run_chunk, chunk, self._keep, key=key, pure=False)
            owner[key], again[key] = chunk, 0
            futures.append(future)
            return future

        def drain(stream: Any) -> Iterator[tuple[int, Any]]:
            """Yield the results of the tasks in *stream* as they complete; raise _Lost when the scheduler is gone."""
            for future in stream:
                results = None
                if future.status == "finished":
                    try:
                        results = future.result()  # fetched from a worker: the connection may break here
                    except CancelledError:  # its result was lost with its worker as it was fetched
                        results = None
                if results is not None:
                    for i, result in results:
                        finished.add(i)
                        yield i, result
                elif client.status != "running":  # the scheduler is gone: no task of this run will finish now
                    raise _Lost
                elif future.status != "error" and again[future.key] < RESUBMIT:
                    # cancelled, not failed: its result was lost with a worker that a run killed, and Dask
                    # cancelled the task rather than compute it again - so it is sent again
                    retry = submit(owner[future.key], f"{future.key}-again{again[future.key] + 1}")
                    again[retry.key] = again[future.key] + 1
                    if future.key in alone:
                        alone.add(retry.key)
                    stream.add(retry)
                elif future.key not in alone and isinstance(_exception(future), KilledWorker):
                    # the scheduler gave up on it because workers died while it was there - but it may only
                    # have waited beside the task that killed them (queued on the same worker, or on its
                    # other thread): each of its calls runs again alone, below, to tell which one kills
                    suspects.extend(owner[future.key])
                elif future.key in alone and isinstance(_exception(future), KilledWorker):
                    # it kills its worker even alone: that run's error, as the local pool says of a worker
                    # process that died with its job (the words are ours: Dask's name a random key and a port)
                    for i, _ in owner[future.key]:
                        finished.add(i)
                        yield i, WorkerDied(KILLED)
                else:  # it failed otherwise, or was cancelled again: say so per call
                    why = f"run on the Dask cluster failed: {_failure(future)}"
                    for i, _ in owner[future.key]:
                        finished.add(i)
                        yield i, TaskFailed(why)

        try:
            workers = self.workers()
            size = self.chunk or max(1, min(MAX_CHUNK, math.ceil(len(calls) / (workers * CHUNKS_PER_WORKER))))
            pairs = list(enumerate(calls))
            token = uuid.uuid4().hex[:12]
            first = [submit(pairs[start:start + size], f"btgen-{token}-{j}")
                     for j, start in enumerate(range(0, len(pairs), size))]  # fmt: skip
            try:
                yield from drain(as_completed(first, loop=client.loop))
                for i, call in sorted(suspects, key=lambda pair: pair[0]):  # one at a time: no bystander
                    solo = submit([(i, call)], f"btgen-{token}-alone{i}")
                    alone.add(solo.key)
                    yield from drain(as_completed([solo], loop=client.loop))
            except (_Lost, OSError):  # OSError: CommClosedError, a refused connection - the scheduler is gone
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


class _Lost(Exception):
    """The scheduler is gone: no task of the current call will finish now."""


def _exception(future: Any) -> BaseException | None:
    """The exception *future* ended with, or the one met asking for it (cancelled, disconnected)."""
    try:
        return future.exception(timeout=5)
    except Exception as problem:  # noqa: BLE001 - the client cannot tell any more (cancelled, disconnected)
        return problem


KILLED = ("the Dask worker process died each time it ran this run, alone on the cluster "
          "(os._exit, a crash or a signal in user code or a simulator, or out of memory)")
"""What a run that kills its worker even alone says: the same words each time (Dask's own message names the
task's random key and the last worker's address, which would make two reports of one sweep differ)."""


def _failure(future: Any) -> str:
    """``ValueError: ...``: why the cluster gave up on *future*."""
    exc = _exception(future)
    if exc is None:
        return f"the task was {future.status}"
    return f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__

