"""``falsify SWEEP.json``: search the sweep's box for a failing setting (docs/falsify.md).

Everything that can be refused is refused before the first run (exit 2): the
extra, the file (the template and the nominal case are validated like a
sweep's), the ``search`` block, the options, the output paths, the scheduler.
Exit 1 when a run failed, 0 when none did within the budget; Ctrl-C keeps
what was found (the outputs are written) and exits 130.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import signal
import sys
from typing import Any, Mapping

from ..construct import generate
from ..loader import validate
from ..render import GraphvizMissing
from ..run import run
from ..run.plot import plot_format
from ..run.replay import replay_html
from ..errors import ExitCode, InvalidTestCase, Problem, UsageError
from ..leaves import Registry, default_registry
from ..output import OutputError, check_target, commit, emit
from ..sweep.case import Sweep, Variation, load_sweep
from ..parallel import Interrupted, progress_stream
from ..sweep.command import file_name, make_executor, run_options, run_variations
from ..sweep.jobs import VariationOutcome
from ..sweep.variations import format_value, label
from .jobs import job_probe
from .margins import groups_of, row_margins
from .plot import search_plot
from .report import report_data, table, to_json
from .sampler import HINT, METHODS, available
from .search import Search, Settings
from .space import Space

__all__ = ["cmd_falsify", "settings_of", "concrete_case", "add_arguments"]

_MAX_LIMIT = 10**18


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The ``falsify`` subcommand's own options (``--jobs``, ``--plugin`` come from the shared parents)."""
    parser.add_argument("file", metavar="SWEEP", help="a test case with a variations block (its box is searched)")
    parser.add_argument("--method", choices=METHODS, help="search method (default: the file's search.method, else auto)")
    parser.add_argument("--budget", type=int, metavar="N", help="most runs (default: search.budget, else 200)")
    parser.add_argument("--seed", type=int, metavar="S", help="seed of the search (default: search.seed, else 0)")
    parser.add_argument("--batch", type=int, metavar="N", help="runs asked and run together (default: search.batch, else 8)")
    parser.add_argument("--stop", choices=("first", "all"), help="first: stop after the first failure's cluster is shrunk and bounded; all (default): search to the end of the budget")
    parser.add_argument("--json", metavar="REPORT", help="write the search as JSON (schemas/falsify.schema.json)")
    parser.add_argument("--plot", metavar="PATH", help="draw convergence and the parameter space coloured by margin (.svg/.png; needs the 'plot' extra)")
    parser.add_argument("--executor", choices=("local", "dask"), default="local", help="where runs execute: local worker processes (--jobs), or a Dask cluster (--scheduler)")
    parser.add_argument("--scheduler", metavar="ADDRESS", help="with --executor dask: the scheduler, tcp://HOST:PORT (default: $DASK_SCHEDULER_ADDRESS)")


def _bad(path: tuple[Any, ...], message: str) -> Problem:
    return Problem(("search", *path), message, "parameter")


def settings_of(block: Mapping[str, Any] | None, args: argparse.Namespace, criteria: set[str], source: str) -> Settings:
    """The search's settings: the file's ``search`` block (its schema was checked), the options winning.

    Raises:
        InvalidTestCase: a ``scale`` names no criterion.
        UsageError: an option out of range.
    """
    block = dict(block or {})
    problems = [_bad(("scale", k), f"{k!r} is not a criterion of the oracle (criteria: {', '.join(sorted(criteria)) or 'none'})")
                for k in block.get("scale", {}) if k not in criteria]  # fmt: skip
    if problems:
        raise InvalidTestCase(problems, source)
    for option, low in (("budget", 1), ("batch", 1), ("seed", 0)):
        value = getattr(args, option, None)
        if value is not None and value < low:
            raise UsageError(f"--{option} {value}: must be at least {low}")
    pick = {k: (getattr(args, k, None) if getattr(args, k, None) is not None else block.get(k))
            for k in ("budget", "method", "seed", "batch", "stop", "start")}  # fmt: skip
    given = {k: v for k, v in pick.items() if v is not None}
    return Settings(scale=dict(block.get("scale", {})), **given)


def concrete_case(sweep: Sweep, values: Mapping[str, Any], where: str | None = None) -> dict[str, Any]:
    """The concrete case for *values*, runnable from *where* (a folder): a system ``config`` path is
    rewritten relative to it (the sweep's is relative to the sweep's folder)."""
    doc = sweep.document({**sweep.defaults, **values})
    system = doc.get("system")
    if where is not None and isinstance(system, dict) and isinstance(system.get("config"), str) and not os.path.isabs(system["config"]):
        full = os.path.join(os.path.dirname(os.path.abspath(sweep.source)), system["config"])
        doc["system"] = {**system, "config": os.path.relpath(full, os.path.abspath(where))}
    return doc


def _load(args: argparse.Namespace) -> Sweep:
    registry = default_registry(args.plugin or ())
    sweep = load_sweep(args.file, registry=registry, max_variations=_MAX_LIMIT, check_all=False)
    if not sweep.variations.axes:
        raise InvalidTestCase([Problem(("variations",), "falsify searches the box of a 'variations' block; this case has none", "parameter")], sweep.source)
    return sweep


