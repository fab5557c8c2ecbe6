"""The local executor: jobs in worker processes of this machine, one bad job costing only itself.

:func:`process` runs ``job(path, *args)`` per path - in this process, in worker processes
(``--jobs N``), or on another engine such as :class:`~.dask.DaskExecutor` - and returns one
:class:`~.outcome.Outcome` per path, in input order, whatever each job did: it knows nothing of
what the jobs are (files of a batch, variations of a sweep, a search's probes).

A progress line is drawn on stderr when it is a terminal, nothing otherwise.
"""

from __future__ import annotations

import multiprocessing
import multiprocessing.context
import os
import signal
import sys
import time
from contextlib import contextmanager
from functools import partial
from multiprocessing.connection import Connection, wait
from typing import Any, Callable, Iterator, Sequence, TextIO

from ..errors import ExitCode, Interrupt
from .outcome import Interrupted, Outcome, WorkerDied, died, guard

__all__ = ["process", "progress_stream", "Workers"]


class _Stop(Interrupt):
    """Raised in a worker by SIGTERM, so ``finally`` blocks (temporary files) run before it exits."""


def _stop(signum: int, frame: object) -> None:
    raise _Stop(signum)


_HELD = (signal.SIGINT, signal.SIGTERM)


@contextmanager
def _signals_held() -> Iterator[None]:
    """Ctrl-C and SIGTERM wait (blocked, not lost) while workers are forked.

    A signal that arrives during ``fork()`` is handled in the parent inside the
    interpreter's after-fork hooks, where an exception is printed and dropped:
    the CLI's handler would raise its :class:`~btgen_pytrees.errors.Interrupt` into the void
    and ignore the signals after it, so the command would run on. Held, the
    signal is handled after the fork, where it stops the command. The child
    starts with them blocked too and unblocks them once its own handlers are set.
    """
    if not hasattr(signal, "pthread_sigmask"):  # Windows: no fork either
        yield
        return
    before = signal.pthread_sigmask(signal.SIG_BLOCK, _HELD)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


_WATCH = 1.0
"""Seconds between a waiting worker's checks that its parent is alive."""


