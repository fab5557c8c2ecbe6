"""The Graphviz views (dot, svg, png) tell the truth about the tree.

The DOT text is parsed back (with pydot) into a tree and compared with the
py_trees tree node by node, so a missing entry, a wrong policy, a lost edge or
a lost wait would fail here. SVG/PNG need Graphviz's ``dot``: those tests skip
without it, except under CI (``CI`` set), where ``.ci/run`` installs it.
"""

from __future__ import annotations

import os
import pathlib
import random
import re
import shutil
import struct
import xml.etree.ElementTree as ET
from typing import Any

import py_trees
import pydot
import pytest
from helpers import case, crit, entry, generate

import btgen_pytrees
from btgen_pytrees.cli import main
from btgen_pytrees.leaves.wiring import Trigger
from btgen_pytrees.render import render
from btgen_pytrees.render.dot import STYLES, GraphvizMissing, dot_source, graphviz_render
from btgen_pytrees.render.nodes import annotation, node_info, role, walk
from btgen_pytrees.timeline import timeline

pytestmark = pytest.mark.filterwarnings("ignore:.*deprecated.*:DeprecationWarning")  # pydot's parser on new pyparsing
needs_dot = pytest.mark.skipif(
    shutil.which("dot") is None and not os.environ.get("CI"),
    reason="Graphviz's dot is not installed (CI installs it)",
)
SVG = "{http://www.w3.org/2000/svg}"
ROOT = pathlib.Path(__file__).resolve().parent.parent


def unquote(value: str) -> str:
    """A DOT quoted string back to text (the inverse of ``dot._quoted``)."""
    assert value.startswith('"') and value.endswith('"'), value
    out, chars = [], iter(value[1:-1])
    for c in chars:
        if c == "\\":
            nxt = next(chars)
            out.append("\n" if nxt == "n" else nxt)
        else:
            out.append(c)
    return "".join(out)


class Picture:
    """The DOT text parsed back: nodes with their attributes, tree edges in order, wait edges."""

    def __init__(self, source: str):
        (graph,) = pydot.graph_from_dot_data(source)
        self.graph = graph
        self.nodes = {n.get_name(): n.get_attributes() for n in graph.get_nodes() if n.get_name() not in ("node", "edge", "graph")}
        self.children: dict[str, list[str]] = {}
        self.edge_attrs: dict[tuple[str, str], dict[str, Any]] = {}
        self.waits: set[tuple[str, str]] = set()
        for edge in graph.get_edges():
            src, dst, attrs = edge.get_source(), edge.get_destination(), edge.get_attributes()
            if attrs.get("constraint") == "false":
                self.waits.add((src, dst))
            else:
                self.children.setdefault(src, []).append(dst)
                self.edge_attrs[(src, dst)] = attrs
        self.legend = [s for s in graph.get_subgraphs() if s.get_name() == "cluster_legend"]
        self.element_ids = {unquote(a["id"]): n for n, a in self.nodes.items() if "id" in a}

    def label(self, name: str) -> list[str]:
        return unquote(self.nodes[name]["label"]).split("\n")

    def by_element_id(self, element_id: str) -> str:
        return self.element_ids[element_id]


