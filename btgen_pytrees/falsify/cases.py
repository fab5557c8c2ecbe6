"""What the search runs and what it leaves as cases: the settings (the file's ``search`` block, the
options winning), the concrete case of a point, a batch of points run as a sweep's variations (their
rows, with each criterion's margin), and the counterexamples as case files with their replay pages.

The command line's half (the options, the checks before anything runs, the printing) is
:mod:`btgen_pytrees.cli.falsify`; this module takes plain values and prints nothing.
"""

from __future__ import annotations

import json
import os
from typing import Any, Callable, Mapping

from ..construct import generate
from ..errors import InvalidTestCase, Problem, UsageError
from ..leaves import Registry
from ..load import validate
from ..load.schema import schema
from ..render import GraphvizMissing
from ..run import run
from ..run.replay import replay_html
from ..load.template import Sweep, Variation
from ..parallel import Workers
from ..sweep.jobs import RunOptions, VariationOutcome
from ..sweep.overrides import variation_name
from ..sweep.runs import file_name, run_variations
from ..validator import shared_validator
from .jobs import job_probe
from .margins import row_margins
from .search import Settings

__all__ = ["settings_of", "signals_of", "concrete_case", "evaluator", "counterexample_files"]


_COUNTS = ("budget", "seed", "batch", "start")
"""The settings that are whole numbers."""


def _bad(path: tuple[Any, ...], message: str) -> Problem:
    return Problem(("search", *path), message, "parameter")


def settings_of(block: Mapping[str, Any] | None, options: Mapping[str, Any], criteria: set[str], source: str,
                workers: int = 1) -> Settings:  # fmt: skip
    """The search's settings: the file's ``search`` block (its schema was checked), the *options*
    (``budget``, ``method``, ``seed``, ``batch``, ``stop``, ``start``; None: not given) winning. The
    batch neither gives is *workers*, the number of runs that can run at once (``--jobs``, a Dask
    cluster's workers), so a seed and a worker count give the same search.

    Raises:
        InvalidTestCase: a ``scale`` names no criterion.
        UsageError: an option out of range.
    """
    block = dict(block or {})
    problems = [_bad(("scale", k), f"{k!r} is not a criterion of the oracle (criteria: {', '.join(sorted(criteria)) or 'none'})")
                for k in block.get("scale", {}) if k not in criteria]  # fmt: skip
    if problems:
        raise InvalidTestCase(problems, source)
    ranges = schema()["$defs"]["search"]["properties"]  # an option's range is the search block's, written once
    for option in ("budget", "batch", "seed"):
        value = options.get(option)
        error = next(shared_validator(ranges[option]).iter_errors(value), None) if value is not None else None
        if error is not None:
            raise UsageError(f"--{option} {value}: {error.message} (as search.{option} in the file)")
    pick = {k: (options.get(k) if options.get(k) is not None else block.get(k))
            for k in ("budget", "method", "seed", "batch", "stop", "start")}  # fmt: skip
    # an integer-valued number is an integer (the schema's "integer": 2.0 and 1e0 are 2 and 1, as a sweep's
    # samples reads 1e1; 2.5 was refused by it)
    given = {k: (int(v) if isinstance(v, float) and k in _COUNTS else v) for k, v in pick.items() if v is not None}
    given.setdefault("batch", max(1, workers))
    return Settings(scale=dict(block.get("scale", {})), **given)


def signals_of(sweep: Sweep) -> tuple[tuple[str, ...], ...]:
    """The case's input signals as the search sees them: for each ``profile`` entry of ``execute``, the
    parameters its points' values are (a point's value written as a whole ``$name``), in the points' order -
    which is time order (docs/format.md, ``profile``). A value written otherwise (a number, ``$a`` inside a
    text) is not a searched value of the signal."""
    execute = sweep.template.get("execute")
    entries = execute if isinstance(execute, list) else []
    found: dict[int, list[tuple[int, str]]] = {}
    for site in sweep.sites:
        path = site.path
        if not (site.whole and len(path) == 6 and path[0] == "execute" and path[2:4] == ("params", "points") and path[5] == 1):
            continue
        i, j = path[1], path[4]
        if isinstance(i, int) and isinstance(j, int) and isinstance(entries[i], dict) and entries[i].get("action") == "profile":
            found.setdefault(i, []).append((j, site.text[1:]))
    return tuple(tuple(dict.fromkeys(name for _, name in sorted(points))) for _, points in sorted(found.items()))


