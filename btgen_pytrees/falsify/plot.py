"""``falsify --plot``: convergence, and the parameter space coloured by margin.

Left: each run's objective against its number (failures as red crosses), the
best so far as a line, the first failure marked. Right: the searched box in the
sweep's verdict-map style - two parameters or more: the first two as a plane
(a list parameter by its choice index), every run a dot coloured by its
objective on a red-yellow-green scale centred on zero, failures as crosses,
each cluster's box as a rectangle and the boundary points as diamonds; one
parameter: the objective against it. The figure is built with matplotlib's
object API (no pyplot state) and saved with fixed metadata: same search, same
bytes. matplotlib is the ``plot`` extra, imported only here.
"""

from __future__ import annotations

from typing import Any, Mapping

from ..run.plot import figure_bytes
from .search import Search

__all__ = ["search_plot"]


def _coordinate(search: Search, k: int, value: Any) -> float:
    d = search.space.dimensions[k]
    if not d.continuous:
        return float(d.choices.index(value))
    return float(value)


def search_plot(search: Search, data: Mapping[str, Any], fmt: str) -> bytes:
    """The figure as ``svg`` or ``png`` bytes (``html``: the svg in a page)."""
    import matplotlib
    from matplotlib.colors import TwoSlopeNorm
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    figure = Figure(figsize=(12, 5))
    left, right = figure.subplots(1, 2)
    runs = data["runs"]
    objectives = [r["objective"] for r in runs]
    known = [o for o in objectives if o is not None]
    low, high = (min(min(known), -1e-9), max(max(known), 1e-9)) if known else (-1.0, 1.0)
    norm = TwoSlopeNorm(vcenter=0.0, vmin=low, vmax=high)
    cmap = matplotlib.colormaps["RdYlGn"]
    with matplotlib.rc_context({"text.parse_math": False}):
        xs = [r["index"] + 1 for r in runs if r["objective"] is not None]
        ys = [r["objective"] for r in runs if r["objective"] is not None]
        left.scatter(xs, ys, s=10, c=[cmap(norm(y)) for y in ys], edgecolors="none")
        best, line = None, []
        for r in runs:
            if r["objective"] is not None and (best is None or r["objective"] < best):
                best = r["objective"]
            line.append(best if best is not None else float("nan"))
        left.step(range(1, len(runs) + 1), line, where="post", color="#333333", linewidth=1, label="best so far")
        fails = [(r["index"] + 1, r["objective"] or 0.0) for r in runs if r["verdict"] != "pass"]
        if fails:
            left.scatter(*zip(*fails), marker="x", color="#d62728", s=25, label="failing run")
        if data["first_failure"]:
            left.axvline(data["first_failure"], color="#d62728", linewidth=0.8, linestyle=":", label=f"first failure (run {data['first_failure']})")
        left.axhline(0.0, color="#999999", linewidth=0.6)
        left.set_xlabel("run")
        left.set_ylabel("objective (scaled margin; < 0 fails)")
        left.set_title(f"convergence ({data['method']}, seed {data['seed']})")
        left.legend(loc="upper right", fontsize=8)
        names = [d["name"] for d in data["space"]]
        if len(names) >= 2:
            kx, ky = 0, 1
            px = [_coordinate(search, kx, r["parameters"][names[kx]]) for r in runs]
            py = [_coordinate(search, ky, r["parameters"][names[ky]]) for r in runs]
            colours = [cmap(norm(r["objective"])) if r["objective"] is not None else "#969696" for r in runs]
            right.scatter(px, py, s=12, c=colours, edgecolors="none")
            bad = [(x, y) for x, y, r in zip(px, py, runs) if r["verdict"] != "pass"]
            if bad:
                right.scatter(*zip(*bad), marker="x", color="#7f0000", s=20, linewidths=0.8)
            for c in data["clusters"]:
                bx, by = c["box"][names[kx]], c["box"][names[ky]]
                x0, x1 = _coordinate(search, kx, bx[0]), _coordinate(search, kx, bx[-1])
                y0, y1 = _coordinate(search, ky, by[0]), _coordinate(search, ky, by[-1])
                right.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, edgecolor="#7f0000", linewidth=1))
                right.annotate(str(c["cluster"]), (x1, y1), fontsize=8, color="#7f0000")
            edge = [(_coordinate(search, kx, b["parameters"][names[kx]]), _coordinate(search, ky, b["parameters"][names[ky]]))
                    for b in data["boundary"]]  # fmt: skip
            if edge:
                right.scatter(*zip(*edge), marker="D", facecolors="none", edgecolors="#000000", s=28, label="boundary point")
                right.legend(loc="upper right", fontsize=8)
            right.set_xlabel(names[kx])
            right.set_ylabel(names[ky])
            extra = f" (of {len(names)} parameters)" if len(names) > 2 else ""
            right.set_title(f"runs coloured by objective{extra}")
        else:
            px = [_coordinate(search, 0, r["parameters"][names[0]]) for r in runs]
            right.scatter(px, [r["objective"] if r["objective"] is not None else 0.0 for r in runs], s=12,
                          c=[cmap(norm(r["objective"])) if r["objective"] is not None else "#969696" for r in runs])  # fmt: skip
            right.axhline(0.0, color="#999999", linewidth=0.6)
            right.set_xlabel(names[0])
            right.set_ylabel("objective")
            right.set_title("runs by parameter")
        figure.colorbar(matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap), ax=right, label="objective")
        figure.suptitle(f"{data['test']}: {data['verdict']} - {data['runs_done']} runs, {data['failures']} failing")
        figure.tight_layout()
    return figure_bytes(figure, fmt, f"{data['test']}: {data['verdict']}")
