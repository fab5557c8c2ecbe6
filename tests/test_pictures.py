"""Every picture and sample output of the README and docs/ is what the project makes now (docs/pictures.py).

A stale picture or sample fails here; ``python docs/pictures.py`` makes them again. What is compared
for a rendered picture (its data, matplotlib's SVG where the same matplotlib made it, and the file
against the record written with it) is explained in docs/pictures.py. The SUMO pictures need libsumo
and skip without it, except under CI.
"""

from __future__ import annotations

import importlib.util
import json
import os
import pathlib
import re
import sys
from typing import Any

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "docs"))
import pictures  # noqa: E402


def test_every_sample_output_is_what_its_command_prints() -> None:
    skipped: list[str] = []
    assert pictures.samples(skip=None if os.environ.get("CI") else skipped.append) == [], \
        "stale: run python docs/pictures.py samples"  # fmt: skip
    if skipped:
        pytest.skip(f"not checked without libsumo: {', '.join(skipped)}")


def test_the_samples_are_found_and_a_stale_one_is_told(tmp_path: pathlib.Path, monkeypatch: Any) -> None:
    marked = {doc.name: len(pictures.SAMPLE.findall(doc.read_text(encoding="utf-8"))) for doc in pictures.DOCS}
    assert marked["README.md"] >= 2 and marked["sumo.md"] >= 1 and marked["format.md"] >= 1 and marked["sweeps.md"] >= 1
    doc = tmp_path / "doc.md"
    doc.write_text("<!-- sample: examples/fig1.json --format matrix -->\n```text\n   B1 C1\n```\n\n"
                   "<!-- sample file: examples/fig1.json -->\n```json\n{}\n```\n", encoding="utf-8")  # fmt: skip
    monkeypatch.setattr(pictures, "DOCS", [doc])
    assert pictures.samples() == ["doc.md: examples/fig1.json --format matrix", "doc.md: examples/fig1.json"]
    assert pictures.samples(write=True) and pictures.samples() == []
    assert "B1  0  1  1  0  0  0" in doc.read_text(encoding="utf-8")


def test_every_picture_of_the_docs_is_made_by_the_script() -> None:
    """Every picture a doc shows, and every file in docs/images/, is one the script makes and has recorded."""
    shown = set()
    for doc in pictures.DOCS:
        shown |= set(re.findall(r"\]\((?:docs/)?images/([^)\s]+)\)", doc.read_text(encoding="utf-8")))
    made = {picture.file for picture in pictures.PICTURES}
    assert shown <= made
    assert {p.name for p in pictures.IMAGES.iterdir()} - {pictures.RECORD.name} == made
    assert set(pictures.read_record()["pictures"]) == made


def test_every_picture_is_what_the_project_draws_now() -> None:
    skipped: list[str] = []

    def skip(picture: Any, reasons: list[str], missing: bool) -> None:
        if os.environ.get("CI") and missing:
            pytest.fail(f"{picture.file}: {', '.join(reasons)} missing under CI")
        skipped.append(f"{picture.file} ({', '.join(reasons)})")

    assert pictures.stale_pictures(skip=skip) == [], "stale: run python docs/pictures.py"
    if skipped:
        pytest.skip(f"not checked here: {', '.join(skipped)}")


def test_a_stale_picture_is_told(tmp_path: pathlib.Path, monkeypatch: Any) -> None:
    """A picture whose data changed, or whose file is not the recorded one, is reported (on the tree picture:
    its dot source is made without Graphviz)."""
    (tree,) = [p for p in pictures.PICTURES if p.kind == "tree"]
    record = pictures.read_record()
    record["pictures"] = {tree.file: record["pictures"][tree.file]}
    monkeypatch.setattr(pictures, "PICTURES", (tree,))
    monkeypatch.setattr(pictures, "RECORD", tmp_path / "pictures.json")
    (tmp_path / "pictures.json").write_text(json.dumps(record), encoding="utf-8")
    assert pictures.stale_pictures() == []
    record["pictures"][tree.file]["drawn_from"]["tree.dot"] = "0" * 64
    (tmp_path / "pictures.json").write_text(json.dumps(record), encoding="utf-8")
    assert pictures.stale_pictures() == [f"{tree.file}: its tree.dot is not what the project makes now"]
    record["pictures"][tree.file]["sha256"] = "0" * 64
    (tmp_path / "pictures.json").write_text(json.dumps(record), encoding="utf-8")
    assert pictures.stale_pictures() == [f"{tree.file}: the file is not the one its record was written with"]


@pytest.mark.skipif(importlib.util.find_spec("matplotlib") is None, reason="matplotlib is not installed")
def test_the_record_names_the_matplotlib_that_drew_each_figure() -> None:
    """matplotlib's SVG is compared exactly only where the same matplotlib made the picture: the record says which."""
    for picture in pictures.PICTURES:
        kept = pictures.read_record()["pictures"][picture.file]
        assert ("matplotlib" in kept) == (picture.kind in ("plot", "map")), picture.file
        if picture.file.endswith(".svg") and picture.kind in ("plot", "map"):
            text = (pictures.IMAGES / picture.file).read_text(encoding="utf-8")
            assert f"Matplotlib v{kept['matplotlib']}," in text  # the SVG's own metadata


def test_without_libsumo_the_sumo_samples_and_pictures_are_skipped_not_stale(monkeypatch: Any) -> None:
    """The README's set-up installs no SUMO: its samples and pictures are then left out (outside CI), not failed."""
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "libsumo" else real(name, *a))
    skipped: list[str] = []
    monkeypatch.setattr(pictures, "DOCS", [ROOT / "docs" / "sumo.md"])
    assert pictures.samples(skip=skipped.append) == [] and skipped == ["sumo.md: session (needs libsumo)"]
    assert [p.file for p in pictures.PICTURES if pictures.needs(p) == ["libsumo"]] == [
        "cut_in-run.svg", "cut_in_sweep_map.svg", "cut_in-replay.png"]


def test_a_picture_of_another_sumo_is_not_compared(tmp_path: pathlib.Path, monkeypatch: Any) -> None:
    """A SUMO release may move a vehicle by a millimetre: a SUMO picture's data is compared only with the SUMO
    that made it (the record says which); with another one it is reported as not comparable, not as stale."""
    (picture,) = [p for p in pictures.PICTURES if p.file == "cut_in-run.svg"]
    record = pictures.read_record()
    assert record["pictures"][picture.file]["sumo"]
    record["pictures"] = {picture.file: {**record["pictures"][picture.file], "sumo": "0.0.0"}}
    monkeypatch.setattr(pictures, "PICTURES", (picture,))
    monkeypatch.setattr(pictures, "RECORD", tmp_path / "pictures.json")
    (tmp_path / "pictures.json").write_text(json.dumps(record), encoding="utf-8")
    monkeypatch.setattr(pictures, "sumo_version", lambda: "1.28.0")
    monkeypatch.setattr(pictures, "needs", lambda p: [])
    told: list[tuple[str, list[str], bool]] = []
    assert pictures.stale_pictures(skip=lambda p, reasons, missing: told.append((p.file, reasons, missing))) == []
    assert told == [("cut_in-run.svg", ["SUMO 0.0.0 (here 1.28.0)"], False)]
