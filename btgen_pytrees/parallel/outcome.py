"""What happened to one job of many: :class:`Outcome`, the :func:`guard` that makes one of whatever a job
does or raises, and the renderings of many outcomes (the summary table, one JUnit document).

The executors (:mod:`.pool`, :mod:`.dask`) run jobs and return outcomes; they know nothing of what a
job does. A job's invalid input is classified by the one family :class:`~btgen_pytrees.errors.UserError`
(an :class:`~btgen_pytrees.errors.InvalidTestCase` with its problems listed), never by importing the
error types of the modules that raise them.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from typing import Callable, Sequence

from ..errors import MAX_LINE, MAX_PROBLEMS, ExitCode, InvalidTestCase, UserError, is_interrupt, plural, printable, shorten, xml_safe

__all__ = ["Outcome", "Interrupted", "WorkerDied", "guard", "died", "capped", "summary", "merge_junit", "WORDS"]

WORDS = {ExitCode.OK: "ok", ExitCode.FAIL: "FAIL", ExitCode.INVALID: "INVALID", ExitCode.INTERNAL: "ERROR"}
"""The summary's result column for an outcome's code (unless the outcome names its own)."""


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
        died: the worker process died running it (see :func:`died`)
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
    died: bool = False

    @property
    def word(self) -> str:
        """The result column: ``ok``, ``FAIL``, ``INVALID``, ``ERROR``, ... ."""
        return self.result or WORDS.get(self.code, str(self.code))


class WorkerDied(Exception):
    """What an executor gives in place of a job's outcome when the worker process died running it
    (not raised: given back); ``str()`` says how."""


def died(path: str, why: str) -> Outcome:
    """The outcome of a job whose worker process died running it (*why*: how): an error of that run
    (code 1, like a leaf that raises), not an internal error - user code or a simulator killed it
    (``os._exit``, a crash, a signal, the out-of-memory killer). The local pool and a Dask cluster
    say it alike."""
    return Outcome(path, ExitCode.FAIL, f"error: {why}", [f"{path}: error: {why}"], result="ERROR", died=True)


def guard(job: Callable[..., Outcome], path: str, *args: object) -> Outcome:
    """Run *job*, turning every exception into the file's outcome (never raise).

    Invalid input (an :class:`~btgen_pytrees.errors.UserError`: an invalid test case, an unusable plugin
    or factory, a missing tool) is code 2. Anything user code raises - ``SystemExit`` and
    ``KeyboardInterrupt`` included, since in a worker they can only come from a
    plugin, a factory or a leaf - is this file's error (code 1); it never ends
    the batch or sets the CLI's exit code.
    """
    try:
        return job(path, *args)
    except InvalidTestCase as error:
        lines = [p.render(error.source) for p in error.problems]
        return Outcome(path, ExitCode.INVALID, f"invalid ({len(lines)} problem{'s' if len(lines) != 1 else ''})", capped(lines))
    except UserError as error:
        return Outcome(path, ExitCode.INVALID, str(error).splitlines()[0], [f"{path}: {error}"])
    except Exception as exc:  # noqa: BLE001 - one bad file must not stop the batch
        why = f"internal error: {type(exc).__name__}: {exc}"
        return Outcome(path, ExitCode.INTERNAL, why, [f"{path}: {why}"])  # printed by every command, 'validate' too
    except BaseException as exc:  # noqa: BLE001 - SystemExit/KeyboardInterrupt from user code
        if is_interrupt(exc):
            raise
        why = f"error: user code raised {type(exc).__name__}" + (f": {exc}" if str(exc) else "")
        return Outcome(path, ExitCode.FAIL, why, [f"{path}: {why}"], result="ERROR")


def capped(lines: list[str], limit: int | None = None) -> list[str]:
    """The first *limit* lines, then one ``… and N more problems`` line."""
    limit = MAX_PROBLEMS if limit is None else limit
    if len(lines) <= limit:
        return lines
    return lines[:limit] + [f"… and {plural(len(lines) - limit, 'more problem')}"]


class Interrupted(Exception):
    """The batch was stopped by a signal (Ctrl-C, SIGTERM); *outcomes* are the files finished so far.

    Files that had not finished get an outcome with code ``ExitCode.INTERRUPTED`` (``not run``).
    """

    def __init__(self, signum: int, outcomes: list[Outcome]):
        super().__init__(f"interrupted by signal {signum}")
        self.signum = signum
        self.outcomes = outcomes


def merge_junit(outcomes: Sequence[Outcome]) -> str:
    """One JUnit XML document for a whole batch: one ``testsuite`` per input file, in input order.

    A file that ran contributes the suite of its own JUnit report; a file that
    did not (invalid, or its user code failed) contributes a suite with one
    ``testcase`` whose ``error`` says why, so CI servers count it. The
    ``testsuites`` element carries the totals.
    """
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
