"""What several commands share on the command line: the parser with one-line errors, the option
groups a command's sub-parser takes as parents (``--jobs``, ``--out-dir``/``--quiet``, ``--plugin``,
``--set``/``--params``), the argument types, and what the shared options mean (a registry, a system,
one variation). Each command module adds its own options (pytest style: a feature owns its flags).
"""

from __future__ import annotations

import argparse
import os
from dataclasses import dataclass
from typing import Any, NoReturn

from ..errors import ExitCode, UsageError
from ..leaves import Registry, default_registry
from ..load import load_json
from ..sweep.overrides import choose, parse_set, read_params
from ..systems import SystemSpec
from .terminal import err

__all__ = ["Parser", "Parents", "parents", "MAX_JOBS", "MAX_INDENT", "non_negative", "indent", "positive", "registry",
           "system", "chosen", "check_jobs", "SIDECAR_NOTE"]  # fmt: skip

SIDECAR_NOTE = ("a .xosc takes its ego, timeout and extra criteria from SCENARIO.oracle.json beside it "
                "(docs/openscenario.md; 'convert --ego/--timeout/--oracle' writes them into a case)")
"""What the commands that take a case file say of an OpenSCENARIO file's options: the sidecar file is their
interface (only ``convert`` takes them on its command line), so a scenario judges alike in every command,
worker and pytest session."""

MAX_JOBS = 64
"""Most worker processes ``--jobs`` may ask for (more is a usage error)."""

MAX_INDENT = 16
"""Most spaces ``--indent`` may ask for: every tree level indents by twice that (the node and its
``children`` list), so a large N on a deep tree multiplies the file's size for nothing."""


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors (``btgen_pytrees: error: ...``), exit 2."""

    def error(self, message: str) -> NoReturn:
        err(f"btgen_pytrees: error: {message} (see --help)")
        raise SystemExit(ExitCode.INVALID)


@dataclass(frozen=True)
class Parents:
    """The option groups commands share, as argparse parent parsers."""

    jobs: argparse.ArgumentParser
    many: argparse.ArgumentParser
    plugin: argparse.ArgumentParser
    chosen: argparse.ArgumentParser


def parents() -> Parents:
    jobs = argparse.ArgumentParser(add_help=False)
    jobs.add_argument("--jobs", "-j", type=whole, default=min(os.cpu_count() or 1, MAX_JOBS), metavar="N",
                      help=f"with several files or a sweep: worker processes, 1 to {MAX_JOBS} (default: the number of CPUs)")  # fmt: skip
    many = argparse.ArgumentParser(add_help=False, parents=[jobs])
    many.add_argument("--out-dir", metavar="DIR", help="write each file's output into DIR (made when first written)")
    many.add_argument("--quiet", "-q", action="store_true", help="do not print warnings (overlapping writes of a signal)")
    plugin = argparse.ArgumentParser(add_help=False)
    plugin.add_argument("--plugin", action="append", metavar="MODULE|FILE.py",
                        help="import MODULE (the current directory is importable) or the Python file FILE.py and call its register(registry) to add leaves or systems (repeatable)")  # fmt: skip

    chosen = argparse.ArgumentParser(add_help=False)
    chosen.add_argument("--set", action="append", metavar="NAME=VALUE",
                        help="one variation: parameter NAME takes VALUE (a number, true or false), the others their defaults (repeatable)")  # fmt: skip
    chosen.add_argument("--params", metavar="FILE.json", help="one variation: parameter values from a JSON object (--set wins)")
    return Parents(jobs, many, plugin, chosen)


def whole(text: str) -> int:
    """A whole number as a case file reads one: ``10``, ``1e1`` and ``10.0`` are 10; ``2.5`` is refused."""
    try:
        return int(text)
    except ValueError:
        pass
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not value.is_integer():  # also inf and nan
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number")
    return int(value)


def non_negative(text: str) -> int:
    value = whole(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"{value} is negative; the root is depth 0")
    return value


def indent(text: str) -> int | None | str:
    """``--indent``: a whole number of spaces 0 to :data:`MAX_INDENT`, ``none`` (compact) or ``auto``."""
    word = text.strip().lower()
    if word in ("none", "auto"):
        return None if word == "none" else "auto"
    try:
        value = int(word)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of spaces, 'none' or 'auto'") from None
    if not 0 <= value <= MAX_INDENT:
        raise argparse.ArgumentTypeError(f"{value} must be between 0 and {MAX_INDENT} spaces")
    return value


def positive(text: str) -> int:
    value = whole(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value} must be at least 1")
    return value


def check_jobs(args: argparse.Namespace) -> None:
    if not 1 <= args.jobs <= MAX_JOBS:
        raise UsageError(f"--jobs {args.jobs}: must be between 1 and {MAX_JOBS}")


def registry(args: argparse.Namespace) -> Registry:
    """The registry of ``--plugin``: the built-ins plus the plugins named."""
    return default_registry(args.plugin or ())


def system(args: argparse.Namespace) -> SystemSpec | None:
    """``--system TYPE[:CONFIG]`` as a spec (CONFIG relative to the current directory), or None."""
    if not args.system:
        return None
    kind, colon, config = args.system.partition(":")
    if not kind or (colon and not config):
        raise UsageError(f"--system {args.system}: expected TYPE or TYPE:CONFIG")
    return SystemSpec(kind, os.path.abspath(config) if config else None)


def chosen(args: argparse.Namespace, known: Registry | None = None) -> dict[str, Any] | None:
    """``--set``/``--params``: the one variation they choose of ``args.file`` (None without them)."""
    sets, params = getattr(args, "set", None) or [], getattr(args, "params", None)
    if not sets and not params:
        return None
    if getattr(args, "file", None) is None:
        raise UsageError("--set/--params choose one variation of one file")
    given = read_params(params) if params else {}
    pairs = [parse_set(text) for text in sets]
    twice = sorted({n for i, (n, _) in enumerate(pairs) if n in dict(pairs[:i])})
    if twice:
        raise UsageError(f"--set {twice[0]}: given twice")
    given.update(dict(pairs))
    spec = system(args) if hasattr(args, "system") else None
    return choose(load_json(args.file), args.file, given, registry=known or registry(args), system=spec).document
