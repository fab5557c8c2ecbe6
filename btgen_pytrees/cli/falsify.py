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
import math
import os
import signal
from typing import Any

from ..errors import ExitCode, InvalidTestCase, Problem, UsageError
from ..falsify.cases import concrete_case, counterexample_files, evaluator, settings_of, signals_of
from ..falsify.margins import groups_of
from ..falsify.plot import search_plot
from ..falsify.report import report_data, table, to_json
from ..falsify.sampler import HINT, METHODS, available
from ..falsify.search import Search
from ..falsify.space import Space
from ..load import validate
from ..writing import check_distinct, check_target, same_file
from ..parallel import Interrupted, Workers, progress_stream
from ..run.plot import plot_format
from ..load.sweep import load_sweep
from ..load.template import Sweep
from ..load.variations import format_value
from ..sweep.runs import file_name
from ..systems.sumo import keep_simulations, release_simulations, reuse_simulations
from .checks import check_out_dir, make_out_dir
from .options import SIDECAR_NOTE, Parents, registry, whole
from .sweep import add_executor_options, make_executor, run_options
from .terminal import deliver, err

__all__ = ["add_parser", "cmd_falsify"]

_NO_LIMIT = math.inf
"""The box is searched, not enumerated: however many points its grid would count, no variation limit."""


def add_parser(sub: Any, parents: Parents) -> None:
    """The ``falsify`` subcommand and its own options (``--jobs``, ``--plugin`` come from the shared parents)."""
    parser = sub.add_parser("falsify", parents=[parents.plugin, parents.many], help="search a sweep's parameter box for a failing setting (docs/falsify.md)")
    parser.add_argument("file", metavar="SWEEP", help="a test case with a variations block (its box is searched), or a ParameterValueDistribution (.xosc); " + SIDECAR_NOTE)
    parser.add_argument("--method", choices=METHODS, help="search method (default: the file's search.method, else auto)")
    parser.add_argument("--budget", type=whole, metavar="N", help="most runs (default: search.budget, else 200)")
    parser.add_argument("--seed", type=whole, metavar="S", help="seed of the search (default: search.seed, else 0)")
    parser.add_argument("--batch", type=whole, metavar="N", help="runs asked and run together (default: search.batch, else the runs that can run at once: --jobs, or the Dask cluster's workers)")
    parser.add_argument("--stop", choices=("failure", "cluster", "all", "first"),
                        help="failure: stop at the first failing run; cluster: stop once the first failure's cluster is shrunk and bounded "
                             "(first: its old name); all (default): search to the end of the budget")  # fmt: skip
    parser.add_argument("--json", metavar="REPORT", help="write the search as JSON (schemas/falsify.schema.json)")
    parser.add_argument("--plot", metavar="PATH", help="draw convergence and the parameter space coloured by margin (.svg, .png or .html; needs the 'plot' extra)")
    add_executor_options(parser)
    parser.set_defaults(func=cmd_falsify)


def load(args: argparse.Namespace) -> Sweep:
    sweep = load_sweep(args.file, registry=registry(args), max_variations=_NO_LIMIT, check_all=False)
    if not sweep.variations.axes:
        raise InvalidTestCase([Problem(("variations",), "falsify searches the box of a 'variations' block; this case has none", "parameter")], sweep.source)
    return sweep


def progress_line(stream: Any) -> Any:
    def show(search: Search) -> None:
        best = min((r.objective for r in search.runs if r.objective is not None), default=None)
        fails = sum(1 for r in search.runs if r.failed)
        stream.write(f"\rfalsify: {len(search.runs)}/{search.settings.budget} runs, lowest objective "
                     f"{'-' if best is None else format_value(round(best, 6) + 0.0)}, {fails} failing   ")  # fmt: skip
        stream.flush()

    return show


def check_outputs(args: argparse.Namespace, name: str) -> None:
    """--json, --plot and --out-dir can be written, --json and --plot are two files, and no counterexample
    written to --out-dir can land on the input, --json or --plot (checked before anything runs: the
    counterexamples' names are known only after the search, so every name one could take is refused)."""
    for path, option in ((args.json, "--json"), (args.plot, "--plot")):
        if path:
            check_target(path, option, [args.file])  # OutputError: a usage error
    check_distinct([("--json", args.json), ("--plot", args.plot)])
    if args.out_dir:
        check_out_dir(args, [args.file], writes_json=False)  # a directory, or one that can be made
        check_counterexample_names(args.out_dir, name, [("the input", args.file), ("--json", args.json), ("--plot", args.plot)])