def concrete_case(sweep: Sweep, values: Mapping[str, Any], where: str | None = None) -> dict[str, Any]:
    """The concrete case for *values*, runnable from *where* (a folder): a system ``config`` path is
    rewritten relative to it (the sweep's is relative to the sweep's folder)."""
    doc = sweep.document({**sweep.defaults, **values})
    system = doc.get("system")
    if where is not None and isinstance(system, dict) and isinstance(system.get("config"), str) and not os.path.isabs(system["config"]):
        full = os.path.join(os.path.dirname(os.path.abspath(sweep.source)), system["config"])
        doc["system"] = {**system, "config": os.path.relpath(full, os.path.abspath(where))}
    return doc


def evaluator(sweep: Sweep, options: RunOptions, workers: int, executor: Any,
              pool: Workers | None = None) -> Callable[[list[dict[str, Any]]], list[dict[str, Any]]]:  # fmt: skip
    """The search's ``evaluate``: a batch of points run as the sweep's variations (numbered on from 0
    across batches), each a row with its verdict and every criterion's margin; on *executor* (a Dask
    cluster), in *pool* (:class:`~btgen_pytrees.parallel.Workers` kept for the whole search), else in
    *workers* processes started for each batch (or in this process for one)."""
    counter = [0]

    def evaluate(points: list[dict[str, Any]]) -> list[dict[str, Any]]:
        variations = []
        for values in points:
            point = tuple(values.items())
            variations.append(Variation(counter[0], point, {**sweep.defaults, **values}, concrete_case(sweep, values)))
            counter[0] += 1
        outcomes = run_variations(sweep, variations, options, None, workers, executor, None, job=job_probe, pool=pool)
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

    return evaluate


def counterexample_files(sweep: Sweep, data: Mapping[str, Any], out_dir: str,
                         registry: Registry) -> tuple[list[tuple[str, str | bytes]], list[str]]:  # fmt: skip
    """Each counterexample as a concrete case in *out_dir* (runnable from any directory) and its replay
    page (``.html`` beside it); and a note for each page that could not be drawn (Graphviz is missing).
    Counterexamples with the same values are one case, written once (the first's): where the nominal
    point fails, every cluster's shrink ends there."""
    outputs: list[tuple[str, str | bytes]] = []
    notes: list[str] = []
    written: set[str] = set()
    for k, ce in enumerate(data["counterexamples"]):
        if ce["label"] in written:
            continue
        written.add(ce["label"])
        doc = concrete_case(sweep, ce["parameters"], out_dir)
        what = f"counterexample {k + 1} ({ce['kind']}, cluster {ce['cluster']}) of {os.path.basename(sweep.source)} found by falsify: {ce['label']}"
        doc["description"] = f"{doc['description']} ({what})" if doc.get("description") else what[0].upper() + what[1:]
        doc["name"] = variation_name(sweep.name, ce["label"])  # named as its file: its reports say which point
        path = os.path.join(out_dir, file_name(sweep.name, ce["label"], ce["run"]))
        outputs.append((path, json.dumps(doc, indent=2, ensure_ascii=False) + "\n"))
        try:
            case = validate(doc, path, registry)
            page = replay_html(run(case, registry=registry), case, generate(case, registry=registry))
        except GraphvizMissing as missing:
            notes.append(f"no replay pages: {missing}")
            continue
        except InvalidTestCase as invalid:  # the run's error: its values make no valid case (run says the same)
            notes.append(f"no replay page for {os.path.basename(path)}: the case is invalid "
                         f"({invalid.problems[0].render(path) if invalid.problems else 'see run'})")  # fmt: skip
            continue
        outputs.append((os.path.splitext(path)[0] + ".html", page))
    return outputs, notes