def _worker(conn: Connection, parent: int, initializer: Callable[[], None] | None = None) -> None:
    """A worker process: run tasks from *conn* one at a time until told to stop.

    Ctrl-C reaches every process of the terminal's group: workers ignore it and
    let the parent decide (it stops them with SIGTERM, then SIGKILL). A parent
    that dies without a word (SIGKILL, the out-of-memory killer) is noticed while
    waiting for a task: forked workers hold their pipes' other ends, so no EOF
    would ever come, and they would wait forever. *parent* is the parent's pid as the parent saw
    it before forking: read in the child, it would already be the reaper's when the parent was killed
    between the fork and the read, and the worker would never notice. *initializer* (of a kept pool,
    :class:`Workers`) is called once, before the first task.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        signal.signal(signal.SIGTERM, _stop)
        if hasattr(signal, "pthread_sigmask"):  # forked with them held (_signals_held): a SIGTERM waiting now stops it
            signal.pthread_sigmask(signal.SIG_UNBLOCK, _HELD)
        if initializer is not None:
            initializer()
        while True:
            while not conn.poll(_WATCH):
                if os.getppid() != parent:  # orphaned: the parent is gone
                    return
            try:
                task = conn.recv()
            except EOFError:
                return
            if task is None:
                return
            index, job, path, args = task
            conn.send((index, guard(job, path, *args)))
    except (_Stop, BrokenPipeError):
        return
    finally:  # leaving: a late SIGTERM must end the process quietly, not raise in multiprocessing's exit code
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _death(exitcode: int | None) -> str:
    """Why a worker process ended, in words."""
    if exitcode is None:
        return "the worker process stopped answering"
    if exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            name = f"signal {-exitcode}"
        hint = " (out of memory, or killed from outside)" if -exitcode == signal.SIGKILL else ""
        return f"the worker process was killed by {name}{hint}"
    return f"the worker process exited with status {exitcode} (os._exit or a crash in user code)"


class _Slot:
    """One worker process and the task it is running."""

    def __init__(self, context: multiprocessing.context.BaseContext, initializer: Callable[[], None] | None = None):
        self.conn, child = context.Pipe()
        self.process = context.Process(target=_worker, args=(child, os.getpid(), initializer), daemon=True)
        self.process.start()
        child.close()
        self.task: int | None = None


def _stop_all(slots: list[_Slot], grace: float = 0.5, *, asked: bool = False) -> None:
    """Stop every worker: SIGTERM (finally blocks run, temporary files go), SIGKILL after *grace*.

    With *asked* the workers were already told to leave (sent ``None``): they get
    *grace* seconds to exit on their own before the signals, so a worker that is
    already on its way out is never interrupted in the middle of it.
    """
    deadline = time.monotonic() + grace
    if asked:
        for slot in slots:
            slot.process.join(max(0.0, deadline - time.monotonic()))
        deadline = time.monotonic() + 0.5
    for slot in slots:
        if slot.process.is_alive():
            slot.process.terminate()
    for slot in slots:
        slot.process.join(max(0.0, deadline - time.monotonic()))
        if slot.process.is_alive():
            slot.process.kill()
            slot.process.join(1)
        slot.conn.close()


class Workers:
    """Worker processes of this machine kept for several calls of :func:`process` (``pool=``).

    :func:`process` alone starts its workers and stops them at its end: right for one sweep or one
    batch of files, but a search calls it once per batch, and each call would fork its workers again
    and each of them would start its system afresh (importing libsumo, starting SUMO). A search keeps
    one :class:`Workers` for all its batches instead; *initializer* runs once in each worker process
    before its first task (``falsify`` passes :func:`~btgen_pytrees.systems.sumo.keep_simulations`, so a
    worker keeps its SUMO open between tasks). A worker that dies is replaced, as in :func:`process`;
    Ctrl-C stops every worker at once; :meth:`close` (or the end of a ``with`` block) lets them leave.

    Args:
        size: how many worker processes at most
        initializer: called in each worker process before its first task
    """

    def __init__(self, size: int, initializer: Callable[[], None] | None = None):
        self.size = max(1, size)
        self.initializer = initializer
        self._context = multiprocessing.get_context()
        self._slots: list[_Slot] = []

    def __enter__(self) -> "Workers":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def pids(self) -> list[int | None]:
        """The worker processes' ids (those started so far)."""
        return [slot.process.pid for slot in self._slots]

    def take(self, n: int) -> list[_Slot]:
        """*n* workers (at most :attr:`size`), started as needed; every one idle."""
        with _signals_held():  # every worker is in the list before a Ctrl-C is handled, so none is left behind
            while len(self._slots) < min(n, self.size):
                self._slots.append(_Slot(self._context, self.initializer))
        return self._slots[: min(n, self.size)]

    def replace(self, slot: _Slot) -> _Slot:
        """A new worker in *slot*'s place (it died, or its pipe broke); *slot*'s process is stopped."""
        _stop_all([slot])
        with _signals_held():
            new = _Slot(self._context, self.initializer)
        self._slots[self._slots.index(slot)] = new
        return new

    def stop(self) -> None:
        """Stop every worker now (SIGTERM, then SIGKILL): Ctrl-C."""
        slots, self._slots = self._slots, []
        _stop_all(slots)

    def close(self) -> None:
        """Ask every worker to leave, and make sure they do (again: nothing)."""
        slots, self._slots = self._slots, []
        for slot in slots:
            try:
                slot.conn.send(None)
            except OSError:
                pass
        _stop_all(slots, grace=2.0, asked=True)


