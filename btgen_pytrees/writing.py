"""Writing results: checked before the work, all or nothing, never over an input or a device.

Rules (docs/limits.md, "Outputs"):

* Targets are checked *before* a command does its work (:func:`check_target`):
  the directory must exist, the target must not be a directory, and it must not
  be one of the command's inputs (``run x.json --json x.json`` would replace the
  test case). Problems are :class:`OutputError`, a one-line usage error.
* A command's outputs are written together (:func:`commit`): every regular file
  is first written to a temporary file beside its target, and only when all of
  them are complete are they renamed into place. A failure (or Ctrl-C, or
  SIGTERM turned into an exception by the CLI) removes the temporary files, so
  no half-written or stray output is left.
* Two options never name one file (:func:`check_distinct`): ``--json X --junit X``
  would leave X holding one of them.
* Symbolic links are followed: the file the link points to is replaced, the link
  stays. Targets that are not regular files - ``/dev/null``, ``/dev/stdout``, a
  FIFO, anything under ``/dev`` or ``/proc`` - are written directly: renaming
  over them would replace the device (as root) or fail.
* A target that passed the checks and still cannot be written when it is made
  (a full disk, ``/dev/full``, a ``/proc`` or ``/sys`` file that refuses the
  data) is the environment's fault: :class:`WriteFailed`, a one-line message
  naming it. A command that ran something still prints its verdict and exits by
  it (``cli.terminal.deliver``); one that only writes exits 2.

The CLI's own process (:func:`divert_stdout`, :func:`pin_directory`) keeps its
standard streams and its working directory out of user code's reach: what it
prints goes through its own copies of file descriptors 1 and 2, which a plugin
closing or replacing ``sys.stdout`` cannot break, and relative output paths are
written in the directory they were checked in, wherever a plugin ``chdir``-ed.
"""

from __future__ import annotations

import os
import stat
import sys
from contextlib import contextmanager
from typing import Any, Callable, Iterable, Iterator, Sequence, TextIO, Union

from .errors import UserError, printable

__all__ = ["OutputError", "WriteFailed", "check_target", "check_distinct", "commit", "write_file", "same_file",
           "is_direct", "emit", "on_stdout", "divert_stdout", "own_stdout", "own_streams", "stdout_stream",
           "stderr_stream", "stdout_isatty", "report_outputs", "pin_directory", "at_home", "write_stdout_bytes"]  # fmt: skip

_stdout_fd: int | None = None
"""The real standard output while :func:`divert_stdout` is in force (None: not diverted)."""

_own: dict[str, TextIO] = {}
"""The CLI's own ``stdout`` and ``stderr`` streams while :func:`divert_stdout` is in force: over copies
of file descriptors 1 and 2 made before any user code ran, so user code closing or replacing
``sys.stdout``/``sys.stderr`` (or closing descriptor 1 or 2) cannot stop the verdict from being printed."""

_home: list[int] = []
"""A descriptor of the CLI's working directory while :func:`pin_directory` is in force."""


def _stream(fd: int, like: Any) -> TextIO:
    """A line-buffered text stream over *fd*, encoded like the stream *like* (``PYTHONIOENCODING`` is honoured)."""
    encoding = getattr(like, "encoding", None) or "utf-8"
    return open(fd, "w", encoding=encoding, errors="backslashreplace", buffering=1, closefd=True)  # noqa: SIM115


def stdout_stream() -> TextIO:
    """Where btgen_pytrees prints its own output: the CLI's copy of the real stdout, else ``sys.stdout``."""
    return _own.get("stdout") or sys.stdout


def stderr_stream() -> TextIO:
    """Where btgen_pytrees prints its messages: the CLI's copy of stderr, else ``sys.stderr``."""
    return _own.get("stderr") or sys.stderr


def own_streams() -> tuple[TextIO, ...]:
    """The CLI's own streams (none unless :func:`divert_stdout` ran), for flushing before the process ends."""
    return tuple(_own.values())


