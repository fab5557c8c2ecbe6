"""Command line: ``python -m btgen_pytrees [show|validate|run|schema] ...``.

``show`` is the default command, so ``python -m btgen_pytrees test.json`` prints
the tree. Exit codes: 0 success (run: pass), 1 run fail/timeout/error,
2 invalid input or usage. Invalid input is reported as one
``FILE: /json/pointer: message`` line per problem on stderr, never a traceback,
and nothing is written.
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import Callable, Sequence, TextIO

from . import __version__
from . import batch
from .construct import generate
from .errors import InvalidTestCase, Problem
from .leaves import PluginError, Registry, default_registry
from .loader import load, schema_text
from .output import write_file
from .render import FORMATS, GraphvizMissing, render
from .timeline import timeline

__all__ = ["main"]

EXIT_OK, EXIT_FAIL, EXIT_INVALID, EXIT_INTERNAL = 0, 1, 2, 3
COMMANDS = ("show", "validate", "run", "schema")


def _can_encode(stream: TextIO, text: str = "·…") -> bool:
    try:
        text.encode(getattr(stream, "encoding", None) or "ascii")
        return True
    except (UnicodeEncodeError, LookupError):
        return False


def _write(text: str | bytes, path: str | None) -> None:
    if path is None or path == "-":
        if isinstance(text, bytes):  # png
            sys.stdout.flush()
            sys.stdout.buffer.write(text)
            sys.stdout.buffer.flush()
        else:
            sys.stdout.write(text)
        return
    write_file(path, text)


def _report_invalid(error: InvalidTestCase) -> int:
    for problem in error.problems:
        print(problem.render(error.source), file=sys.stderr)
    return EXIT_INVALID


def _registry(args: argparse.Namespace) -> Registry:
    return default_registry(args.plugin or ())


def _batch(args: argparse.Namespace, files: list[str], job: Callable[..., batch.Outcome],
           job_args: Callable[[int], tuple[object, ...]]) -> int:  # fmt: skip
    """Process *files* in worker processes, report problems as they would be singly, end with a summary."""
    if args.out_dir:
        os.makedirs(args.out_dir, exist_ok=True)
    outcomes = _process(args, job, [job_args(i) for i in range(len(files))], files)
    sys.stdout.write(batch.summary(outcomes))
    return max(o.code for o in outcomes)


def _process(args: argparse.Namespace, job: Callable[..., batch.Outcome], job_args: list[tuple[object, ...]],
             files: list[str]) -> list[batch.Outcome]:  # fmt: skip
    """Run *job* over *files* (in parallel when there are several); print each file's problems."""
    workers = args.jobs if len(files) > 1 else 1
    outcomes = batch.process(job, job_args, files, workers=workers, progress=batch.progress_stream())
    for outcome in outcomes:
        for line in outcome.problems:
            print(line, file=sys.stderr)
    return outcomes


def _expand(args: argparse.Namespace) -> list[str]:
    """The files named, directories replaced by their *.json files; invalid input if none."""
    files = batch.expand(args.files)
    if not files:
        raise InvalidTestCase([Problem((), "no *.json files found", "json")], ", ".join(args.files))
    return files


def _single(args: argparse.Namespace) -> list[str] | None:
    """The expanded file list when this is a batch, else None (one file given, not a directory)."""
    if len(args.files) == 1 and not os.path.isdir(args.files[0]):
        args.file = args.files[0]
        return None
    return _expand(args)


def _targets(args: argparse.Namespace, files: list[str], suffix: str) -> list[str | None]:
    if not args.out_dir:
        return [None] * len(files)
    return [os.path.join(args.out_dir, name) for name in batch.output_names(files, suffix)]


def cmd_show(args: argparse.Namespace) -> int:
    files = _single(args)
    if files is not None:
        if args.output:
            print("btgen_pytrees: -o/--output takes one file; use --out-dir with several", file=sys.stderr)
            return EXIT_INVALID
        fmt = args.format or "unicode"
        suffix = "." + {"unicode": "txt", "ascii": "txt", "matrix": "txt", "btcpp": "xml"}.get(fmt, fmt)
        targets = _targets(args, files, suffix)
        return _batch(args, files, batch.job_show,
                      lambda i: (tuple(args.plugin or ()), fmt, targets[i], args.max_depth))  # fmt: skip
    registry = _registry(args)
    case = load(args.file, registry=registry)
    fmt = args.format or ("unicode" if args.output or _can_encode(sys.stdout) else "ascii")
    try:
        text = render(generate(case, registry=registry), timeline(case), fmt, max_depth=args.max_depth)
    except GraphvizMissing as missing:  # svg/png without Graphviz: a hint, not a traceback
        print(f"btgen_pytrees: {missing}", file=sys.stderr)
        return EXIT_INVALID
    _write(text, args.output)
    return EXIT_OK


def cmd_validate(args: argparse.Namespace) -> int:
    files = _expand(args)
    outcomes = _process(args, batch.job_validate, [(tuple(args.plugin or ()),)] * len(files), files)
    if not args.quiet:
        for outcome in outcomes:
            if outcome.code == EXIT_OK:
                print(f"{outcome.path}: {outcome.summary}")
        if len(files) > 1:
            print(batch.summary(outcomes).splitlines()[-1])
    return max(o.code for o in outcomes)


