"""Command line: ``python -m btgen_pytrees [show|validate|run|schema] ...``.

``show`` is the default command, so ``python -m btgen_pytrees test.json`` prints
the tree. Exit codes: 0 success (run: pass), 1 run fail/timeout/error,
2 invalid input or usage. Invalid input is reported as one
``FILE: /json/pointer: message`` line per problem on stderr, never a traceback,
and nothing is written.
"""

from __future__ import annotations

import argparse
import fnmatch
import os
import signal
import stat
import sys
from difflib import get_close_matches
from typing import Any, Callable, Iterable, NoReturn, Sequence, TextIO

from . import __version__
from . import batch
from .construct import generate
from .errors import MAX_PROBLEMS, UNSAFE, ExitCode, Interrupt, InvalidTestCase, Problem, UsageError, UserError, printable
from .leaves import Registry, default_registry, loads_user_code
from .loader import MAX_FILE_BYTES, load, load_json, parse_json, schema_for, validate
from .loader import MAX_WORK, check_work
from .model import TestCase
from .overlap import warning_lines
from .parallel import Interrupted, Outcome, merge_junit, process, progress_stream, summary
from .progress import terminal_progress
from .output import check_distinct, check_target, commit, divert_stdout, emit, is_direct, own_stdout
from .output import on_stdout, report_outputs, same_file, stdout_isatty
from .supervise import supervised
from .render import FORMATS, JSON_INDENT_LIMIT, GraphvizMissing, render_chunks
from .render.dot import png_depth
from .run import run
from .run.btlog import BtlogError, btlog_bytes, check_btlog
from .run.export import ExportUnavailable, export_format, require_pyarrow, table_bytes
from .run.plot import PlotUnavailable, plot_bytes, plot_format, require_matplotlib
from .run.replay import replay_html
from .run.report import Report
from .systems import SystemSpec
from .falsify.command import add_arguments as falsify_arguments, cmd_falsify
from .sweep.case import has_variations
from .sweep.command import make_executor, resolved_system, run_options, run_sweep, ship
from .sweep.command import cmd_expand as expand_sweep
from .sweep.overrides import choose, given_values, parse_set, read_params
from .timeline import timeline

__all__ = ["main", "MAX_JOBS"]

COMMANDS = ("show", "validate", "run", "expand", "falsify", "schema")

MAX_JOBS = 64
"""Most worker processes ``--jobs`` may ask for (more is a usage error)."""

SUFFIX_FORMATS = {".svg": "svg", ".png": "png", ".dot": "dot", ".gv": "dot", ".json": "json", ".xml": "btcpp",
                  ".txt": "unicode"}  # fmt: skip
"""``show -o PATH`` without ``--format``: the format its suffix names."""

FORMAT_SUFFIXES = {"unicode": ".txt", "ascii": ".txt", "matrix": ".txt", "btcpp": ".xml"}
BINARY_FORMATS = ("png",)


def _can_encode(stream: TextIO, text: str = "·…") -> bool:
    try:
        text.encode(getattr(stream, "encoding", None) or "ascii")
        return True
    except (UnicodeEncodeError, LookupError):
        return False


def _print(text: str, stream: TextIO | None = None) -> None:
    """Print *text* with every unsafe character escaped (:func:`~.output.emit`); default: stdout."""
    emit(text, stream)


def _err(text: str) -> None:
    _print(text + "\n", sys.stderr)


def _count(n: int, word: str) -> str:
    """``1 file``, ``2 files``."""
    return f"{n} {word}" if n == 1 else f"{n} {word}s"


def _report_invalid(error: InvalidTestCase) -> int:
    problems = error.problems
    for problem in problems[:MAX_PROBLEMS]:
        _err(problem.render(error.source))
    if len(problems) > MAX_PROBLEMS:
        _err(f"{error.source}: … and {len(problems) - MAX_PROBLEMS} more problems")
    return ExitCode.INVALID


def _registry(args: argparse.Namespace) -> Registry:
    return default_registry(args.plugin or ())


def _stdout_text(text: str, fmt: str) -> str:
    """A view's text made safe for a terminal without breaking its syntax.

    JSON gets ``\\uNNNN`` escapes (still valid JSON), XML/SVG character
    references, everything else the ``\\xNN`` escapes of :func:`printable`.
    """
    if fmt == "json":
        return UNSAFE.sub(lambda m: m.group() if m.group() == "\n" else f"\\u{ord(m.group()):04x}", text)
    if fmt in ("btcpp", "svg"):
        return UNSAFE.sub(lambda m: m.group() if m.group() == "\n" else f"&#x{ord(m.group()):x};", text)
    return printable(text, keep_newlines=True)


