"""Reading a test-case file within the limits, and strict JSON: no duplicate keys, no NaN, bounded nesting."""

from __future__ import annotations

import json
import os
import re
import stat
import sys
from typing import Any, Callable, Iterable, Iterator, Protocol

from ..errors import InvalidTestCase, Problem
from ..model import DEFAULT_JOIN
from ..openscenario import is_openscenario, read_openscenario
from ..text import shorten
from .limits import MAX_FILE_BYTES

__all__ = ["DuplicateKey", "no_duplicates", "reject_constant", "load_json", "read_file", "parse_json", "NotStreamed", "stream"]

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
    """Read a JSON file with the limits of a test case; problems raise :class:`InvalidTestCase`.

    An OpenSCENARIO file (``.xosc``) is read as the test-case document it converts to
    (:func:`btgen_pytrees.openscenario.read_openscenario`): every command reads case files here,
    so each takes ``.xosc`` as it takes ``.json``."""
    if is_openscenario(path):
        return read_openscenario(os.fspath(path))
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



# ---------------------------------------------------------------------------
# reading the execute array entry by entry
#
# A reading choice, not a rule set: the top-level object is read key by key with the json
# module's own scanner (the one json.loads uses, with the same duplicate-key hook and constants
# rule), and the execute array element by element, each item handed to the entry loop as soon as
# it is read (its parsed dict is then freed: on a 100,000-entry timeline the parsed document's
# containers made the cyclic garbage collector's full collections the largest cost of loading).
# Whatever this reader does not accept (invalid JSON, a duplicate key, a trailing comma, extra
# data, a key written twice in an entry) raises NotStreamed: the caller reads the text whole with
# parse_json, which says what is wrong, or accepts it.


class NotStreamed(Exception):
    """The text cannot be read entry by entry: read it whole (:func:`parse_json`)."""


class EntrySink(Protocol):
    """What :func:`stream` feeds: the entry loop (:class:`btgen_pytrees.load.entries.Entries`)."""

    default_join: Any
    join_known: bool
    count_keys: bool
    keys: int

    def add_all(self, items: Iterable[Any]) -> None: ...


_WHITESPACE = re.compile(r"[ \t\n\r]*")  # what json's scanner skips between tokens
_SPACE = " \t\n\r"
_SPACED_KEY = re.compile(r'"[ \t\n\r]+:')  # a string, white space, a colon: a key written "key" : value


def stream(raw: bytes | str, sink: EntrySink) -> dict[str, Any]:
    """Parse the top-level object of *raw*, feeding ``execute``'s items to *sink* one by one.

    Returns the top-level dict with ``execute`` mapped to ``None`` (its entries went to the
    sink). Raises :class:`NotStreamed` for anything ``json.loads`` might reject or this reader
    does not handle; what *sink* raises passes through.
    """
    try:
        text = raw.decode("utf-8-sig") if isinstance(raw, bytes) else raw
        return _stream(text, sink)
    except (ValueError, RecursionError, StopIteration, IndexError):
        # not JSON the whole reader accepts (ValueError: invalid JSON, a duplicate key, NaN): it says why
        raise NotStreamed from None


def _stream(text: str, sink: EntrySink) -> dict[str, Any]:
    scan = _scanner()
    skip = _WHITESPACE.match
    end = len(text)
    i = skip(text, 0).end()
    if text[i : i + 1] != "{":
        raise NotStreamed
    top: dict[str, Any] = {}
    i = skip(text, i + 1).end()
    if text[i : i + 1] == "}":
        raise NotStreamed  # {} is not a test case
    while True:
        if text[i : i + 1] != '"':
            raise NotStreamed
        key, i = scan(text, i)
        i = skip(text, i).end()
        if text[i : i + 1] != ":" or key in top:
            raise NotStreamed
        i = skip(text, i + 1).end()
        if key == "execute" and text[i : i + 1] == "[":
            sink.default_join = top.get("join", DEFAULT_JOIN)
            sink.join_known = "join" in top
            start, stop = i, []
            if _SPACED_KEY.search(text, i) is None:  # every key is written "key": - count them instead of hooking
                sink.count_keys = True
                sink.add_all(_items(text, skip(text, i + 1).end(), _scanner(hook=False), skip, stop))
                i = stop[0]
                if text.count('":', start, i) != sink.keys:
                    raise NotStreamed  # a key twice in one object (or '":' inside a string): the whole reader decides
            else:
                sink.add_all(_items(text, skip(text, i + 1).end(), scan, skip, stop))
                i = stop[0]
            top[key] = None
        else:
            top[key], i = scan(text, i)
        i = skip(text, i).end()
        c = text[i : i + 1]
        if c == "}":
            break
        if c != ",":
            raise NotStreamed
        i = skip(text, i + 1).end()
    if skip(text, i + 1).end() != end:
        raise NotStreamed  # extra data after the object
    return top


def _items(text: str, i: int, scan: Callable[[str, int], Any], skip: Callable[..., Any], end: list[int]) -> Iterator[Any]:
    """The items of the array whose first item starts at *i*; *end* receives the index after its ``]``."""
    if text[i] == "]":
        end.append(i + 1)
        return
    while True:
        try:
            raw, i = scan(text, i)
        except StopIteration:  # no value here (inside a generator it would become a RuntimeError)
            raise NotStreamed from None
        yield raw
        c = text[i]
        if c in _SPACE:
            i = skip(text, i).end()
            c = text[i]
        if c == ",":
            i += 1
            if text[i] in _SPACE:
                i = skip(text, i).end()
        elif c == "]":
            end.append(i + 1)
            return
        else:
            raise NotStreamed


def _scanner(hook: bool = True) -> Callable[[str, int], Any]:
    """``json.loads``' scanner with this module's hooks: ``scan(text, index) -> (value, end)``.

    A new one per document: the scanner keeps a memo of keys between the hook's calls.
    Without *hook*, objects are built in C and a key written twice is not detected:
    the entries are read so (the duplicate-key hook was a third of reading them) and
    their keys counted instead. Where no key is followed by white space before its
    colon, every key written ends in ``":``, so the execute array holds at least as
    many ``":`` as keys written; when that count equals the number of keys of the
    dicts read (the sink's ``keys``), no object had a key twice.
    """
    if not hook:
        return json.JSONDecoder(parse_constant=reject_constant).scan_once
    return json.JSONDecoder(object_pairs_hook=no_duplicates, parse_constant=reject_constant).scan_once
