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
import signal
import sys
from typing import Any, Callable, NoReturn

from .errors import ExitCode
from .writing import own_streams

__all__ = ["supervised", "STOP_GRACE"]

STOP_GRACE = 2.0
"""Seconds a supervised command has to stop after SIGINT/SIGTERM (its own workers get half a second
of them) before it is killed: user code may ignore the signals."""


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
    on_error(f"btgen_pytrees: error: the command's process {_death(status)} before giving a verdict (user code - "
             "a plugin, a leaf or a system - ended it, e.g. with os._exit); nothing it did counts")  # fmt: skip
    return ExitCode.FAIL