def _write_stdout(data: str | bytes | Iterable[str | bytes], fmt: str) -> None:
    """Write a view to stdout: text escaped for a terminal (:func:`_stdout_text`), bytes as they are.

    Chunks (:func:`~.render.render_chunks`) are written one by one as they are
    made, so a large tree's view starts at once and is never held whole; the
    escaping works character by character, so chunking does not change it.
    """
    for chunk in [data] if isinstance(data, (str, bytes)) else data:
        if isinstance(chunk, bytes):
            with own_stdout():
                sys.stdout.flush()
                sys.stdout.buffer.write(chunk)
                sys.stdout.buffer.flush()
        else:
            _print(_stdout_text(chunk, fmt))


# -- checks made before any work ------------------------------------------------------------------


def _check_output(path: str | None, option: str, inputs: Sequence[str], made_later: bool = False) -> None:
    if path is not None:
        check_target(path, option, inputs, made_later=made_later)  # OutputError: a usage error


def _check_out_dir(args: argparse.Namespace, files: list[str], writes_json: bool) -> None:
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


def _check_jobs(args: argparse.Namespace) -> None:
    if not 1 <= args.jobs <= MAX_JOBS:
        raise UsageError(f"--jobs {args.jobs}: must be between 1 and {MAX_JOBS}")


def _make_out_dir(args: argparse.Namespace) -> None:
    try:
        os.makedirs(args.out_dir, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"--out-dir {args.out_dir}: cannot be created: {exc.strerror or exc}") from None


# -- batch ----------------------------------------------------------------------------------------


def _batch(args: argparse.Namespace, files: list[str], job: Callable[..., Outcome],
           job_args: Callable[[int], tuple[object, ...]], *,
           after: Callable[[list[Outcome]], None] | None = None) -> int:  # fmt: skip
    """Process *files* in worker processes; write each file's outputs as it finishes, then a summary.

    The output directory is made when the first output is written, so a batch
    of invalid files leaves none.
    """
    made: list[bool] = []

    def write(outcome: Outcome) -> None:
        outputs = [(t, d) for t, d in outcome.outputs if t != "-"]
        if not outputs:
            return
        if args.out_dir and not made:
            _make_out_dir(args)
            made.append(True)
        try:
            outcome.written = commit(outputs)
        except OSError as exc:
            outcome.code, outcome.result = max(outcome.code, ExitCode.INTERNAL), "ERROR"
            outcome.summary = f"cannot write outputs: {exc.strerror or exc}"
        outcome.outputs = [(t, d) for t, d in outcome.outputs if t == "-"]

    try:
        outcomes = _process(args, job, [job_args(i) for i in range(len(files))], files, on_result=write)
    except Interrupted as stop:
        for outcome in stop.outcomes:
            _problems(outcome, args.quiet)
        _print(summary(stop.outcomes))
        _err(f"btgen_pytrees: interrupted by {signal.Signals(stop.signum).name}; files not run are marked NOT RUN")
        return 128 + stop.signum
    if after is not None:
        after(outcomes)
    _print(summary(outcomes))
    return max(o.code for o in outcomes)


def _problems(outcome: Outcome, quiet: bool = False) -> None:
    """A file's problems on stderr, then its warnings (capped where they were made) unless *quiet*."""
    for line in outcome.problems[: MAX_PROBLEMS + 1]:
        _err(line)
    for line in [] if quiet else outcome.warnings:
        _err(line)


def _process(args: argparse.Namespace, job: Callable[..., Outcome], job_args: list[tuple[object, ...]],
             files: list[str], on_result: Callable[[Outcome], None] | None = None) -> list[Outcome]:  # fmt: skip
    """Run *job* over *files* (in worker processes when there are several); print each file's problems."""
    workers = min(args.jobs, len(files))
    executor = getattr(args, "dask", None)  # run --executor dask (btgen_pytrees.sweep.command)
    try:
        outcomes = process(job, job_args, files, workers=workers, progress=progress_stream(),
                                 on_result=on_result, executor=executor)  # fmt: skip
    finally:
        if executor is not None:
            executor.close()
    for outcome in outcomes:
        _problems(outcome, getattr(args, "quiet", False))
    return outcomes


def _expand(args: argparse.Namespace) -> list[str]:
    """The files named, directories replaced by their *.json files; invalid input if none."""
    files = batch.expand(args.files)
    if not files:
        raise InvalidTestCase([Problem((), "no *.json files found", "json")], ", ".join(args.files))
    return files


