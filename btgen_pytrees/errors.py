"""Errors as data.

Like :mod:`jsonschema`, the loader does not stop at the first problem and does not
format messages itself: every problem is a :class:`Problem` (a JSON path, a
message and the check that found it) and the caller decides how to show them.
The CLI renders each as ``FILE: /json/pointer: message``.

>>> p = Problem(("execute", 3, "after", 0), "unknown id 'B9'", "graph")
>>> p.pointer
'/execute/3/after/0'
>>> str(InvalidTestCase([p], source="t.json"))
"t.json: /execute/3/after/0: unknown id 'B9'"
"""

from __future__ import annotations

import enum
import re
import signal
from dataclasses import dataclass
from typing import Any, Iterable, Union

from .text import MAX_MESSAGE, shorten

__all__ = ["Problem", "by_place", "UserError", "UsageError", "InvalidTestCase", "ExitCode", "Interrupt", "is_interrupt", "pointer", "plural", "printable", "shorten", "xml_safe", "MAX_PROBLEMS", "MAX_MESSAGE", "MAX_LINE"]

PathPart = Union[str, int]


class ExitCode(enum.IntEnum):
    """The exit codes of the command line, and the code of each file of a batch (the worst one wins).

    docs/limits.md says what each one means. They print as their numbers (``str``, f-strings, JSON).
    """

    OK = 0
    """Success (``run``: every test passed)."""
    FAIL = 1
    """A run failed, timed out or ended in ``error`` (user code raised, or killed its worker)."""
    INVALID = 2
    """Invalid input, an unusable plugin or factory, or a usage error."""
    INTERNAL = 3
    """An internal error of btgen_pytrees itself."""
    INTERRUPTED = 130
    """Stopped by Ctrl-C (128 + SIGINT); in a batch, a file that was not run."""

    def __str__(self) -> str:  # Python 3.10 would print "ExitCode.FAIL"
        return str(self.value)

MAX_PROBLEMS = 100
"""Problems printed per file; the rest are counted in one ``… and N more problems`` line."""

MAX_LINE = 400
"""Any printed line (a problem with its file name and pointer, a summary row) is cut to this length."""

UNSAFE = re.compile(
    "[\x00-\x1f\x7f-\x9f\u061c\u200b-\u200f\u2028-\u202e\u2060-\u206f\ufeff\ufff9-\ufffb\ufffe\uffff\ud800-\udfff]"
)
"""What a terminal could act on or hide text with: C0, DEL, C1 (ESC sequences, cursor moves), bidi
overrides and isolates (text shown in another order than it is), zero-width characters, line and
paragraph separators, and lone surrogates (the undecodable bytes of a non-UTF-8 file name)."""


def _escape(match: re.Match[str]) -> str:
    code = ord(match.group())
    if 0xDC80 <= code <= 0xDCFF:  # a byte os.fsdecode could not decode (surrogateescape)
        return f"\\x{code - 0xDC00:02x}"
    return f"\\x{code:02x}" if code < 256 else f"\\u{code:04x}"


def plural(n: int, word: str, many: str | None = None) -> str:
    """``1 tick``, ``2 ticks``, ``1 criterion``/``3 criteria`` (*many*: the plural when it is not *word* + s).

    >>> plural(1, "file"), plural(0, "file"), plural(1, "entry", "entries")
    ('1 file', '0 files', '1 entry')
    """
    return f"{n} {word if n == 1 else many or word + 's'}"


def printable(text: str, *, limit: int | None = None, keep_newlines: bool = False) -> str:
    """*text* safe to print: every character in :data:`UNSAFE` escaped as ``\\xNN``/``\\uNNNN``.

    A name like ``"t: PASS\\u001b[8m"`` then cannot hide what follows it, and a key
    with a newline cannot split a one-line message. With *keep_newlines* ``\\n``
    stays (multi-line text such as a tree); with *limit* each line is shortened.

    >>> printable("ok\\x1b[8m \\u202egnp.exe")
    'ok\\\\x1b[8m \\\\u202egnp.exe'
    """
    if keep_newlines:
        return "\n".join(printable(line, limit=limit) for line in text.split("\n"))
    text = UNSAFE.sub(_escape, text)
    return shorten(text, limit) if limit is not None else text


XML_FORBIDDEN = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ufffe\uffff\ud800-\udfff]")
"""Characters XML 1.0 cannot hold at all, not even as character references."""


