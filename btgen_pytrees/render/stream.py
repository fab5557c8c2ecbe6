"""Views as streams of text chunks, so a large tree's view is written while it is drawn.

A 100,000-entry tree's text view is tens of megabytes; built as one string it
sits in memory whole (several times over while lines are joined) and nothing
appears until the last line is drawn. The text views are therefore generators
of small pieces (a line, a JSON fragment), and :func:`chunked` groups those
pieces into chunks of about :data:`CHUNK_CHARS` characters: large enough that
writing them costs little per chunk, small enough that the first one is out
after a few hundred nodes and memory holds one chunk, not the view.
"""

from __future__ import annotations

from typing import Iterable, Iterator

__all__ = ["CHUNK_CHARS", "chunked"]

CHUNK_CHARS = 1 << 16
"""Characters per chunk (about; a chunk ends at the first piece that reaches it)."""


def chunked(pieces: Iterable[str], size: int | None = None) -> Iterator[str]:
    """Join consecutive *pieces* into chunks of at least *size* characters (the last may be shorter).

    *size* defaults to :data:`CHUNK_CHARS` as it is when the stream starts. Never
    yields an empty chunk; an empty stream yields nothing.
    """
    size = CHUNK_CHARS if size is None else size
    buffer: list[str] = []
    length = 0
    for piece in pieces:
        buffer.append(piece)
        length += len(piece)
        if length >= size:
            yield "".join(buffer)
            buffer.clear()
            length = 0
    if length:
        yield "".join(buffer)