def _single(args: argparse.Namespace) -> list[str] | None:
    """The expanded file list when this is a batch (several files, a directory, or --out-dir), else None."""
    if len(args.files) == 1 and not os.path.isdir(args.files[0]) and not args.out_dir:
        args.file = args.files[0]
        return None
    if args.set or args.params:
        raise UsageError("--set/--params choose one variation of one file (not a directory, several files or --out-dir)")
    return _expand(args)


def _targets(args: argparse.Namespace, files: list[str], suffixes: Sequence[str]) -> list[str | None]:
    """Each file's output base path in --out-dir (``None`` without it), checked against the inputs."""
    if not args.out_dir:
        return [None] * len(files)
    targets = [os.path.join(args.out_dir, name) for name in batch.output_names(files, "")]
    for target in targets:
        for suffix in suffixes:
            _check_output(target + suffix, "--out-dir", files, made_later=True)
    return list(targets)


def _show_format(args: argparse.Namespace) -> str:
    if args.format:
        return str(args.format)
    if args.output and args.output != "-" and not is_direct(args.output):
        suffix = os.path.splitext(args.output)[1].lower()
        if suffix and suffix not in SUFFIX_FORMATS:  # text in an .html file would be a lie
            raise UsageError(f"-o {args.output}: {suffix} names no format; use {' '.join(SUFFIX_FORMATS)}, "
                             "or give --format for another name")  # fmt: skip
        return SUFFIX_FORMATS.get(suffix, "unicode")
    return "unicode" if args.output or _can_encode(sys.stdout) else "ascii"


def _check_indent(args: argparse.Namespace, fmt: str) -> None:
    if args.indent != "auto" and fmt != "json":
        raise UsageError(f"--indent applies to the json format only, not {fmt}")


def _refuse_binary_to_terminal(fmt: str, path: str | None) -> None:
    if fmt in BINARY_FORMATS and (path is None or path == "-" or same_file(path, "/dev/stdout")) and stdout_isatty():
        raise UsageError(f"--format {fmt} is binary and stdout is a terminal: write it with -o FILE.{fmt} or redirect stdout")


def cmd_show(args: argparse.Namespace) -> int:
    files = _single(args)
    if files is not None:
        if args.output:
            raise UsageError("-o/--output takes one file; use --out-dir with several")
        fmt = args.format or ("unicode" if args.out_dir or _can_encode(sys.stdout) else "ascii")
        if not args.out_dir and fmt in BINARY_FORMATS:
            raise UsageError(f"--format {fmt} with several files needs --out-dir")
        _check_indent(args, fmt)
        suffix = FORMAT_SUFFIXES.get(fmt, "." + fmt)
        if args.out_dir:
            _check_out_dir(args, files, writes_json=suffix == ".json")
        targets = _targets(args, files, [suffix])

        def shown(outcomes: list[Outcome]) -> None:
            for outcome in outcomes:
                for target, data in outcome.outputs:
                    if target == "-" and isinstance(data, str):
                        _print(f"==> {outcome.path} <==\n")
                        _write_stdout(data if data.endswith("\n") else data + "\n", fmt)

        return _batch(args, files, batch.job_show,
                      lambda i: (tuple(args.plugin or ()), fmt, None if targets[i] is None else targets[i] + suffix,
                                 args.max_depth, args.indent), after=shown)  # fmt: skip
    fmt = _show_format(args)
    _check_indent(args, fmt)
    _check_output(args.output, "-o", [args.file])
    _refuse_binary_to_terminal(fmt, args.output)
    registry = _registry(args)
    chosen = _chosen(args, registry)
    case = load(args.file, registry=registry) if chosen is None else validate(chosen, args.file, registry=registry)
    for line in [] if args.quiet else warning_lines(case):
        _err(line)
    root = generate(case, registry=registry)
    try:  # the text views are drawn while they are written (render_chunks)
        chunks = render_chunks(root, timeline(case), fmt, max_depth=args.max_depth, indent=args.indent)
    except GraphvizMissing as missing:  # svg/png without Graphviz: a hint, not a traceback
        raise UsageError(str(missing)) from None
    if fmt == "png" and args.max_depth is None and png_depth(root) is not None:  # collapsed to stay readable: say so
        _err(f"{args.file}: {sum(1 for _ in root.iterate())} nodes cannot be read in one PNG: drawn down to depth "
             f"{png_depth(root)} (deeper subtrees are '… N more nodes' boxes); choose with --max-depth N, or use .svg")
    if args.output is None or args.output == "-":
        _write_stdout(chunks, fmt)
    else:
        commit([(args.output, chunks)])
    return ExitCode.OK


