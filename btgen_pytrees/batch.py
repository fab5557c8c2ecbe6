"""Batch mode: validate, show or run many test cases, in parallel.

``python -m btgen_pytrees validate|show|run DIR_OR_FILES... [--jobs N] [--out-dir D]``
expands directories to the ``*.json`` files under them (sorted, so the order and
the output names are stable), processes each file in a worker process, and ends
with a summary table. One bad file never stops the others: every file gets an
:class:`Outcome`, and the exit code is the worst of all (0 < 1 < 2 < 3).

A progress line is drawn on stderr when it is a terminal, nothing otherwise.
"""

from __future__ import annotations

import multiprocessing
import multiprocessing.context
import os
import signal
import sys
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from multiprocessing.connection import Connection, wait
from typing import Any, Callable, Iterable, Iterator, Sequence, TextIO

from .construct import generate
from .errors import MAX_LINE, MAX_PROBLEMS, ExitCode, Interrupt, InvalidTestCase, is_interrupt, plural, printable, shorten, xml_safe
from .leaves import FactoryError, PluginError, default_registry
from .loader import MAX_WORK, check_work, load, load_json, parse_json, validate
from .overlap import warning_lines
from .render import GraphvizMissing, render
from .sweep import MAX_VARIATIONS, has_variations, load_sweep
from .sweep.variations import Variations
from .timeline import timeline

__all__ = ["Outcome", "Interrupted", "guard", "expand", "output_names", "process", "summary", "job_validate", "job_show",
           "job_run", "defaults_only", "EXIT_ERROR", "NOT_RUN"]  # fmt: skip

EXIT_ERROR = ExitCode.FAIL
"""Code of a file whose user code (plugin, factory, leaf) raised or killed its worker: like a run's verdict ``error``."""

NOT_RUN = ExitCode.INTERRUPTED
"""Code of a file a Ctrl-C left unprocessed."""

WORDS = {ExitCode.OK: "ok", ExitCode.FAIL: "FAIL", ExitCode.INVALID: "INVALID", ExitCode.INTERNAL: "ERROR"}


@dataclass
class Outcome:
    """What happened to one file.

    Attributes:
        path: the input file
        code: its exit code (0 ok/pass, 1 fail/timeout, 2 invalid, 3 internal error)
        summary: one line for the summary table
        problems: rendered ``FILE: /pointer: message`` lines (for code 2)
        written: files written for it
        result: the word in the summary's result column (default: from *code*)
        outputs: ``(target, data)`` the job produced; the parent process writes
            them (workers never write files, so a killed worker leaves none half-written)
        warnings: the file's warning lines (printed on stderr unless ``--quiet``)
    """

    path: str
    code: int
    summary: str
    problems: list[str] = field(default_factory=list)
    written: list[str] = field(default_factory=list)
    result: str = ""
    outputs: list[tuple[str, str | bytes]] = field(default_factory=list, repr=False)
    junit: str = field(default="", repr=False)
    warnings: list[str] = field(default_factory=list)

    @property
    def word(self) -> str:
        """The result column: ``ok``, ``FAIL``, ``INVALID``, ``ERROR``, ... ."""
        return self.result or WORDS.get(self.code, str(self.code))


def expand(paths: Iterable[str]) -> list[str]:
    """Files as given, directories replaced by the ``*.json`` entries under them (recursive, sorted).

    The walk is iterative (a tree 1,000 folders deep is fine) and does not
    follow symbolic links to directories (no loops). Every ``*.json`` entry that
    is not a directory is listed - a dangling symlink, a FIFO or a device too -
    so the loader reports it instead of it being skipped in silence.
    """
    out: list[str] = []
    for raw in paths:
        if not os.path.isdir(raw):
            out.append(raw)
            continue
        found: list[str] = []
        stack = [raw]
        while stack:
            folder = stack.pop()
            try:
                with os.scandir(folder) as listing:
                    items = list(listing)
            except OSError:
                found.append(folder)  # unreadable folder: the loader says why
                continue
            for item in items:
                try:
                    is_dir = item.is_dir(follow_symlinks=False)
                except OSError:
                    is_dir = False
                if is_dir:
                    stack.append(item.path)
                elif item.name.endswith(".json"):
                    found.append(item.path)
        out.extend(sorted(found, key=_path_key))
    return out


