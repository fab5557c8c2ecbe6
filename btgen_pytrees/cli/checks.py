"""Output paths and ``--out-dir`` checked before any work: a command that cannot write its results
refuses at once (exit 2), before anything runs."""

from __future__ import annotations

import argparse
import os
from typing import Sequence

from ..batch import output_names
from ..errors import UsageError
from ..writing import at_home, check_target

__all__ = ["check_output", "check_out_dir", "make_out_dir", "targets"]


def check_output(path: str | None, option: str, inputs: Sequence[str], made_later: bool = False) -> None:
    if path is not None:
        check_target(path, option, inputs, made_later=made_later)  # OutputError: a usage error


def check_out_dir(args: argparse.Namespace, files: list[str], writes_json: bool) -> None:
    """--out-dir must be a directory or creatable, and (for .json outputs) not inside an input directory."""
    out = args.out_dir
    if os.path.exists(out) and not os.path.isdir(out):
        raise UsageError(f"--out-dir {out}: exists and is not a directory")
    if not os.path.exists(out):
        parent = os.path.dirname(os.path.abspath(out))
        while not os.path.exists(parent):
            parent = os.path.dirname(parent)
        if not os.path.isdir(parent) or not os.access(parent, os.W_OK | os.X_OK):
            raise UsageError(f"--out-dir {out}: cannot be created ({parent} is not a writable directory)")
    elif not os.access(out, os.W_OK | os.X_OK):
        raise UsageError(f"--out-dir {out}: is not writable")
    if writes_json:
        real = os.path.realpath(out)
        for given in args.files:
            if os.path.isdir(given):
                top = os.path.realpath(given)
                if real == top or real.startswith(top.rstrip(os.sep) + os.sep):
                    raise UsageError(f"--out-dir {out}: is inside the input directory {given}, where its .json "
                                     "outputs would be read as test cases; choose a directory outside it")  # fmt: skip


def make_out_dir(args: argparse.Namespace) -> None:
    at_home()  # where --out-dir was checked, whatever directory user code moved to
    try:
        os.makedirs(args.out_dir, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"--out-dir {args.out_dir}: cannot be created: {exc.strerror or exc}") from None


def targets(args: argparse.Namespace, files: list[str], suffixes: Sequence[str]) -> list[str | None]:
    """Each file's output base path in --out-dir (``None`` without it), checked against the inputs."""
    if not args.out_dir:
        return [None] * len(files)
    found = [os.path.join(args.out_dir, name) for name in output_names(files, "")]
    for target in found:
        for suffix in suffixes:
            check_output(target + suffix, "--out-dir", files, made_later=True)
    return list(found)