def xml_safe(text: str) -> str:
    """*text* with the characters XML 1.0 forbids escaped as ``\\xNN`` text, so the document stays well-formed.

    >>> xml_safe("a\\x1bb\\x00")
    'a\\\\x1bb\\\\x00'
    """
    return XML_FORBIDDEN.sub(_escape, text)


def _printable(text: str) -> str:
    return printable(text, limit=MAX_LINE)


def pointer(path: Iterable[PathPart]) -> str:
    """Render a path as an RFC 6901 JSON pointer; the whole document is ``/``."""
    parts = [str(p).replace("~", "~0").replace("/", "~1") for p in path]
    return "/" + "/".join(parts)


@dataclass(frozen=True, order=True)
class Problem:
    """One thing wrong with a test case.

    Attributes:
        path: where, as keys and indices from the document root
        message: what, in words a test author understands
        cause: which check found it: ``json``, ``schema``, ``id``, ``graph``,
            ``expression``, ``action``, ``signal``, ``limit``, ``system``
    """

    path: tuple[PathPart, ...]
    message: str
    cause: str = "schema"

    @property
    def pointer(self) -> str:
        return pointer(self.path)

    def render(self, source: str) -> str:
        """``source: /pointer: message`` on one line: control characters escaped, the message cut
        to :data:`MAX_MESSAGE` characters, the whole line to :data:`MAX_LINE`."""
        return _printable(f"{source}: {self.pointer}: {shorten(self.message)}")


def by_place(problem: Problem) -> tuple[Any, ...]:
    """The key that sorts problems as they are listed (``sorted(problems, key=by_place)``): by place in
    the document - at one level an index before a key, indices by number - then by message."""
    return tuple((0, p, "") if isinstance(p, int) else (1, 0, p) for p in problem.path), problem.message


class UserError(Exception):
    """What the user gave cannot be used: exit code 2 (:attr:`ExitCode.INVALID`), nothing run.

    The one family the command line and the worker pool both classify by: the CLI prints
    ``btgen_pytrees: `` before each of :meth:`messages` on stderr; a batch's worker makes it the
    file's outcome (:func:`btgen_pytrees.parallel.guard`). Its members are errors of input, not of
    btgen_pytrees: :class:`InvalidTestCase`, :class:`UsageError`, an unusable plugin or leaf factory
    (``PluginError``, ``FactoryError``), a missing tool (``GraphvizMissing``), given parameters that
    cannot be used (``ParameterError``), an unusable output path (``OutputError``) or cluster
    (``DaskUnavailable``, ``ShippingError``).
    """

    def messages(self) -> list[str]:
        """What the CLI prints, a ``btgen_pytrees: `` line each (default: ``str(self)``)."""
        return [str(self)]


class UsageError(UserError):
    """A command line that cannot work (options that do not go together, a value out of range);
    ``str()`` is one line for the user."""


class InvalidTestCase(UserError, ValueError):
    """A test case that cannot be turned into a tree.

    Attributes:
        problems: every problem found, sorted by position in the document
        source: the file name (or ``<dict>``) the case came from
    """

    def __init__(self, problems: Iterable[Problem], source: str = "<dict>"):
        self.problems: tuple[Problem, ...] = tuple(problems)
        self.source = source
        super().__init__("\n".join(p.render(source) for p in self.problems))


class Interrupt(KeyboardInterrupt):
    """Raised by the CLI's own signal handlers (Ctrl-C, SIGTERM): the process is being stopped.

    Code that contains user code (plugins, factories, leaves) turns whatever it
    raises - ``SystemExit`` and ``KeyboardInterrupt`` included - into that
    file's error, except this (see :func:`is_interrupt`).
    """

    def __init__(self, signum: int = signal.SIGINT):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def is_interrupt(exc: BaseException) -> bool:
    """Whether *exc* is someone stopping this process, not user code misbehaving.

    True for :class:`Interrupt`, and for a plain ``KeyboardInterrupt`` while
    Python's own Ctrl-C handler is installed (a host application or a REPL:
    its Ctrl-C must still stop the run). Under the CLI, whose handlers raise
    :class:`Interrupt`, a plain ``KeyboardInterrupt`` can only come from user code.
    """
    if isinstance(exc, Interrupt):
        return True
    return type(exc) is KeyboardInterrupt and signal.getsignal(signal.SIGINT) is signal.default_int_handler