def cmd_validate(args: argparse.Namespace) -> int:
    files = _expand(args)
    try:
        outcomes = _process(args, batch.job_validate, [(tuple(args.plugin or ()), args.max_variations)] * len(files), files)
    except Interrupted as stop:  # Ctrl-C/SIGTERM while a sweep's variations are checked: 130/143, not an error
        for outcome in stop.outcomes:
            _problems(outcome, args.quiet)
        checked = sum(o.code != ExitCode.INTERRUPTED for o in stop.outcomes)
        _err(f"btgen_pytrees: interrupted by {signal.Signals(stop.signum).name} after checking {checked} of {_count(len(files), 'file')}")
        return 128 + stop.signum
    if not args.quiet:
        for outcome in outcomes:
            if outcome.code == ExitCode.OK:
                _print(f"{outcome.path}: {outcome.summary}\n")
        if len(files) > 1:
            _print(summary(outcomes).splitlines()[-1] + "\n")
    return max(o.code for o in outcomes)


def _plot_check(path: str) -> str:
    """The plot format of *path* (or of a bare ``svg``/``png``/``html``), with matplotlib importable."""
    try:
        fmt = path.lower() if path.lower() in ("svg", "png", "html") else plot_format(path)
        require_matplotlib()
    except (ValueError, PlotUnavailable) as problem:
        raise UsageError(str(problem)) from None
    return fmt


def _system(args: argparse.Namespace) -> SystemSpec | None:
    """``--system TYPE[:CONFIG]`` as a spec (CONFIG relative to the current directory), or None."""
    if not args.system:
        return None
    kind, colon, config = args.system.partition(":")
    if not kind or (colon and not config):
        raise UsageError(f"--system {args.system}: expected TYPE or TYPE:CONFIG")
    return SystemSpec(kind, os.path.abspath(config) if config else None)


def _chosen(args: argparse.Namespace, registry: Registry | None = None) -> dict[str, Any] | None:
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
    given.update(given_values(dict(pairs)))
    system = _system(args) if hasattr(args, "system") else None
    return choose(load_json(args.file), args.file, given, registry=registry or _registry(args), system=system).document


def _replay_check(args: argparse.Namespace) -> None:
    """--replay/--btlog need a file name, --btlog a .btlog one: found out before the run, not after it."""
    for option in ("replay", "btlog"):
        if getattr(args, option) == "-":  # stdout carries the verdict table
            raise UsageError(f"--{option} -: give a file name (stdout carries the verdict table)")
    if args.btlog and os.path.splitext(args.btlog)[1].lower() != ".btlog" and not is_direct(args.btlog):
        raise UsageError(f"--btlog {args.btlog}: the file name must end in .btlog (Groot2 opens only those)")


def _btlog_tree(args: argparse.Namespace, case: TestCase, registry: Registry) -> Any:
    """For --btlog: the tree to log (generated like the run's), checked before the run: at most 65,535 nodes."""
    if not args.btlog:
        return None
    root = generate(case, registry=registry)
    try:
        check_btlog(root, case.timeout + case.tick)
    except BtlogError as problem:
        raise UsageError(f"--btlog {args.btlog}: {problem}") from None
    return root


def _replay_outputs(args: argparse.Namespace, report: Report, case: TestCase, registry: Registry,
                    logged: Any) -> list[tuple[str, bytes]]:  # fmt: skip
    """The --replay page and the --btlog file, drawn from the run's trace on a tree generated alike."""
    if not (args.replay or args.btlog):
        return []
    outputs = []
    if args.replay:
        outputs.append((args.replay, replay_html(report, case, generate(case, registry=registry), max_depth=args.max_depth,
                                                 signals=args.signals)))  # fmt: skip
    if args.btlog:
        outputs.append((args.btlog, btlog_bytes(report.trace, logged)))
    return outputs


def _is_sweep(path: str) -> bool:
    """Whether *path* holds a sweep (a readable test case with ``variations``); a file that cannot be read is not."""
    try:
        return has_variations(load_json(path))
    except InvalidTestCase:
        return False


def _sweep_alone(args: argparse.Namespace, path: str, target: str | None, plot: str | None, system: SystemSpec | None) -> int:
    """A batch of one sweep file (``run S.json --out-dir D``, a folder holding only S.json): the sweep's
    variations, as ``run S.json`` runs them, with the sweep's report, JUnit and map as its ``--out-dir`` files."""
    alone = argparse.Namespace(**vars(args))
    alone.file = path
    alone.json = alone.junit = alone.plot = None
    extra: list[tuple[str, str]] = []
    if target is not None:
        alone.json, alone.junit = target + ".report.json", target + ".junit.xml"
        alone.plot = f"{target}.{plot}" if plot else None
        if args.junit:
            extra.append((args.junit, "junit"))
    else:
        alone.junit = args.junit
    return run_sweep(alone, load_json(path), system, extra=extra, out_dir=args.out_dir)


