"""Words for people: "did you mean" suggestions and long messages shortened, written once.

Every message of the package that proposes a name (an unknown id, key, signal, action, option,
parameter) or cuts a long text goes through here, so they all read alike.

>>> did_you_mean("sped", ["speed", "gap"])
" (did you mean 'speed'?)"
>>> shorten("a" * 10 + " is too long", 12)
'aaaaaa… long'
"""

from __future__ import annotations

import difflib
from typing import Iterable

__all__ = ["MAX_MESSAGE", "closest", "did_you_mean", "shorten"]

MAX_MESSAGE = 200
"""A problem's message is shortened (its middle cut out) to about this many characters."""


def closest(word: str, candidates: Iterable[str], *, similar_length: bool = False) -> str | None:
    """The candidate closest to *word* (difflib's ratio of at least 0.6), or ``None``.

    With *similar_length*, only candidates whose length is within ``max(3, len(word) // 2)`` of
    *word*'s are compared: the loader's bound on the cost of many suggestions in one document.
    """
    if similar_length:
        size = len(word)
        slack = max(3, size // 2)
        candidates = [c for c in candidates if abs(len(c) - size) <= slack]
    hint = difflib.get_close_matches(word, list(candidates), n=1)
    return hint[0] if hint else None


def did_you_mean(word: str, candidates: Iterable[str], *, similar_length: bool = False) -> str:
    """`` (did you mean 'x'?)`` for the :func:`closest` candidate, or ``""`` when none is close."""
    hint = closest(word, candidates, similar_length=similar_length)
    return f" (did you mean {hint!r}?)" if hint is not None else ""


def shorten(text: str, limit: int = MAX_MESSAGE, *, keep_end: bool = True) -> str:
    """*text* cut to *limit* characters, ``…`` marking the cut.

    The middle is cut out (*keep_end*): messages like "'dd…dd' is too long" end with the reason.
    Without *keep_end* the end is cut (the parameters' and variations' checks cut this way).
    """
    if len(text) <= limit:
        return text
    if not keep_end:
        return text[: limit - 1] + "…"
    half = limit // 2
    return text[:half] + "…" + text[-(limit - half - 1) :]
