"""``validate FILE...``: check test cases (a sweep: every variation); exit 0 only if all are valid."""

from __future__ import annotations

import argparse
import signal
from typing import Any

from .. import batch
from ..errors import ExitCode, plural
from ..writing import emit
from ..parallel import Interrupted, summary
from .many import expand_files, process_files
from .options import SIDECAR_NOTE, Parents, whole
from .terminal import err, problems

__all__ = ["add_parser", "cmd_validate"]


def add_parser(sub: Any, parents: Parents) -> None:
    validate = sub.add_parser("validate", parents=[parents.plugin, parents.jobs], help="check test case files; exit 0 only if all are valid")
    validate.add_argument("files", nargs="+", metavar="FILE", help="test case files (.json, .xosc) or directories of them; " + SIDECAR_NOTE)
    validate.add_argument("--quiet", "-q", action="store_true", help="print problems only (no 'ok' lines, no warnings)")
    validate.add_argument("--max-variations", type=whole, metavar="N", help="a sweep may have at most N variations (default 10000)")
    validate.set_defaults(func=cmd_validate)


def cmd_validate(args: argparse.Namespace) -> int:
    files = expand_files(args)
    try:
        outcomes = process_files(args, batch.job_validate, [(tuple(args.plugin or ()), args.max_variations)] * len(files), files)
    except Interrupted as stop:  # Ctrl-C/SIGTERM while a sweep's variations are checked: 130/143, not an error
        for outcome in stop.outcomes:
            problems(outcome, args.quiet)
        checked = sum(o.code != ExitCode.INTERRUPTED for o in stop.outcomes)
        err(f"btgen_pytrees: interrupted by {signal.Signals(stop.signum).name} after checking {checked} of {plural(len(files), 'file')}")
        return 128 + stop.signum
    if not args.quiet:
        for outcome in outcomes:
            if outcome.code == ExitCode.OK:
                emit(f"{outcome.path}: {outcome.summary}\n")
        if len(files) > 1:
            emit(summary(outcomes).splitlines()[-1] + "\n")
    return max(o.code for o in outcomes)