def cmd_run(args: argparse.Namespace) -> int:
    if args.scheduler and args.executor != "dask":
        raise UsageError("--scheduler applies to --executor dask only; add --executor dask to run there")

    files = _single(args)
    if files is not None:
        if args.json or args.trace:
            raise UsageError("--json/--trace take one file; with several use --out-dir (a report per file)")
        if args.replay or args.btlog or args.signals_out or args.signals:
            raise UsageError("--replay/--btlog/--signals-out/--signals take one file")
        plot = None
        if args.plot:
            if not args.out_dir:
                raise UsageError("--plot with several files needs --out-dir (one picture per file)")
            plot = _plot_check(args.plot)
        if args.junit:
            _check_output(args.junit, "--junit", files)
        if args.out_dir:
            _check_out_dir(args, files, writes_json=True)
        suffixes = [".report.json", ".junit.xml"] + ([f".{plot}"] if plot else [])
        targets = _targets(args, files, suffixes)
        check_distinct([("--junit", args.junit)] + [("--out-dir", t + x) for t in targets if t for x in suffixes])

        def junit(outcomes: list[Outcome]) -> None:
            if args.junit:
                commit([(args.junit, merge_junit(outcomes))])

        system = _system(args)
        if len(files) == 1 and _is_sweep(files[0]):  # a sweep given alone runs its variations, in any form
            return _sweep_alone(args, files[0], targets[0], plot, system)
        if args.variations:
            if args.executor == "dask":
                raise UsageError("--variations runs each sweep on one local worker; with --executor dask run each sweep alone")
            return _batch(args, files, batch.job_run_variations,
                          lambda i: (tuple(args.plugin or ()), targets[i], plot, bool(args.junit), system, args.max_work,
                                     args.require_complete, args.max_variations),
                          after=junit)  # fmt: skip
        if args.executor == "dask":  # on a Dask cluster (btgen_pytrees.sweep.command)
            executor, job, job_args = dask_batch_args(args, files, targets, plot, system)
            args.dask = executor
            return _batch(args, files, job, job_args, after=junit)

        return _batch(args, files, batch.job_run,
                      lambda i: (tuple(args.plugin or ()), targets[i], plot, bool(args.junit), system, args.max_work,
                                    args.require_complete),
                      after=junit)  # fmt: skip
    outputs_named = ("json", "junit", "plot", "replay", "btlog", "signals_out")
    for option in outputs_named:
        _check_output(getattr(args, option), f"--{option.replace('_', '-')}", [args.file])
    check_distinct([(f"--{option.replace('_', '-')}", getattr(args, option)) for option in outputs_named])
    _replay_check(args)
    if args.signals_out:  # a bad suffix or a missing pyarrow: found out before the run
        try:
            if export_format(args.signals_out) == "parquet":
                require_pyarrow()
        except (ValueError, ExportUnavailable) as exc:
            raise UsageError(str(exc)) from None
    if args.plot:  # check before running: a missing extra or a bad suffix should not cost a run
        _plot_check(args.plot)
        plot_format(args.plot)
    data = _chosen(args) or load_json(args.file)
    if has_variations(data):  # a sweep: every variation (btgen_pytrees.sweep)
        if args.replay or args.btlog or args.signals_out or args.signals:
            raise UsageError("--replay/--btlog/--signals-out/--signals take one case, not a sweep's variations")

        return run_sweep(args, data, _system(args))
    registry = _registry(args)
    case = validate(data, args.file, registry=registry, system=_system(args))
    check_work(case, args.max_work)  # before anything runs: a tree whose one tick exceeds the budget
    for line in [] if args.quiet else warning_lines(case):
        _err(line)
    logged = _btlog_tree(args, case, registry)
    trace = (lambda line: _err(line)) if args.trace else None
    progress = None if args.trace else terminal_progress(case.name, case.timeout, sys.stderr)  # a terminal's line only
    try:
        report = run(case, registry=registry, trace=trace, require_complete=args.require_complete or None,
                     progress=progress, max_work=args.max_work)  # fmt: skip
    finally:
        if progress is not None:
            progress.done()
    if args.signals and report.trace is not None:  # a typo would quietly draw nothing (globs as run.export.select)
        for pattern in args.signals:
            if not any(fnmatch.fnmatchcase(name, pattern) for name in report.trace.signals):
                _err(f"btgen_pytrees: warning: --signals {pattern!r} matches no signal of the run")
    outputs = report_outputs(report, args.json, args.junit, args.plot,
                             lambda: plot_bytes(report, case, plot_format(args.plot), args.signals))  # fmt: skip
    if args.signals_out:
        outputs.append((args.signals_out, table_bytes(report, case, export_format(args.signals_out), args.signals)))
    outputs += _replay_outputs(args, report, case, registry, logged)
    shown = {args.json: "json", args.junit: "btcpp"}  # '-': printed like any view, escaped for a terminal
    outputs = [(t, _stdout_text(d, shown.get(t, "")).encode("utf-8") if t == "-" and isinstance(d, str) else d)
               for t, d in outputs]  # fmt: skip
    commit(outputs)  # all together, after everything was made: a failure leaves none
    _print(report.table(), sys.stderr if on_stdout(t for t, _ in outputs) else None)  # stdout: the document only
    return ExitCode.OK if report.passed else ExitCode.FAIL


