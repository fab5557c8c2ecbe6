"""A picture of one run: why it passed or failed, at a glance.

Top: a timeline (Gantt) with one row per execute entry, from its start to its
end, in file order. Entries behind a trigger (joins: several predecessors)
show the trigger's wait as a dashed line from the run's first tick to the
moment the entry started; thin lines join each predecessor's end to the start
it allowed. Below them, one row per oracle criterion: a ``record`` spans the
run, a ``period`` its window, a ``final`` is a diamond at its instant. Green
passed, grey undecided, red failed; every failure (an entry or a criterion)
also gets a red vertical line across the whole figure, labelled with its id.

Bottom: every numeric signal of the run, as steps from each change the run's
trace recorded (:mod:`.trace`: every signal on every tick it changed, whoever
wrote or read it); the values a failing criterion read are red dots.

matplotlib is an optional extra (``pip install 'btgen_pytrees[plot]'``); this
module imports it only when drawing, so the core install never needs it.
Output is deterministic: the same report gives the same SVG bytes.

>>> from btgen_pytrees import load
>>> from btgen_pytrees.run import run
>>> case = load("examples/fig1.json")
>>> rows = timeline_rows(run(case), case)
>>> [(r.id, r.start, r.end) for r in rows if r.section == "execute"]
[('B1', 0.0, 0.0), ('C1', 0.0, 0.0), ('B2', 0.0, 2.0), ('C2', 0.0, 1.0), ('B3', 1.0, 1.5), ('B4', 1.5, 1.5)]
>>> next(r for r in rows if r.id == "B4").waits_for
('B2', 'B3')
"""

from __future__ import annotations

import html
import io
import os
import textwrap
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..errors import printable, shorten, xml_safe
from ..model import TestCase
from .report import Report

if TYPE_CHECKING:  # pragma: no cover - types only
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["Row", "timeline_rows", "plot_figure", "plot_run", "plot_bytes", "plot_format", "require_matplotlib",
           "PlotUnavailable", "SUFFIXES", "COLOURS"]  # fmt: skip

SUFFIXES = {".svg": "svg", ".png": "png", ".html": "html", ".htm": "html"}

COLOURS = {
    "behavior": "#6baed6",
    "constraint": "#9e9ac8",
    "fail": "#d62728",
    "pass": "#31a354",
    "inconclusive": "#969696",
    "wait": "#08519c",
    "dependency": "#737373",
}
"""Bar colours; behaviours and constraints match the tree picture of :mod:`btgen_pytrees.render.dot`."""

HINT = "--plot needs matplotlib: pip install 'btgen_pytrees[plot]'"


class PlotUnavailable(RuntimeError):
    """matplotlib is not installed; ``str()`` is a one-line hint."""


def require_matplotlib() -> None:
    """Raise :class:`PlotUnavailable` (with an install hint) unless matplotlib can be imported."""
    try:
        import matplotlib  # noqa: F401
    except ImportError as exc:
        raise PlotUnavailable(HINT) from exc


def plot_format(path: str) -> str:
    """``svg``, ``png`` or ``html`` from *path*'s suffix; :class:`ValueError` for anything else."""
    suffix = os.path.splitext(path)[1].lower()
    if suffix not in SUFFIXES:
        raise ValueError(f"--plot {path}: the file name must end in .svg, .png or .html")
    return SUFFIXES[suffix]


@dataclass(frozen=True)
class Row:
    """One row of the timeline, as data (what :func:`plot_bytes` draws).

    Attributes:
        section: ``execute`` or ``oracle``
        id: entry or criterion id
        kind: ``behavior``/``constraint``, or the criterion type
        label: the row's text
        start, end: the bar; ``None`` when it never started / has no end.
            For criteria: a record spans the run, a period its window, a final
            has ``start == end`` (its instant)
        status: an entry's status, or a criterion's verdict
        waits_for, join: a join entry's predecessors and how they join
            (empty for entries that no trigger holds)
        after: every predecessor (for the dependency lines)
        failed_at: when it failed, else ``None``
        message: why it failed ("" otherwise)
    """

    section: str
    id: str
    kind: str
    label: str
    start: float | None
    end: float | None
    status: str
    waits_for: tuple[str, ...] = ()
    join: str = ""
    after: tuple[str, ...] = ()
    failed_at: float | None = None
    message: str = ""