def _flush_user_stdout() -> None:
    """Write out what user code left in ``sys.stdout``'s buffer (it goes to stderr); user code may have closed
    or replaced it: nothing to do then."""
    try:
        sys.stdout.flush()
    except (OSError, ValueError, AttributeError):
        pass


def _lost(name: str) -> None:
    """The CLI's own stream *name* failed (a full device, a reader gone): close it, dropping what it holds
    (so the process's end does not try again and print a traceback), and write nothing more there."""
    stream = _own.get(name)
    if stream is None:
        return
    try:
        stream.close()
    except (OSError, ValueError):
        pass
    _own[name] = open(os.devnull, "w", encoding="utf-8")  # noqa: SIM115 - lives as long as the process


def pin_directory() -> None:
    """Remember the working directory: the CLI's process calls this before any user code runs, so relative
    output paths are written (:func:`commit`) where they were checked, whatever directory user code moved to."""
    if not _home:
        _home.append(os.open(".", os.O_RDONLY))


def at_home() -> None:
    """Back in the directory :func:`pin_directory` remembered (a no-op unless it ran): user code may have
    changed directory (at import, in ``register()``, in a leaf) since the command checked its paths."""
    if _home:
        os.fchdir(_home[0])


def divert_stdout() -> None:
    """Send file descriptor 1 to stderr for good; btgen_pytrees's own output reaches stdout through :func:`own_stdout`.

    For the CLI's process only (it owns its file descriptors; the library never
    calls this): whatever user code prints - a plugin at import, a leaf, a
    system, C code, a worker process forked later - goes to stderr, so a
    document on stdout (``show -f json``, ``run --json -``) is never mixed with it.
    """
    global _stdout_fd
    if _stdout_fd is not None:
        return
    sys.stdout.flush()
    _stdout_fd = os.dup(1)
    _own["stdout"] = _stream(os.dup(1), sys.stdout)
    _own["stderr"] = _stream(os.dup(2), sys.stderr)
    os.dup2(2, 1)


@contextmanager
def own_stdout() -> Iterator[None]:
    """File descriptor 1 is the real stdout for the duration (see :func:`divert_stdout`); no-op when not diverted."""
    if _stdout_fd is None:
        yield
        return
    _flush_user_stdout()
    os.dup2(_stdout_fd, 1)
    try:
        yield
    finally:
        try:
            _flush_user_stdout()
        finally:
            os.dup2(2, 1)


def stdout_isatty() -> bool:
    """Whether the real standard output is a terminal (diverted or not)."""
    try:
        return os.isatty(_stdout_fd) if _stdout_fd is not None else sys.stdout.isatty()
    except (OSError, ValueError):
        return False


def emit(text: str, stream: TextIO | None = None) -> None:
    """Print *text* with every unsafe character escaped (see :func:`~.errors.printable`); default: stdout.

    Characters the stream cannot encode become ``\\xNN``-style replacements rather
    than an exception (non-UTF-8 file names, a C locale).
    """
    target = stream or stdout_stream()
    safe = printable(text, keep_newlines=True)
    encoding = getattr(target, "encoding", None) or "utf-8"
    try:
        safe.encode(encoding)
    except (UnicodeEncodeError, LookupError):
        safe = safe.encode(encoding, "backslashreplace").decode(encoding, "replace")
    if stream is None:
        with _printing("-", "stdout"):
            target.write(safe)
            target.flush()
    else:
        with _printing(None, "stderr" if target is _own.get("stderr") else ""):
            target.write(safe)


@contextmanager
def _printing(path: str | None, name: str) -> Iterator[None]:
    """Writing to the CLI's stream *name*: a failure drops the stream (:func:`_lost`); on stdout (*path* ``-``) it
    is :class:`WriteFailed` (a reader gone is still ``BrokenPipeError``), on stderr it is ignored (nowhere is
    left to say it)."""
    try:
        yield
    except OSError as exc:
        if name:
            _lost(name)
        if path is None:
            return
        if isinstance(exc, BrokenPipeError):
            raise
        raise WriteFailed(path, exc) from None


