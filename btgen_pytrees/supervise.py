"""No verdict, no exit 0: the CLI runs a command that loads user code in a child process it watches.

User code - a plugin at import or in ``register()``, a leaf, a system - can end
its process with any status it likes: ``os._exit(0)`` cannot be caught, and a
CI server would take the 0 for "every test passed". So when user code may be
loaded, the CLI process forks; the child runs the command as usual (same
standard streams, its own worker processes) and, when it has its exit code,
hands it to the parent through a pipe before it exits. The parent never imports
user code and exits only with a code it was handed: a child that ended without
handing one over is reported as an error (exit 1, like a batch file whose worker
died).

The pytest plugin runs each test case the same way (:func:`in_child`): the run
in a forked child that hands its result back, an item whose child ended without
handing it over failing with the same line.

Signals: Ctrl-C reaches both processes (the terminal signals its whole
process group) and a SIGINT or SIGTERM sent to the parent alone is passed on
to the child, which stops as it always does (130/143). User code can ignore
both signals (``signal.signal(SIGTERM, SIG_IGN)``), so the parent escalates as a
batch does with its workers: a child still running :data:`STOP_GRACE` seconds
after the first signal is killed (SIGKILL), and the command ends with 130/143 all
the same. A child whose parent is gone (killed by user code, or from outside)
has no one to hand its code to: it stops quietly. For the CLI's process only;
the library never forks.
"""

from __future__ import annotations

import atexit
import os
import select
import signal
import sys
import time
from typing import Any, Callable, NoReturn

from .errors import ExitCode
from .writing import own_streams

__all__ = ["supervised", "STOP_GRACE", "in_child", "ChildLost", "LOST"]

STOP_GRACE = 2.0
"""Seconds a supervised command has to stop after SIGINT/SIGTERM (its own workers get half a second
of them) before it is killed: user code may ignore the signals. A pytest item's child, the same."""

LOST = ("before giving a verdict (user code - a plugin, a leaf or a system - ended it, e.g. with os._exit); "
        "nothing it did counts")
"""What the CLI and the pytest plugin say of a child that ended without handing over its result."""


class ChildLost(Exception):
    """The child of :func:`in_child` ended without handing back its result; ``str()`` says how it ended
    (``exited with status 0``, ``was killed by SIGSEGV``)."""


def _death(status: int) -> str:
    if os.WIFSIGNALED(status):
        signum = os.WTERMSIG(status)
        try:
            name = signal.Signals(signum).name
        except ValueError:
            name = f"signal {signum}"
        return f"was killed by {name}"
    return f"exited with status {os.waitstatus_to_exitcode(status)}"


def _die_with_parent() -> None:
    """Linux: SIGTERM this process if the parent dies (killed with SIGKILL), so nothing runs on unwatched."""
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # pragma: no cover - no libc prctl
        pass


def _leave(code: int) -> NoReturn:
    """End the child once its code is handed over: its ``atexit`` handlers (user code's too) run and its
    buffered output is written, but not the interpreter's teardown - the parent does one already, and two
    in a row cost a second on a loaded machine."""
    try:
        atexit._run_exitfuncs()
    finally:
        for stream in (sys.stdout, sys.stderr, *own_streams()):
            try:
                stream.flush()
            except (OSError, ValueError, AttributeError):  # closed or replaced by user code (None), a full disk
                pass
        os._exit(code)


