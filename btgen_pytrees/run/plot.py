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
import math
import os
import textwrap
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Sequence

from ..errors import plural, printable, shorten, xml_safe
from ..expressions import bounds
from ..formulas import formula_bounds
from ..model import TestCase
from ..writing import write_file
from .export import ordered_signals, select
from .report import OracleResult, Report
from .trace import ENDED

if TYPE_CHECKING:  # pragma: no cover - types only
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["Row", "timeline_rows", "signal_panels", "plot_figure", "plot_run", "plot_bytes", "figure_bytes", "plot_format", "require_matplotlib",
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
        failed = result.status in ("failure", "error")
        rows.append(Row(
            "execute", result.id, result.kind, printable(f"{result.id}  {entry.action}"), result.start, end, result.status,
            waits_for=entry.after if len(entry.after) > 1 else (), join=entry.join if len(entry.after) > 1 else "",
            after=entry.after, failed_at=result.end if failed else None, message=printable(shorten(result.message)) if failed else ""))  # fmt: skip
    criteria = {c.id: c for c in case.criteria}
    for oracle in report.oracles:
        start, end = _criterion_span(oracle, criteria[oracle.id], report.duration)
        failed = oracle.verdict == "fail"
        rows.append(Row(
            "oracle", oracle.id, oracle.type, printable(f"{oracle.id}  {oracle.type}: {oracle.expect}"), start, end,
            oracle.verdict, failed_at=oracle.at if failed else None, message=printable(shorten(oracle.message)) if failed else ""))  # fmt: skip
    return rows


def _criterion_span(oracle: OracleResult, criterion: Any, duration: float) -> tuple[float | None, float | None]:
    """Where a criterion is drawn: a record over the run, a period over its window, a final at its instant,
    a temporal criterion from its anchor to its horizon (cut at the end of the run)."""
    kind, at, verdict = oracle.type, oracle.at, oracle.verdict
    if kind == "final":
        instant = at if at is not None else criterion.at
        return instant, instant
    if kind == "period":
        start = criterion.start or 0.0
        end = criterion.end if criterion.end is not None else (at if verdict == "pass" and at is not None else duration)
        return start, end
    if kind == "temporal":  # the horizon's window: the anchor to the horizon
        if oracle.window is not None:
            start, horizon = oracle.window
            return start, duration if horizon is None else min(horizon, duration)
        return (criterion.start or 0.0) if criterion.anchor is None else None, duration
    return 0.0, duration


# -- drawing ----------------------------------------------------------------------------------------


def plot_figure(report: Report, case: TestCase, signals: Sequence[str] | None = None) -> Figure:
    """The run picture as a matplotlib Figure (not attached to pyplot, so no GUI backend is involved).

    *signals*: shell globs choosing the signals drawn (``--signals``; default all, in telling order).
    """
    import matplotlib

    with matplotlib.rc_context({"text.parse_math": False}):  # a '$' in a name is a dollar sign, not math
        return _plot_figure(report, case, signals)


def _capped(rows: list[Row], limit: int, report: Report | None = None) -> tuple[list[Row], int]:
    """At most *limit* rows, but never without the rows that carry the verdict.

    Kept first, whatever the limit: every failed row and every criterion whose
    verdict counts for the run (:meth:`Report.decisive`); then the other rows in
    order until *limit*. The kept rows stay in file order.
    """
    if len(rows) <= limit:
        return rows, 0
    decisive = {o.id for o in report.oracles if report.decisive(o)} if report is not None else set()
    keep = {i for i, row in enumerate(rows)
            if row.failed_at is not None or (row.section == "oracle" and (report is None or row.id in decisive))}
    for i in range(len(rows)):
        if len(keep) >= limit:
            break
        keep.add(i)
    return [row for i, row in enumerate(rows) if i in keep], len(rows) - len(keep)


def _plot_figure(report: Report, case: TestCase, patterns: Sequence[str] | None) -> Figure:
    from matplotlib.figure import Figure

    rows, hidden = _capped(timeline_rows(report, case), MAX_ROWS, report)
    series = _signal_series(report)
    chosen = ordered_signals(report, case, select(series, patterns))
    panels, left_out = _panels({name: series[name] for name in chosen}, _kinds(report))
    height_rows = max(1.6, 0.32 * len(rows) + 0.9)
    heights = [height_rows] + [PANEL_HEIGHT] * len(panels)
    width = 11.0
    subtitle = _subtitle(report, rows, hidden, left_out, len(chosen), width)
    title_height = 0.3 + 0.2 * (subtitle.count("\n") + 1 if subtitle else 0)
    fig = Figure(figsize=(width, sum(heights) + 0.6 + title_height), layout="constrained")
    axes = fig.subplots(len(heights), 1, sharex=True, height_ratios=heights, squeeze=False)[:, 0]
    top = axes[0]
    span = max(report.duration, case.tick, 1e-3)
    _draw_rows(top, rows, span)
    for ax, (title, names) in zip(axes[1:], panels):
        _draw_panel(ax, title, names, series, report, case, span)
    if panels:
        top.set_xlabel("")  # the signals below carry the shared time axis
        for ax in axes[:-1]:
            ax.set_xlabel("")
        axes[-1].set_xlabel("run time, s")
    failures = sorted({row.failed_at for row in rows if row.failed_at is not None})
    for ax in axes:
        for at in failures:
            ax.axvline(at, color=COLOURS["fail"], linewidth=1.2, alpha=0.8)
    top.set_xlim(-0.02 * span, span * 1.04)
    verdict = printable(f"{report.test}: {report.verdict.upper()} after {report.duration:g} s ({plural(report.ticks, 'tick')})")
    colour = COLOURS["pass"] if report.passed else COLOURS["fail"]
    fig.suptitle(verdict, color=colour, fontsize=12, fontweight="bold")
    if subtitle:
        # the figure's own text, wrapped to its width (its lines were counted into its height)
        top.set_title(subtitle, fontsize=SUBTITLE_SIZE, color=colour, loc="left", pad=8)
    return fig


def _subtitle(report: Report, rows: list[Row], hidden: int, left_out: list[str], drawn: int, width: float) -> str:
    """Why it ended, and what was not drawn; wrapped to fit *width* inches of :data:`SUBTITLE_SIZE` text."""
    chars = int(width * 72 / (SUBTITLE_SIZE * 0.62))
    lines = textwrap.wrap(printable(shorten(report.message, 400)), chars) if report.message else []
    notes = []
    if hidden:
        notes.append(f"{hidden} of {hidden + len(rows)} rows (limit {MAX_ROWS}; failures and deciding criteria are"
                     " always drawn)")  # fmt: skip
    if left_out:
        named = ", ".join(left_out[:6]) + (f", … ({len(left_out) - 6} more)" if len(left_out) > 6 else "")
        notes.append(f"{len(left_out)} of {drawn} signals ({named}; limits {MAX_PANELS} panels of"
                     f" {MAX_PER_PANEL}; choose with --signals)")  # fmt: skip
    if notes:
        lines += textwrap.wrap("not drawn: " + "; ".join(notes) + "; the JSON report and --signals-out have"
                               " everything", chars)  # fmt: skip
    return "\n".join(lines[:8])


MAX_ROWS = 200
"""Most timeline rows drawn (entries and criteria) besides the rows that carry the verdict."""

MAX_PANELS = 8
"""Most signal panels drawn."""

MAX_PER_PANEL = 6
"""Most curves in one panel (each its own colour)."""

PANEL_HEIGHT = 1.5
SUBTITLE_SIZE = 9


def _draw_rows(ax: Axes, rows: list[Row], span: float) -> None:
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    y = {row.id: i for i, row in enumerate(rows)}
    ends = {row.id: row.end for row in rows if row.section == "execute" and row.status in ("success", "failure", "error")}
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
    colour = COLOURS["fail"] if row.status in ("failure", "error") else COLOURS.get(row.kind, COLOURS["behavior"])
    unfinished = row.status in ("running", "stopped")
    ax.barh(i, max(end - row.start, 0.0), left=row.start, height=0.6, color=colour, edgecolor="black",
            linewidth=0.5, hatch="///" if unfinished else None, alpha=0.6 if unfinished else 1.0, zorder=2)  # fmt: skip
    if end - row.start < span * 0.004:  # an instant: a bar too thin to see
        ax.plot([row.start], [i], marker="|", markersize=11, markeredgewidth=2.5, color=colour, zorder=3)
    note = row.status if unfinished else (f"{'failed' if row.status == 'failure' else 'error'}: {row.message}"
                                          if row.status in ("failure", "error") else "")  # fmt: skip
    if note:
        _note(ax, note, end, i, span, COLOURS["fail"] if row.status in ("failure", "error") else "black")


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
    left out; booleans are 0/1. Where a signal ended (:data:`~.trace.ENDED`) the
    point is NaN: its line stops there, until it has a value again.
    """
    trace = report.trace
    if trace is not None:
        series = {}
        for name in sorted(trace.signals):
            points = [(t, math.nan if v is ENDED else float(v)) for t, v in trace.series(name)
                      if v is ENDED or isinstance(v, (bool, int, float))]  # fmt: skip
            if any(not math.isnan(v) for _, v in points):
                series[name] = points
        return series
    samples: dict[str, dict[float, float]] = {}
    for oracle in report.oracles:
        for t, values in oracle.samples:
            for name, value in values.items():
                if isinstance(value, (bool, int, float)):
                    samples.setdefault(name, {})[t] = float(value)
    return {name: sorted(points.items()) for name, points in sorted(samples.items())}


def _kinds(report: Report) -> dict[str, str]:
    """Each signal's kind: ``flag`` (only booleans), ``integer`` (only integers) or ``value``."""
    kinds: dict[str, str] = {}
    trace = report.trace
    if trace is not None:
        for name, (_, values) in trace.signals.items():
            numbers = [v for v in values if isinstance(v, (bool, int, float))]
            if numbers and all(isinstance(v, bool) for v in numbers):
                kinds[name] = "flag"
            elif numbers and all(isinstance(v, int) for v in numbers):
                kinds[name] = "integer"
            else:
                kinds[name] = "value"
    return kinds


def signal_panels(report: Report, case: TestCase, signals: Sequence[str] | None = None) -> list[tuple[str, list[str]]]:
    """The signal panels the run picture draws, as data: ``[(title, [signal, ...]), ...]``.

    The chosen signals (*signals*: globs, as ``--signals``) in telling order
    (:func:`~.export.ordered_signals`) are grouped: booleans into one panel of
    flags, the others by kind (integers as steps, other numbers as lines) and
    order of magnitude of their largest finite value, so that a lane index is
    never squashed flat under a position in metres. Panels come in the order of
    their most telling signal; past :data:`MAX_PANELS` panels or
    :data:`MAX_PER_PANEL` curves in one the rest is left out (the picture says so).
    """
    series = _signal_series(report)
    chosen = ordered_signals(report, case, select(series, signals))
    return _panels({name: series[name] for name in chosen}, _kinds(report))[0]


def _magnitude(points: list[tuple[float, float]]) -> int:
    finite = [abs(v) for _, v in points if math.isfinite(v)]
    top = max(finite, default=0.0)
    return math.floor(math.log10(top)) if top > 0 else 0


def _panels(series: dict[str, list[tuple[float, float]]], kinds: dict[str, str] | None = None
            ) -> tuple[list[tuple[str, list[str]]], list[str]]:  # fmt: skip
    """``(panels, left out)`` for *series* (already in telling order)."""
    kinds = kinds if kinds is not None else {}
    groups: dict[tuple[str, int], list[str]] = {}
    for name, points in series.items():
        kind = kinds.get(name, "value")
        groups.setdefault((kind, 0 if kind == "flag" else _magnitude(points)), []).append(name)
    panels, left_out = [], []
    for (kind, magnitude), names in groups.items():  # insertion order: the order of each group's first signal
        if len(panels) >= MAX_PANELS:
            left_out += names
            continue
        left_out += names[MAX_PER_PANEL:]
        names = names[:MAX_PER_PANEL]
        if kind == "flag":
            title = "flags"
        else:
            scale = f"up to ~{10 ** (magnitude + 1):g}" if magnitude >= 0 else f"under ~{10 ** (magnitude + 1):g}"
            title = ("integers " if kind == "integer" else "") + scale
        panels.append((f"{kind}:{title}", names))
    left_out.sort(key=list(series).index)
    return panels, left_out


def _draw_panel(ax: Axes, title: str, names: list[str], series: dict[str, list[tuple[float, float]]],
                report: Report, case: TestCase, span: float) -> None:  # fmt: skip
    kind, label = title.split(":", 1)
    end = max(report.duration, span)
    colours = [f"C{i}" for i in range(10)]
    if kind == "flag":  # one lane per flag, like a logic analyser: 0 low, 1 high
        for i, name in enumerate(names):
            points = series[name]
            times = [t for t, _ in points] + [max(end, points[-1][0])]
            values = [i + 0.7 * v for _, v in points] + [i + 0.7 * points[-1][1]]
            ax.step(times, values, where="post", label=name, linewidth=1.4, color=colours[i])
        ax.set_yticks([i + 0.35 for i in range(len(names))], names, fontsize=7)
        ax.set_ylim(-0.3, len(names))
    else:
        for i, name in enumerate(names):
            points = series[name]
            times = [t for t, _ in points] + [max(end, points[-1][0])]
            values = [v for _, v in points] + [points[-1][1]]
            if kind == "integer":
                ax.step(times, values, where="post", label=name, linewidth=1.4, color=colours[i])
            else:
                ax.plot(times, values, label=name, linewidth=1.4, color=colours[i])
        _draw_bounds(ax, names, report, case)
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)
    ax.set_ylabel(label, fontsize=7)
    ax.tick_params(axis="y", labelsize=7)
    ax.grid(linewidth=0.3)
    # the values a failing criterion read, at its time
    for oracle in report.oracles:
        if oracle.verdict == "fail" and oracle.at is not None:
            at, read = _violation(oracle)
            for name, value in read.items():
                if name in names and isinstance(value, (bool, int, float)):
                    y = names.index(name) + 0.7 * float(value) if kind == "flag" else float(value)
                    ax.plot([at], [y], marker="X", markersize=9, color=COLOURS["fail"],
                            markeredgecolor="black", zorder=5, label="_violation")  # fmt: skip