def cmd_expand(args: argparse.Namespace) -> int:
    return expand_sweep(args, _chosen(args))


def cmd_schema(args: argparse.Namespace) -> int:
    import json

    _print(json.dumps(schema_for(_registry(args)), indent=2, ensure_ascii=False) + "\n")
    return ExitCode.OK


def _non_negative(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"{value} is negative; the root is depth 0")
    return value


MAX_INDENT = 16
"""Most spaces ``--indent`` may ask for: every tree level indents by twice that (the node and its
``children`` list), so a large N on a deep tree multiplies the file's size for nothing."""


def _indent(text: str) -> int | None | str:
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


def _positive(text: str) -> int:
    try:
        value = int(float(text)) if "e" in text.lower() else int(text)
    except (ValueError, OverflowError):
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value} must be at least 1")
    return value


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (``btgen_pytrees: error: ...``), exit 2."""

    def error(self, message: str) -> NoReturn:
        _err(f"btgen_pytrees: error: {message} (see --help)")
        raise SystemExit(ExitCode.INVALID)


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="python -m btgen_pytrees",
        description="Generate a py_trees behaviour tree from a JSON test case, show it, or run it.",
        epilog="'show' is the default command: 'python -m btgen_pytrees test.json' prints the tree.",
    )
    parser.add_argument("--version", action="version", version=f"btgen_pytrees {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="{show,validate,run,expand,falsify,schema}", parser_class=_Parser)
    jobs = argparse.ArgumentParser(add_help=False)
    jobs.add_argument("--jobs", "-j", type=int, default=min(os.cpu_count() or 1, MAX_JOBS), metavar="N",
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

    show = sub.add_parser("show", parents=[plugin, many, chosen], help="print the generated tree (default command)")
    show.add_argument("files", nargs="+", metavar="FILE", help="test case JSON file (several, or directories: batch mode)")
    show.add_argument("--format", "-f", choices=sorted(FORMATS), help="output format (default: from the -o suffix, else unicode if the terminal can show it, else ascii)")
    show.add_argument("--output", "-o", metavar="PATH", help="write to PATH instead of stdout (.svg/.png/.dot/.json/.xml/.txt choose the format)")
    show.add_argument("--max-depth", type=_non_negative, metavar="N", help="text and dot/svg/png formats: show nodes down to depth N only (root = 0); deeper subtrees are collapsed")
    show.add_argument("--indent", type=_indent, default="auto", metavar="N|none",
                      help=f"json format: indent N spaces per level (0 to {MAX_INDENT}; 0: a key per line), or 'none': compact, one line (default: 2 up to {JSON_INDENT_LIMIT:,} nodes, compact above)")  # fmt: skip
    show.set_defaults(func=cmd_show)

    validate = sub.add_parser("validate", parents=[plugin, jobs], help="check test case files; exit 0 only if all are valid")
    validate.add_argument("files", nargs="+", metavar="FILE", help="test case JSON files or directories")
    validate.add_argument("--quiet", "-q", action="store_true", help="print problems only (no 'ok' lines, no warnings)")
    validate.add_argument("--max-variations", type=int, metavar="N", help="a sweep may have at most N variations (default 10000)")
    validate.set_defaults(func=cmd_validate)

    run = sub.add_parser("run", parents=[plugin, many, chosen], help="run the tree against its system (default: the virtual-clock simulator) and print verdicts")
    run.add_argument("files", nargs="+", metavar="FILE", help="test case JSON file (several, or directories: batch mode)")
    run.add_argument("--json", metavar="REPORT", help="write the report as JSON (schemas/report.schema.json; a sweep's: schemas/sweep-report.schema.json)")
    run.add_argument("--junit", metavar="XML", help="write the report as JUnit XML (several files: one file, a testsuite per case)")
    run.add_argument("--require-complete", action="store_true",
                     help="fail a run that passes before every entry has run to success (as the case key require_complete)")
    run.add_argument("--trace", action="store_true",
                     help="print a line per entry start/success/failure/stopped on stderr (docs/semantics.md#the-trace)")
    run.add_argument("--system", metavar="TYPE[:CONFIG]", help="run against this system instead of the case's own (CONFIG relative to the current directory); checked like the case's 'system'")
    run.add_argument("--plot", metavar="PATH", help="draw the run (timeline, oracles, signals) to PATH: .svg, .png or .html; several files: svg, png or html, one per file in --out-dir; needs the 'plot' extra")
    run.add_argument("--replay", metavar="PATH", help="write a replay page of the run to PATH: one self-contained HTML file (tree, time slider, statuses, signals, verdicts, a SUMO run's scene)")
    run.add_argument("--signals", action="append", metavar="PATTERN", help="draw/export only the signals matching this glob (repeatable: ego.*, *.speed); for --plot, --replay, --signals-out")
    run.add_argument("--signals-out", metavar="PATH", help="write every signal on every tick, and every entry's and criterion's status, as a table: .csv, or .parquet (needs pyarrow: the 'parquet' extra)")
    run.add_argument("--max-depth", type=_non_negative, metavar="N", help="--replay: open with the subtrees below depth N collapsed (default: a tree over 100 nodes opens breadth first)")
    run.add_argument("--max-work", type=_positive, default=MAX_WORK, metavar="N",
                     help=f"work budget of a run: ticks x (entries + criteria + 10), default {MAX_WORK:.0e}; a case over it is refused before running")  # fmt: skip
    run.add_argument("--btlog", metavar="PATH", help="write the run as a BehaviorTree.CPP .btlog (FileLogger2) for Groot2")
    run.add_argument("--max-variations", type=int, metavar="N", help="a sweep may have at most N variations (default 10000)")
    run.add_argument("--variations", action="store_true",
                     help="batch mode: run every variation of each sweep file, on one worker per file (default: a sweep in a batch of several files runs its defaults, and its row says so; a sweep given alone always runs its variations)")  # fmt: skip
    run.add_argument("--executor", choices=("local", "dask"), default="local",
                     help="where runs execute: local worker processes (--jobs), or a Dask cluster (--scheduler)")  # fmt: skip
    run.add_argument("--scheduler", metavar="ADDRESS",
                     help="with --executor dask: the scheduler, tcp://HOST:PORT (default: $DASK_SCHEDULER_ADDRESS)")  # fmt: skip
    run.set_defaults(func=cmd_run)

    expand = sub.add_parser("expand", parents=[plugin, chosen], help="write each variation of a sweep as a concrete test case")
    expand.add_argument("file", metavar="FILE", help="test case JSON file with variations")
    expand.add_argument("--out-dir", required=True, metavar="DIR", help="write name[gap=5,...].json files into DIR")
    expand.add_argument("--max-variations", type=int, metavar="N", help="refuse more than N variations (default 10000)")
    expand.set_defaults(func=cmd_expand)

    falsify = sub.add_parser("falsify", parents=[plugin, many], help="search a sweep's parameter box for a failing setting (docs/falsify.md)")
    falsify_arguments(falsify)
    falsify.set_defaults(func=cmd_falsify)

    schema = sub.add_parser("schema", parents=[plugin],
                            help="print the test case JSON Schema, with the params of every registered action")
    schema.set_defaults(func=cmd_schema)
    return parser


_stopping: list[int] = []
"""The signal that is stopping the CLI, once one arrived."""


def _on_signal(signum: int, frame: Any) -> None:
    """Stop the command: raise :class:`~.errors.Interrupt` for the first signal, ignore the ones after it.

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
        _err("btgen_pytrees: standard output is closed; redirect it (to a file or /dev/null) instead")
        return ExitCode.INVALID
    args_list = list(sys.argv[1:] if argv is None else argv)
    if args_list and args_list[0] not in COMMANDS and not args_list[0].startswith("-"):
        word = args_list[0]
        if _looks_like_a_command(word):
            hint = get_close_matches(word, COMMANDS, n=1)
            _err(f"btgen_pytrees: unknown command {word!r}" + (f" (did you mean {hint[0]!r}?)" if hint else
                 f"; the commands are {', '.join(COMMANDS)}, or give a test case FILE to show it"))  # fmt: skip
            return ExitCode.INVALID
        args_list.insert(0, "show")
    parser = _parser()
    try:
        args = parser.parse_args(args_list)
    except SystemExit as done:  # --help, --version (0) or a usage error (2, already printed)
        return done.code if isinstance(done.code, int) else ExitCode.INVALID
    if args.command is None:
        parser.print_help(sys.stderr)
        return ExitCode.INVALID
    if argv is None:  # the real CLI process
        divert_stdout()  # stdout carries only what btgen_pytrees prints; user code's prints go to stderr
        if loads_user_code(getattr(args, "plugin", None) or ()):  # no verdict, no exit 0 (btgen_pytrees.supervise)
            return supervised(lambda: _command(args, real=True), _err)
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
            _check_jobs(args)
        return func(args)
    except InvalidTestCase as error:
        return _report_invalid(error)
    except UserError as problem:  # the one family of input errors: a usage error, a plugin, a factory, ...
        for line in problem.messages():
            _err(f"btgen_pytrees: {line}")
        return ExitCode.INVALID
    except Interrupt as stop:
        _err(f"btgen_pytrees: interrupted by {signal.Signals(stop.signum).name}")
        return 128 + stop.signum
    except Interrupted as stop:
        _err(f"btgen_pytrees: interrupted by {signal.Signals(stop.signum).name}")
        return 128 + stop.signum
    except BrokenPipeError:
        return ExitCode.OK
    except Exception as exc:  # noqa: BLE001 - the CLI never shows a traceback
        _err(f"btgen_pytrees: internal error: {type(exc).__name__}: {exc}")
        return ExitCode.INTERNAL
    except BaseException as exc:  # noqa: BLE001 - SystemExit/KeyboardInterrupt raised by user code
        if isinstance(exc, KeyboardInterrupt) and not real:
            raise  # a test's own Ctrl-C
        _err(f"btgen_pytrees: error: user code (a plugin or leaf) raised {type(exc).__name__}" + (f": {exc}" if str(exc) else ""))
        return ExitCode.FAIL
    finally:
        for signum, handler in handlers.items():
            signal.signal(signum, handler)