def timeline_rows(report: Report, case: TestCase) -> list[Row]:
    """The rows of *report*'s timeline: every execute entry, then every criterion, in file order."""
    rows = []
    entries = {e.id: e for e in case.entries}
    for result in report.execute:
        entry = entries[result.id]
        end = result.end if result.end is not None or result.start is None else report.duration
        failed = result.status == "failure"
        rows.append(Row(
            "execute", result.id, result.kind, printable(f"{result.id}  {entry.action}"), result.start, end, result.status,
            waits_for=entry.after if len(entry.after) > 1 else (), join=entry.join if len(entry.after) > 1 else "",
            after=entry.after, failed_at=result.end if failed else None, message=printable(shorten(result.message)) if failed else ""))  # fmt: skip
    criteria = {c.id: c for c in case.criteria}
    for oracle in report.oracles:
        start, end = _criterion_span(oracle.type, criteria[oracle.id], oracle.at, oracle.verdict, report.duration)
        failed = oracle.verdict == "fail"
        rows.append(Row(
            "oracle", oracle.id, oracle.type, printable(f"{oracle.id}  {oracle.type}: {oracle.expect}"), start, end,
            oracle.verdict, failed_at=oracle.at if failed else None, message=printable(shorten(oracle.message)) if failed else ""))  # fmt: skip
    return rows


def _criterion_span(kind: str, criterion: Any, at: float | None, verdict: str, duration: float) -> tuple[float | None, float | None]:
    """Where a criterion is drawn: a record over the run, a period over its window, a final at its instant."""
    if kind == "final":
        instant = at if at is not None else criterion.at
        return instant, instant
    if kind == "period":
        start = criterion.start or 0.0
        end = criterion.end if criterion.end is not None else (at if verdict == "pass" and at is not None else duration)
        return start, end
    return 0.0, duration


# -- drawing ----------------------------------------------------------------------------------------


def plot_figure(report: Report, case: TestCase) -> Figure:
    """The run picture as a matplotlib Figure (not attached to pyplot, so no GUI backend is involved)."""
    import matplotlib

    with matplotlib.rc_context({"text.parse_math": False}):  # a '$' in a name is a dollar sign, not math
        return _plot_figure(report, case)


def _capped(rows: list[Row], limit: int) -> tuple[list[Row], int]:
    """At most *limit* rows: every failed row first (up to the limit), then the others in order."""
    if len(rows) <= limit:
        return rows, 0
    keep = {i for i, row in enumerate(rows) if row.failed_at is not None}
    keep = set(sorted(keep)[:limit])
    for i in range(len(rows)):
        if len(keep) >= limit:
            break
        keep.add(i)
    return [row for i, row in enumerate(rows) if i in keep], len(rows) - len(keep)


def _plot_figure(report: Report, case: TestCase) -> Figure:
    from matplotlib.figure import Figure

    rows, hidden = _capped(timeline_rows(report, case), MAX_ROWS)
    samples = _signal_series(report)
    if len(samples) > MAX_SIGNALS:
        hidden_signals = len(samples) - MAX_SIGNALS
        samples = dict(list(samples.items())[:MAX_SIGNALS])
    else:
        hidden_signals = 0
    height_rows = max(1.6, 0.32 * len(rows) + 0.9)
    height_signals = 2.4 if samples else 0.0
    fig = Figure(figsize=(11, height_rows + height_signals + 1.1), layout="constrained")
    if samples:
        top, bottom = fig.subplots(2, 1, sharex=True, height_ratios=[height_rows, height_signals])
    else:
        top, bottom = fig.subplots(1, 1), None
    span = max(report.duration, case.tick, 1e-3)
    _draw_rows(top, rows, span)
    if bottom is not None:
        _draw_signals(bottom, samples, report, span)
        top.set_xlabel("")  # the signals below carry the shared time axis
    for axes in (top, bottom):
        if axes is not None:
            for row in rows:
                if row.failed_at is not None:
                    axes.axvline(row.failed_at, color=COLOURS["fail"], linewidth=1.2, alpha=0.8)
    top.set_xlim(-0.02 * span, span * 1.04)
    verdict = f"{report.test}: {report.verdict.upper()} after {report.duration:g} s ({report.ticks} ticks)"
    colour = COLOURS["pass"] if report.passed else COLOURS["fail"]
    subtitle = "\n".join(textwrap.wrap(printable(shorten(report.message, 600)), 120)) if report.message else ""
    if hidden or hidden_signals:
        left_out = [f"{hidden} of {hidden + len(rows)} rows" if hidden else "",
                    f"{hidden_signals} of {hidden_signals + len(samples)} signals" if hidden_signals else ""]  # fmt: skip
        subtitle += ("\n" if subtitle else "") + (
            f"not drawn: {' and '.join(w for w in left_out if w)} (limits {MAX_ROWS} rows, {MAX_SIGNALS} signals;"
            " failures are always drawn; the JSON report has everything)")
    verdict = printable(verdict)
    fig.suptitle(verdict + ("\n" + subtitle if subtitle else ""), color=colour, fontsize=12, fontweight="bold")
    return fig


