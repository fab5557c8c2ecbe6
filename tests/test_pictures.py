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
    """A sample that cannot be made here is skipped: libsumo only outside CI, the corpus wherever it is absent."""
    skipped: list[str] = []
    unchecked: list[str] = []
    stale = pictures.samples(skip=lambda sample: (unchecked if os.environ.get("CI") and "(needs libsumo)" in sample
                                                  else skipped).append(sample))  # fmt: skip
    assert stale + unchecked == [], "stale: run python docs/pictures.py samples"
    if skipped:
        pytest.skip(f"not checked here: {', '.join(skipped)}")


def test_the_samples_are_found_and_a_stale_one_is_told(tmp_path: pathlib.Path, monkeypatch: Any) -> None:
    marked = {doc.name: len(pictures.SAMPLE.findall(doc.read_text(encoding="utf-8"))) for doc in pictures.DOCS}
    assert marked["README.md"] >= 2 and marked["sumo.md"] >= 1 and marked["format.md"] >= 1 and marked["sweeps.md"] >= 4
    assert marked["pytest.md"] >= 4 and marked["falsify.md"] >= 1 and marked["semantics.md"] >= 4
    kinds = {m["kind"] for doc in pictures.DOCS for m in pictures.SAMPLE.finditer(doc.read_text(encoding="utf-8"))}
    assert kinds == set(pictures.RUNNERS)  # every kind of sample is used, and checked by the test above
    doc = tmp_path / "doc.md"
    doc.write_text("<!-- sample: examples/fig1.json --format matrix -->\n```text\n   B1 C1\n```\n\n"
                   "<!-- sample file: examples/fig1.json -->\n```json\n{}\n```\n\n"
                   "<!-- sample: falsify --help | usage -->\n```text\nfalsify SWEEP.json [--budget N]\n```\n\n"
                   '```json\n{"name": "d", "tick": 0.1, "timeout": 1, "execute": [{"id": "A", "kind": "behavior", '
                   '"action": "hold", "params": {"duration": 0.1}}]}\n```\n\n```text\nnot a case\n```\n\n'
                   "<!-- sample (f.json = examples/fig1_failing.json, cases/b.json = the 2nd block above): "
                   "validate f.json cases/b.json | lines ok: -->\n```text\n$ python -m btgen_pytrees\n```\n", encoding="utf-8")  # fmt: skip
    monkeypatch.setattr(pictures, "DOCS", [doc])
    assert pictures.samples() == ["doc.md: examples/fig1.json --format matrix", "doc.md: examples/fig1.json",
                                  "doc.md: falsify --help | usage", "doc.md: validate f.json cases/b.json | lines ok:"]  # fmt: skip
    assert pictures.samples(write=True) and pictures.samples() == []
    made = doc.read_text(encoding="utf-8")
    assert "B1  0  1  1  0  0  0" in made
    assert "```text\nusage: python -m btgen_pytrees falsify [-h]" in made and "  SWEEP  " not in made  # the usage alone
    # files from the repository and from the 2nd block above, shown from the prompt, the last line left out as "..."
    assert ("```text\n$ python -m btgen_pytrees validate f.json cases/b.json\nf.json: ok: 6 entries, 3 criteria\n"
            "cases/b.json: ok: 1 entry, 0 criteria\n...\n```") in made  # fmt: skip


def test_an_excerpt_is_made_by_its_rule_and_a_rule_that_keeps_nothing_is_an_error() -> None:
    """``lines`` and ``section`` mark each run of left-out lines with one ``...``; ``usage`` is the first paragraph."""
    out = ("F.    [100%]\n===== FAILURES =====\n_____ a_exit _____\na_exit: ERROR - it ended\n\nmore\n"
           "_____ b[x=1] _____\nb: FAIL\n===== short test summary info =====\nFAILED a\n")  # fmt: skip
    assert pictures.excerpt(out, None, None) == out
    assert pictures.excerpt(out, "section", "a_exit") == "...\n_____ a_exit _____\na_exit: ERROR - it ended\n\nmore\n...\n"
    assert pictures.excerpt(out, "section", "b[x=1]") == "...\n_____ b[x=1] _____\nb: FAIL\n...\n"
    assert pictures.excerpt(out, "lines", "^F|FAIL") == "F.    [100%]\n===== FAILURES =====\n...\nb: FAIL\n...\nFAILED a\n"
    assert pictures.excerpt(out, "usage", None) == "F.    [100%]\n===== FAILURES =====\n_____ a_exit _____\na_exit: ERROR - it ended\n"
    with pytest.raises(ValueError, match="keeps no line"):
        pictures.excerpt(out, "section", "c")
    assert pictures.EXCERPT.fullmatch("-k 'a or b' x.json -q | lines a|b")["args"] == "-k 'a or b' x.json -q"  # type: ignore[index]
    assert pictures.EXCERPT.fullmatch("x.json -q")["rule"] is None  # type: ignore[index]
    assert [pictures.DURATION.sub("", line) for line in ("1 failed, 2 passed in 0.52s", "30 tests collected in 12s",
                                                          "1 error in 61.20s (0:01:01)", "nothing in 3s here")] == [
        "1 failed, 2 passed", "30 tests collected", "1 error", "nothing in 3s here"]  # fmt: skip
    with pytest.raises(ValueError, match="needs -q"):
        pictures.pytest_output(["--collect-only"])


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


def test_a_sample_of_the_corpus_is_skipped_where_the_corpus_is_absent(tmp_path: pathlib.Path, monkeypatch: Any) -> None:
    """The ALKS corpus is not part of the repository (it may be absent in CI): its samples are checked where it is."""
    (sample,) = [m for m in pictures.SAMPLE.finditer((ROOT / "README.md").read_text(encoding="utf-8")) if m["inputs"]]
    doc = tmp_path / "doc.md"
    doc.write_text(sample.group(0).replace("PASS", "FAIL") + "\n", encoding="utf-8")
    monkeypatch.setattr(pictures, "DOCS", [doc])
    monkeypatch.setattr(pictures, "CORPUS", tmp_path / "no-corpus")
    skipped: list[str] = []
    assert pictures.samples(skip=skipped.append) == [] and skipped == [f"doc.md: {sample['args']} (needs the OpenSCENARIO corpus)"]
    assert pictures.samples() == [f"doc.md: {sample['args']} (needs the OpenSCENARIO corpus)"]


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