def supervised(work: Callable[[], int], on_error: Callable[[str], None]) -> int:
    """Run *work* in a forked child and return the code it returns.

    Only a code the child hands over counts: if the child ends without one
    (``os._exit``, a crash, killed), *on_error* gets one line saying so and the
    result is ``ExitCode.FAIL``, as for a verdict ``error`` (``128 + signum`` when SIGINT or SIGTERM
    killed it, with the line the command itself prints then). In the child this
    function does not return: once the code is handed over, the child's ``atexit``
    handlers run, its buffers are written and it exits with that code.
    """
    for stream in (sys.stdout, sys.stderr):
        stream.flush()
    parent = os.getpid()
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: the command itself
        os.close(read_end)
        _die_with_parent()
        if os.getppid() != parent:  # the parent died before prctl took effect
            os._exit(ExitCode.FAIL)
        code: int = ExitCode.FAIL
        try:
            code = work()
        finally:
            try:
                os.write(write_end, bytes([code & 0xFF]))
            except OSError:  # the parent is gone (user code killed it): no one waits for the code
                pass
            finally:
                os.close(write_end)
        _leave(code)
    os.close(write_end)
    stopping: list[int] = []

    def forward(signum: int, frame: Any) -> None:
        if not stopping:  # the first signal starts the grace period (ITIMER_REAL: SIGALRM when it ends)
            stopping.append(signum)
            signal.setitimer(signal.ITIMER_REAL, STOP_GRACE)
        try:
            os.kill(pid, signum)
        except ProcessLookupError:
            pass

    def kill(signum: int, frame: Any) -> None:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass

    previous = {s: signal.signal(s, forward) for s in (signal.SIGINT, signal.SIGTERM)}
    previous[signal.SIGALRM] = signal.signal(signal.SIGALRM, kill)
    try:
        _, status = os.waitpid(pid, 0)  # EINTR is retried (PEP 475) after forward() ran
        os.set_blocking(read_end, False)
        try:
            handed = os.read(read_end, 1)
        except BlockingIOError:  # a grandchild still holds the pipe open, and nothing was written
            handed = b""
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        os.close(read_end)
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    if handed:
        return handed[0]
    if stopping and os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGKILL:  # killed after the grace period
        on_error(f"btgen_pytrees: interrupted by {signal.Signals(stopping[0]).name} (the command did not stop within "
                 f"{STOP_GRACE:g} s - user code ignores the signal - and was killed)")  # fmt: skip
        return 128 + stopping[0]
    if os.WIFSIGNALED(status) and os.WTERMSIG(status) in (signal.SIGINT, signal.SIGTERM):  # before its handlers
        on_error(f"btgen_pytrees: interrupted by {signal.Signals(os.WTERMSIG(status)).name}")
        return 128 + os.WTERMSIG(status)
    on_error(f"btgen_pytrees: error: the command's process {_death(status)} {LOST}")
    return ExitCode.FAIL


def _flush() -> None:
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError, AttributeError):  # closed or replaced by user code (None), a full disk
            pass


def _stop(pid: int) -> None:
    """End child *pid* and reap it: SIGTERM, :data:`STOP_GRACE` seconds, then SIGKILL."""
    try:
        os.kill(pid, signal.SIGTERM)
        deadline = time.monotonic() + STOP_GRACE
        while time.monotonic() < deadline:
            if os.waitpid(pid, os.WNOHANG)[0]:
                return
            time.sleep(0.01)
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
    except ChildProcessError:  # already reaped
        pass
    except ProcessLookupError:
        os.waitpid(pid, 0)


def _collect(read_end: int, pid: int) -> tuple[bytes, int]:
    """What child *pid* wrote to *read_end*, and its wait status, once it has ended. A grandchild still
    holding the pipe open does not keep this waiting: the child's end is checked every 0.1 s."""
    chunks: list[bytes] = []
    while True:
        if select.select([read_end], [], [], 0.1)[0]:
            chunk = os.read(read_end, 1 << 16)
            if chunk:
                chunks.append(chunk)
                continue
            return b"".join(chunks), os.waitpid(pid, 0)[1]  # every writer closed the pipe
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            os.set_blocking(read_end, False)
            try:
                while chunk := os.read(read_end, 1 << 16):
                    chunks.append(chunk)
            except BlockingIOError:
                pass
            return b"".join(chunks), status


def in_child(work: Callable[[], bytes]) -> bytes:
    """Run *work* in a forked child and return the bytes it returns; :class:`ChildLost` if the child ends
    without handing them back whole (``os._exit``, a crash, killed).

    The child runs nothing else: once its bytes are handed over it ends at once (``os._exit``), with
    neither the ``atexit`` handlers nor the teardown of the process it is a copy of - they belong to the
    parent. *work* should return its errors as bytes too: one it raises ends the child unheard. An
    exception in the parent while it waits (Ctrl-C) stops the child (SIGTERM, then SIGKILL after
    :data:`STOP_GRACE` seconds) before it propagates. Needs ``os.fork`` (POSIX).
    """
    _flush()
    parent = os.getpid()
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child
        status = ExitCode.FAIL
        try:
            os.close(read_end)
            _die_with_parent()
            if os.getppid() == parent:  # else the parent died before prctl took effect
                payload = work()
                view = memoryview(len(payload).to_bytes(8, "big") + payload)
                while view:
                    view = view[os.write(write_end, view):]
                status = 0
        finally:
            _flush()
            os._exit(status)
    os.close(write_end)
    try:
        data, status = _collect(read_end, pid)
    except BaseException:
        _stop(pid)
        raise
    finally:
        os.close(read_end)
    if len(data) >= 8 and int.from_bytes(data[:8], "big") == len(data) - 8:
        return data[8:]
    raise ChildLost(_death(status))
