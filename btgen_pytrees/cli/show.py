"""``show FILE...``: print or write the generated tree in one of the views (the default command)."""

from __future__ import annotations

import argparse
import os
import sys
from typing import Any

from ..batch import job_show
from ..construct import generate
from ..errors import ExitCode, UsageError
from ..load import load, validate
from ..writing import commit, emit, is_direct, same_file, stdout_isatty
from ..load.warnings import warning_lines
from ..parallel import Outcome
from ..render import FORMATS, JSON_INDENT_LIMIT, render_chunks
from ..render.dot import png_depth
from ..timeline import timeline
from .checks import check_out_dir, check_output, targets
from .many import run_batch, single
from .options import MAX_INDENT, SIDECAR_NOTE, Parents, chosen, indent, non_negative, registry
from .terminal import can_encode, err, write_stdout

__all__ = ["add_parser", "cmd_show", "SUFFIX_FORMATS"]

SUFFIX_FORMATS = {".svg": "svg", ".png": "png", ".dot": "dot", ".gv": "dot", ".json": "json", ".xml": "btcpp",
                  ".txt": "unicode"}  # fmt: skip
"""``show -o PATH`` without ``--format``: the format its suffix names."""

FORMAT_SUFFIXES = {"unicode": ".txt", "ascii": ".txt", "matrix": ".txt", "btcpp": ".xml"}
BINARY_FORMATS = ("png",)


def add_parser(sub: Any, parents: Parents) -> None:
    show = sub.add_parser("show", parents=[parents.plugin, parents.many, parents.chosen], help="print the generated tree (default command)")
    show.add_argument("files", nargs="+", metavar="FILE", help="test case file, .json or .xosc (several, or directories of them: batch mode); " + SIDECAR_NOTE)
    show.add_argument("--format", "-f", choices=sorted(FORMATS), help="output format (default: from the -o suffix, else unicode if the terminal can show it, else ascii)")
    show.add_argument("--output", "-o", metavar="PATH", help="write to PATH instead of stdout (.svg/.png/.dot/.json/.xml/.txt choose the format)")
    show.add_argument("--max-depth", type=non_negative, metavar="N", help="text and dot/svg/png formats: show nodes down to depth N only (root = 0); deeper subtrees are collapsed")
    show.add_argument("--indent", type=indent, default="auto", metavar="N|none",
                      help=f"json format: indent N spaces per level (0 to {MAX_INDENT}; 0: a key per line), or 'none': compact, one line (default: 2 up to {JSON_INDENT_LIMIT:,} nodes, compact above)")  # fmt: skip
    show.set_defaults(func=cmd_show)


def show_format(args: argparse.Namespace) -> str:
    if args.format:
        return str(args.format)
    if args.output and args.output != "-" and not is_direct(args.output):
        suffix = os.path.splitext(args.output)[1].lower()
        if suffix and suffix not in SUFFIX_FORMATS:  # text in an .html file would be a lie
            raise UsageError(f"-o {args.output}: {suffix} names no format; use {' '.join(SUFFIX_FORMATS)}, "
                             "or give --format for another name")  # fmt: skip
        return SUFFIX_FORMATS.get(suffix, "unicode")
    return "unicode" if args.output or can_encode(sys.stdout) else "ascii"


def check_indent(args: argparse.Namespace, fmt: str) -> None:
    if args.indent != "auto" and fmt != "json":
        raise UsageError(f"--indent applies to the json format only, not {fmt}")


def refuse_binary_to_terminal(fmt: str, path: str | None) -> None:
    if fmt in BINARY_FORMATS and (path is None or path == "-" or same_file(path, "/dev/stdout")) and stdout_isatty():
        raise UsageError(f"--format {fmt} is binary and stdout is a terminal: write it with -o FILE.{fmt} or redirect stdout")


def cmd_show(args: argparse.Namespace) -> int:
    files = single(args)
    if files is not None:
        if args.output:
            raise UsageError("-o/--output takes one file; use --out-dir with several")
        fmt = args.format or ("unicode" if args.out_dir or can_encode(sys.stdout) else "ascii")
        if not args.out_dir and fmt in BINARY_FORMATS:
            raise UsageError(f"--format {fmt} with several files needs --out-dir")
        check_indent(args, fmt)
        suffix = FORMAT_SUFFIXES.get(fmt, "." + fmt)
        if args.out_dir:
            check_out_dir(args, files, writes_json=suffix == ".json")
        bases = targets(args, files, [suffix])

        def shown(outcomes: list[Outcome]) -> None:
            for outcome in outcomes:
                for target, data in outcome.outputs:
                    if target == "-" and isinstance(data, str):
                        emit(f"==> {outcome.path} <==\n")
                        write_stdout(data if data.endswith("\n") else data + "\n", fmt)

        return run_batch(args, files, job_show,
                         lambda i: (tuple(args.plugin or ()), fmt, None if bases[i] is None else bases[i] + suffix,
                                    args.max_depth, args.indent), after=shown)  # fmt: skip
    fmt = show_format(args)
    check_indent(args, fmt)
    check_output(args.output, "-o", [args.file])
    refuse_binary_to_terminal(fmt, args.output)
    known = registry(args)
    document = chosen(args, known)
    case = load(args.file, registry=known) if document is None else validate(document, args.file, registry=known)
    for line in [] if args.quiet else warning_lines(case):
        err(line)
    root = generate(case, registry=known)
    # the text views are drawn while they are written; svg/png without Graphviz: GraphvizMissing, a usage error
    chunks = render_chunks(root, timeline(case), fmt, max_depth=args.max_depth, indent=args.indent)
    if fmt == "png" and args.max_depth is None and png_depth(root) is not None:  # collapsed to stay readable: say so
        err(f"{args.file}: {sum(1 for _ in root.iterate())} nodes cannot be read in one PNG: drawn down to depth "
            f"{png_depth(root)} (deeper subtrees are '… N more nodes' boxes); choose with --max-depth N, or use .svg")
    if args.output is None or args.output == "-":
        write_stdout(chunks, fmt)
    else:
        commit([(args.output, chunks)])
    return ExitCode.OK
