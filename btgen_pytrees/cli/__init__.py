"""Command line: ``python -m btgen_pytrees [show|validate|run|expand|falsify|schema] ...``.

``show`` is the default command, so ``python -m btgen_pytrees test.json`` prints
the tree. Exit codes (:class:`~btgen_pytrees.errors.ExitCode`): 0 success (run: pass),
1 run fail/timeout/error, 2 invalid input or usage, 3 internal error. Invalid input is
reported as one ``FILE: /json/pointer: message`` line per problem on stderr, never a
traceback, and nothing is written.

This module parses, dispatches and maps what the command raised to an exit code: the one
family of input errors (:class:`~btgen_pytrees.errors.UserError`) is exit 2. It knows no
feature's flags: each command module (:mod:`.show`, :mod:`.validate`, :mod:`.run`,
:mod:`.sweep` for ``expand``, :mod:`.falsify`, :mod:`.schema`) adds its own sub-parser.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
from typing import Any, Callable, Sequence

from .. import __version__
from ..errors import ExitCode, Interrupt, InvalidTestCase, UserError
from ..leaves import loads_user_code
from ..writing import divert_stdout, pin_directory
from ..parallel import Interrupted
from ..supervise import supervised
from ..text import did_you_mean
from . import falsify, openscenario, run, schema, show, sweep, validate
from .options import MAX_JOBS, Parser, check_jobs, parents
from .terminal import err, report_invalid

__all__ = ["main", "MAX_JOBS"]

COMMANDS = ("show", "validate", "run", "expand", "falsify", "schema", "convert", "coverage")
_SUB_PARSERS = (show.add_parser, validate.add_parser, run.add_parser, sweep.add_parser, falsify.add_parser, schema.add_parser,
                openscenario.add_convert, openscenario.add_parser)
"""Each command's own sub-parser, in the order of :data:`COMMANDS` (``expand`` is the sweep's)."""


def parser() -> argparse.ArgumentParser:
    """The root parser: ``--version``, and each command's sub-parser as its module adds it."""
    root = Parser(
        prog="python -m btgen_pytrees",
        description="Generate a py_trees behaviour tree from a JSON test case, show it, or run it.",
        epilog="'show' is the default command: 'python -m btgen_pytrees test.json' prints the tree.",
    )
    root.add_argument("--version", action="version", version=f"btgen_pytrees {__version__}")
    sub = root.add_subparsers(dest="command", metavar="{" + ",".join(COMMANDS) + "}", parser_class=Parser)
    shared = parents()
    for add in _SUB_PARSERS:
        add(sub, shared)
    return root


_stopping: list[int] = []
"""The signal that is stopping the CLI, once one arrived."""


def _on_signal(signum: int, frame: Any) -> None:
    """Stop the command: raise :class:`~btgen_pytrees.errors.Interrupt` for the first signal, ignore the ones after it.

    Ctrl-C reaches a supervised command twice (from the terminal, and passed on by
    the watching process, btgen_pytrees.supervise): a second signal must not break
    the stopping the first one began (workers stopped, temporary files removed).
    """
    if _stopping:
        return
    _stopping.append(signum)
    raise Interrupt(signum)


def _looks_like_a_command(word: str) -> bool:
    """A first word that is not a file and not named like one (no ``.``, no ``/``): a mistyped command
    (``runn``), not a test case to show; ``missing.json`` still gets the loader's "cannot read" message."""
    return not os.path.lexists(word) and "." not in word and "/" not in word and os.sep not in word


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; return the exit code.

    Ctrl-C and SIGTERM end it with 130/143 after stopping worker processes and
    removing temporary files. Whatever user code raises (``SystemExit`` and
    ``KeyboardInterrupt`` included) is reported as an error of the file that
    ran it, never taken as the CLI's own exit.
    """
    if getattr(sys.stdout, "btgen_closed", False):
        err("btgen_pytrees: standard output is closed; redirect it (to a file or /dev/null) instead")
        return ExitCode.INVALID
    args_list = list(sys.argv[1:] if argv is None else argv)
    if args_list and args_list[0] not in COMMANDS and not args_list[0].startswith("-"):
        word = args_list[0]
        if _looks_like_a_command(word):
            hint = did_you_mean(word, COMMANDS)
            err(f"btgen_pytrees: unknown command {word!r}" + (hint or
                f"; the commands are {', '.join(COMMANDS)}, or give a test case FILE to show it"))  # fmt: skip
            return ExitCode.INVALID
        args_list.insert(0, "show")
    root = parser()
    try:
        args = root.parse_args(args_list)
    except SystemExit as done:  # --help, --version (0) or a usage error (2, already printed)
        return done.code if isinstance(done.code, int) else ExitCode.INVALID
    if args.command is None:
        root.print_help(sys.stderr)
        return ExitCode.INVALID
    if argv is None:  # the real CLI process
        divert_stdout()  # stdout carries only what btgen_pytrees prints; user code's prints go to stderr
        pin_directory()  # outputs land where they were checked, whatever directory user code moves to
        if loads_user_code(getattr(args, "plugin", None) or ()):  # no verdict, no exit 0 (btgen_pytrees.supervise)
            return supervised(lambda: _command(args, real=True), err)
    return _command(args, real=argv is None)


def _command(args: argparse.Namespace, *, real: bool) -> int:
    """Run the parsed command; every outcome is an exit code (see :func:`main`).

    *real*: this is the CLI's own process, so the signal handlers are ours; a
    test calling :func:`main` with arguments keeps its own.
    """
    func: Callable[[argparse.Namespace], int] = args.func
    handlers = {}
    if real:
        _stopping.clear()
        for signum in (signal.SIGINT, signal.SIGTERM):
            handlers[signum] = signal.signal(signum, _on_signal)
    try:
        if hasattr(args, "jobs"):
            check_jobs(args)
        return func(args)
    except InvalidTestCase as error:
        return report_invalid(error)
    except UserError as problem:  # the one family of input errors: usage, a plugin, a factory, Graphviz, ...
        for line in problem.messages():
            err(f"btgen_pytrees: {line}")
        return ExitCode.INVALID
    except (Interrupt, Interrupted) as stop:
        err(f"btgen_pytrees: interrupted by {signal.Signals(stop.signum).name}")
        return 128 + stop.signum
    except BrokenPipeError:
        return ExitCode.OK
    except Exception as exc:  # noqa: BLE001 - the CLI never shows a traceback
        err(f"btgen_pytrees: internal error: {type(exc).__name__}: {exc}")
        return ExitCode.INTERNAL
    except BaseException as exc:  # noqa: BLE001 - SystemExit/KeyboardInterrupt raised by user code
        if isinstance(exc, KeyboardInterrupt) and not real:
            raise  # a test's own Ctrl-C
        err(f"btgen_pytrees: error: user code (a plugin or leaf) raised {type(exc).__name__}" + (f": {exc}" if str(exc) else ""))
        return ExitCode.FAIL
    finally:
        for signum, handler in handlers.items():
            signal.signal(signum, handler)
