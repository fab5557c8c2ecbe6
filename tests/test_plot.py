"""The run picture (``run --plot``) shows what happened: every entry when it ran, waits, oracles, failures.

The rows (what is drawn) are checked against the report; the drawn figure is
checked for its bars and red failure lines; the files are checked to parse as
SVG/PNG/HTML and to name every entry and criterion. matplotlib is the
optional ``plot`` extra: without it these tests skip, except under CI.
"""

from __future__ import annotations

import json
import os
import pathlib
import re
import sys
import xml.etree.ElementTree as ET
from typing import Any

import pytest
from helpers import case, crit, entry

import btgen_pytrees
from btgen_pytrees.cli import main
from btgen_pytrees.run import run
from btgen_pytrees.run.plot import COLOURS, PlotUnavailable, plot_bytes, plot_figure, plot_format, timeline_rows

if not os.environ.get("CI"):
    pytest.importorskip("matplotlib")

SVG = "{http://www.w3.org/2000/svg}"
ROOT = pathlib.Path(__file__).resolve().parent.parent


def fig1_failing(fig1_path: str) -> Any:
    """fig1 with B2 ramping to 40: R1 (speed <= 30) fails at 1.6 s while B2 is still running."""
    data = json.loads(open(fig1_path, encoding="utf-8").read())
    data["execute"][2]["params"]["to"] = 40
    return btgen_pytrees.load(data)


def test_rows_are_the_report(fig1_path: str) -> None:
    case_ = btgen_pytrees.load(fig1_path)
    report = run(case_)
    rows = timeline_rows(report, case_)
    execute = [r for r in rows if r.section == "execute"]
    assert [(r.id, r.start, r.end, r.status) for r in execute] == [(e.id, e.start, e.end, e.status) for e in report.execute]
    assert [r.id for r in rows if r.section == "oracle"] == [o.id for o in report.oracles]
    by_id = {r.id: r for r in rows}
    assert by_id["B4"].waits_for == ("B2", "B3") and by_id["B4"].join == "any"
    assert by_id["B3"].waits_for == () and by_id["B3"].after == ("C2",)  # a chain successor: no trigger
    assert (by_id["P1"].start, by_id["P1"].end) == (0, 3)  # the period's window
    assert by_id["F1"].start == by_id["F1"].end == 2.0  # the final's instant
    assert (by_id["R1"].start, by_id["R1"].end) == (0.0, report.duration)
    assert all(r.failed_at is None for r in rows)


def test_failing_run_rows_and_red_lines(fig1_path: str) -> None:
    case_ = fig1_failing(fig1_path)
    report = run(case_)
    assert report.verdict == "fail"
    rows = {r.id: r for r in timeline_rows(report, case_)}
    assert rows["R1"].failed_at == 1.6 and "speed <= 30 false by" in rows["R1"].message
    assert rows["B2"].status == "stopped" and rows["B2"].end == report.duration  # drawn to the end of the run
    assert rows["B4"].start == 1.5
    figure = plot_figure(report, case_)
    red_lines = [line for ax in figure.axes for line in ax.get_lines()
                 if line.get_color() == COLOURS["fail"] and list(line.get_xdata()) == [1.6, 1.6]
                 and line.get_label() != "_margin"]  # fmt: skip
    assert len(red_lines) == len(figure.axes) == 4  # across the timeline and every signal panel
    timeline_axes = figure.axes[0]
    labels = [t.get_text() for t in timeline_axes.get_yticklabels()]
    assert labels[0].startswith("B1") and any(t.startswith("R1") for t in labels)
    red_labels = [t.get_text() for t in timeline_axes.get_yticklabels() if t.get_color() == COLOURS["fail"]]
    assert red_labels == ["R1  record: speed <= 30"]


def test_passing_run_has_no_red_line(fig1_path: str) -> None:
    case_ = btgen_pytrees.load(fig1_path)
    figure = plot_figure(run(case_), case_)
    assert not [line for ax in figure.axes for line in ax.get_lines() if line.get_color() == COLOURS["fail"]]


def test_bars_span_each_entry(fig1_path: str) -> None:
    case_ = btgen_pytrees.load(fig1_path)
    report = run(case_)
    figure = plot_figure(report, case_)
    bars = [p for p in figure.axes[0].patches if p.get_height() == pytest.approx(0.6)]
    spans = sorted((round(p.get_x(), 6), round(p.get_x() + p.get_width(), 6)) for p in bars)
    expected = [(e.start, e.end) for e in report.execute] + [(0, 3)]  # entries, and the period window
    assert spans == sorted(expected)


def test_svg_names_everything_and_is_deterministic(fig1_path: str) -> None:
    case_ = fig1_failing(fig1_path)
    report = run(case_)
    svg = plot_bytes(report, case_, "svg")
    assert svg == plot_bytes(run(case_), case_, "svg")
    tree = ET.fromstring(svg)
    texts = " ".join(t.text or "" for t in tree.iter(f"{SVG}text"))
    for e in case_.entries:
        assert e.id in texts
    for c in case_.criteria:
        assert c.id in texts
    assert "FAIL" in texts and "waits for any(B2, B3)" in texts and "failed: speed <= 30" in texts


def test_the_svg_does_not_depend_on_the_layout_solvers_last_bits(fig1_path: str, monkeypatch: pytest.MonkeyPatch) -> None:
    # constrained layout (kiwisolver) was seen to place an axes differently in a float's last bits from one
    # process to the next, and matplotlib names each SVG clip rectangle by a hash of its exact bounds
    from matplotlib.layout_engine import ConstrainedLayoutEngine

    case_ = fig1_failing(fig1_path)
    report = run(case_)
    steady = plot_bytes(report, case_, "svg")
    solve = ConstrainedLayoutEngine.execute

    def jittered(self: Any, figure: Any) -> Any:
        done = solve(self, figure)
        for axes in figure.axes:
            x, y, w, h = axes.get_position().bounds
            axes.set_position([x + 3e-13, y - 2e-13, w, h + 1e-13], which="both")
        return done

    monkeypatch.setattr(ConstrainedLayoutEngine, "execute", jittered)
    assert plot_bytes(report, case_, "svg") == steady