def cmd_run(args: argparse.Namespace) -> int:
    from .run import run

    files = _single(args)
    if files is not None:
        if args.json or args.junit or args.plot or args.trace:
            print("btgen_pytrees: --json/--junit/--plot/--trace take one file; use --out-dir with several", file=sys.stderr)
            return EXIT_INVALID
        targets = _targets(args, files, "")
        return _batch(args, files, batch.job_run, lambda i: (tuple(args.plugin or ()), targets[i]))
    registry = _registry(args)
    case = load(args.file, registry=registry)
    if args.plot:  # check before running: a missing extra or a bad suffix should not cost a run
        from .run.plot import PlotUnavailable, plot_format, require_matplotlib

        try:
            plot_format(args.plot)
            require_matplotlib()
        except (ValueError, PlotUnavailable) as problem:
            print(f"btgen_pytrees: {problem}", file=sys.stderr)
            return EXIT_INVALID
    trace = (lambda line: print(line, file=sys.stderr)) if args.trace else None
    report = run(case, registry=registry, trace=trace)
    if args.json:
        _write(report.to_json(), args.json)
    if args.junit:
        _write(report.to_junit(), args.junit)
    if args.plot:
        from .run.plot import plot_run

        plot_run(report, case, args.plot)
    sys.stdout.write(report.table())
    return EXIT_OK if report.passed else EXIT_FAIL


def cmd_schema(args: argparse.Namespace) -> int:
    sys.stdout.write(schema_text())
    return EXIT_OK


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m btgen_pytrees",
        description="Generate a py_trees behaviour tree from a JSON test case, show it, or run it.",
        epilog="'show' is the default command: 'python -m btgen_pytrees test.json' prints the tree.",
    )
    parser.add_argument("--version", action="version", version=f"btgen_pytrees {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="{show,validate,run,schema}")
    many = argparse.ArgumentParser(add_help=False)
    many.add_argument("--jobs", "-j", type=int, default=os.cpu_count() or 1, metavar="N",
                      help="with several files: worker processes (default: the number of CPUs)")  # fmt: skip
    many.add_argument("--out-dir", metavar="DIR", help="with several files: write each file's output into DIR")
    plugin = argparse.ArgumentParser(add_help=False)
    plugin.add_argument("--plugin", action="append", metavar="MODULE",
                        help="import MODULE and call its register(registry) to add leaves (repeatable)")  # fmt: skip

    show = sub.add_parser("show", parents=[plugin, many], help="print the generated tree (default command)")
    show.add_argument("files", nargs="+", metavar="FILE", help="test case JSON file (several, or directories: batch mode)")
    show.add_argument("--format", "-f", choices=sorted(FORMATS), help="output format (default: unicode if the terminal can show it, else ascii)")
    show.add_argument("--output", "-o", metavar="PATH", help="write to PATH instead of stdout")
    show.add_argument("--max-depth", type=int, metavar="N", help="text and dot/svg/png formats: show nodes down to depth N only (root = 0); deeper subtrees are collapsed")
    show.set_defaults(func=cmd_show)

    validate = sub.add_parser("validate", parents=[plugin, many], help="check test case files; exit 0 only if all are valid")
    validate.add_argument("files", nargs="+", metavar="FILE", help="test case JSON files or directories")
    validate.add_argument("--quiet", "-q", action="store_true", help="print problems only")
    validate.set_defaults(func=cmd_validate)

    run = sub.add_parser("run", parents=[plugin, many], help="run the tree on the virtual-clock simulator and print verdicts")
    run.add_argument("files", nargs="+", metavar="FILE", help="test case JSON file (several, or directories: batch mode)")
    run.add_argument("--json", metavar="REPORT", help="write the report as JSON (schemas/report.schema.json)")
    run.add_argument("--junit", metavar="XML", help="write the report as JUnit XML")
    run.add_argument("--trace", action="store_true", help="print a line per entry start/finish on stderr")
    run.add_argument("--plot", metavar="PATH", help="draw the run (timeline, oracles, signals) to PATH: .svg, .png or .html; needs the 'plot' extra")
    run.set_defaults(func=cmd_run)

    schema = sub.add_parser("schema", help="print the test case JSON Schema")
    schema.set_defaults(func=cmd_schema)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; return the exit code."""
    args_list = list(sys.argv[1:] if argv is None else argv)
    if args_list and args_list[0] not in COMMANDS and not args_list[0].startswith("-"):
        args_list.insert(0, "show")
    parser = _parser()
    args = parser.parse_args(args_list)
    if args.command is None:
        parser.print_help(sys.stderr)
        return EXIT_INVALID
    func: Callable[[argparse.Namespace], int] = args.func
    try:
        return func(args)
    except InvalidTestCase as error:
        return _report_invalid(error)
    except PluginError as error:
        print(f"btgen_pytrees: {error}", file=sys.stderr)
        return EXIT_INVALID
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        return EXIT_OK
    except Exception as exc:  # noqa: BLE001 - the CLI never shows a traceback
        print(f"btgen_pytrees: internal error: {type(exc).__name__}: {exc}", file=sys.stderr)
        return EXIT_INTERNAL