class OutputError(UserError, ValueError):
    """An output path that cannot be used; ``str()`` is one line for the user (exit 2)."""


class WriteFailed(OutputError, OSError):
    """An output that passed the checks and could not be written when it was made: a full disk or device,
    a ``/proc`` or ``/sys`` file that refuses the data. ``path``: the output (``-``: standard output)."""

    def __init__(self, path: str, error: OSError):
        shown = "standard output" if path == "-" else printable(path)
        super().__init__(f"{shown}: cannot write: {error.strerror or error}")
        self.path = path


def is_direct(path: str) -> bool:
    """Whether *path* must be written in place: stdout (``-``), a device or a FIFO, ``/dev`` or ``/proc``."""
    if path == "-":
        return True
    absolute = os.path.abspath(path)
    if absolute.startswith(("/dev/", "/proc/")):
        return True
    try:
        return not stat.S_ISREG(os.stat(path).st_mode)
    except OSError:
        return False


def same_file(a: str, b: str) -> bool:
    """Whether paths *a* and *b* name the same existing file (hard links and symlinks included)."""
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return False


def check_target(path: str, option: str, inputs: Sequence[str] = (), *, made_later: bool = False) -> None:
    """Raise :class:`OutputError` unless *path* can be written by this command.

    Args:
        path: the output path as given
        option: the option that named it (``--json``), for the message
        inputs: the command's input files; writing over one of them is refused
        made_later: its directory is made by the command (``--out-dir``): only
            check it if it exists already
    """
    if path == "-":
        return
    for source in inputs:
        if same_file(path, source):
            raise OutputError(f"{option} {path}: is one of the input files; refusing to overwrite it")
    if is_direct(path):
        if os.path.isdir(path):
            raise OutputError(f"{option} {path}: is a directory; give a file name")
        return
    real = os.path.realpath(path)
    if os.path.isdir(real):
        raise OutputError(f"{option} {path}: is a directory; give a file name")
    parent = os.path.dirname(real) or "."
    if made_later and not os.path.exists(parent):
        return
    if not os.path.isdir(parent):
        raise OutputError(f"{option} {path}: directory {os.path.dirname(path) or '.'} does not exist")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputError(f"{option} {path}: directory {os.path.dirname(path) or '.'} is not writable")
    if os.path.exists(real) and not os.access(real, os.W_OK):
        raise OutputError(f"{option} {path}: file is not writable")


_STDOUT_NAMES = ("/dev/stdout", "/dev/fd/1", "/proc/self/fd/1")


def _one_file(a: str, b: str) -> bool:
    def stdout(path: str) -> bool:
        return path == "-" or os.path.abspath(path) in _STDOUT_NAMES

    if stdout(a) or stdout(b):
        return stdout(a) and stdout(b)
    return os.path.realpath(a) == os.path.realpath(b) or same_file(a, b)


def on_stdout(paths: Iterable[str | None]) -> bool:
    """Whether one of *paths* is standard output (``-``, ``/dev/stdout``): then stdout carries that document
    only, and the command's table goes to stderr."""
    return any(path and _one_file(path, "-") for path in paths)


def check_distinct(targets: Iterable[tuple[str, str | None]]) -> None:
    """Raise :class:`OutputError` when two ``(option, path)`` name one file.

    Symlinks and hard links count, and ``-`` is ``/dev/stdout`` (two documents on
    stdout cannot be read back). ``/dev/null`` may be named any number of times.
    """
    seen: list[tuple[str, str]] = []
    for option, path in targets:
        if not path:
            continue
        if path != "-" and os.path.abspath(path) == os.devnull:
            continue
        for other_option, other in seen:
            if _one_file(path, other):
                raise OutputError(f"{other_option} {other} and {option} {path}: the same file; give each output its own")
        seen.append((option, path))


Data = Union[str, bytes, Iterable[Union[str, bytes]]]
"""What :func:`commit` writes to a path: text, bytes, or an iterable of chunks of either
(:func:`~.render.render_chunks`), taken one at a time while they are written."""


