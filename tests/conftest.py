import pathlib
import signal
from typing import Any, Iterator

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent


@pytest.fixture
def fig1_path() -> str:
    return str(ROOT / "examples" / "fig1.json")


def _sigint(handler: Any) -> Iterator[None]:
    previous = signal.signal(signal.SIGINT, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous if previous is not None else signal.SIG_DFL)


@pytest.fixture
def pythons_ctrl_c() -> Iterator[None]:
    """Python's own Ctrl-C handler for the test, as in a host application or a REPL.

    A plain ``KeyboardInterrupt`` is the host's Ctrl-C only while it is installed
    (:func:`btgen_pytrees.errors.is_interrupt`); a test that expects one to go on through a run
    needs it. pytest does not always have it: a Python started with SIGINT ignored (under
    ``nohup``, or as ``cmd &`` in a script, where the shell ignores SIGINT for it) keeps SIGINT
    ignored and installs no handler, and there a leaf's ``KeyboardInterrupt`` is the run's error.
    """
    yield from _sigint(signal.default_int_handler)


@pytest.fixture
def sigint_ignored() -> Iterator[None]:
    """SIGINT ignored for the test, as in a process started under ``nohup`` or in a script's background."""
    yield from _sigint(signal.SIG_IGN)