def process(job: Callable[..., Outcome], jobs_args: Sequence[tuple[object, ...]], paths: Sequence[str], *,
            workers: int = 1, progress: TextIO | None = None, isolate: bool | None = None,
            on_result: Callable[[Outcome], None] | None = None, executor: Any = None,
            pool: Workers | None = None) -> list[Outcome]:  # fmt: skip
    """Run ``job(path, *args)`` for each path (``jobs_args[i]`` are path *i*'s extra arguments).

    Outcomes come back in input order whatever order the workers finish in.
    With *isolate* (default: when there are several paths) every job runs in a
    worker process, so user code that kills its process (``os._exit``, a
    signal, the out-of-memory killer) costs only its own file: that file's
    outcome is an error naming the cause, a new worker takes the next file.
    *on_result* is called in this process with each outcome as it arrives
    (the CLI writes the file's outputs there). *executor* (e.g.
    :class:`.dask.DaskExecutor`) runs the jobs instead of
    the local workers: its ``map_unordered(calls)`` yields ``(index, outcome)``
    as they finish (anything but an Outcome is recorded as an internal error).
    *pool* (a :class:`Workers`) runs the jobs in its kept workers (every job in a
    worker, even one alone) instead of workers started and stopped for this call.

    Raises:
        Interrupted: on Ctrl-C (or a signal the caller turned into
            KeyboardInterrupt) the workers are stopped at once and the
            outcomes so far are attached.
    """
    results: list[Outcome | None] = [None] * len(paths)
    done = 0

    def tick() -> None:
        if progress is not None:
            width = 30
            filled = width * done // max(1, len(paths))
            progress.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{len(paths)}")
            progress.flush()

    def so_far() -> list[Outcome]:
        return [r if r is not None else Outcome(p, ExitCode.INTERRUPTED, "not run (interrupted)", result="NOT RUN")
                for p, r in zip(paths, results)]  # fmt: skip

    def record(i: int, outcome: Outcome) -> None:
        nonlocal done
        results[i] = outcome
        if on_result is not None:
            on_result(outcome)
        done += 1
        tick()

    tick()
    if isolate is None:
        isolate = len(paths) > 1 or pool is not None
    own = pool is None
    kept = pool if pool is not None else Workers(workers)
    ended = False
    try:
        if executor is not None:  # another engine (a Dask cluster): the same guarded calls
            stream = executor.map_unordered([partial(guard, job, p, *jobs_args[i]) for i, p in enumerate(paths)])
            try:
                for i, result in stream:
                    if isinstance(result, WorkerDied):
                        record(i, died(paths[i], str(result)))
                    else:
                        ok = isinstance(result, Outcome)
                        record(i, result if ok else Outcome(paths[i], ExitCode.INTERNAL, f"internal error: {result}"))
            finally:
                stream.close()  # stopped early (Ctrl-C): the engine cancels what is left
        elif not isolate:
            for i, path in enumerate(paths):
                record(i, guard(job, path, *jobs_args[i]))
        else:
            pending = list(range(len(paths)))[::-1]  # a stack: pop() gives input order
            slots = kept.take(max(1, len(paths)))
            while done < len(paths):
                for n, slot in enumerate(slots):
                    if slot.task is None and pending:
                        task = pending.pop()
                        try:
                            slot.conn.send((task, job, paths[task], jobs_args[task]))
                            slot.task = task
                        except OSError:  # the idle worker died (killed from outside): a new one, task back
                            pending.append(task)
                            slots[n] = kept.replace(slot)
                busy = [s for s in slots if s.task is not None]
                if not busy:  # every idle worker was replaced just now: hand out the tasks again
                    continue
                ready = wait([s.conn for s in busy] + [s.process.sentinel for s in busy])
                for slot in busy:
                    if slot.conn in ready or slot.process.sentinel in ready:
                        outcome = None
                        try:
                            if slot.conn.poll():
                                index, outcome = slot.conn.recv()
                        except (EOFError, OSError):
                            pass
                        if outcome is None:  # the worker died with this task: blame it, start a new worker
                            slot.process.join(1)
                            index = slot.task
                            outcome = died(paths[index], _death(slot.process.exitcode))
                            slots[slots.index(slot)] = kept.replace(slot)
                        else:
                            slot.task = None
                        record(index, outcome)
        ended = True
    except KeyboardInterrupt as stop:
        kept.stop()
        if progress is not None:
            progress.write("\n")
        raise Interrupted(getattr(stop, "signum", signal.SIGINT), so_far()) from None
    finally:
        if own:  # normal end: ask each worker to leave, then make sure
            kept.close()
        elif not ended:  # a kept pool left mid-call (on_result raised): its busy workers' results must not reach the next call
            kept.stop()
    if progress is not None:
        progress.write("\n")
    return [r for r in results if r is not None]


def progress_stream() -> TextIO | None:
    """stderr if it is a terminal (a progress line helps there), else None (logs stay clean); None too when
    user code closed or replaced ``sys.stderr`` (``None``): the run goes on without its progress line."""
    stream = sys.stderr
    try:
        return stream if stream.isatty() else None
    except (AttributeError, ValueError, OSError):
        return None