def _path_key(path: str) -> tuple[str, ...]:
    """Sort by path components, so ``a/b.json`` and ``a-b.json`` order as ``pathlib`` does."""
    return tuple(path.split(os.sep))


def output_names(paths: Sequence[str], suffix: str) -> list[str]:
    """``<stem><suffix>`` per path, unique over the whole batch, in input order.

    A stem used by several inputs gets ``-2``, ``-3``, ... on its second and
    later uses, skipping every name another input has (or was given), compared
    case-insensitively (a case-insensitive disk must not merge two reports):
    ``a/x.json``, ``b/x.json`` and ``x-2.json`` give ``x``, ``x-3`` and ``x-2``.
    Characters a file name cannot hold safely (control characters) are replaced.
    """
    stems = [_safe_stem(p) for p in paths]
    taken = {stem.casefold() for stem in stems}
    first: set[str] = set()
    names = []
    for stem in stems:
        key = stem.casefold()
        if key not in first:
            first.add(key)
            names.append(stem + suffix)
            continue
        n = 2
        while f"{stem}-{n}".casefold() in taken:
            n += 1
        taken.add(f"{stem}-{n}".casefold())
        names.append(f"{stem}-{n}{suffix}")
    return names


def _safe_stem(path: str) -> str:
    name = os.path.basename(path.rstrip(os.sep))
    stem = name[: -len(".json")] if name.endswith(".json") and len(name) > len(".json") else name
    stem = "".join("_" if ord(c) < 32 or ord(c) == 127 else c for c in stem)
    return stem if stem not in ("", ".", "..") else "case"


def guard(job: Callable[..., Outcome], path: str, *args: object) -> Outcome:
    """Run *job*, turning every exception into the file's outcome (never raise).

    Invalid input is code 2. Anything user code raises - ``SystemExit`` and
    ``KeyboardInterrupt`` included, since in a worker they can only come from a
    plugin, a factory or a leaf - is this file's error (code 1); it never ends
    the batch or sets the CLI's exit code.
    """
    try:
        return job(path, *args)
    except InvalidTestCase as error:
        lines = [p.render(error.source) for p in error.problems]
        return Outcome(path, ExitCode.INVALID, f"invalid ({len(lines)} problem{'s' if len(lines) != 1 else ''})", _capped(lines))
    except (PluginError, FactoryError, GraphvizMissing) as error:
        return Outcome(path, ExitCode.INVALID, str(error).splitlines()[0], [f"{path}: {error}"])
    except Exception as exc:  # noqa: BLE001 - one bad file must not stop the batch
        why = f"internal error: {type(exc).__name__}: {exc}"
        return Outcome(path, ExitCode.INTERNAL, why, [f"{path}: {why}"])  # printed by every command, 'validate' too
    except BaseException as exc:  # noqa: BLE001 - SystemExit/KeyboardInterrupt from user code
        if is_interrupt(exc):
            raise
        why = f"error: user code raised {type(exc).__name__}" + (f": {exc}" if str(exc) else "")
        return Outcome(path, EXIT_ERROR, why, [f"{path}: {why}"], result="ERROR")


def _capped(lines: list[str], limit: int | None = None) -> list[str]:
    """The first *limit* lines, then one ``… and N more problems`` line."""
    limit = MAX_PROBLEMS if limit is None else limit
    if len(lines) <= limit:
        return lines
    return lines[:limit] + [f"… and {len(lines) - limit} more problems"]


