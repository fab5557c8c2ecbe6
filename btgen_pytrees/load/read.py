"""Reading a test-case file within the limits, and strict JSON: no duplicate keys, no NaN, bounded nesting."""

from __future__ import annotations

import json
import os
import stat
import sys
from typing import Any

from ..errors import InvalidTestCase, Problem
from ..text import shorten
from .limits import MAX_FILE_BYTES

__all__ = ["DuplicateKey", "no_duplicates", "reject_constant", "load_json", "read_file", "parse_json"]

class DuplicateKey(ValueError):
    pass


def no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    obj = dict(pairs)  # in C; a key seen twice makes the dict shorter than the pairs
    if len(obj) != len(pairs):
        seen: set[str] = set()
        for key, _ in pairs:
            if key in seen:
                raise DuplicateKey(key)
            seen.add(key)
    return obj


def reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not valid JSON")


def load_json(path: str | os.PathLike[str]) -> Any:
    """Read a JSON file with the limits of a test case; problems raise :class:`InvalidTestCase`."""
    return parse_json(*read_file(path))


def read_file(path: str | os.PathLike[str]) -> tuple[bytes, str]:
    """The bytes of a test-case file (``-``: standard input) within the size limit, and its name for errors."""
    source = os.fspath(path)
    if source == "-":  # standard input, read up to the limit
        raw = sys.stdin.buffer.read(MAX_FILE_BYTES + 1)
        source = "<stdin>"
    else:
        try:
            info = os.stat(source)
            if not stat.S_ISREG(info.st_mode):
                # a FIFO or socket would wait for a writer, a terminal (/dev/ptmx, /dev/tty) for a
                # person, a device (/dev/zero, /dev/urandom) never ends: only regular files are read
                kind = "a directory" if stat.S_ISDIR(info.st_mode) else "a pipe or socket" if (
                    stat.S_ISFIFO(info.st_mode) or stat.S_ISSOCK(info.st_mode)) else "a device"  # fmt: skip
                raise InvalidTestCase([Problem((), f"not a regular file ({kind})", "json")], source)
            size = info.st_size
            if size > MAX_FILE_BYTES:
                raise InvalidTestCase([Problem((), f"file is {size} bytes; the limit is {MAX_FILE_BYTES}", "limit")], source)
            with open(source, "rb") as fh:
                raw = fh.read(size + 1)
                if len(raw) > size:  # it grew since stat(): read on, up to the limit
                    raw += fh.read(MAX_FILE_BYTES + 1 - len(raw))
        except OSError as exc:
            why = exc.strerror or str(exc)
            if os.path.islink(source) and not os.path.exists(source):
                why = f"dangling symbolic link to {os.readlink(source)}"
            raise InvalidTestCase([Problem((), f"cannot read file: {why}", "json")], source) from None
    if len(raw) > MAX_FILE_BYTES:  # the file grew while we looked
        raise InvalidTestCase([Problem((), f"file is larger than {MAX_FILE_BYTES} bytes", "limit")], source)
    return raw, source


def parse_json(raw: bytes | str, source: str = "<string>") -> Any:
    """Parse JSON text strictly: no NaN/Infinity, no duplicate keys, bounded nesting."""
    def fail(message: str) -> InvalidTestCase:
        return InvalidTestCase([Problem((), message, "json")], source)

    try:
        text = raw.decode("utf-8-sig") if isinstance(raw, bytes) else raw
    except UnicodeDecodeError as exc:
        raise fail(f"not UTF-8 text (byte {exc.start})") from None
    try:
        return json.loads(text, object_pairs_hook=no_duplicates, parse_constant=reject_constant)
    except json.JSONDecodeError as exc:
        raise fail(f"invalid JSON at line {exc.lineno} column {exc.colno}: {exc.msg}") from None
    except DuplicateKey as exc:
        raise fail(f"invalid JSON: key {exc.args[0]!r} appears twice in one object") from None
    except RecursionError:
        raise fail("invalid JSON: nested too deeply") from None
    except ValueError as exc:  # NaN/Infinity, integers with too many digits
        raise fail(f"invalid JSON: {shorten(str(exc))}") from None