def _violation(oracle: OracleResult) -> tuple[float, dict[str, Any]]:
    """Where a failed criterion's violation is drawn, and the values read there: a temporal criterion's at the
    tick its explanation names (its verdict comes at the horizon), the others' at their verdict."""
    if oracle.violation is not None:
        return oracle.violation
    assert oracle.at is not None
    return oracle.at, oracle.values


def _draw_bounds(ax: Axes, names: list[str], report: Report, case: TestCase) -> None:
    """Each criterion's bound on a drawn signal as a dashed line; where it failed, the distance to it in red."""
    verdicts = {o.id: o for o in report.oracles}
    for criterion in case.criteria:
        oracle = verdicts.get(criterion.id)
        failed = oracle is not None and oracle.verdict == "fail" and oracle.at is not None
        if criterion.type == "temporal" and oracle is not None:  # the window the formula was judged over
            start, end = _criterion_span(oracle, criterion, report.duration)
            if start is not None and end is not None and end > start:
                ax.axvspan(start, end, color=COLOURS["fail"] if failed else "#555555", alpha=0.06, label="_window")
        for signal, op, bound in (formula_bounds(criterion.expect) if criterion.type == "temporal" else bounds(criterion.expect)):
            if signal not in names or not math.isfinite(bound):
                continue
            colour = COLOURS["fail"] if failed else "#555555"
            ax.axhline(bound, color=colour, linestyle="--", linewidth=0.9, alpha=0.9, label="_bound")
            ax.annotate(printable(f"{criterion.id}: {signal} {op} {bound:g}"), (0.0, bound), xycoords=("axes fraction", "data"),
                        xytext=(3, 2), textcoords="offset points", fontsize=7, color=colour)  # fmt: skip
            at, read = _violation(oracle) if failed else (None, {})  # type: ignore[arg-type]
            value = read.get(signal)
            if isinstance(value, (bool, int, float)) and math.isfinite(float(value)):
                ax.plot([at, at], [bound, float(value)], color=COLOURS["fail"], linewidth=2.5,
                        solid_capstyle="butt", zorder=4, label="_margin")  # fmt: skip