def _progress_line(stream: Any) -> Any:
    def show(search: Search) -> None:
        best = min((r.objective for r in search.runs if r.objective is not None), default=None)
        fails = sum(1 for r in search.runs if r.failed)
        stream.write(f"\rfalsify: {len(search.runs)}/{search.settings.budget} runs, best margin "
                     f"{'-' if best is None else format_value(round(best, 6) + 0.0)}, {fails} failing   ")  # fmt: skip
        stream.flush()

    return show


def cmd_falsify(args: argparse.Namespace) -> int:
    """Run the search; see the module notes for exit codes."""
    if not available():
        raise UsageError(HINT)
    sweep = _load(args)
    criteria = {c.get("id") for c in (sweep.template.get("oracle") or {}).get("criteria", []) if isinstance(c, dict)}
    settings = settings_of(sweep.search, args, {c for c in criteria if isinstance(c, str)}, sweep.source)
    _check_outputs(args)
    if args.plot:  # a bad suffix or a missing extra: refused before anything runs
        try:
            plot_format(args.plot)
        except ValueError as problem:
            raise UsageError(str(problem)) from None
        if importlib.util.find_spec("matplotlib") is None:
            raise UsageError("--plot needs matplotlib: pip install -e '.[plot]'")
    space = Space.of(sweep.variations)
    registry = default_registry(args.plugin or ())
    groups = groups_of(validate(concrete_case(sweep, {}), sweep.source, registry))
    executor = make_executor(args)
    options = run_options(args)
    stream = progress_stream()
    counter = [0]

    def evaluate(points: list[dict[str, Any]]) -> list[dict[str, Any]]:
        variations = []
        for values in points:
            point = tuple(values.items())
            variations.append(Variation(counter[0], point, {**sweep.defaults, **values}, concrete_case(sweep, values)))
            counter[0] += 1
        outcomes = run_variations(sweep, variations, options, None, args.jobs, executor, None, job=job_probe)
        rows = []
        for o in outcomes:
            if isinstance(o, VariationOutcome):
                row = dict(o.row)
            else:
                row = {"verdict": "error", "message": o.summary if not o.problems else "; ".join(o.problems),
                       "duration": 0.0, "ticks": 0, "oracles": [], "wall": 0.0}  # fmt: skip
            row["margins"] = row_margins(row)
            rows.append(row)
        return rows

    search = Search(space, sweep.defaults, settings, evaluate, groups, _progress_line(stream) if stream else None)
    signum = None
    try:
        try:
            search.run()
        except Interrupted as stop:
            search.interrupted, signum = True, stop.signum
    finally:
        if executor is not None:
            executor.close()
        if stream is not None:
            stream.write("\n")
    if search.interrupted and signum is None:
        signum = signal.SIGINT
    data = report_data(search, sweep.name, sweep.source)
    outputs: list[tuple[str, str | bytes]] = []
    if args.json:
        outputs.append((args.json, to_json(data)))
    if args.out_dir and data["counterexamples"]:
        os.makedirs(args.out_dir, exist_ok=True)
        outputs += _cases(sweep, data, args.out_dir, registry)
    if args.plot:
        outputs.append((args.plot, search_plot(search, data, plot_format(args.plot))))
    commit(outputs)
    emit(table(data))  # the real stdout (the CLI sends file descriptor 1 to stderr for user code)
    if signum is not None:
        emit(f"btgen_pytrees: interrupted by {signal.Signals(signum).name} after {len(search.runs)} runs; what was found is kept\n",
             sys.stderr)  # fmt: skip
        return 128 + signum
    return ExitCode.FAIL if data["failures"] else ExitCode.OK


def _check_outputs(args: argparse.Namespace) -> None:
    """--json, --plot and --out-dir can be written (checked before anything runs)."""
    try:
        for path, option in ((args.json, "--json"), (args.plot, "--plot")):
            if path:
                check_target(path, option, [args.file])
    except OutputError as problem:
        raise UsageError(str(problem)) from None
    out = args.out_dir
    if out and os.path.exists(out) and not os.path.isdir(out):
        raise UsageError(f"--out-dir {out}: exists and is not a directory")


def _cases(sweep: Sweep, data: Mapping[str, Any], out_dir: str, registry: Registry) -> list[tuple[str, str | bytes]]:
    """Each counterexample as a concrete case in *out_dir* (runnable from any directory) and its replay
    page (``.html`` beside it; skipped with a note when Graphviz is missing)."""
    outputs: list[tuple[str, str | bytes]] = []
    for k, ce in enumerate(data["counterexamples"]):
        doc = concrete_case(sweep, ce["parameters"], out_dir)
        what = f"counterexample {k + 1} ({ce['kind']}, cluster {ce['cluster']}) of {os.path.basename(sweep.source)} found by falsify: {ce['label']}"
        doc["description"] = f"{doc['description']} ({what})" if doc.get("description") else what[0].upper() + what[1:]
        path = os.path.join(out_dir, file_name(sweep.name, ce["label"], ce["run"]))
        outputs.append((path, json.dumps(doc, indent=2, ensure_ascii=False) + "\n"))
        try:
            case = validate(doc, path, registry)
            page = replay_html(run(case, registry=registry), case, generate(case, registry=registry))
        except GraphvizMissing as missing:
            print(f"btgen_pytrees: no replay pages: {missing}", file=sys.stderr)
            continue
        outputs.append((os.path.splitext(path)[0] + ".html", page))
    return outputs
