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

import re
from dataclasses import dataclass
from typing import Iterable, Union

__all__ = ["Problem", "InvalidTestCase", "pointer"]

PathPart = Union[str, int]


_CONTROL = re.compile(r"[\x00-\x1f\x7f\u2028\u2029]")


def _printable(text: str) -> str:
    """Escape control characters, so a key like ``"a\\nb"`` cannot split a one-line message."""
    return _CONTROL.sub(lambda m: f"\\x{ord(m.group()):02x}" if ord(m.group()) < 256 else f"\\u{ord(m.group()):04x}", text)


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
        """``source: /pointer: message`` on one line (control characters escaped)."""
        return _printable(f"{source}: {self.pointer}: {self.message}")


class InvalidTestCase(ValueError):
    """A test case that cannot be turned into a tree.

    Attributes:
        problems: every problem found, sorted by position in the document
        source: the file name (or ``<dict>``) the case came from
    """

    def __init__(self, problems: Iterable[Problem], source: str = "<dict>"):
        self.problems: tuple[Problem, ...] = tuple(problems)
        self.source = source
        super().__init__("\n".join(p.render(source) for p in self.problems))