def job_validate(path: str, plugins: Sequence[str], max_variations: int | None = None) -> Outcome:
    registry = default_registry(plugins)
    data = load_json(path)
    case = validate(data, path, registry)
    found = f"ok: {plural(len(case.entries), 'entry', 'entries')}, {plural(len(case.criteria), 'criterion', 'criteria')}"
    if has_variations(data):  # a sweep: every variation is checked
        limit = max_variations if max_variations is not None else MAX_VARIATIONS
        found += f", {plural(load_sweep(data, registry=registry, max_variations=limit, source_name=path).count, 'variation')}"
    return Outcome(path, ExitCode.OK, found, warnings=warning_lines(case))


def job_show(path: str, plugins: Sequence[str], fmt: str, target: str | None, max_depth: int | None,
             indent: int | None | str = "auto") -> Outcome:  # fmt: skip
    """Render one tree; with a *target* it is an output to write, else the text to print (*indent*: json only)."""
    registry = default_registry(plugins)
    case = load(path, registry=registry)
    text = render(generate(case, registry=registry), timeline(case), fmt, max_depth=max_depth, indent=indent)
    if target is None:
        return Outcome(path, ExitCode.OK, fmt, outputs=[("-", text)], warnings=warning_lines(case))
    return Outcome(path, ExitCode.OK, fmt, outputs=[(target, text)], warnings=warning_lines(case))


def job_run(path: str, plugins: Sequence[str], target: str | None, plot: str | None = None,
            junit: bool = False, system: Any = None, max_work: int | None = None,
            require_complete: bool = False) -> Outcome:  # fmt: skip
    """Run one case; outputs: ``<target>.report.json``, ``<target>.junit.xml`` and, with *plot*
    (``svg``/``png``/``html``), ``<target>.<plot>``. With *junit* the JUnit text also comes back
    (``Outcome.junit``) for one batch-wide file. *system* (a ``SystemSpec``) replaces the case's
    (``run --system``). *max_work* is the work budget (default :data:`~.loader.MAX_WORK`)."""
    registry = default_registry(plugins)
    case = load(path, registry=registry, system=system)
    outcome = run_case(path, case, registry, target, plot, junit, max_work, require_complete)
    with open(path, "rb") as fh:  # read again only to tell a sweep, whose defaults alone ran
        return defaults_only(outcome, fh.read())


def defaults_only(outcome: Outcome, raw: bytes) -> Outcome:
    """*outcome* of a file of a batch; if the file (its bytes *raw*) is a sweep, its row says that only its
    defaults ran, and how many variations it has (``run`` of that file alone, or ``--variations``, runs them)."""
    if b'"variations"' not in raw:
        return outcome
    data = parse_json(raw, outcome.path)
    if has_variations(data):
        count = Variations.parse(data["variations"]).count
        outcome.summary += f"; sweep: defaults only; run it alone or with --variations for its {plural(count, 'variation')}"
    return outcome


def run_case(path: str, case: Any, registry: Any, target: str | None, plot: str | None = None,
             junit: bool = False, max_work: int | None = None, require_complete: bool = False) -> Outcome:  # fmt: skip
    """Check the work budget, run a loaded *case* and make *path*'s :class:`Outcome`.

    The one piece behind every engine's ``run`` of a file (:func:`job_run` on the
    local workers, ``job_run_shipped`` on a Dask cluster), so the outputs, the
    summary line, the warnings and ``--require-complete`` are the same wherever it ran.
    """
    from .run import run  # lazily: the run package is ~120 ms of every command's start-up otherwise

    budget = MAX_WORK if max_work is None else max_work
    check_work(case, budget)
    report = run(case, registry=registry, require_complete=require_complete or None, max_work=budget)
    outputs: list[tuple[str, str | bytes]] = []
    if target is not None:
        outputs = [(f"{target}.report.json", report.to_json()), (f"{target}.junit.xml", report.to_junit())]
        if plot is not None:
            from .run.plot import plot_bytes

            outputs.append((f"{target}.{plot}", plot_bytes(report, case, plot)))
    line = f"{report.verdict} after {report.duration:g} s" + (f": {report.message}" if report.message else "")
    word = "" if report.verdict in ("pass", "fail") else report.verdict.upper()
    outcome = Outcome(path, ExitCode.OK if report.passed else ExitCode.FAIL, line, result=word, outputs=outputs, warnings=warning_lines(case))
    if junit:
        outcome.junit = report.to_junit()
    return outcome


