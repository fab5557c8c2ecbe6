"""The verdict map: where in the parameter space a sweep fails, at a glance.

* one swept parameter - a **strip**: one cell per value, left to right;
* two - a **grid**: the first parameter across, the second up, a cell per
  variation (random draws, which do not form a grid, become a scatter plot);
* more - **parallel coordinates**: one vertical axis per parameter (its range
  scaled to the axis), one line per variation; passes are drawn first, so
  failures lie on top.

Colour is the verdict (pass green, fail red, timeout orange, error grey). When
a criterion grades how close a passing run came, colour is the run's *objective*
instead - the quantity ``falsify`` minimises (:mod:`.objective`: each graded
criterion's margin scaled by its spread over the sweep, combined as the oracle
combines them; negative when failed; a criterion without a gradient, such as a
collision count that is 0 on every passing run, is left out) - on a
red-yellow-green scale centred on zero, and every variation that did not pass is also marked with a cross - so
the map shows how close the passing region is to failing, not just where the
boundary is. A random sweep's ``sample`` number is not an axis.

matplotlib is the optional ``plot`` extra, imported only when drawing; output
is deterministic (same report, same SVG bytes).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Sequence

from ..run.plot import figure_bytes
from .report import VERDICTS, SweepReport
from ..load.variations import format_value

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

__all__ = ["map_figure", "map_bytes", "axes_of", "VERDICT_COLOURS"]

VERDICT_COLOURS = {"pass": "#31a354", "fail": "#d62728", "timeout": "#fd8d3c", "error": "#969696"}
_MARKS = {"fail": "x", "timeout": "T", "error": "E"}


def axes_of(report: SweepReport) -> list[str]:
    """The parameters the map shows: the varied ones without the random sweep's ``sample`` number."""
    return [name for name in report.varied if name != "sample"]


def _number(value: Any) -> float:
    return float(value)


def _colours(report: SweepReport) -> tuple[list[Any], Any, Any]:
    """Per row colour; and (norm, cmap) when the colours are objectives, else (None, None). The objective is
    the search's (:meth:`~.report.SweepReport.objectives`: the margins scaled, criteria without a gradient
    left out), not the oracle's margin: a collision count is 0 wherever the run passes, and pinned the
    margin of every passing run at 0 - one pale colour. With no graded criterion, the verdict's colours."""
    import matplotlib
    from matplotlib.colors import TwoSlopeNorm

    margins = report.objectives()
    if not any(m is not None for m in margins):
        return [VERDICT_COLOURS.get(r["verdict"], VERDICT_COLOURS["error"]) for r in report.rows], None, None
    finite = [m for m in margins if m is not None and math.isfinite(m)]  # an infinite margin takes its end's colour
    low, high = min(finite + [-1e-9]), max(finite + [1e-9])
    norm = TwoSlopeNorm(vcenter=0.0, vmin=low, vmax=high)
    cmap = matplotlib.colormaps["RdYlGn"]
    colours = [cmap(norm(min(max(m, low), high))) if m is not None else VERDICT_COLOURS["error"] for m in margins]
    return colours, norm, cmap


def _bar_ticks(low: float, high: float) -> list[float]:
    """Colour-bar ticks: a few on each side of 0 (the scale is centred there), 0 itself, no tick for a side
    that only pads the scale (+-1e-9)."""
    from matplotlib.ticker import MaxNLocator

    ticks = [0.0]
    for end in (low, high):
        if abs(end) > 1e-6:
            ticks += [t for t in MaxNLocator(4).tick_values(min(0.0, end), max(0.0, end)) if t != 0 and abs(t) <= abs(end)]
    return sorted(set(ticks))


def _is_grid(xs: Sequence[Any], ys: Sequence[Any]) -> bool:
    pairs = set(zip(xs, ys))
    return len(pairs) == len(xs) and len(pairs) == len(set(xs)) * len(set(ys))


def _ticks(values: Sequence[Any]) -> list[Any]:
    return sorted(set(values), key=lambda v: (isinstance(v, bool), float(v)))


def _cells(ax: Any, report: SweepReport, colours: list[Any], x: str, y: str | None) -> None:
    """Equal cells on categorical axes (the values in order), a mark on each that did not pass."""
    from matplotlib.patches import Rectangle

    xs = _ticks([r["parameters"][x] for r in report.rows])
    ys = _ticks([r["parameters"][y] for r in report.rows]) if y else [None]
    col = {v: i for i, v in enumerate(xs)}
    row = {v: j for j, v in enumerate(ys)}
    small = len(xs) * len(ys) <= 900
    for r, colour in zip(report.rows, colours):
        i, j = col[r["parameters"][x]], row[r["parameters"][y]] if y else 0
        ax.add_patch(Rectangle((i - 0.5, j - 0.5), 1, 1, facecolor=colour, edgecolor="white", linewidth=0.5))
        if r["verdict"] != "pass" and small:
            ax.text(i, j, _MARKS.get(r["verdict"], "?"), ha="center", va="center", fontsize=8, color="black")
    ax.set_xlim(-0.5, len(xs) - 0.5)
    ax.set_ylim(-0.5, len(ys) - 0.5)
    step = max(1, math.ceil(len(xs) / 20))
    ax.set_xticks(range(0, len(xs), step), [format_value(v) for v in xs[::step]], rotation=45 if len(xs) > 8 else 0)
    ax.set_xlabel(x)
    if y:
        step = max(1, math.ceil(len(ys) / 20))
        ax.set_yticks(range(0, len(ys), step), [format_value(v) for v in ys[::step]])
        ax.set_ylabel(y)
    else:
        ax.set_yticks([])
        ax.set_aspect("equal")


