"""The text views are streams: drawn while written, never held whole, equal to the whole text (issue 11 item 3)."""

from __future__ import annotations

import io
import json
import os
import pathlib
import subprocess
import sys
import tracemalloc
from typing import Any, Iterator

import py_trees
import pytest
from helpers import case, entry
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_properties import timelines

import btgen_pytrees
from btgen_pytrees import cli
from btgen_pytrees.writing import commit
from btgen_pytrees.render import iter_json_tree, iter_text_tree, render, render_chunks, stream, text, tree_data
from btgen_pytrees.render.nodes import annotation, symbol, walk
from btgen_pytrees.timeline import matrix_lines

ROOT = pathlib.Path(__file__).resolve().parent.parent
FIG1 = ROOT / "examples" / "fig1.json"


def comb(steps: int) -> dict[str, Any]:
    entries = []
    for i in range(steps):
        entries.append(entry(f"S{i}", [f"S{i - 1}"] if i else [], duration=0.1))
        entries.append(entry(f"C{i}", [f"S{i}"], action="wait", duration=0.1))
    return case(*entries)


def reference_text(root: py_trees.behaviour.Behaviour, *, unicode: bool = True, max_depth: int | None = None) -> str:
    """The text view as it was written before it streamed (one list of lines, joined): the oracle."""
    sep, ellipsis = (" · ", "…") if unicode else (" - ", "...")
    lines, hidden = [], 0
    for depth, node in walk(root):
        if max_depth is not None and depth > max_depth:
            hidden += 1
            continue
        if hidden:
            lines.append(f"{'    ' * ((max_depth or 0) + 1)}{ellipsis} {hidden} more node{'s' if hidden > 1 else ''}")
            hidden = 0
        note = annotation(node)
        line = f"{'    ' * depth}{symbol(node)} {node.name}" + (f"{sep}{note}" if note else "")
        lines.append(line if unicode else line.encode("ascii", "replace").decode("ascii"))
    if hidden:
        lines.append(f"{'    ' * ((max_depth or 0) + 1)}{ellipsis} {hidden} more node{'s' if hidden > 1 else ''}")
    return "\n".join(lines) + "\n"


def reference_json(root: py_trees.behaviour.Behaviour, indent: int | None) -> str:
    """``json.dumps`` of the nested data, as the JSON view was made before it streamed: the oracle."""
    if indent is None:
        return json.dumps(tree_data(root), separators=(",", ":"), ensure_ascii=False, allow_nan=False) + "\n"
    return json.dumps(tree_data(root), indent=indent, ensure_ascii=False, allow_nan=False) + "\n"


class Unreachable(py_trees.behaviour.Behaviour):
    """A leaf that fails the test if any view walks as far as it (its ``children`` cannot be read)."""

    def update(self) -> py_trees.common.Status:
        return py_trees.common.Status.SUCCESS

    @property  # type: ignore[override]
    def children(self) -> list[py_trees.behaviour.Behaviour]:
        raise AssertionError("the view walked the whole tree before its first chunk")

    @children.setter
    def children(self, value: list[py_trees.behaviour.Behaviour]) -> None:
        pass


def wide_tree_ending_in_unreachable(leaves: int = 5_000) -> py_trees.behaviour.Behaviour:
    root = py_trees.composites.Sequence("root", memory=True)
    root.add_children([py_trees.behaviours.Success(f"leaf-{i}") for i in range(leaves)])
    root.add_child(Unreachable("last"))
    return root


# -- drawn while written ---------------------------------------------------------------------------


@pytest.mark.parametrize("view", ["unicode", "ascii", "json", "json-indented"])
def test_the_first_chunk_comes_before_the_tree_is_walked(view: str) -> None:
    root = wide_tree_ending_in_unreachable()
    if view.startswith("json"):
        chunks = iter_json_tree(root, 2 if view == "json-indented" else "auto")
    else:
        chunks = iter_text_tree(root, unicode=view == "unicode")
    first = next(chunks)
    assert first.startswith(("/_/", "{-} root", '{"name":"root"', '{\n  "name": "root"')) and "leaf-100" in first
    with pytest.raises(AssertionError, match="walked the whole tree"):
        list(chunks)  # the last node is reached only now


def test_the_matrix_is_drawn_row_by_row() -> None:
    loaded = btgen_pytrees.load(comb(300))
    rows = matrix_lines(btgen_pytrees.timeline(loaded))
    assert next(rows).startswith("# adjacency matrix of 600 entries")
    assert next(rows) == "S0: C0 S1\n"
    assert "".join(render_chunks(None, btgen_pytrees.timeline(loaded), "matrix")) == render(None, btgen_pytrees.timeline(loaded), "matrix")  # type: ignore[arg-type]