def check_faithful(root: py_trees.behaviour.Behaviour, source: str) -> Picture:
    """Walk the py_trees tree and the parsed picture together; every node, edge and detail must match."""
    picture = Picture(source)
    assert unquote(picture.graph.get_attributes()["label"]) == root.name  # the title
    assert picture.graph.get_attributes()["ordering"] == "out"  # children drawn in tick order
    shown: dict[int, str] = {}
    stack = [(root, "n0")]
    while stack:
        node, name = stack.pop()
        shown[id(node)] = name
        label = picture.label(name)
        assert label[0] == node.name
        info = node_info(node)
        text = " ".join(label[1:])
        note = annotation(node)
        if isinstance(node, (py_trees.composites.Parallel, py_trees.composites.Sequence)):
            note = f"{info['type']}: {note}"
        assert text.split() == note.split()  # the same words as the text view, wrapped
        if "policy" in info:
            assert text.startswith(f"Parallel: {info['policy']}")
            for selected in info.get("selected", []):
                assert selected in text
        if "id" in info:  # entries and criteria: the id is on the leaf and is the SVG element id
            assert info["id"] in label[0] + " " + text
            prefix = "entry" if "action" in info else "oracle"
            assert picture.nodes[name]["id"] == f'"{prefix}-{info["id"]}"'
        style = STYLES[role(node)] if role(node) != "composite" else None
        if style is not None:
            assert picture.nodes[name]["shape"] == style["shape"]
            assert picture.nodes[name]["fillcolor"].strip('"') == style["fillcolor"]
        kids = picture.children.get(name, [])
        assert len(kids) == len(node.children), f"{node.name}: {kids}"
        policy = getattr(node, "policy", None)
        for child, kid in zip(node.children, kids):
            selected = isinstance(policy, py_trees.common.ParallelPolicy.SuccessOnSelected) and child in policy.children
            assert (picture.edge_attrs[(name, kid)].get("label") == '"selected"') == selected
        stack.extend(zip(node.children, kids))
    assert len(shown) == sum(1 for _ in walk(root))
    expected_waits = set()
    for _, node in walk(root):
        if isinstance(node, Trigger):
            for waited in node.waits_for:
                expected_waits.add((picture.by_element_id(f"entry-{waited}"), shown[id(node)]))
    assert picture.waits == expected_waits
    return picture


def test_fig1_dot_is_faithful(fig1_path: str) -> None:
    root = btgen_pytrees.generate(btgen_pytrees.load(fig1_path))
    picture = check_faithful(root, dot_source(root))
    trigger = picture.by_element_id("entry-B4")
    assert picture.label(trigger)[0] == "B4"
    assert len(picture.waits) == 2 and picture.legend


def test_roles_are_told_apart(fig1_path: str) -> None:
    picture = Picture(dot_source(btgen_pytrees.generate(btgen_pytrees.load(fig1_path))))
    shapes = {kind: picture.nodes[picture.by_element_id(eid)]["shape"] for kind, eid in
              (("behavior", "entry-B1"), ("constraint", "entry-C1"), ("oracle", "oracle-R1"))}  # fmt: skip
    assert len(set(shapes.values())) == 3
    legend = picture.legend[0].to_string()
    for kind in ("behavior", "constraint", "oracle", "trigger", "Sequence", "Parallel"):
        assert f"legend_{kind}" in legend


@pytest.mark.parametrize("relation", ["&&", "||"])
def test_joins_forks_and_or_groups(relation: str) -> None:
    data = case(
        entry("A"), entry("B", ["A"]), entry("C", ["A"]), entry("D"), entry("J", ["B", "C", "D"], join="all"),
        entry("K", ["J", "A"]),
        criteria=[crit("R1", "record", "x >= 0"), crit("R2", "record", "x < 9"), crit("F1", "final", "x >= 0")],
        relation=relation, signals={"x": 0},
    )  # fmt: skip
    root = generate(data)
    picture = check_faithful(root, dot_source(root))
    assert len(picture.waits) == 5  # J waits for B, C, D; K for J and A


def test_names_graphviz_would_misread_stay_as_written() -> None:
    names = ['x:y', 'node', 'graph', 'a "quoted" name', 'back\\slash \\N \\l', 'edge; {} -> []', 'é ü ∑']
    data = case(*[dict(entry(f"E{i}"), name=n) for i, n in enumerate(names)], name='test: "odd" \\name')
    root = generate(data)
    picture = check_faithful(root, dot_source(root))
    assert [picture.label(picture.by_element_id(f"entry-E{i}"))[0] for i in range(len(names))] == names


def test_dot_is_deterministic(fig1_path: str) -> None:
    outputs = {render(btgen_pytrees.generate(btgen_pytrees.load(fig1_path)), nx_graph(fig1_path), "dot") for _ in range(3)}
    assert len(outputs) == 1