MAX_ROWS = 200
"""Most timeline rows drawn (entries and criteria); a 20k-entry run would need a 6,000-inch figure."""

MAX_SIGNALS = 20
"""Most signal curves drawn."""


def _draw_rows(ax: Axes, rows: list[Row], span: float) -> None:
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    y = {row.id: i for i, row in enumerate(rows)}
    ends = {row.id: row.end for row in rows if row.section == "execute" and row.status in ("success", "failure")}
    dependencies: list[list[tuple[float, float]]] = []
    waits: list[list[tuple[float, float]]] = []
    for i, row in enumerate(rows):
        if row.section == "execute":
            _draw_entry(ax, i, row, span)
            for pred in row.after:
                end = ends.get(pred)
                if end is not None and row.start is not None and end <= row.start + 1e-9:  # it allowed the start
                    dependencies.append([(end, y[pred]), (row.start, i)])
            if row.waits_for:
                waits.append([(0.0, i), (row.start if row.start is not None else span, i)])
                text = f"waits for {row.join}({', '.join(row.waits_for)})"
                ax.annotate(text, (0.0, i), xytext=(2, 7), textcoords="offset points", fontsize=7, color=COLOURS["wait"])
        else:
            _draw_criterion(ax, i, row, span)
    ax.add_collection(LineCollection(dependencies, colors=COLOURS["dependency"], linewidths=0.7, zorder=1))
    ax.add_collection(LineCollection(waits, colors=COLOURS["wait"], linewidths=1.2, linestyles="dashed", zorder=1))
    executes = sum(1 for row in rows if row.section == "execute")
    if 0 < executes < len(rows):
        ax.axhline(executes - 0.5, color="black", linewidth=0.6)
    ax.set_yticks(range(len(rows)), [row.label for row in rows], fontsize=8)
    for tick, row in zip(ax.get_yticklabels(), rows):
        if row.failed_at is not None:
            tick.set_color(COLOURS["fail"])
    ax.set_ylim(len(rows) - 0.4, -0.8)
    ax.grid(axis="x", linewidth=0.3)
    ax.set_xlabel("run time, s")
    handles = [
        Patch(color=COLOURS["behavior"], label="behaviour"),
        Patch(color=COLOURS["constraint"], label="constraint"),
        Patch(facecolor="white", edgecolor="black", hatch="///", label="still running / stopped"),
        Line2D([], [], color=COLOURS["wait"], linestyle="--", label="trigger wait"),
        Line2D([], [], color=COLOURS["dependency"], linewidth=0.7, label="after"),
        Patch(color=COLOURS["pass"], alpha=0.5, label="criterion passed"),
        Patch(color=COLOURS["inconclusive"], alpha=0.5, label="undecided"),
        Patch(color=COLOURS["fail"], label="failed"),
    ]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)


def _note(ax: Axes, text: str, x: float, i: int, span: float, colour: str) -> None:
    """A short note beside a row's end; near the right edge it goes above the row, leftwards, to stay inside."""
    if x > 0.6 * span:
        ax.annotate(text, (x, i), xytext=(-6, 7), textcoords="offset points", fontsize=7, color=colour, ha="right")
    else:
        ax.annotate(text, (x, i), xytext=(7, -3), textcoords="offset points", fontsize=7, color=colour)


def _draw_entry(ax: Axes, i: int, row: Row, span: float) -> None:
    if row.start is None:
        ax.annotate("not started", (0.0, i), xytext=(2, -3), textcoords="offset points", fontsize=7, color="gray")
        return
    end = row.end if row.end is not None else row.start
    colour = COLOURS["fail"] if row.status == "failure" else COLOURS.get(row.kind, COLOURS["behavior"])
    unfinished = row.status in ("running", "stopped")
    ax.barh(i, max(end - row.start, 0.0), left=row.start, height=0.6, color=colour, edgecolor="black",
            linewidth=0.5, hatch="///" if unfinished else None, alpha=0.6 if unfinished else 1.0, zorder=2)  # fmt: skip
    if end - row.start < span * 0.004:  # an instant: a bar too thin to see
        ax.plot([row.start], [i], marker="|", markersize=11, markeredgewidth=2.5, color=colour, zorder=3)
    note = row.status if unfinished else (f"failed: {row.message}" if row.status == "failure" else "")
    if note:
        _note(ax, note, end, i, span, COLOURS["fail"] if row.status == "failure" else "black")


