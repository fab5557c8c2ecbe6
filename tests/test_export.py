"""Signals at real size (issue 23, items 1-5): telling order, choice by glob, the tidy table, the plot's panels.

Checked on fig1, on the SUMO cut-in (two vehicles, 24 signals; the real
simulator, skipped without libsumo outside CI) and on a generated 500-entry
case (docs/pictures.py's ``timeline_case``).
"""

from __future__ import annotations

import csv
import importlib.util
import io
import os
import pathlib
import sys
from typing import Any

import pytest
from helpers import case, crit, entry

import btgen_pytrees
from btgen_pytrees.cli import main
from btgen_pytrees.run import run
from btgen_pytrees.run.export import ordered_signals, select, signal_table, table_bytes

ROOT = pathlib.Path(__file__).resolve().parent.parent
CUT_IN = str(ROOT / "examples" / "sumo" / "cut_in.json")
FAILING = str(ROOT / "examples" / "fig1_failing.json")
sys.path.insert(0, str(ROOT / "docs"))
from pictures import timeline_case  # noqa: E402

needs_sumo = pytest.mark.skipif(importlib.util.find_spec("libsumo") is None and not os.environ.get("CI"),
                                reason="libsumo is not installed (CI installs it)")  # fmt: skip
needs_matplotlib = pytest.mark.skipif(importlib.util.find_spec("matplotlib") is None and not os.environ.get("CI"),
                                      reason="matplotlib is not installed (CI installs it)")  # fmt: skip
needs_pyarrow = pytest.mark.skipif(importlib.util.find_spec("pyarrow") is None and not os.environ.get("CI"),
                                   reason="pyarrow is not installed (CI installs the parquet extra)")  # fmt: skip


@pytest.fixture(scope="module")
def cut_in() -> tuple[Any, Any]:
    loaded = btgen_pytrees.load(CUT_IN)
    return loaded, run(loaded)


@pytest.fixture(scope="module")
def big() -> tuple[Any, Any]:
    loaded = btgen_pytrees.load(timeline_case())
    assert len(loaded.entries) == 500
    return loaded, run(loaded)


# -- 1. order ------------------------------------------------------------------------------------------


def test_order_failing_criteria_then_other_readers_then_the_rest() -> None:
    data = case(entry("B1", action="ramp", signal="a", to=10, duration=1),
                entry("C1", action="until", expect="u > 0", timeout=5),
                entry("B2", action="set", signal="u", value=1),
                criteria=[crit("R1", "record", "zed < 5"), crit("F1", "final", "m >= 0", at=0.5)],
                signals={"a": 0, "zed": 9, "m": 0, "u": 0, "other": 1})  # fmt: skip
    loaded = btgen_pytrees.load(data)
    report = run(loaded)
    assert report.verdict == "fail"
    # zed: read by the failing R1; m (F1) and u (until): other readers; the rest alphabetically
    assert ordered_signals(report, loaded) == ["zed", "m", "u", "a", "other"]


@needs_sumo
def test_cut_in_orders_what_decided_first(cut_in: tuple[Any, Any]) -> None:
    loaded, report = cut_in
    assert report.verdict == "fail" and len(report.trace.signals) > 20
    order = ordered_signals(report, loaded)
    assert order[:2] == ["sim.collisions", "ego.present"]  # R1 failed on it; P1 reads ego.present


# -- 4. choice -----------------------------------------------------------------------------------------


def test_select_by_globs() -> None:
    names = ["cutter.x", "ego.speed", "ego.x", "sim.collisions"]
    assert select(names, None) == names
    assert select(names, ["ego.*"]) == ["ego.speed", "ego.x"]
    assert select(names, ["*.x", "sim.*"]) == ["cutter.x", "ego.x", "sim.collisions"]
    assert select(names, ["EGO.*"]) == []  # case-sensitive, like signal names


# -- 5. the table --------------------------------------------------------------------------------------


def test_table_is_one_row_per_tick_with_the_traces_values_and_statuses() -> None:
    loaded = btgen_pytrees.load(FAILING)
    report = run(loaded)
    trace = report.trace
    columns, rows = signal_table(report, loaded)
    assert len(rows) == report.ticks == len(trace.times)
    assert columns[:2] == ["tick", "time"] and columns[-3:] == ["status:R1", "status:P1", "status:F1"]
    for k, row in enumerate(rows):
        assert row[0] == k and row[1] == trace.times[k]
        for name in trace.signals:
            assert row[columns.index(name)] == trace.value_at(name, k)
        for ident in ("B2", "R1"):
            assert row[columns.index(f"status:{ident}")] == trace.status_at(trace.node_index(ident), k)
    assert rows[-1][columns.index("status:R1")] == "failure"


