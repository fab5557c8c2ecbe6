"""What a run reads from the client's disk, sent to workers that share no disk with it.

A case names files besides itself: a SUMO ``.sumocfg`` and the network, route
and additional files it lists (any system type that has a ``files(spec)``
method says which), and ``--plugin path/to/robot.py`` files. On a Dask cluster
the workers may run on other machines and in other directories, so the client
resolves every such path (relative to the case file, or to its own working
directory for ``--plugin`` and ``--system TYPE:CONFIG``), reads the files into
one :class:`Files` value, and the executor sends that value to each worker
*once* (a Dask worker plugin that installs it as the worker starts), not with every task.

On a worker, :func:`install` writes the files into a private directory (the
Dask worker's own scratch directory, removed with the worker) that mirrors the
client's absolute paths, so a ``.sumocfg`` finds its network and routes under
the same relative names; a job then maps each client path to its copy with
:func:`local`. Copies are keyed by a hash of the contents: two clients that
share workers never see each other's files.

>>> files = Files.of([("/cases/a.sumocfg", b"<configuration/>")])
>>> len(files.digest), files.size
(64, 16)
"""

from __future__ import annotations

import hashlib
import os
import shutil
import stat
import tempfile
import threading
from dataclasses import dataclass
from typing import Iterable

from ..errors import UserError

__all__ = ["Files", "ShippingError", "read_files", "install", "local", "MAX_SHIPPED_BYTES"]

MAX_SHIPPED_BYTES = 256 * 1024 * 1024
"""Most bytes one run of a command ships to the workers (every file together)."""


class ShippingError(UserError, ValueError):
    """A file to ship cannot be read or the files are too large; ``str()`` says which (a usage error)."""


@dataclass(frozen=True)
class Files:
    """Files by their absolute path on the client, with their bytes (sorted by path).

    Attributes:
        items: ``((path, data), ...)``
        digest: SHA-256 of every path and content (names the copies on the workers)
    """

    items: tuple[tuple[str, bytes], ...]
    digest: str

    @classmethod
    def of(cls, items: Iterable[tuple[str, bytes]]) -> "Files":
        ordered = tuple(sorted(dict(items).items()))
        h = hashlib.sha256()
        for path, data in ordered:
            h.update(path.encode("utf-8", "surrogateescape") + b"\0" + len(data).to_bytes(8, "big") + data)
        return cls(ordered, h.hexdigest())

    @property
    def size(self) -> int:
        return sum(len(data) for _, data in self.items)

    @property
    def paths(self) -> tuple[str, ...]:
        return tuple(path for path, _ in self.items)


def read_files(paths: Iterable[str], limit: int = MAX_SHIPPED_BYTES) -> Files:
    """Read *paths* (absolute) on the client, each a regular file, at most *limit* bytes in all.

    Raises:
        ShippingError: a file cannot be read or is not a regular file, or the total is over *limit*.
    """
    items: list[tuple[str, bytes]] = []
    total = 0
    for path in dict.fromkeys(paths):
        try:
            if not stat.S_ISREG(os.stat(path).st_mode):
                raise ShippingError(f"{path}: not a regular file (cannot send it to the workers)")
            with open(path, "rb") as fh:
                data = fh.read(limit - total + 1)
        except OSError as exc:
            raise ShippingError(f"{path}: cannot read: {exc.strerror or exc}") from None
        total += len(data)
        if total > limit:
            raise ShippingError(f"the files the runs need are more than {limit} bytes in all (at {path}); "
                                "the workers get a copy of each, so this is the limit")  # fmt: skip
        items.append((path, data))
    return Files.of(items)


_installed: dict[str, dict[str, str]] = {}
"""digest -> {client path: path of its copy} of the files installed in this process."""
_lock = threading.Lock()


def _mirrored(path: str) -> str:
    """``/cases/x/a.sumocfg`` -> ``cases/x/a.sumocfg`` (``C:\\x\\a`` -> ``C/x/a``): a relative path keeping the layout."""
    drive, rest = os.path.splitdrive(path)
    return os.path.join(drive.strip(":\\/") or "", rest.lstrip("\\/"))


def install(files: Files, directory: str | None = None) -> str:
    """Write *files* under *directory* (default: the temporary directory) once per process; the copies' root.

    The copies appear all at once (written to a temporary directory, then renamed),
    so a run never sees half of them. Thread-safe.
    """
    with _lock:
        known = _installed.get(files.digest)
        directory = directory or tempfile.gettempdir()
        root = os.path.join(directory, f"btgen-files-{files.digest[:20]}")
        if known is not None and all(os.path.isfile(p) for p in known.values()):
            return root
        if not os.path.isdir(root):
            staging = tempfile.mkdtemp(prefix=".btgen-files-", dir=directory)
            try:
                for path, data in files.items:
                    target = os.path.join(staging, _mirrored(path))
                    os.makedirs(os.path.dirname(target), exist_ok=True)
                    with open(target, "wb") as fh:
                        fh.write(data)
                try:
                    os.rename(staging, root)
                except OSError:  # another process of this machine made it first: same contents (same digest)
                    shutil.rmtree(staging, ignore_errors=True)
            except BaseException:
                shutil.rmtree(staging, ignore_errors=True)
                raise
        _installed[files.digest] = {path: os.path.join(root, _mirrored(path)) for path, _ in files.items}
        return root


def local(digest: str | None, path: str) -> str:
    """The copy of the client's *path* installed for *digest* in this process; *path* itself when there is none
    (the local pool: workers share the client's disk)."""
    if digest is None:
        return path
    table = _installed.get(digest)
    if table is None:
        raise ShippingError(f"the files of this run ({digest[:12]}) were never installed in this process")
    return table.get(path, path)
