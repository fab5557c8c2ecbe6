"""Statements of the README and docs/ that were false (issue 35), each held by a test that checks it.

Where the statement is about what a command needs or accepts, the test runs the command that way;
where it is about a file or a figure, it compares the docs with what the project makes now. The
pictures and sample outputs themselves are compared in tests/test_pictures.py.
"""

from __future__ import annotations

import io
import os
import pathlib
import re
import shutil
from contextlib import redirect_stdout
from typing import Any

import pytest

from btgen_pytrees.cli import main
from btgen_pytrees.run.plot import SUFFIXES

ROOT = pathlib.Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text(encoding="utf-8")
VIEWS = (ROOT / "docs" / "views.md").read_text(encoding="utf-8")


def table_rows(text: str, header: str) -> list[list[str]]:
    """The rows of the Markdown table whose header line starts with *header*, as lists of cells."""
    lines = text[text.index(header):].splitlines()
    rows = []
    for line in lines[2:]:
        if not line.startswith("|"):
            break
        rows.append([cell.strip() for cell in line.strip("|").split(" | ")])
    return rows


def test_views_table_names_graphviz_only_for_the_pictures_it_draws(tmp_path: pathlib.Path, monkeypatch: Any) -> None:
    """docs/views.md said `--replay` needs Graphviz's dot: only `--format svg`/`png` do. The row's command runs
    with nothing on PATH (the page lays the tree out itself)."""
    rows = table_rows(VIEWS, "| command | what you get | needs |")
    assert len(rows) >= 7
    for command, _, needs in rows:
        assert ("Graphviz" in needs) == ("--format svg" in command), command
    replay = next(row for row in rows if "--replay" in row[0])
    assert replay[2] == "-"
    monkeypatch.setenv("PATH", str(tmp_path))
    assert shutil.which("dot") is None
    assert main(["run", str(ROOT / "examples" / "fig1.json"), "--replay", str(tmp_path / "run.html")]) == 0
    assert (tmp_path / "run.html").read_bytes().startswith(b"<!DOCTYPE html>")


def falsify_help() -> str:
    out = io.StringIO()
    with redirect_stdout(out):
        assert main(["falsify", "--help"]) == 0
    return " ".join(out.getvalue().split())


def test_falsify_help_names_every_plot_format(tmp_path: pathlib.Path) -> None:
    """`falsify --help` said `.svg/.png` for `--plot`, which takes `.html` too (as `run --plot` does)."""
    text = falsify_help()
    plot = text[text.index("--plot PATH "):][:200]
    for suffix in sorted(set(SUFFIXES) - {".htm"}):  # .htm: another spelling of .html
        assert suffix in plot, (suffix, plot)
    from btgen_pytrees.falsify.sampler import available

    if not available() and not os.environ.get("CI"):
        pytest.skip("the 'search' extra is not installed (CI installs it)")
    pytest.importorskip("matplotlib")
    page = tmp_path / "falsify.html"
    island = ROOT / "benchmarks" / "falsify_cases" / "island_2d.json"
    assert main(["falsify", str(island), "--budget", "6", "--jobs", "1", "--plot", str(page)]) in (0, 1)
    text = page.read_text(encoding="utf-8")
    assert text.startswith("<!DOCTYPE html>") and "<svg" in text


def test_readme_suite_figures_say_what_was_installed() -> None:
    """The README's figures for the set-up commands in a fresh venv were measured with Graphviz present, and
    did not say so: on a machine without it the tree pictures' tests skip too (more skips, fewer passes)."""
    start = README.index("Without the extras")
    sentence = README[start:README.index(".\n", start)]
    assert "Graphviz" in sentence and "skip" in sentence, sentence


def test_readme_replay_picture_says_what_it_shows() -> None:
    """The README's alt text said "tick 12" of a picture that shows tick 13 of 17 (the page counts from 1)."""
    alt = re.search(r"!\[([^\]]*)\]\(docs/images/fig1-replay\.png\)", README)
    assert alt and "tick 13 of 17" in alt.group(1) and "tick 12" not in alt.group(1)
    views = re.search(r"!\[([^\]]*)\]\(images/fig1-replay\.png\)", VIEWS)
    assert views and "tick 13 of 17" in views.group(1)


def test_readme_verdict_map_is_described_by_margins() -> None:
    """The README described the cut-in's map as red/green verdict cells: since margins, cells are coloured by
    how far each run was from failing, the margins scaled as falsify's objective (docs/sweeps.md), the scale
    the picture's colour bar names. The picture is made and checked by docs/pictures.py."""
    start = README.index("A sweep - one case, many parameter values")
    paragraph = README[start:README.index("](docs/images/cut_in_sweep_map.svg)", start)]
    assert "objective" in paragraph and "red-yellow-green scale" in paragraph and "red where" not in paragraph
    record = (ROOT / "docs" / "images" / "pictures.json").read_text(encoding="utf-8")
    assert '"cut_in_sweep_map.svg"' in record
    svg = (ROOT / "docs" / "images" / "cut_in_sweep_map.svg").read_text(encoding="utf-8")
    bar = [text for text in re.findall(r">([^<]*)</text>", svg) if "0 failed" in text]
    assert len(bar) == 1 and bar[0].startswith("objective"), bar  # the colour bar's label
