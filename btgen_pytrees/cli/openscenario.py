"""``coverage DIR``: which elements of which OpenSCENARIO files convert (docs/openscenario.md)."""

from __future__ import annotations

import argparse
import os
from typing import Any

from ..errors import ExitCode, UsageError
from ..openscenario.coverage import coverage, markdown, table, to_json
from ..writing import check_target, commit, emit
from .options import Parents

__all__ = ["add_parser", "cmd_coverage"]


def add_parser(sub: Any, parents: Parents) -> None:
    cov = sub.add_parser("coverage", help="which elements of which OpenSCENARIO (.xosc) files are supported")
    cov.add_argument("path", metavar="DIR", help="a directory (every .xosc file under it) or one .xosc file")
    cov.add_argument("--format", choices=("table", "json", "markdown"), default="table",
                     help="table (default), JSON (schemas/coverage.schema.json) or the Markdown table of the elements")  # fmt: skip
    cov.add_argument("--out", metavar="FILE", help="write there instead of standard output")
    cov.set_defaults(func=cmd_coverage)


def cmd_coverage(args: argparse.Namespace) -> int:
    """Exit 0 when every file converts, 1 when some do not (the table says which and why), 2 for a bad path."""
    if not os.path.exists(args.path):
        raise UsageError(f"{args.path}: no such file or directory")
    if args.out:
        check_target(args.out, "--out", [args.path])
    data = coverage(args.path)
    text = {"table": table, "json": to_json, "markdown": markdown}[args.format](data)
    if args.out:
        commit([(args.out, text)])
    else:
        emit(text)
    return ExitCode.OK if all(f["converts"] for f in data["files"]) else ExitCode.FAIL