def dask_batch_args(args: argparse.Namespace, files: list[str], targets: Sequence[str | None],
                    plot: str | None, system: Any = None) -> tuple[Any, Callable[..., Outcome], Callable[[int], tuple[object, ...]]]:  # fmt: skip
    """``run FILE... --executor dask``: the cluster, the job and its arguments for the CLI's batch.

    Each file is read here (with the loader's limits) and its bytes travel with
    its task, so workers need no copy of the files; the files the cases name
    (SUMO configurations and their networks and routes) and the ``--plugin``
    files are sent to every worker once. The outputs come back as data and the
    CLI writes them here, never on a worker.
    """
    executor = make_executor(args)
    shipped: list[tuple[bytes | None, list[Problem], SystemSpec | None]] = []
    for path in files:
        try:
            raw: bytes | None = _read(path)
            problems: list[Problem] = []
        except InvalidTestCase as error:
            raw, problems = None, list(error.problems)
        shipped.append((raw, problems, _system_of(raw, path, system)))
    options = ship(executor, run_options(args), [s for _, _, s in shipped], default_registry(()))

    def job_args(i: int) -> tuple[object, ...]:
        raw, problems, spec = shipped[i]
        return (options, raw, problems, targets[i], plot, bool(args.junit), spec)

    return executor, batch.job_run_shipped, job_args


def _system_of(raw: bytes | None, path: str, system: SystemSpec | None) -> SystemSpec | None:
    """The system of the file *path* holding *raw*, resolved here (None if it cannot be read: the worker says why)."""
    if system is not None or raw is None:
        return system
    try:
        document = parse_json(raw, path)
    except InvalidTestCase:
        return None
    return resolved_system(document, path, None)


def _read(path: str) -> bytes:
    """The file's bytes, with the loader's checks (size limit, no FIFOs) - read once, here."""
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):  # a FIFO would block the open
            raise InvalidTestCase([Problem((), "not a regular file", "json")], path)
        with open(path, "rb") as fh:
            raw = fh.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise InvalidTestCase([Problem((), f"cannot read file: {exc.strerror or exc}", "json")], path) from None
    if len(raw) > MAX_FILE_BYTES:
        raise InvalidTestCase([Problem((), f"file is larger than {MAX_FILE_BYTES} bytes", "limit")], path)
    return raw