def _scatter(ax: Any, report: SweepReport, colours: list[Any], x: str, y: str | None) -> None:
    """Points at their values (random draws), failures on top and outlined."""
    order = sorted(range(len(report.rows)), key=lambda k: report.rows[k]["verdict"] != "pass")
    for k in order:
        r = report.rows[k]
        px = _number(r["parameters"][x])
        py = _number(r["parameters"][y]) if y else 0.0
        bad = r["verdict"] != "pass"
        ax.scatter([px], [py], s=28, color=colours[k], edgecolors="black" if bad else "none", linewidths=0.6,
                   marker="X" if bad else "o", zorder=3 if bad else 2)  # fmt: skip
    ax.set_xlabel(x)
    if y:
        ax.set_ylabel(y)
    else:
        ax.set_yticks([])
    ax.grid(linewidth=0.3)


def _parallel(ax: Any, report: SweepReport, colours: list[Any], names: list[str]) -> None:
    """One axis per parameter, one line per variation (failures drawn last, on top)."""
    spans = {}
    for n in names:
        values = [_number(r["parameters"][n]) for r in report.rows]
        spans[n] = (min(values), max(values))

    def scaled(n: str, v: Any) -> float:
        low, high = spans[n]
        return 0.5 if high == low else (_number(v) - low) / (high - low)

    order = sorted(range(len(report.rows)), key=lambda k: report.rows[k]["verdict"] != "pass")
    for k in order:
        r = report.rows[k]
        bad = r["verdict"] != "pass"
        ax.plot(range(len(names)), [scaled(n, r["parameters"][n]) for n in names], color=colours[k],
                linewidth=1.2 if bad else 0.6, alpha=0.9 if bad else 0.5, zorder=3 if bad else 2)  # fmt: skip
    for i, n in enumerate(names):
        ax.axvline(i, color="black", linewidth=0.8)
        low, high = spans[n]
        ax.text(i, -0.06, format_value(low), ha="center", va="top", fontsize=7)
        ax.text(i, 1.06, format_value(high), ha="center", va="bottom", fontsize=7)
    ax.set_xticks(range(len(names)), names)
    ax.set_yticks([])
    ax.set_ylim(-0.15, 1.15)
    for side in ("left", "right", "top"):
        ax.spines[side].set_visible(False)


def map_figure(report: SweepReport) -> "Figure":
    """The verdict map of *report* as a matplotlib Figure (not shown, not saved)."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    names = axes_of(report)
    colours, norm, cmap = _colours(report)
    wide = len(names) >= 3
    figure = Figure(figsize=(8, 2.6) if len(names) == 1 else (8, 5.5) if not wide else (9, 5))
    ax = figure.add_subplot(1, 1, 1)
    if not names or not report.rows:
        ax.text(0.5, 0.5, "nothing was varied", ha="center", va="center")
        ax.set_axis_off()
    elif len(names) == 1:
        values = [r["parameters"][names[0]] for r in report.rows]
        (_cells if len(set(values)) == len(values) else _scatter)(ax, report, colours, names[0], None)
    elif len(names) == 2:
        xs = [r["parameters"][names[0]] for r in report.rows]
        ys = [r["parameters"][names[1]] for r in report.rows]
        (_cells if _is_grid(xs, ys) else _scatter)(ax, report, colours, names[0], names[1])
    else:
        _parallel(ax, report, colours, names)
    counts = ", ".join(f"{n} {v}" for v, n in report.counts.items())
    ax.set_title(f"{report.test}: {len(report.rows)} variations - {counts}", fontsize=10)
    if norm is not None:
        from matplotlib.cm import ScalarMappable

        bar = figure.colorbar(ScalarMappable(norm=norm, cmap=cmap), ax=ax, fraction=0.05, pad=0.02)
        bar.set_ticks(_bar_ticks(norm.vmin, norm.vmax))  # each side of 0 has its own scale: ticks on both
        bar.set_label("objective (margins scaled, as falsify's; < 0 failed)", fontsize=8)
        handles = [Patch(facecolor="white", edgecolor="black", label=f"{_MARKS[v]} {v}") for v in ("fail", "timeout", "error")
                   if v in report.counts]  # fmt: skip
    else:
        handles = [Patch(facecolor=VERDICT_COLOURS[v], label=f"{v} ({report.counts[v]})") for v in VERDICTS if v in report.counts]
    if handles:
        ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(0.0, -0.18 if len(names) != 1 else -0.45),
                  ncol=len(handles), fontsize=8, frameon=False)  # fmt: skip
    figure.tight_layout()
    return figure


def map_bytes(report: SweepReport, fmt: str) -> bytes:
    """The map as ``svg``, ``png`` or ``html`` bytes (same report, same bytes)."""
    return figure_bytes(map_figure(report), fmt, f"{report.test}: {report.verdict}", report.summary())


