"""Writing results: all or nothing.

Outputs are written to a temporary file beside the target and renamed into
place, so an interrupted or failed command never leaves half a file, and a
command that fails validation writes nothing at all.
"""

from __future__ import annotations

import os

__all__ = ["write_file"]


def write_file(path: str, data: str | bytes) -> None:
    """Write *data* (text as UTF-8 with ``\\n`` line ends, or bytes) to *path* atomically."""
    tmp = f"{path}.tmp{os.getpid()}"
    try:
        if isinstance(data, bytes):
            with open(tmp, "wb") as fh:
                fh.write(data)
        else:
            with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
                fh.write(data)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
