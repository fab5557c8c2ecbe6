"""Batch mode: validate, show or run many test cases, in parallel.

``python -m btgen_pytrees validate|show|run DIR_OR_FILES... [--jobs N] [--out-dir D]``
expands directories to the ``*.json`` files under them (sorted, so the order and
the output names are stable), processes each file in a worker process, and ends
with a summary table. One bad file never stops the others: every file gets an
:class:`Outcome`, and the exit code is the worst of all (0 < 1 < 2 < 3).

A progress line is drawn on stderr when it is a terminal, nothing otherwise.
"""

from __future__ import annotations

import pathlib
import sys
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from functools import partial
from typing import Callable, Iterable, Sequence, TextIO

from .output import write_file

__all__ = ["Outcome", "expand", "output_names", "process", "summary", "job_validate", "job_show", "job_run"]


@dataclass
class Outcome:
    """What happened to one file.

    Attributes:
        path: the input file
        code: its exit code (0 ok/pass, 1 fail/timeout, 2 invalid, 3 internal error)
        summary: one line for the summary table
        problems: rendered ``FILE: /pointer: message`` lines (for code 2)
        written: files written for it
    """

    path: str
    code: int
    summary: str
    problems: list[str] = field(default_factory=list)
    written: list[str] = field(default_factory=list)


def expand(paths: Iterable[str]) -> list[str]:
    """Files as given, directories replaced by their ``*.json`` files (recursive, sorted)."""
    out: list[str] = []
    for raw in paths:
        path = pathlib.Path(raw)
        if path.is_dir():
            out.extend(str(p) for p in sorted(path.rglob("*.json")) if p.is_file())
        else:
            out.append(raw)
    return out


def output_names(paths: Sequence[str], suffix: str) -> list[str]:
    """``<stem><suffix>`` per path, made unique (``x.json`` twice → ``x``, ``x-2``) in input order."""
    seen: dict[str, int] = {}
    names = []
    for p in paths:
        stem = pathlib.Path(p).stem or "case"
        seen[stem] = seen.get(stem, 0) + 1
        names.append(f"{stem}{suffix}" if seen[stem] == 1 else f"{stem}-{seen[stem]}{suffix}")
    return names


def _guard(job: Callable[..., Outcome], path: str, *args: object) -> Outcome:
    """Run *job*, turning invalid input into code 2 and anything else into code 3 (never raise)."""
    from .errors import InvalidTestCase
    from .leaves import PluginError
    from .render import GraphvizMissing

    try:
        return job(path, *args)
    except InvalidTestCase as error:
        lines = [p.render(error.source) for p in error.problems]
        return Outcome(path, 2, f"invalid ({len(lines)} problem{'s' if len(lines) != 1 else ''})", lines)
    except (PluginError, GraphvizMissing) as error:
        return Outcome(path, 2, str(error).splitlines()[0], [f"{path}: {error}"])
    except Exception as exc:  # noqa: BLE001 - one bad file must not stop the batch
        return Outcome(path, 3, f"internal error: {type(exc).__name__}: {exc}")


def job_validate(path: str, plugins: Sequence[str]) -> Outcome:
    from .leaves import default_registry
    from .loader import load

    case = load(path, registry=default_registry(plugins))
    return Outcome(path, 0, f"ok: {len(case.entries)} entries, {len(case.criteria)} criteria")


def job_show(path: str, plugins: Sequence[str], fmt: str, target: str | None, max_depth: int | None) -> Outcome:
    from .construct import generate
    from .leaves import default_registry
    from .loader import load
    from .render import render
    from .timeline import timeline

    registry = default_registry(plugins)
    case = load(path, registry=registry)
    text = render(generate(case, registry=registry), timeline(case), fmt, max_depth=max_depth)
    if target is None:
        return Outcome(path, 0, f"{fmt}: {len(text)} {'bytes' if isinstance(text, bytes) else 'characters'}")
    write_file(target, text)
    return Outcome(path, 0, f"{fmt} -> {target}", written=[target])


def job_run(path: str, plugins: Sequence[str], target: str | None) -> Outcome:
    from .leaves import default_registry
    from .loader import load
    from .run import run

    registry = default_registry(plugins)
    report = run(load(path, registry=registry), registry=registry)
    written = []
    if target is not None:
        write_file(f"{target}.report.json", report.to_json())
        write_file(f"{target}.junit.xml", report.to_junit())
        written = [f"{target}.report.json", f"{target}.junit.xml"]
    line = f"{report.verdict} after {report.duration:g} s" + (f": {report.message}" if report.message else "")
    return Outcome(path, 0 if report.passed else 1, line, written=written)


def process(job: Callable[..., Outcome], jobs_args: Sequence[tuple[object, ...]], paths: Sequence[str], *,
            workers: int = 1, progress: TextIO | None = None) -> list[Outcome]:  # fmt: skip
    """Run ``job(path, *args)`` for each path (``jobs_args[i]`` are path *i*'s extra arguments).

    Outcomes come back in input order whatever order the workers finish in.
    """
    results: list[Outcome | None] = [None] * len(paths)
    done = 0

    def tick() -> None:
        if progress is not None:
            width = 30
            filled = width * done // max(1, len(paths))
            progress.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{len(paths)}")
            progress.flush()

    tick()
    if workers <= 1 or len(paths) <= 1:
        for i, path in enumerate(paths):
            results[i] = _guard(job, path, *jobs_args[i])
            done += 1
            tick()
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            futures = {pool.submit(partial(_guard, job, path, *jobs_args[i])): i for i, path in enumerate(paths)}
            for future in as_completed(futures):
                results[futures[future]] = future.result()
                done += 1
                tick()
    if progress is not None:
        progress.write("\n")
    return [r for r in results if r is not None]


def summary(outcomes: Sequence[Outcome]) -> str:
    """The table printed at the end of a batch."""
    words = {0: "ok", 1: "FAIL", 2: "INVALID", 3: "ERROR"}
    width = max([len(o.path) for o in outcomes] + [4])
    lines = [f"{'file'.ljust(width)}  result   detail", f"{'-' * width}  -------  ------"]
    lines += [f"{o.path.ljust(width)}  {words.get(o.code, str(o.code)).ljust(7)}  {o.summary}" for o in outcomes]
    counts = {word: sum(1 for o in outcomes if words.get(o.code) == word) for word in words.values()}
    lines.append("")
    lines.append(f"{len(outcomes)} files: " + ", ".join(f"{n} {w.lower()}" for w, n in counts.items() if n))
    return "\n".join(lines) + "\n"


def progress_stream() -> TextIO | None:
    """stderr if it is a terminal (a progress line helps there), else None (logs stay clean)."""
    return sys.stderr if sys.stderr.isatty() else None
