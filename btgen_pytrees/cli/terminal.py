"""Printing safely to a terminal: every text btgen_pytrees prints goes through here or :func:`~btgen_pytrees.writing.emit`."""

from __future__ import annotations

from typing import Iterable, Sequence, TextIO

from ..errors import MAX_PROBLEMS, UNSAFE, ExitCode, InvalidTestCase, plural, printable
from ..writing import Data, WriteFailed, commit, emit, on_stdout, stderr_stream, write_stdout_bytes
from ..parallel import Outcome

__all__ = ["can_encode", "deliver", "err", "report_invalid", "problems", "stdout_text", "write_stdout"]


def can_encode(stream: TextIO, text: str = "·…") -> bool:
    try:
        text.encode(getattr(stream, "encoding", None) or "ascii")
        return True
    except (UnicodeEncodeError, LookupError):
        return False


def err(text: str) -> None:
    """One line on stderr, escaped (:func:`~btgen_pytrees.writing.emit`)."""
    emit(text + "\n", stderr_stream())


def deliver(outputs: Sequence[tuple[str, Data]], text: str, code: int) -> int:
    """Write a command's *outputs* together (:func:`~btgen_pytrees.writing.commit`), then print *text* (its
    verdict table or summary: on stdout, on stderr when an output is stdout); return *code*, the verdict's.

    An output that cannot be written when it is made - a full disk, ``/dev/full``, a ``/proc`` or ``/sys``
    file that refuses the data, stdout itself - is the environment's fault: the verdict is printed all the
    same, one line names the output that failed, and the exit code stays the verdict's, never 3
    (docs/limits.md, "Outputs"). A reader of stdout that went away (``| head``) only ends the printing.
    """
    failed: list[WriteFailed] = []
    try:
        commit(outputs)
    except WriteFailed as exc:
        failed.append(exc)
    except BrokenPipeError:
        pass
    try:
        emit(text, stderr_stream() if on_stdout(t for t, _ in outputs) else None)
    except WriteFailed as exc:
        failed.append(exc)
    except BrokenPipeError:
        pass
    for problem in failed:
        err(f"btgen_pytrees: {problem}")
    return code


def report_invalid(error: InvalidTestCase) -> int:
    """An invalid test case's problems on stderr, a line each (at most :data:`~btgen_pytrees.errors.MAX_PROBLEMS`)."""
    found = error.problems
    for problem in found[:MAX_PROBLEMS]:
        err(problem.render(error.source))
    if len(found) > MAX_PROBLEMS:
        err(f"{error.source}: … and {plural(len(found) - MAX_PROBLEMS, 'more problem')}")
    return ExitCode.INVALID


def problems(outcome: Outcome, quiet: bool = False) -> None:
    """A file's problems on stderr, then its warnings (capped where they were made) unless *quiet*."""
    for line in outcome.problems[: MAX_PROBLEMS + 1]:
        err(line)
    for line in [] if quiet else outcome.warnings:
        err(line)


def stdout_text(text: str, fmt: str) -> str:
    """A view's text made safe for a terminal without breaking its syntax.

    JSON gets ``\\uNNNN`` escapes (still valid JSON), XML/SVG character
    references, everything else the ``\\xNN`` escapes of :func:`printable`.
    """
    if fmt == "json":
        return UNSAFE.sub(lambda m: m.group() if m.group() == "\n" else f"\\u{ord(m.group()):04x}", text)
    if fmt in ("btcpp", "svg"):
        return UNSAFE.sub(lambda m: m.group() if m.group() == "\n" else f"&#x{ord(m.group()):x};", text)
    return printable(text, keep_newlines=True)


def write_stdout(data: str | bytes | Iterable[str | bytes], fmt: str) -> None:
    """Write a view to stdout: text escaped for a terminal (:func:`stdout_text`), bytes as they are.

    Chunks (:func:`~btgen_pytrees.render.render_chunks`) are written one by one as they are
    made, so a large tree's view starts at once and is never held whole; the
    escaping works character by character, so chunking does not change it.
    """
    for chunk in [data] if isinstance(data, (str, bytes)) else data:
        if isinstance(chunk, bytes):
            write_stdout_bytes(chunk)
        else:
            emit(stdout_text(chunk, fmt))