def test_a_signal_without_value_is_empty_not_carried() -> None:
    """`late` is first written at 1 s: before, its cells are empty (not 0, not the first value)."""
    data = case(entry("W", action="wait", duration=1), entry("B1", ["W"], action="set", signal="late", value=7),
                criteria=[crit("F1", "final", "late == 7")])  # fmt: skip
    loaded = btgen_pytrees.load(data)
    report = run(loaded)
    text = table_bytes(report, loaded, "csv").decode()
    table = list(csv.DictReader(io.StringIO(text)))
    assert [r["late"] for r in table[:10]] == [""] * 10 and table[10]["late"] == "7"
    assert table[0]["status:W"] == "running" and table[-1]["status:F1"] == "success"


@needs_sumo
def test_cut_in_csv_every_signal_every_tick(cut_in: tuple[Any, Any], tmp_path: pathlib.Path) -> None:
    loaded, report = cut_in
    out = tmp_path / "cut_in.csv"
    assert main(["run", CUT_IN, "--signals-out", str(out)]) == 1
    table = list(csv.DictReader(io.StringIO(out.read_text(encoding="utf-8"))))
    assert len(table) == report.ticks
    assert set(report.trace.signals) <= set(table[0])
    assert table[0]["ego.present"] == "true" and table[-1]["sim.collisions"] == "1"
    assert table[-1]["status:R1"] == "failure"
    only = tmp_path / "ego.csv"
    assert main(["run", CUT_IN, "--signals-out", str(only), "--signals", "ego.*", "--signals", "sim.collisions"]) == 1
    header = only.read_text(encoding="utf-8").splitlines()[0].split(",")
    signals = [c for c in header if c not in ("tick", "time") and not c.startswith("status:")]
    assert signals and all(c.startswith("ego.") or c == "sim.collisions" for c in signals)


@needs_pyarrow
def test_parquet_round_trip_keeps_types_and_nulls(big: tuple[Any, Any], tmp_path: pathlib.Path) -> None:
    import pyarrow.parquet as pq

    data = case(entry("W", action="wait", duration=1), entry("B1", ["W"], action="set", signal="late", value=7),
                entry("B2", action="set", signal="flag", value=True),
                criteria=[crit("F1", "final", "late == 7")])  # fmt: skip
    loaded = btgen_pytrees.load(data)
    report = run(loaded)
    table = pq.read_table(io.BytesIO(table_bytes(report, loaded, "parquet")))
    assert table.num_rows == report.ticks
    assert str(table.schema.field("late").type) == "int64" and str(table.schema.field("flag").type) == "bool"
    assert str(table.schema.field("status:W").type) == "string"
    late = table.column("late").to_pylist()
    assert late[:10] == [None] * 10 and late[10] == 7
    loaded_big, report_big = big
    out = tmp_path / "big.parquet"
    assert main(["run", _write(tmp_path), "--signals-out", str(out)]) == 0
    again = pq.read_table(str(out))
    assert again.num_rows == report_big.ticks and "status:E99_3" in again.column_names
    assert str(again.schema.field("level").type) == "double"  # 0, then the ramp's floats


def _write(tmp_path: pathlib.Path) -> str:
    import json

    path = tmp_path / "timeline_500.json"
    path.write_text(json.dumps(timeline_case()), encoding="utf-8")
    return str(path)