def _draw_criterion(ax: Axes, i: int, row: Row, span: float) -> None:
    colour = COLOURS.get(row.status, COLOURS["inconclusive"])
    if row.start is None:
        ax.annotate("never evaluated", (0.0, i), xytext=(2, -3), textcoords="offset points", fontsize=7, color="gray")
    elif row.kind == "final":
        ax.plot([row.start], [i], marker="D", markersize=8, color=colour, markeredgecolor="black", zorder=3)
    else:
        height = 0.25 if row.kind == "record" else 0.6
        ax.barh(i, (row.end or row.start) - row.start, left=row.start, height=height, color=colour, alpha=0.5,
                edgecolor=colour, zorder=2)  # fmt: skip
    if row.failed_at is not None:
        ax.plot([row.failed_at], [i], marker="X", markersize=10, color=COLOURS["fail"], markeredgecolor="black", zorder=4)
        _note(ax, f"failed: {row.message}", row.failed_at, i, span, COLOURS["fail"])


def _signal_series(report: Report) -> dict[str, list[tuple[float, float]]]:
    """Every numeric signal of the run: ``{name: [(t, value), ...]}``, sorted by name, one point per change.

    Drawn from the run's trace; a report without one (made by hand) falls back
    to what its oracles read. Values that are not numbers (strings, lists) are
    left out; booleans are 0/1.
    """
    trace = report.trace
    if trace is not None:
        series = {}
        for name in sorted(trace.signals):
            points = [(t, float(v)) for t, v in trace.series(name) if isinstance(v, (bool, int, float))]
            if points:
                series[name] = points
        return series
    samples: dict[str, dict[float, float]] = {}
    for oracle in report.oracles:
        for t, values in oracle.samples:
            for name, value in values.items():
                if isinstance(value, (bool, int, float)):
                    samples.setdefault(name, {})[t] = float(value)
    return {name: sorted(points.items()) for name, points in sorted(samples.items())}


def _draw_signals(ax: Axes, series: dict[str, list[tuple[float, float]]], report: Report, span: float) -> None:
    for name, points in series.items():
        times = [t for t, _ in points] + [max(report.duration, points[-1][0])]
        values = [v for _, v in points] + [points[-1][1]]
        ax.step(times, values, where="post", label=name, linewidth=1.4)
        ax.plot(times[:-1], values[:-1], linestyle="none", marker=".", markersize=4, color="black")
    for oracle in report.oracles:
        if oracle.verdict == "fail" and oracle.at is not None:
            for name, value in oracle.values.items():
                if name in series and isinstance(value, (bool, int, float)):
                    ax.plot([oracle.at], [float(value)], marker="o", markersize=7, color=COLOURS["fail"], zorder=4)
    ax.set_ylabel("signals", fontsize=8)
    ax.set_xlabel("run time, s")
    ax.grid(linewidth=0.3)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)


def plot_bytes(report: Report, case: TestCase, fmt: str) -> bytes:
    """The run picture as ``svg``, ``png`` or ``html`` (a page with the verdict table and the SVG)."""
    require_matplotlib()
    import matplotlib

    if fmt not in ("svg", "png", "html"):
        raise ValueError(f"fmt must be svg, png or html, not {fmt!r}")
    figure = plot_figure(report, case)
    buffer = io.BytesIO()
    # a fixed hash salt and no date make the SVG the same bytes on every run; text stays text
    with matplotlib.rc_context({"svg.hashsalt": "btgen_pytrees", "svg.fonttype": "none", "text.parse_math": False}):
        if fmt == "png":
            figure.savefig(buffer, format="png", dpi=100, metadata={"Software": None})
        else:
            figure.savefig(buffer, format="svg", metadata={"Date": None})
    data = buffer.getvalue()
    if fmt == "png":
        return data
    svg = xml_safe(data.decode("utf-8"))  # well-formed whatever a name held
    return _html_page(report, svg) if fmt == "html" else svg.encode("utf-8")


def _html_page(report: Report, svg: str) -> bytes:
    body = svg[svg.index("<svg"):]
    page = (
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
        f"<title>{html.escape(printable(report.test))}: {report.verdict}</title>\n</head>\n<body>\n"
        f"<pre>{html.escape(printable(report.table(), keep_newlines=True))}</pre>\n{body}\n</body>\n</html>\n"
    )
    return page.encode("utf-8")


def plot_run(report: Report, case: TestCase, path: str) -> None:
    """Write the run picture of *report* to *path* (``.svg``, ``.png`` or ``.html``).

    Written as every output is (:func:`btgen_pytrees.output.write_file`): complete or not at all,
    no temporary file left behind on failure, symlinks followed, devices written in place.
    """
    from ..output import write_file

    write_file(path, plot_bytes(report, case, plot_format(path)))