def test_chunks_are_bounded_and_never_empty(monkeypatch: pytest.MonkeyPatch) -> None:
    root = btgen_pytrees.generate(btgen_pytrees.load(comb(400)))
    for fmt in ("unicode", "ascii", "json"):
        chunks = list(render_chunks(root, btgen_pytrees.timeline(btgen_pytrees.load(comb(400))), fmt))
        assert len(chunks) > 2 and all(chunks)
        longest_piece = max(len(line) for line in "".join(chunks).splitlines(keepends=True))
        assert all(len(c) < stream.CHUNK_CHARS + longest_piece for c in chunks)  # one piece past the size at most


def test_memory_holds_a_chunk_not_the_view() -> None:
    """Taking the chunks one by one allocates a small part of the text's size at most (tracemalloc, not timed)."""
    loaded = btgen_pytrees.load(comb(4_000))
    root, graph = btgen_pytrees.generate(loaded), btgen_pytrees.timeline(loaded)
    for fmt, options in (("unicode", {}), ("json", {"indent": None}), ("json", {"indent": 2})):
        size = len(render(root, graph, fmt, **options))
        tracemalloc.start()
        try:
            for _ in render_chunks(root, graph, fmt, **options):
                pass
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert size > 1_500_000 and peak < size / 4, (fmt, options, size, peak)


# -- byte for byte what the whole text was -----------------------------------------------------------


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(timelines(max_entries=30), st.sampled_from([None, 0, 1, 2, 3]), st.sampled_from([None, 0, 1, 3]),
       st.sampled_from([1, 7, 200]))  # fmt: skip
def test_streams_join_to_the_whole_text(data: dict[str, Any], max_depth: int | None, indent: int | None, size: int) -> None:
    stream_size = stream.CHUNK_CHARS
    stream.CHUNK_CHARS = size  # small chunks: every boundary between pieces is exercised
    try:
        loaded = btgen_pytrees.load(data)
        root = btgen_pytrees.generate(loaded)
        for unicode in (True, False):
            chunks = list(iter_text_tree(root, unicode=unicode, max_depth=max_depth))
            assert "".join(chunks) == reference_text(root, unicode=unicode, max_depth=max_depth)
            assert text.text_tree(root, unicode=unicode, max_depth=max_depth) == "".join(chunks)
        assert "".join(iter_json_tree(root, indent)) == reference_json(root, indent)
    finally:
        stream.CHUNK_CHARS = stream_size


names = st.text(st.characters(codec="utf-8", exclude_categories=["Cs"]), max_size=8) | st.sampled_from(
    ['"', "\\", "\n", "\x1b[8m", "\u2028", "children", "a\tb", "é€😀"]
)


@st.composite
def py_trees_trees(draw: Any, budget: int = 40) -> py_trees.behaviour.Behaviour:
    """Any shape of stock py_trees composites, decorators and leaves, with any names."""
    count = [0]

    def node(depth: int) -> py_trees.behaviour.Behaviour:
        count[0] += 1
        name = draw(names)
        kind = draw(st.sampled_from(["leaf", "sequence", "selector", "parallel", "decorator"]))
        if depth > 6 or count[0] > budget or kind == "leaf":
            return py_trees.behaviours.Success(name)
        if kind == "decorator":
            return py_trees.decorators.Inverter(name, node(depth + 1))
        children = [node(depth + 1) for _ in range(draw(st.integers(0, 4)))]
        if kind == "parallel":
            policy = draw(st.sampled_from(["all", "one", "selected"]))
            made = {"all": lambda: py_trees.common.ParallelPolicy.SuccessOnAll(synchronise=draw(st.booleans())),
                    "one": py_trees.common.ParallelPolicy.SuccessOnOne,
                    "selected": lambda: py_trees.common.ParallelPolicy.SuccessOnSelected(children[:1])}[policy]()  # fmt: skip
            return py_trees.composites.Parallel(name, policy=made, children=children)
        cls = py_trees.composites.Sequence if kind == "sequence" else py_trees.composites.Selector
        return cls(name, memory=draw(st.booleans()), children=children)

    return node(0)


@settings(max_examples=150, deadline=None)
@given(py_trees_trees(), st.sampled_from([None, 0, 1, 2, 4]), st.sampled_from([1, 5, 64]))
def test_json_stream_equals_json_dumps_for_any_tree_and_names(root: py_trees.behaviour.Behaviour, indent: int | None,
                                                               size: int) -> None:  # fmt: skip
    stream_size = stream.CHUNK_CHARS
    stream.CHUNK_CHARS = size
    try:
        streamed = "".join(iter_json_tree(root, indent))
        assert streamed == reference_json(root, indent)
        assert json.loads(streamed) == tree_data(root)
        assert "".join(iter_text_tree(root)) == reference_text(root)
    finally:
        stream.CHUNK_CHARS = stream_size