def _encoded(data: str | bytes) -> bytes:
    return data if isinstance(data, bytes) else data.encode("utf-8", "surrogateescape")


def _chunks(data: Data) -> Iterator[bytes]:
    if isinstance(data, (str, bytes)):
        yield _encoded(data)
    else:
        for chunk in data:
            yield _encoded(chunk)


def _write_direct(path: str, data: Data) -> None:
    with open(path, "wb") as fh:
        for chunk in _chunks(data):
            fh.write(chunk)


def write_stdout_bytes(data: Data) -> None:
    """*data* on the real standard output, as bytes (:class:`WriteFailed` if it cannot take them)."""
    out = stdout_stream()
    with _printing("-", "stdout" if out is _own.get("stdout") else ""):
        out.flush()
        for chunk in _chunks(data):
            out.buffer.write(chunk)
            out.buffer.flush()


def report_outputs(report: Any, json: str | None = None, junit: str | None = None, plot: str | None = None,
                   draw: Callable[[], bytes | str] | None = None) -> list[tuple[str, str | bytes]]:
    """The ``--json``, ``--junit`` and ``--plot`` outputs of *report* (anything with ``to_json()`` and
    ``to_junit()``: a run's report, a sweep's) as ``(target, data)`` pairs for :func:`commit`, in that order;
    a target that is None is not made. *draw* makes the picture written to *plot*."""
    outputs: list[tuple[str, str | bytes]] = []
    if json:
        outputs.append((json, report.to_json()))
    if junit:
        outputs.append((junit, report.to_junit()))
    if plot and draw is not None:
        outputs.append((plot, draw()))
    return outputs


def commit(outputs: Iterable[tuple[str, Data]]) -> list[str]:
    """Write every ``(path, data)`` together: all regular targets appear, or none changes.

    Text is written as UTF-8 with ``\\n`` line ends. Returns the paths written.

    *data* may be an iterable of chunks: each is written as soon as it is
    made, into the temporary file of a regular target (renamed only once all
    are complete, as above). A target written in place (stdout, a device)
    cannot be taken back: it is written after every regular target is in
    place, chunk by chunk when only such targets are given; with regular
    targets beside it its chunks are first all made, so that a failure while
    making them still leaves no output changed.
    """
    outputs = list(outputs)
    at_home()  # relative paths: where they were checked
    in_place_only = all(is_direct(path) for path, _ in outputs)
    staged: list[tuple[str, str]] = []  # (tmp, final)
    direct: list[tuple[str, Data]] = []
    try:
        for path, data in outputs:
            if is_direct(path):
                direct.append((path, data if in_place_only else b"".join(_chunks(data))))
                continue
            final = os.path.realpath(path)  # follow a symlink: replace what it points to, keep the link
            tmp = f"{final}.tmp{os.getpid()}"
            staged.append((tmp, final))
            try:
                with open(tmp, "wb") as fh:
                    for chunk in _chunks(data):
                        fh.write(chunk)
            except OSError as exc:  # a full disk: the environment's fault, named
                raise WriteFailed(path, exc) from None
        for tmp, final in staged:
            os.replace(tmp, final)
        for path, data in direct:
            if path == "-":
                write_stdout_bytes(data)
                continue
            try:
                with own_stdout():  # /dev/stdout is the real stdout
                    _write_direct(path, data)
            except BrokenPipeError:
                raise
            except OSError as exc:  # /dev/full, a /proc or /sys file that refuses the data
                raise WriteFailed(path, exc) from None
    finally:
        for tmp, _ in staged:
            if os.path.lexists(tmp):
                os.unlink(tmp)
    return [path for path, _ in [*((f, b"") for _, f in staged), *direct]]


def write_file(path: str, data: Data) -> None:
    """Write *data* (text as UTF-8 with ``\\n`` line ends, bytes, or chunks of either) to *path*: see :func:`commit`."""
    commit([(path, data)])