class Interrupted(Exception):
    """The batch was stopped by a signal (Ctrl-C, SIGTERM); *outcomes* are the files finished so far.

    Files that had not finished get an outcome with code :data:`NOT_RUN` (``not run``).
    """

    def __init__(self, signum: int, outcomes: list[Outcome]):
        super().__init__(f"interrupted by signal {signum}")
        self.signum = signum
        self.outcomes = outcomes


class _Stop(Interrupt):
    """Raised in a worker by SIGTERM, so ``finally`` blocks (temporary files) run before it exits."""


def _stop(signum: int, frame: object) -> None:
    raise _Stop(signum)


_HELD = (signal.SIGINT, signal.SIGTERM)


@contextmanager
def _signals_held() -> Iterator[None]:
    """Ctrl-C and SIGTERM wait (blocked, not lost) while workers are forked.

    A signal that arrives during ``fork()`` is handled in the parent inside the
    interpreter's after-fork hooks, where an exception is printed and dropped:
    the CLI's handler would raise its :class:`~.errors.Interrupt` into the void
    and ignore the signals after it, so the command would run on. Held, the
    signal is handled after the fork, where it stops the command. The child
    starts with them blocked too and unblocks them once its own handlers are set.
    """
    if not hasattr(signal, "pthread_sigmask"):  # Windows: no fork either
        yield
        return
    before = signal.pthread_sigmask(signal.SIG_BLOCK, _HELD)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


