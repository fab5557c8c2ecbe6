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
* Symbolic links are followed: the file the link points to is replaced, the link
  stays. Targets that are not regular files - ``/dev/null``, ``/dev/stdout``, a
  FIFO, anything under ``/dev`` or ``/proc`` - are written directly: renaming
  over them would replace the device (as root) or fail.
"""

from __future__ import annotations

import os
import stat
from typing import Iterable, Iterator, Sequence, Union

__all__ = ["OutputError", "check_target", "commit", "write_file", "same_file", "is_direct"]


class OutputError(ValueError):
    """An output path that cannot be used; ``str()`` is one line for the user (exit 2)."""


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


def _write_stdout(data: Data) -> None:
    import sys

    sys.stdout.flush()
    for chunk in _chunks(data):
        sys.stdout.buffer.write(chunk)
        sys.stdout.buffer.flush()


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
            with open(tmp, "wb") as fh:
                for chunk in _chunks(data):
                    fh.write(chunk)
        for tmp, final in staged:
            os.replace(tmp, final)
        for path, data in direct:
            if path == "-":
                _write_stdout(data)
            else:
                _write_direct(path, data)
    finally:
        for tmp, _ in staged:
            if os.path.lexists(tmp):
                os.unlink(tmp)
    return [path for path, _ in [*((f, b"") for _, f in staged), *direct]]


def write_file(path: str, data: Data) -> None:
    """Write *data* (text as UTF-8 with ``\\n`` line ends, bytes, or chunks of either) to *path*: see :func:`commit`."""
    commit([(path, data)])
