"""Which signals tell a run's story, and every signal on every tick as a table (``run --signals-out``).

**Order** (:func:`ordered_signals`): the signals read by a *failing* criterion
first, then those read by any other criterion or by an entry's expression
(``until``'s ``expect``, a user action's declared expressions), then the rest;
alphabetical within each rank. The run picture draws them in that order, so a
cap on curves never drops what decided the verdict.

**Choice** (:func:`select`): ``--signals PATTERN`` (repeatable) keeps the
signals that match any of the shell-style globs (:mod:`fnmatch`, case-sensitive:
``ego.*``, ``*.speed``, ``sim.collisions``); no pattern keeps every signal.

**The table** (:func:`signal_table`): one row per tick, in order; the columns
are ``tick`` (0, 1, ...), ``time`` (run seconds), one column per signal
(alphabetical), then ``status:<id>`` for every execute entry and every
criterion, in file order: the status its node had at the end of that tick
(``invalid`` before it ran or after it was halted, ``running``, ``success``,
``failure``; py_trees' names). A signal that had no value on a tick (not
written yet; a SUMO vehicle that is not in the network) is an empty cell, never
its last value.

>>> from btgen_pytrees import load
>>> from btgen_pytrees.run import run
>>> case = load("examples/fig1_failing.json")
>>> report = run(case)
>>> ordered_signals(report, case)
['speed', 'mode', 'target', 'brake']
>>> columns, rows = signal_table(report, case)
>>> columns[:6], columns[-3:]
(['tick', 'time', 'brake', 'mode', 'speed', 'target'], ['status:R1', 'status:P1', 'status:F1'])
>>> rows[15][:6], rows[15][-3:], rows[16][-3:]
([15, 1.5, 0, 1, 15.0, 25], ['running', 'running', 'running'], ['failure', 'invalid', 'invalid'])
"""

from __future__ import annotations

import fnmatch
import io
import json
import math
import os
from typing import Any, Iterable, Sequence

from ..model import TestCase
from .report import Report
from .trace import ENDED, STATUSES

__all__ = ["ordered_signals", "read_by", "select", "signal_table", "table_bytes", "export_format",
           "require_pyarrow", "ExportUnavailable", "SUFFIXES"]  # fmt: skip

SUFFIXES = {".csv": "csv", ".parquet": "parquet"}
HINT = "--signals-out .parquet needs pyarrow: pip install 'btgen_pytrees[parquet]' (or write .csv)"


class ExportUnavailable(RuntimeError):
    """pyarrow is not installed; ``str()`` is a one-line hint."""


def require_pyarrow() -> None:
    """Raise :class:`ExportUnavailable` (with an install hint) unless pyarrow can be imported."""
    try:
        import pyarrow  # noqa: F401
    except ImportError as exc:
        raise ExportUnavailable(HINT) from exc


def export_format(path: str) -> str:
    """``csv`` or ``parquet`` from *path*'s suffix; :class:`ValueError` for anything else."""
    suffix = os.path.splitext(path)[1].lower()
    if suffix not in SUFFIXES:
        raise ValueError(f"--signals-out {path}: the file name must end in .csv or .parquet")
    return SUFFIXES[suffix]


def read_by(case: TestCase) -> tuple[dict[str, set[str]], set[str]]:
    """``({criterion id: the signals it reads}, the signals the entries' expressions read)``."""
    criteria = {}
    for criterion in case.criteria:
        names = set(criterion.expect.names)
        for expression in criterion.expressions.values():
            names |= expression.names
        criteria[criterion.id] = names
    entries: set[str] = set()
    for entry in case.entries:
        for expression in entry.expressions.values():
            entries |= expression.names
    return criteria, entries


def ordered_signals(report: Report, case: TestCase, names: Iterable[str] | None = None) -> list[str]:
    """*names* (default: every signal of the run's trace) in telling order (see the module notes)."""
    if names is None:
        names = report.trace.signals if report.trace is not None else _sampled(report)
    criteria, entries = read_by(case)
    failing = set().union(*(criteria.get(o.id, set()) for o in report.oracles if o.verdict == "fail"))
    others = entries.union(*criteria.values())
    return sorted(names, key=lambda name: (0 if name in failing else 1 if name in others else 2, name))


def _sampled(report: Report) -> set[str]:
    return {name for oracle in report.oracles for _, values in oracle.samples for name in values}