def test_cli_signals_out_refuses_a_bad_name_before_the_run(tmp_path: pathlib.Path, capsys: Any) -> None:
    assert main(["run", FAILING, "--signals-out", str(tmp_path / "x.xlsx")]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1 and ".csv or .parquet" in captured.err
    assert main(["run", FAILING, FAILING, "--signals-out", str(tmp_path / "x.csv")]) == 2
    assert "take one file" in capsys.readouterr().err
    # --signals chooses for one run's views; a batch or a sweep would ignore it: refused, not ignored
    assert main(["run", FAILING, FAILING, "--out-dir", str(tmp_path / "o"), "--plot", "svg", "--signals", "s*"]) == 2
    assert "take one file" in capsys.readouterr().err
    sweep = str(ROOT / "examples" / "fig1_sweep.json")
    assert main(["run", sweep, "--signals", "speed"]) == 2
    assert "not a sweep's variations" in capsys.readouterr().err
    out = tmp_path / "few.csv"
    assert main(["run", FAILING, "--signals-out", str(out), "--signals", "sped", "--signals", "speed"]) == 1
    err = capsys.readouterr().err
    assert err == "btgen_pytrees: warning: --signals 'sped' matches no signal of the run\n"
    assert out.read_text(encoding="utf-8").splitlines()[0].startswith("tick,time,speed,status:")


def test_cli_parquet_without_pyarrow_is_a_hint(tmp_path: pathlib.Path, capsys: Any, monkeypatch: Any) -> None:
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    assert main(["run", FAILING, "--signals-out", str(tmp_path / "x.parquet")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "pip install 'btgen_pytrees[parquet]'" in err
    assert not (tmp_path / "x.parquet").exists()


@needs_sumo
def test_stdout_stays_the_report_with_pyarrow_installed() -> None:
    """libsumo prints a pyarrow version warning on stdout when imported; `--json -` must stay JSON."""
    import json
    import subprocess

    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-m", "btgen_pytrees", "run", CUT_IN, "--json", "-"], capture_output=True,
                          text=True, env=env, timeout=120, check=False)  # fmt: skip
    assert done.returncode == 1, done.stderr
    assert json.JSONDecoder().raw_decode(done.stdout)[0]["verdict"] == "fail" and "Warning" not in done.stdout


# -- 1-3: the plot at real size ------------------------------------------------------------------------


@needs_matplotlib
@needs_sumo
def test_cut_in_plot_draws_the_deciding_signal_with_its_bound(cut_in: tuple[Any, Any]) -> None:
    from btgen_pytrees.run.plot import COLOURS, plot_bytes, plot_figure, signal_panels

    loaded, report = cut_in
    panels = signal_panels(report, loaded)
    assert panels[0][1][0] == "sim.collisions"  # the failing criterion's signal: first panel, first curve
    drawn = [name for _, names in panels for name in names]
    assert "ego.x" in drawn and "ego.present" in drawn
    flags = next(names for title, names in panels if title.startswith("flag:"))
    assert set(flags) >= {"ego.present", "ego.collided", "cutter.present"}  # booleans together, as lanes
    figure = plot_figure(report, loaded)
    first = figure.axes[1]
    curves = {line.get_label(): line for line in first.get_lines()}
    assert curves["sim.collisions"].get_drawstyle() == "steps-post"  # an integer: steps
    bound = [line for line in first.get_lines() if line.get_label() == "_bound"]
    assert bound and list(bound[0].get_ydata()) == [0, 0] and bound[0].get_color() == COLOURS["fail"]
    margin = [line for line in first.get_lines() if line.get_label() == "_margin"]
    assert margin and list(margin[0].get_xdata()) == [4.0, 4.0] and list(margin[0].get_ydata()) == [0.0, 1.0]
    for ax in figure.axes:  # the failing tick across every panel
        assert any(list(line.get_xdata()) == [4.0, 4.0] and line.get_color() == COLOURS["fail"] for line in ax.get_lines())
    floats = next(ax for ax in figure.axes[1:] if "ego.speed" in {ln.get_label() for ln in ax.get_lines()})
    assert {ln.get_label(): ln for ln in floats.get_lines()}["ego.speed"].get_drawstyle() == "default"  # a line
    svg = plot_bytes(report, loaded, "svg").decode()
    assert "<text" in svg and "sim.collisions" in svg and "R1: sim.collisions == 0" in svg  # text stays text
    chosen = signal_panels(report, loaded, ["ego.*"])
    assert {n for _, names in chosen for n in names} <= {s for s in report.trace.signals if s.startswith("ego.")}


@needs_matplotlib
def test_big_run_keeps_the_verdict_rows_and_its_subtitle_fits(big: tuple[Any, Any]) -> None:
    from btgen_pytrees.run.plot import MAX_ROWS, plot_figure

    loaded, report = big
    assert report.verdict == "pass"
    figure = plot_figure(report, loaded)
    labels = [t.get_text() for t in figure.axes[0].get_yticklabels()]
    assert any(t.startswith("R1") for t in labels) and any(t.startswith("F1") for t in labels)
    assert MAX_ROWS <= len(labels) <= MAX_ROWS + 2
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.text import Text

    canvas = FigureCanvasAgg(figure)
    canvas.draw()
    renderer = canvas.get_renderer()
    titles = [t for t in figure.findobj(Text) if "not drawn" in t.get_text() or "PASS after" in t.get_text()]
    assert len(titles) == 2 and "R1" not in titles[0].get_text()
    for title in titles:  # inside the figure, left and right
        box = title.get_window_extent(renderer)
        assert 0 <= box.x0 and box.x1 <= figure.bbox.width