def plot_bytes(report: Report, case: TestCase, fmt: str, signals: Sequence[str] | None = None) -> bytes:
    """The run picture as ``svg``, ``png`` or ``html`` (a page with the verdict table and the SVG).

    *signals*: shell globs choosing the signals drawn (default: all, in telling order).
    """
    require_matplotlib()
    if fmt not in ("svg", "png", "html"):
        raise ValueError(f"fmt must be svg, png or html, not {fmt!r}")
    return figure_bytes(plot_figure(report, case, signals), fmt, f"{report.test}: {report.verdict}", report.table())


def figure_bytes(figure: Figure, fmt: str, title: str, text: str = "") -> bytes:
    """*figure* as ``svg``, ``png`` or ``html`` bytes (a page titled *title*: *text* above the SVG).

    The one way every picture of the package is written: a fixed hash salt and no date make the
    same figure the same bytes on every run; SVG text stays text; no mathtext, so a ``$`` in a name
    is a dollar sign; the SVG is well-formed whatever a name held.
    """
    import matplotlib

    buffer = io.BytesIO()
    with matplotlib.rc_context({"svg.hashsalt": "btgen_pytrees", "svg.fonttype": "none", "text.parse_math": False}):
        freeze_layout(figure)
        if fmt == "png":
            figure.savefig(buffer, format="png", dpi=100, metadata={"Software": None})
        else:
            figure.savefig(buffer, format="svg", metadata={"Date": None})
    data = buffer.getvalue()
    if fmt == "png":
        return data
    svg = xml_safe(data.decode("utf-8"))
    if fmt != "html":
        return svg.encode("utf-8")
    pre = f"<pre>{html.escape(printable(text, keep_newlines=True))}</pre>\n" if text else ""
    page = (
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
        f"<title>{html.escape(printable(title))}</title>\n</head>\n<body>\n"
        f"{pre}{svg[svg.index('<svg'):]}\n</body>\n</html>\n"
    )
    return page.encode("utf-8")


def freeze_layout(figure: Figure) -> None:
    """Lay *figure* out once and fix each axes' place, rounded to 1e-6 of the figure.

    Constrained layout (kiwisolver) can place an axes differently in the last bits of a float
    from one process to the next, and matplotlib's SVG names each clip rectangle by a hash of
    its exact bounds: the same figure would be other bytes now and then. Rounded places are
    the same in every process.
    """
    engine = figure.get_layout_engine()
    if engine is None:
        return
    engine.execute(figure)
    figure.set_layout_engine("none")
    for axes in figure.axes:
        axes.set_position([round(v, 6) for v in axes.get_position().bounds])


def plot_run(report: Report, case: TestCase, path: str, signals: Sequence[str] | None = None) -> None:
    """Write the run picture of *report* to *path* (``.svg``, ``.png`` or ``.html``).

    Written as every output is (:func:`btgen_pytrees.writing.write_file`): complete or not at all,
    no temporary file left behind on failure, symlinks followed, devices written in place.
    """
    write_file(path, plot_bytes(report, case, plot_format(path), signals))