def select(names: Iterable[str], patterns: Sequence[str] | None) -> list[str]:
    """The names that match any of *patterns* (shell globs), in their order; all of them without patterns."""
    if not patterns:
        return list(names)
    return [name for name in names if any(fnmatch.fnmatchcase(name, p) for p in patterns)]


def signal_table(report: Report, case: TestCase, patterns: Sequence[str] | None = None) -> tuple[list[str], list[list[Any]]]:
    """``(columns, rows)``: every tick of *report*'s trace, its signals (those *patterns* select) and statuses.

    A cell is ``None`` where a signal had no value. Needs the run's trace
    (:class:`ValueError` without one: a report made by hand).
    """
    trace = report.trace
    if trace is None:
        raise ValueError("the report has no trace (only a run's own report can be exported)")
    signals = select(sorted(trace.signals), patterns)
    ids = [e.id for e in report.execute] + [o.id for o in report.oracles]
    nodes = {node.id: i for i, node in enumerate(trace.nodes) if node.id}
    watched = [nodes.get(ident, -1) for ident in ids]
    columns = ["tick", "time", *signals, *(f"status:{ident}" for ident in ids)]
    missing = object()
    changes = [trace.signals[name] for name in signals]
    at = [0] * len(signals)
    current: list[Any] = [missing] * len(signals)
    codes = bytearray(len(trace.nodes))
    transitions = list(zip(trace.ticks, trace.nodes_changed, trace.statuses))
    cursor = 0
    rows = []
    for k, t in enumerate(trace.times):
        while cursor < len(transitions) and transitions[cursor][0] <= k:
            codes[transitions[cursor][1]] = transitions[cursor][2]
            cursor += 1
        row: list[Any] = [k, t]
        for j, (ticks, values) in enumerate(changes):
            while at[j] < len(ticks) and ticks[at[j]] <= k:
                current[j] = values[at[j]]
                at[j] += 1
            row.append(None if current[j] is missing or current[j] is ENDED else current[j])  # ENDED: it left
        row += [STATUSES[codes[i]] if i >= 0 else None for i in watched]
        rows.append(row)
    return columns, rows


# -- files ----------------------------------------------------------------------------------------


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else ("nan" if math.isnan(value) else ("inf" if value > 0 else "-inf"))
    if isinstance(value, (int, str)):
        return str(value)
    return json.dumps(value, ensure_ascii=False, separators=(",", ":"), default=str)


def _csv(columns: list[str], rows: list[list[Any]]) -> bytes:
    import csv

    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(columns)
    for row in rows:
        writer.writerow([_cell(v) for v in row])
    return out.getvalue().encode("utf-8")


def _column_type(values: list[Any]) -> str:
    present = [v for v in values if v is not None]
    if present and all(isinstance(v, bool) for v in present):
        return "bool"
    if present and all(isinstance(v, int) and not isinstance(v, bool) for v in present):
        return "int"
    if present and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
        return "float"
    return "string"


def _parquet(columns: list[str], rows: list[list[Any]]) -> bytes:
    require_pyarrow()
    import pyarrow as pa
    import pyarrow.parquet as pq

    arrays = []
    for j, _ in enumerate(columns):
        values = [row[j] for row in rows]
        kind = _column_type(values)
        if kind == "bool":
            arrays.append(pa.array(values, type=pa.bool_()))
        elif kind == "int":
            arrays.append(pa.array(values, type=pa.int64()))
        elif kind == "float":
            arrays.append(pa.array([None if v is None else float(v) for v in values], type=pa.float64()))
        else:
            arrays.append(pa.array([None if v is None else v if isinstance(v, str) else _cell(v) for v in values],
                                   type=pa.string()))  # fmt: skip
    table = pa.table(arrays, names=columns)
    buffer = io.BytesIO()
    pq.write_table(table, buffer, compression="zstd", write_statistics=False)
    return buffer.getvalue()


def table_bytes(report: Report, case: TestCase, fmt: str, patterns: Sequence[str] | None = None) -> bytes:
    """The table of :func:`signal_table` as ``csv`` or ``parquet`` bytes.

    CSV: a header row, then one row per tick; an empty cell is no value;
    booleans ``true``/``false``, floats as Python writes them (``inf``, ``nan``),
    lists and dicts as compact JSON. Parquet: a column of booleans, integers or
    floats when every value of the column is one, else strings; no value is null.
    """
    if fmt not in SUFFIXES.values():
        raise ValueError(f"fmt must be csv or parquet, not {fmt!r}")
    columns, rows = signal_table(report, case, patterns)
    return _csv(columns, rows) if fmt == "csv" else _parquet(columns, rows)