def test_fig1_and_a_large_tree_equal_the_whole_text() -> None:
    for data in (FIG1, comb(1_500)):
        loaded = btgen_pytrees.load(data)
        root, graph = btgen_pytrees.generate(loaded), btgen_pytrees.timeline(loaded)
        for unicode in (True, False):
            for depth in (None, 2):
                assert "".join(iter_text_tree(root, unicode=unicode, max_depth=depth)) == reference_text(
                    root, unicode=unicode, max_depth=depth)  # fmt: skip
        auto = 2 if sum(1 for _ in walk(root)) <= 2_000 else None
        assert render(root, graph, "json") == reference_json(root, auto)
        for fmt in ("unicode", "ascii", "json", "matrix", "dot", "btcpp"):
            assert "".join(render_chunks(root, graph, fmt)) == render(root, graph, fmt)  # type: ignore[arg-type]


# -- the command line writes as it draws -------------------------------------------------------------


class Terminal(io.StringIO):
    """A stdout that notes how many nodes the text view had drawn when the first text reached it."""

    encoding = "utf-8"

    def __init__(self, drawn: list[int]) -> None:
        super().__init__()
        self.drawn = drawn
        self.at_first_write: int | None = None

    def write(self, s: str) -> int:
        if self.at_first_write is None and s:
            self.at_first_write = self.drawn[0]
        return super().write(s)


def test_show_prints_before_the_tree_is_drawn(tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "comb.json"
    path.write_text(json.dumps(comb(1_500)))
    drawn = [0]

    def counting(node: py_trees.behaviour.Behaviour) -> str:
        drawn[0] += 1
        return annotation(node)

    monkeypatch.setattr(text, "annotation", counting)
    out = Terminal(drawn)
    monkeypatch.setattr(sys, "stdout", out)
    assert cli.main(["show", str(path), "-f", "unicode"]) == 0
    nodes = drawn[0]
    assert out.at_first_write is not None and 0 < out.at_first_write < nodes / 4, (out.at_first_write, nodes)
    loaded = btgen_pytrees.load(str(path))
    assert out.getvalue() == render(btgen_pytrees.generate(loaded), btgen_pytrees.timeline(loaded), "unicode")


def cli_run(*args: str) -> subprocess.CompletedProcess[bytes]:
    return subprocess.run([sys.executable, "-m", "btgen_pytrees", *args], capture_output=True, timeout=300, cwd=ROOT)


def test_show_of_a_big_case_prints_and_writes_the_whole_text(tmp_path: pathlib.Path) -> None:
    path = tmp_path / "comb.json"
    path.write_text(json.dumps(comb(1_500)))
    loaded = btgen_pytrees.load(str(path))
    root, graph = btgen_pytrees.generate(loaded), btgen_pytrees.timeline(loaded)
    for fmt in ("unicode", "ascii", "json", "matrix"):
        whole = render(root, graph, fmt).encode("utf-8")  # type: ignore[union-attr]
        shown = cli_run("show", str(path), "-f", fmt)
        assert shown.returncode == 0 and shown.stderr == b"", shown.stderr
        assert shown.stdout == whole, fmt
        target = tmp_path / f"tree.{fmt}"
        assert cli_run("show", str(path), "-f", fmt, "-o", str(target)).returncode == 0
        assert target.read_bytes() == whole
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["comb.json", *(f"tree.{f}" for f in ("unicode", "ascii", "json", "matrix"))])


# -- a stream that fails half-way leaves no file -------------------------------------------------------


def failing_after(chunks: int) -> Iterator[str]:
    for i in range(chunks):
        yield f"chunk {i}\n"
    raise RuntimeError("drawing failed")


def test_a_stream_failing_half_way_leaves_no_file(tmp_path: pathlib.Path) -> None:
    kept = tmp_path / "kept.txt"
    kept.write_text("before\n")
    with pytest.raises(RuntimeError):
        commit([(str(tmp_path / "new.txt"), failing_after(3))])
    with pytest.raises(RuntimeError):
        commit([(str(kept), failing_after(3))])
    with pytest.raises(RuntimeError):  # a target written in place beside a file: made before any file is renamed
        commit([(str(tmp_path / "other.txt"), "whole\n"), (os.devnull, failing_after(3))])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept.txt"] and kept.read_text() == "before\n"
    commit([(str(kept), iter(["a", "b\n", b"c\n"]))])
    assert kept.read_bytes() == b"ab\nc\n"


def test_show_o_failing_while_drawing_leaves_no_file(tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch,
                                                      capsys: pytest.CaptureFixture[str]) -> None:  # fmt: skip
    path = tmp_path / "comb.json"
    path.write_text(json.dumps(comb(1_500)))
    target = tmp_path / "tree.txt"
    target.write_text("old\n")
    drawn = [0]

    def failing(node: py_trees.behaviour.Behaviour) -> str:
        drawn[0] += 1
        if drawn[0] == 3_000:
            raise RuntimeError("a node that cannot be drawn")
        return annotation(node)

    monkeypatch.setattr(text, "annotation", failing)
    assert cli.main(["show", str(path), "-o", str(target)]) == 3
    assert "internal error: RuntimeError: a node that cannot be drawn" in capsys.readouterr().err
    assert target.read_text() == "old\n" and sorted(p.name for p in tmp_path.iterdir()) == ["comb.json", "tree.txt"]