def test_png_and_html(fig1_path: str) -> None:
    case_ = btgen_pytrees.load(fig1_path)
    report = run(case_)
    assert plot_bytes(report, case_, "png")[:8] == b"\x89PNG\r\n\x1a\n"
    page = plot_bytes(report, case_, "html").decode("utf-8")
    assert page.startswith("<!DOCTYPE html>") and "<svg" in page and "fig1: PASS after 3 s" in page


def test_plot_format() -> None:
    assert [plot_format(p) for p in ("a.svg", "B.PNG", "c.html")] == ["svg", "png", "html"]
    with pytest.raises(ValueError):
        plot_format("a.pdf")


def test_many_entries_and_unstarted_ones() -> None:
    entries = [entry(f"E{i}", [f"E{i - 1}"] if i else [], duration=0.1) for i in range(120)]
    data = case(*entries, entry("X", ["E0", "E119"], join="all"), timeout=5, criteria=[crit("R1", "record", "true")])
    case_ = btgen_pytrees.load(data)
    report = run(case_)
    assert report.verdict == "timeout"
    rows = {r.id: r for r in timeline_rows(report, case_)}
    assert rows["X"].start is None and rows["X"].waits_for == ("E0", "E119")
    svg = ET.fromstring(plot_bytes(report, case_, "svg"))
    texts = " ".join(t.text or "" for t in svg.iter(f"{SVG}text"))
    assert "not started" in texts and "E119" in texts


# -- the CLI ------------------------------------------------------------------------------------------


def test_cli_run_plot(fig1_path: str, tmp_path: Any) -> None:
    out = tmp_path / "run.svg"
    assert main(["run", fig1_path, "--plot", str(out)]) == 0
    ET.fromstring(out.read_bytes())
    failing = tmp_path / "failing.json"
    data = json.loads(open(fig1_path, encoding="utf-8").read())
    data["execute"][2]["params"]["to"] = 40
    failing.write_text(json.dumps(data), encoding="utf-8")
    page = tmp_path / "failing.html"
    assert main(["run", str(failing), "--plot", str(page)]) == 1  # the verdict's exit code; the picture is written
    assert "FAIL" in page.read_text(encoding="utf-8")


def test_cli_bad_suffix_is_exit_2_before_running(fig1_path: str, tmp_path: Any, capsys: Any) -> None:
    assert main(["run", fig1_path, "--plot", str(tmp_path / "x.pdf")]) == 2
    captured = capsys.readouterr()
    assert captured.err.count("\n") == 1 and ".svg, .png or .html" in captured.err and captured.out == ""


def test_cli_without_matplotlib_is_a_hint(fig1_path: str, tmp_path: Any, capsys: Any, monkeypatch: Any) -> None:
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib now raises ImportError
    assert main(["run", fig1_path, "--plot", str(tmp_path / "x.svg")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "pip install 'btgen_pytrees[plot]'" in err
    with pytest.raises(PlotUnavailable):
        plot_bytes(run(btgen_pytrees.load(fig1_path)), btgen_pytrees.load(fig1_path), "svg")


def test_readme_run_picture_is_current(fig1_path: str) -> None:
    """docs/images/fig1-run.svg (in the README) names every entry; with the same matplotlib it is today's output."""
    import matplotlib

    committed = (ROOT / "docs" / "images" / "fig1-run.svg").read_bytes()
    texts = " ".join(t.text or "" for t in ET.fromstring(committed).iter(f"{SVG}text"))
    case_ = btgen_pytrees.load(fig1_path)
    assert all(e.id in texts for e in case_.entries) and all(c.id in texts for c in case_.criteria)
    made_by = re.search(rb"Matplotlib v(\S+),", committed)
    if made_by and made_by.group(1).decode() == matplotlib.__version__:
        fresh = plot_bytes(run(case_), case_, "svg")
        assert fresh == committed, "regenerate: python docs/pictures.py plots"


def test_signal_panel_draws_every_signal_change_from_the_trace() -> None:
    """Defect 3: the panel used to sample a signal only when an oracle read it. `gap` is read
    only by `until`; `speed` goes on ramping after the only criterion reading it (a final at
    0.5 s) has decided, so its curve must follow the ramp to 30 at 3 s, tick by tick."""
    data = case(
        entry("B1", action="ramp", signal="gap", to=10, duration=1),
        entry("C1", action="until", expect="gap >= 5", timeout=2),
        entry("B2", action="ramp", signal="speed", to=30, duration=3),
        criteria=[crit("F1", "final", "speed < 10", at=0.5), crit("P1", "period", "true", **{"from": 0, "to": 3})],
        signals={"gap": 0, "speed": 0},
    )
    case_ = btgen_pytrees.load(data)
    report = run(case_)
    assert report.verdict == "pass"
    figure = plot_figure(report, case_)
    signals = figure.axes[1]
    curves = {line.get_label(): line for line in signals.get_lines() if not line.get_label().startswith("_")}
    assert set(curves) == {"gap", "speed"}
    speed = curves["speed"]
    expected = report.trace.series("speed")
    assert list(speed.get_xdata())[:-1] == [t for t, _ in expected] and speed.get_xdata()[-1] == report.duration
    assert list(speed.get_ydata())[:-1] == [float(v) for _, v in expected]
    assert expected[-1] == (3.0, 30) and len(expected) == 31  # every tick of the ramp