def nx_graph(path: str) -> Any:
    return timeline(btgen_pytrees.load(path))


def test_max_depth_collapses_subtrees_and_keeps_waits(fig1_path: str) -> None:
    root = btgen_pytrees.generate(btgen_pytrees.load(fig1_path))
    picture = Picture(dot_source(root, max_depth=3))
    depths = {}
    for depth, node in walk(root):
        depths[id(node)] = depth
    visible = sum(1 for d in depths.values() if d <= 3)
    tree_nodes = [n for n in picture.nodes if n.startswith("n") and not n.endswith("_more")]
    assert len(tree_nodes) == visible
    boxes = {n: unquote(a["label"]) for n, a in picture.nodes.items() if n.endswith("_more")}
    hidden = sum(1 for d in depths.values() if d > 3)
    assert sum(int(text.split()[1]) for text in boxes.values()) == hidden
    # B4's trigger is at depth 4: the waits now end at the box of "join B4"; B2 and B3 are collapsed too
    assert picture.waits and all(dst in boxes for _, dst in picture.waits)
    assert all(src in boxes for src, _ in picture.waits)
    assert "legend_collapsed" in picture.legend[0].to_string()


def test_max_depth_zero_is_the_root_and_one_box(fig1_path: str) -> None:
    picture = Picture(dot_source(btgen_pytrees.generate(btgen_pytrees.load(fig1_path)), max_depth=0))
    assert [n for n in picture.nodes if n.startswith("n")] == ["n0", "n0_more"]
    assert picture.children == {"n0": ["n0_more"]} | {k: v for k, v in picture.children.items() if k.startswith("legend")}


def big_case(n: int, seed: int = 7) -> dict[str, Any]:
    """A random *n*-entry timeline with forks and joins (predecessors among the 20 entries before)."""
    rnd = random.Random(seed)
    entries = []
    for i in range(n):
        k = rnd.choice([0, 1, 1, 1, 2, 3]) if i else 0
        preds = sorted({f"E{rnd.randrange(max(0, i - 20), i)}" for _ in range(k)})
        entries.append(entry(f"E{i}", preds, duration=0.1))
    return case(*entries, criteria=[crit("R1", "record", "x >= 0")], signals={"x": 0})


def test_big_tree_dot_is_faithful() -> None:
    root = generate(big_case(50))
    check_faithful(root, dot_source(root))


# -- svg / png: Graphviz for real -------------------------------------------------------------------


@needs_dot
def test_fig1_svg_parses_and_shows_every_entry(fig1_path: str) -> None:
    case_ = btgen_pytrees.load(fig1_path)
    svg = render(btgen_pytrees.generate(case_), timeline(case_), "svg")
    tree = ET.fromstring(svg)
    ids = {g.get("id") for g in tree.iter(f"{SVG}g")}
    texts = {t.text for t in tree.iter(f"{SVG}text")}
    for e in case_.entries:
        assert f"entry-{e.id}" in ids and e.id in texts
    for c in case_.criteria:
        assert f"oracle-{c.id}" in ids and c.id in texts
    assert "fig1" in texts and "selected" in texts
    dashed = [p for p in tree.iter(f"{SVG}path") if p.get("stroke-dasharray") and p.get("stroke") == "#08519c"]
    assert len(dashed) >= 2  # the trigger's two waits (plus the legend's sample)


@needs_dot
def test_png_is_a_png(fig1_path: str, tmp_path: Any) -> None:
    out = tmp_path / "fig1.png"
    assert main([fig1_path, "--format", "png", "-o", str(out)]) == 0
    data = out.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    width, height = struct.unpack(">II", data[16:24])
    assert width > 500 and height > 200