def _worker(conn: Connection) -> None:
    """A worker process: run tasks from *conn* one at a time until told to stop.

    Ctrl-C reaches every process of the terminal's group: workers ignore it and
    let the parent decide (it stops them with SIGTERM, then SIGKILL).
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        signal.signal(signal.SIGTERM, _stop)
        if hasattr(signal, "pthread_sigmask"):  # forked with them held (_signals_held): a SIGTERM waiting now stops it
            signal.pthread_sigmask(signal.SIG_UNBLOCK, _HELD)
        while True:
            try:
                task = conn.recv()
            except EOFError:
                return
            if task is None:
                return
            index, job, path, args = task
            conn.send((index, guard(job, path, *args)))
    except (_Stop, BrokenPipeError):
        return
    finally:  # leaving: a late SIGTERM must end the process quietly, not raise in multiprocessing's exit code
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _death(exitcode: int | None) -> str:
    """Why a worker process ended, in words."""
    if exitcode is None:
        return "the worker process stopped answering"
    if exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            name = f"signal {-exitcode}"
        hint = " (out of memory, or killed from outside)" if -exitcode == signal.SIGKILL else ""
        return f"the worker process was killed by {name}{hint}"
    return f"the worker process exited with status {exitcode} (os._exit or a crash in user code)"


class _Slot:
    """One worker process and the task it is running."""

    def __init__(self, context: multiprocessing.context.BaseContext):
        self.conn, child = context.Pipe()
        self.process = context.Process(target=_worker, args=(child,), daemon=True)
        self.process.start()
        child.close()
        self.task: int | None = None


def _stop_all(slots: list[_Slot], grace: float = 0.5, *, asked: bool = False) -> None:
    """Stop every worker: SIGTERM (finally blocks run, temporary files go), SIGKILL after *grace*.

    With *asked* the workers were already told to leave (sent ``None``): they get
    *grace* seconds to exit on their own before the signals, so a worker that is
    already on its way out is never interrupted in the middle of it.
    """
    deadline = time.monotonic() + grace
    if asked:
        for slot in slots:
            slot.process.join(max(0.0, deadline - time.monotonic()))
        deadline = time.monotonic() + 0.5
    for slot in slots:
        if slot.process.is_alive():
            slot.process.terminate()
    for slot in slots:
        slot.process.join(max(0.0, deadline - time.monotonic()))
        if slot.process.is_alive():
            slot.process.kill()
            slot.process.join(1)
        slot.conn.close()


def process(job: Callable[..., Outcome], jobs_args: Sequence[tuple[object, ...]], paths: Sequence[str], *,
            workers: int = 1, progress: TextIO | None = None, isolate: bool | None = None,
            on_result: Callable[[Outcome], None] | None = None, executor: Any = None) -> list[Outcome]:  # fmt: skip
    """Run ``job(path, *args)`` for each path (``jobs_args[i]`` are path *i*'s extra arguments).

    Outcomes come back in input order whatever order the workers finish in.
    With *isolate* (default: when there are several paths) every job runs in a
    worker process, so user code that kills its process (``os._exit``, a
    signal, the out-of-memory killer) costs only its own file: that file's
    outcome is an error naming the cause, a new worker takes the next file.
    *on_result* is called in this process with each outcome as it arrives
    (the CLI writes the file's outputs there). *executor* (e.g.
    :class:`btgen_pytrees.sweep.executors.DaskExecutor`) runs the jobs instead of
    the local workers: its ``map_unordered(calls)`` yields ``(index, outcome)``
    as they finish (anything but an Outcome is recorded as an internal error).

    Raises:
        Interrupted: on Ctrl-C (or a signal the caller turned into
            KeyboardInterrupt) the workers are stopped at once and the
            outcomes so far are attached.
    """
    results: list[Outcome | None] = [None] * len(paths)
    done = 0

    def tick() -> None:
        if progress is not None:
            width = 30
            filled = width * done // max(1, len(paths))
            progress.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{len(paths)}")
            progress.flush()

    def partial() -> list[Outcome]:
        return [r if r is not None else Outcome(p, NOT_RUN, "not run (interrupted)", result="NOT RUN")
                for p, r in zip(paths, results)]  # fmt: skip

    tick()
    if isolate is None:
        isolate = len(paths) > 1
    slots: list[_Slot] = []
    try:
        if executor is not None:  # another engine (a Dask cluster): the same guarded calls
            from functools import partial as bind

            stream = executor.map_unordered([bind(guard, job, p, *jobs_args[i]) for i, p in enumerate(paths)])
            try:
                for i, result in stream:
                    ok = isinstance(result, Outcome)
                    results[i] = result if ok else Outcome(paths[i], ExitCode.INTERNAL, f"internal error: {result}")
                    if on_result is not None:
                        on_result(results[i])  # type: ignore[arg-type]
                    done += 1
                    tick()
            finally:
                stream.close()  # stopped early (Ctrl-C): the engine cancels what is left
        elif not isolate:
            for i, path in enumerate(paths):
                results[i] = guard(job, path, *jobs_args[i])
                if on_result is not None:
                    on_result(results[i])  # type: ignore[arg-type]
                done += 1
                tick()
        else:
            context = multiprocessing.get_context()
            pending = list(range(len(paths)))[::-1]  # a stack: pop() gives input order
            with _signals_held():  # every worker is in slots before a Ctrl-C is handled, so none is left behind
                slots = [_Slot(context) for _ in range(max(1, min(workers, len(paths))))]
            while done < len(paths):
                for n, slot in enumerate(slots):
                    if slot.task is None and pending:
                        task = pending.pop()
                        try:
                            slot.conn.send((task, job, paths[task], jobs_args[task]))
                            slot.task = task
                        except OSError:  # the idle worker died (killed from outside): a new one, task back
                            pending.append(task)
                            _stop_all([slot])
                            with _signals_held():
                                slots[n] = _Slot(context)
                busy = [s for s in slots if s.task is not None]
                if not busy:  # every idle worker was replaced just now: hand out the tasks again
                    continue
                ready = wait([s.conn for s in busy] + [s.process.sentinel for s in busy])
                for slot in busy:
                    if slot.conn in ready or slot.process.sentinel in ready:
                        outcome = None
                        try:
                            if slot.conn.poll():
                                index, outcome = slot.conn.recv()
                        except (EOFError, OSError):
                            pass
                        if outcome is None:  # the worker died with this task: blame it, start a new worker
                            slot.process.join(1)
                            index = slot.task
                            outcome = Outcome(paths[index], EXIT_ERROR, f"error: {_death(slot.process.exitcode)}",
                                              [f"{paths[index]}: error: {_death(slot.process.exitcode)}"], result="ERROR")  # fmt: skip
                            _stop_all([slot])
                            with _signals_held():
                                slots[slots.index(slot)] = _Slot(context)
                        else:
                            slot.task = None
                        results[index] = outcome
                        if on_result is not None:
                            on_result(outcome)
                        done += 1
                        tick()
    except KeyboardInterrupt as stop:
        _stop_all(slots)
        slots = []
        if progress is not None:
            progress.write("\n")
        raise Interrupted(getattr(stop, "signum", signal.SIGINT), partial()) from None
    finally:
        for slot in slots:  # normal end: ask each worker to leave, then make sure
            try:
                slot.conn.send(None)
            except OSError:
                pass
        _stop_all(slots, grace=2.0, asked=True)
    if progress is not None:
        progress.write("\n")
    return [r for r in results if r is not None]


def merge_junit(outcomes: Sequence[Outcome]) -> str:
    """One JUnit XML document for a whole batch: one ``testsuite`` per input file, in input order.

    A file that ran contributes the suite of its own JUnit report; a file that
    did not (invalid, or its user code failed) contributes a suite with one
    ``testcase`` whose ``error`` says why, so CI servers count it. The
    ``testsuites`` element carries the totals.
    """
    import xml.etree.ElementTree as ET

    root = ET.Element("testsuites")
    totals = {"tests": 0, "failures": 0, "errors": 0}
    for outcome in outcomes:
        suites = ET.fromstring(outcome.junit).iter("testsuite") if outcome.junit else ()
        added = False
        for suite in suites:
            suite.set("file", xml_safe(outcome.path))
            root.append(suite)
            added = True
        if not added:
            suite = ET.SubElement(root, "testsuite", name=xml_safe(outcome.path), file=xml_safe(outcome.path),
                                  tests="1", failures="0", errors="1", time="0")  # fmt: skip
            case = ET.SubElement(suite, "testcase", classname="btgen", name="load and run", time="0")
            detail = xml_safe("\n".join([outcome.summary, *outcome.problems]))
            ET.SubElement(case, "error", message=xml_safe(f"{outcome.word}: {shorten(outcome.summary)}")).text = detail
    for suite in root.iter("testsuite"):
        for key in totals:
            totals[key] += int(suite.get(key, "0"))
    for key, value in totals.items():
        root.set(key, str(value))
    ET.indent(root)
    return ET.tostring(root, encoding="unicode", xml_declaration=True) + "\n"


def summary(outcomes: Sequence[Outcome]) -> str:
    """The table printed at the end of a batch (every text escaped: see :func:`~.errors.printable`)."""
    paths = [printable(o.path) for o in outcomes]
    width = min(max([len(p) for p in paths] + [4]), 80)
    lines = [f"{'file'.ljust(width)}  result   detail", f"{'-' * width}  -------  ------"]
    for path, o in zip(paths, outcomes):
        detail = shorten(o.summary) + (f" -> {', '.join(os.path.basename(w) for w in o.written)}" if o.written else "")
        lines.append(printable(f"{path.ljust(width)}  {o.word.ljust(7)}  {detail}", limit=MAX_LINE))
    order = ["ok", "FAIL", "TIMEOUT", "INVALID", "ERROR", "NOT RUN"]
    counts: dict[str, int] = {}
    for o in sorted(outcomes, key=lambda o: order.index(o.word) if o.word in order else len(order)):
        counts[o.word] = counts.get(o.word, 0) + 1
    lines.append("")
    lines.append(f"{plural(len(outcomes), 'file')}: " + ", ".join(f"{n} {w.lower()}" for w, n in counts.items()))
    return "\n".join(lines) + "\n"


def progress_stream() -> TextIO | None:
    """stderr if it is a terminal (a progress line helps there), else None (logs stay clean)."""
    return sys.stderr if sys.stderr.isatty() else None