def check_counterexample_names(out_dir: str, name: str, others: list[tuple[str, str | None]]) -> None:
    """Refuse (exit 2) when a file a counterexample could be written to - ``NAME[LABEL].json`` in *out_dir*, or
    its replay page ``.html`` - is one of *others* (``(what, path)``): by its name there, or as an entry of
    *out_dir* under such a name that is a link to it."""
    stem = file_name(name, "x", 0).partition("[")[0]
    stems = (stem + "[", stem[:120] + "[")

    def could_be_written(path: str) -> bool:
        base = os.path.basename(path)
        return base.startswith(stems) and base.endswith(("].json", "].html"))

    real = os.path.realpath(out_dir)
    entries = []
    if os.path.isdir(out_dir):
        entries = [os.path.join(out_dir, e) for e in sorted(os.listdir(out_dir)) if could_be_written(e)]
    for what, path in others:
        if not path or path == "-":
            continue
        here = os.path.realpath(os.path.dirname(os.path.abspath(path))) == real and could_be_written(path)
        linked = next((e for e in entries if same_file(e, path) or os.path.realpath(e) == os.path.realpath(path)), None)
        if here or linked:
            at = path if here else f"{linked} (a link to {path})"
            raise UsageError(f"--out-dir {out_dir}: a counterexample's case or replay page could be written to {at}, "
                             f"which is {what}; refusing to overwrite it - choose another directory")  # fmt: skip


def cmd_falsify(args: argparse.Namespace) -> int:
    """Run the search; see the module notes for exit codes."""
    if not available():
        raise UsageError(HINT)
    sweep = load(args)
    criteria = {c.get("id") for c in (sweep.template.get("oracle") or {}).get("criteria", []) if isinstance(c, dict)}
    criteria_ids = {c for c in criteria if isinstance(c, str)}
    settings = settings_of(sweep.search, vars(args), criteria_ids, sweep.source, args.jobs)  # refused before connecting
    check_outputs(args, sweep.name)
    if args.plot:  # a bad suffix or a missing extra: refused before anything runs
        try:
            plot_format(args.plot)
        except ValueError as problem:
            raise UsageError(str(problem)) from None
        if importlib.util.find_spec("matplotlib") is None:
            raise UsageError("--plot needs matplotlib: pip install -e '.[plot]'")
    space = Space.of(sweep.variations, signals_of(sweep))
    known = registry(args)
    groups = groups_of(validate(concrete_case(sweep, {}), sweep.source, known))
    executor = make_executor(args, keep=(keep_simulations, release_simulations))  # each worker keeps its SUMO open
    if executor is not None:  # the batch follows the cluster's workers, as it follows --jobs locally
        settings = settings_of(sweep.search, vars(args), criteria_ids, sweep.source, executor.workers())
    stream = progress_stream()
    # batches run in local workers (several points, or several workers): the workers are kept for the whole
    # search, each keeping its SUMO open from one batch to the next; one point at a time runs in this process
    pool = Workers(args.jobs, keep_simulations) if executor is None and (args.jobs > 1 or settings.batch > 1) else None
    evaluate = evaluator(sweep, run_options(args), args.jobs, executor, pool)
    search = Search(space, sweep.defaults, settings, evaluate, groups, progress_line(stream) if stream else None)
    signum = None
    try:
        try:
            with reuse_simulations():  # runs in this process (one worker) start SUMO once for the whole search
                search.run()
        except Interrupted as stop:
            search.interrupted, signum = True, stop.signum
    finally:
        if pool is not None:
            pool.close()
        if executor is not None:
            executor.close()
        if stream is not None:
            stream.write("\n")
    if search.interrupted and signum is None:  # stopped in the search's own code, between two batches' runs
        signum = search.signum if search.signum is not None else signal.SIGINT
    data = report_data(search, sweep.name, sweep.source)
    outputs: list[tuple[str, str | bytes]] = []
    if args.json:
        outputs.append((args.json, to_json(data)))
    if args.out_dir and data["counterexamples"]:
        make_out_dir(args)
        cases, notes = counterexample_files(sweep, data, args.out_dir, known)
        for note in notes:
            err(f"btgen_pytrees: {note}")
        outputs += cases
    if args.plot:
        outputs.append((args.plot, search_plot(search, data, plot_format(args.plot))))
    code = 128 + signum if signum is not None else ExitCode.FAIL if data["failures"] else ExitCode.OK
    # the real stdout (the CLI sends file descriptor 1 to stderr for user code); stderr when --json is stdout
    deliver(outputs, table(data), code)
    if signum is not None:
        err(f"btgen_pytrees: interrupted by {signal.Signals(signum).name} after {len(search.runs)} runs; what was found is kept")
    return code
