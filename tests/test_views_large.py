"""The JSON view is compact for large trees and indented for small ones, with the same data."""

from __future__ import annotations

import json
import pathlib
import subprocess
import sys

import pytest
from helpers import case, entry

import btgen_pytrees
from btgen_pytrees.render import JSON_INDENT_LIMIT, render, tree_data

ROOT = pathlib.Path(__file__).resolve().parent.parent
FIG1 = ROOT / "examples" / "fig1.json"


def cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "btgen_pytrees", *args], capture_output=True, text=True,
                          timeout=120, cwd=ROOT)  # fmt: skip


def _comb(steps: int) -> dict:
    entries = []
    for i in range(steps):
        entries.append(entry(f"S{i}", [f"S{i - 1}"] if i else []))
        entries.append(entry(f"C{i}", [f"S{i}"], action="wait"))
    return case(*entries)


def _count(root) -> int:  # type: ignore[no-untyped-def]
    return sum(1 for _ in root.iterate())


def test_large_tree_is_compact_small_tree_indented() -> None:
    small = btgen_pytrees.load(_comb(5))
    large = btgen_pytrees.load(_comb(JSON_INDENT_LIMIT // 4))
    for loaded, indented in ((small, True), (large, False)):
        root = btgen_pytrees.generate(loaded)
        assert (_count(root) <= JSON_INDENT_LIMIT) is indented
        text = render(root, btgen_pytrees.timeline(loaded), "json")
        assert text.endswith("\n") and (text.count("\n") > 1) is indented
        chosen = render(root, btgen_pytrees.timeline(loaded), "json", indent=2 if not indented else None)
        assert json.loads(text) == json.loads(chosen) and len(text) != len(chosen)


def _dumps(data: dict, indent: int | None) -> str:  # type: ignore[type-arg]
    if indent is None:
        return json.dumps(data, separators=(",", ":"), ensure_ascii=False) + "\n"
    return json.dumps(data, indent=indent, ensure_ascii=False) + "\n"


@pytest.mark.parametrize("given, indent", [("0", 0), ("1", 1), ("2", 2), ("4", 4), ("16", 16), ("none", None),
                                           ("NONE", None), ("auto", 2)])  # fmt: skip
def test_show_indent_chooses_the_json_layout(given: str, indent: int | None, tmp_path: pathlib.Path) -> None:
    data = tree_data(btgen_pytrees.generate(btgen_pytrees.load(FIG1)))
    shown = cli("show", str(FIG1), "-f", "json", "--indent", given)
    assert shown.returncode == 0 and shown.stderr == "", shown.stderr
    assert shown.stdout == _dumps(data, indent)
    target = tmp_path / "tree.json"  # the format from the suffix
    assert cli("show", str(FIG1), "-o", str(target), "--indent", given).returncode == 0
    assert target.read_text() == _dumps(data, indent)


def test_show_indent_overrides_the_size_rule_both_ways(tmp_path: pathlib.Path) -> None:
    large = tmp_path / "large.json"
    large.write_text(json.dumps(_comb(JSON_INDENT_LIMIT // 4)))
    data = tree_data(btgen_pytrees.generate(btgen_pytrees.load(str(large))))
    assert cli("show", str(large), "-f", "json").stdout == _dumps(data, None)  # default: compact above the limit
    assert cli("show", str(large), "-f", "json", "--indent", "2").stdout == _dumps(data, 2)
    assert cli("show", str(FIG1), "-f", "json", "--indent", "none").stdout.count("\n") == 1
    out = tmp_path / "out"  # batch mode passes it to every file
    result = cli("show", str(FIG1), str(large), "--out-dir", str(out), "-f", "json", "--indent", "3")
    assert result.returncode == 0, result.stderr
    assert (out / "large.json").read_text() == _dumps(data, 3)
    assert (out / "fig1.json").read_text() == _dumps(tree_data(btgen_pytrees.generate(btgen_pytrees.load(FIG1))), 3)


# -- issue 23 item 10: a big tree as a PNG stays readable ------------------------------------------------


def _png_size(data: bytes) -> tuple[int, int]:
    import struct

    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", data[16:24])  # type: ignore[return-value]


def test_png_of_a_500_entry_case_is_collapsed_readably_and_says_so(tmp_path: pathlib.Path) -> None:
    """It used to be a 32,767 x 229 px image (Graphviz's limit, text scaled to nothing) and no word about it."""
    import os
    import shutil

    if shutil.which("dot") is None and not os.environ.get("CI"):
        pytest.skip("needs Graphviz (CI installs it)")
    sys.path.insert(0, str(ROOT / "docs"))
    from pictures import timeline_case

    from btgen_pytrees.render.dot import PNG_MAX_NODES, png_depth
    from btgen_pytrees.render.nodes import walk

    source = tmp_path / "timeline_500.json"
    source.write_text(json.dumps(timeline_case()), encoding="utf-8")
    out = tmp_path / "big.png"
    done = cli(str(source), "-o", str(out))
    assert done.returncode == 0, done.stderr
    root = btgen_pytrees.generate(btgen_pytrees.load(timeline_case()))
    depth = png_depth(root)
    assert depth is not None and sum(1 for d, _ in walk(root) if d <= depth) <= PNG_MAX_NODES
    assert done.stderr.splitlines() == [f"{source}: {_count(root)} nodes cannot be read in one PNG: drawn down to depth "
                                        f"{depth} (deeper subtrees are '… N more nodes' boxes); choose with --max-depth"
                                        " N, or use .svg"]  # fmt: skip
    width, height = _png_size(out.read_bytes())
    assert width < 32767 and height > 800  # not squeezed to Graphviz's limit: 96 dpi, 10 pt text
    chosen = tmp_path / "chosen.png"
    done = cli(str(source), "-o", str(chosen), "--max-depth", "3")
    assert done.returncode == 0 and done.stderr == ""  # the user chose: no note
    small = tmp_path / "fig1.png"
    done = cli(str(FIG1), "-o", str(small))
    assert done.returncode == 0 and done.stderr == ""  # a small tree: whole, no note