def _drawn(root: py_trees.behaviour.Behaviour, svg: ET.Element) -> tuple[int, int]:
    """(drawn nodes, drawn edges) of *svg* beyond what *root* accounts for: a node per tree node, an edge
    per parent-child link and per trigger wait. What is left is the legend's."""
    classes = [g.get("class") for g in svg.iter(f"{SVG}g")]
    nodes = sum(1 for _ in walk(root))
    waits = sum(len(node.waits_for) for _, node in walk(root) if isinstance(node, Trigger))
    return classes.count("node") - nodes, classes.count("edge") - (nodes - 1) - waits


@needs_dot
def test_500_entries_render_to_svg_and_the_picture_grows_with_the_tree_only() -> None:
    """A 500-entry tree is drawn whole, and what Graphviz lays out is exactly the tree plus the legend.

    The layout's time is not asserted (speed is measured in benchmarks, and a layout that never ends is
    cut by GRAPHVIZ_TIMEOUT); what it depends on is the size of the graph handed to Graphviz, checked
    here exactly: one node per tree node, one edge per link and trigger wait, the same legend as a
    50-entry picture - no node or edge that grows faster than the tree.
    """
    root = generate(big_case(500))
    svg = graphviz_render(dot_source(root), "svg")
    tree = ET.fromstring(svg)
    ids = {g.get("id") for g in tree.iter(f"{SVG}g")}
    assert all(f"entry-E{i}" in ids for i in range(500))
    small = generate(big_case(50))
    legend = _drawn(small, ET.fromstring(graphviz_render(dot_source(small), "svg")))
    assert _drawn(root, tree) == legend and 0 < legend[0] < 20 and 0 <= legend[1] < 20, legend
    collapsed = ET.fromstring(graphviz_render(dot_source(root, max_depth=3), "svg"))
    assert sum(1 for _ in collapsed.iter(f"{SVG}g")) < sum(1 for _ in tree.iter(f"{SVG}g")) / 2


# -- the CLI ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("fmt", ["svg", "png"])
def test_missing_graphviz_is_one_line_and_exit_2(fig1_path: str, fmt: str, monkeypatch: Any, tmp_path: Any,
                                                 capsys: Any) -> None:  # fmt: skip
    monkeypatch.setenv("PATH", str(tmp_path))  # no dot anywhere
    out = tmp_path / f"x.{fmt}"
    assert main([fig1_path, "-f", fmt, "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Graphviz" in err and "apt-get install graphviz" in err and "--format dot" in err
    assert not out.exists()
    assert main([fig1_path, "-f", "dot"]) == 0  # the DOT source needs no binary
    assert capsys.readouterr().out.startswith("digraph btgen {")


def test_graphviz_missing_is_raised_by_the_renderer(monkeypatch: Any, tmp_path: Any) -> None:
    monkeypatch.setenv("PATH", str(tmp_path))
    with pytest.raises(GraphvizMissing):
        graphviz_render("digraph { a }", "svg")


def test_cli_dot_max_depth(fig1_path: str, capsys: Any) -> None:
    assert main([fig1_path, "-f", "dot", "--max-depth", "1"]) == 0
    source = capsys.readouterr().out
    assert "more nodes" in source and 'id="entry-B1"' not in source


def graphviz_version(svg: str) -> str:
    match = re.search(r"Generated by graphviz version (\S+)", svg)
    return match.group(1) if match else ""


def test_readme_tree_picture_is_current(fig1_path: str) -> None:
    """docs/images/fig1.svg (in the README) shows every entry; with the same Graphviz it is today's output."""
    committed = (ROOT / "docs" / "images" / "fig1.svg").read_text(encoding="utf-8")
    ids = {g.get("id") for g in ET.fromstring(committed).iter(f"{SVG}g")}
    case_ = btgen_pytrees.load(fig1_path)
    assert {f"entry-{e.id}" for e in case_.entries} | {f"oracle-{c.id}" for c in case_.criteria} <= ids
    if shutil.which("dot") is None:
        return
    fresh = render(btgen_pytrees.generate(case_), timeline(case_), "svg")
    if graphviz_version(fresh) == graphviz_version(committed):
        assert fresh == committed, "regenerate: python -m btgen_pytrees examples/fig1.json --format svg -o docs/images/fig1.svg"
