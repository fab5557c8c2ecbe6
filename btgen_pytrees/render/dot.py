"""Graphviz views of a generated tree: DOT source, and SVG/PNG through Graphviz's ``dot``.

The picture keeps py_trees' own visual conventions (a Sequence is an orange
box, a Parallel a gold parallelogram, a decorator a pale ellipse, as drawn by
:func:`py_trees.display.dot_tree`) and adds what a reviewer needs that py_trees'
picture lacks:

* each Parallel's policy, and its *selected* children (the exit condition of
  ``SuccessOnSelected``) drawn with a bold edge labelled ``selected``;
* trigger nodes drawn distinctly, with a dashed edge from every entry they wait for;
* behaviours, constraints and oracles told apart by shape and colour, with a legend;
* the entry (or criterion) id on every leaf, and the test name as the title;
* ``max_depth``: deeper subtrees collapse into one ``… N more nodes`` box.

Why not start from :func:`py_trees.display.dot_tree`: it names graph nodes by
behaviour name, and Graphviz reads some names as syntax (``x:y`` becomes node
``x`` with port ``y``; ``node`` and ``graph`` become attribute statements), so
an entry's name could silently change the picture. Its labels also depend on
whether the terminal can show unicode. Here graph nodes are named ``n0, n1, …``
in pre-order and every label is quoted by :func:`_quoted`, so the same tree
always gives the same DOT text, byte for byte. The graph is still built with
pydot, py_trees' own dependency for this job.

>>> from btgen_pytrees import load, generate
>>> source = dot_source(generate(load("examples/fig1.json")))
>>> source.splitlines()[0]
'digraph btgen {'
>>> 'id="entry-B4"' in source and 'label="selected"' in source
True
"""

from __future__ import annotations

import re
import shutil
import subprocess
import textwrap
from typing import Any

import networkx as nx
import py_trees
import pydot
from py_trees.composites import Parallel, Selector, Sequence
from py_trees.decorators import Decorator

from ..errors import UserError, printable, xml_safe
from ..leaves.wiring import Trigger
from .nodes import annotation, depth_for, is_selected, role, type_name, walk

__all__ = [
    "dot_graph", "dot_source", "png_depth", "PNG_MAX_NODES", "graphviz_render", "GraphvizMissing", "GraphvizTimeout", "GRAPHVIZ_TIMEOUT", "IMAGE_FORMATS", "STYLES", "style_key",
    "format_dot", "format_svg", "format_png",
]  # fmt: skip

IMAGE_FORMATS = ("svg", "png")
"""Formats that need Graphviz's ``dot`` program."""

FONT = "Helvetica,Arial,sans-serif"
WRAP = 44
"""Label lines are wrapped near this many characters, so long params do not make huge nodes."""

STYLES: dict[str, dict[str, Any]] = {
    # leaves, by role (see :func:`.nodes.role`)
    "behavior": {"shape": "box", "style": "rounded,filled", "fillcolor": "#9ecae1"},
    "constraint": {"shape": "hexagon", "style": "filled", "fillcolor": "#cbc9e2"},
    "oracle": {"shape": "note", "style": "filled", "fillcolor": "#a1d99b"},
    "trigger": {"shape": "invhouse", "style": "dashed,filled", "fillcolor": "white", "color": "#08519c"},
    "wiring": {"shape": "ellipse", "style": "filled", "fillcolor": "ghostwhite"},
    # composites and anything else, in py_trees' own colours
    "Sequence": {"shape": "box", "style": "filled", "fillcolor": "orange"},
    "Parallel": {"shape": "parallelogram", "style": "filled", "fillcolor": "gold"},
    "Selector": {"shape": "octagon", "style": "filled", "fillcolor": "cyan"},
    "Decorator": {"shape": "ellipse", "style": "filled", "fillcolor": "ghostwhite"},
    "leaf": {"shape": "ellipse", "style": "filled", "fillcolor": "gray"},
    "collapsed": {"shape": "box", "style": "dashed"},
}
"""Node attributes per kind of node; the legend is drawn from the same table."""

WAIT_EDGE: dict[str, Any] = {"style": "dashed", "color": "#08519c", "arrowhead": "empty", "constraint": "false"}
"""A trigger's wait: from the entry waited for to the trigger; not a parent-child edge, so it
does not pull the layout."""

SELECTED_EDGE: dict[str, Any] = {"penwidth": "2.5", "label": '"selected"'}
"""Parent Parallel to a child its ``SuccessOnSelected`` policy selected (its exit condition)."""

LEGEND = (
    ("behavior", "behaviour"),
    ("constraint", "constraint"),
    ("oracle", "oracle criterion"),
    ("trigger", "trigger"),
    ("wiring", "wiring"),
    ("Sequence", "Sequence"),
    ("Parallel", "Parallel"),
)


class GraphvizMissing(UserError, RuntimeError):
    """Graphviz's ``dot`` program is not on ``PATH``; ``str()`` is a one-line hint."""

    def __init__(self, fmt: str, option: str | None = None):
        super().__init__(
            f"{option or '--format ' + fmt} needs Graphviz's 'dot' program, which is not on PATH: install Graphviz "
            "(Debian/Ubuntu: apt-get install graphviz; macOS: brew install graphviz; conda: conda install graphviz) "
            "or use --format dot"
        )
        self.fmt = fmt


def _quoted(text: str) -> str:
    """*text* as a DOT double-quoted string.

    Backslashes are doubled so Graphviz does not read ``\\N`` or ``\\l`` in a
    user's text as its own escapes; newlines become ``\\n`` (a centred line
    break). pydot leaves values that are already quoted alone.
    """
    text = printable(text, keep_newlines=True)  # control characters would break Graphviz or its SVG
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'


def style_key(node: py_trees.behaviour.Behaviour) -> str:
    """The node's key in :data:`STYLES` (its colour in the tree picture and on the replay page)."""
    kind = role(node)
    if kind != "composite":
        return kind
    for cls in (Parallel, Sequence, Selector, Decorator):
        if isinstance(node, cls):
            return cls.__name__
    return "leaf"


def _label(node: py_trees.behaviour.Behaviour) -> str:
    """Name on the first line, then :func:`.nodes.annotation` (with the composite's type)."""
    note = annotation(node)
    if role(node) == "composite" and isinstance(node, (Parallel, Sequence, Selector)):
        note = f"{type_name(node)}: {note}" if note else type_name(node)
    lines = [node.name] + textwrap.wrap(note, WRAP, break_on_hyphens=False)
    return "\n".join(lines)


def _element_id(node: py_trees.behaviour.Behaviour) -> str | None:
    """An id for the node's SVG element, so a picture can be searched or linked by entry id."""
    entry = getattr(node, "btgen_entry", None)
    if entry is not None:
        return f"entry-{entry.id}"
    criterion = getattr(node, "btgen_criterion", None)
    if criterion is not None:
        return f"oracle-{criterion.id}"
    return None


def _node(name: str, node: py_trees.behaviour.Behaviour) -> pydot.Node:
    attrs: dict[str, Any] = dict(STYLES[style_key(node)])
    attrs["label"] = _quoted(_label(node))
    attrs["tooltip"] = _quoted(annotation(node) or node.name)
    element_id = _element_id(node)
    if element_id is not None:
        attrs["id"] = _quoted(element_id)
    return pydot.Node(name, **attrs)


def _add_legend(graph: pydot.Dot, collapsed: bool) -> None:
    """A cluster with one sample node per style and one sample of each special edge."""
    legend = pydot.Subgraph("cluster_legend", label='"legend"', style="dashed", fontsize="10", color="gray50")
    keys = list(LEGEND) + ([("collapsed", "collapsed subtree")] if collapsed else [])
    row = pydot.Subgraph("legend_row", rank="same")
    for i, (key, text) in enumerate(keys):
        row.add_node(pydot.Node(f"legend_{key}", **dict(STYLES[key], label=_quoted(text))))
        if i:  # invisible edges keep the samples in the table's order, left to right
            row.add_edge(pydot.Edge(f"legend_{keys[i - 1][0]}", f"legend_{key}", style="invis"))
    legend.add_subgraph(row)
    for name, text, attrs in (
        ("wait", "waits for", WAIT_EDGE),
        ("selected", "selected (exit condition)", SELECTED_EDGE),
    ):
        legend.add_node(pydot.Node(f"legend_{name}_from", shape="point"))
        legend.add_node(pydot.Node(f"legend_{name}_to", shape="point"))
        edge_attrs = dict(attrs, label=_quoted(text), constraint="true")
        legend.add_edge(pydot.Edge(f"legend_{name}_from", f"legend_{name}_to", **edge_attrs))
    graph.add_subgraph(legend)


def dot_graph(root: py_trees.behaviour.Behaviour, *, max_depth: int | None = None, legend: bool = True,
              endpoints: dict[int, str] | None = None) -> pydot.Dot:  # fmt: skip
    """Build the review picture of *root* as a pydot graph (see the module notes).

    Args:
        max_depth: show nodes down to this depth (root = 0); each deeper subtree
            becomes one dashed ``… N more nodes`` box, which keeps its wait edges
        legend: add the legend cluster
        endpoints: if given, filled with ``id(node)`` -> the graph node that shows
            it (``n<i>``, or the ``n<i>_more`` box it is collapsed into)
    """
    graph = pydot.Dot("btgen", graph_type="digraph", ordering="out", rankdir="TB", labelloc="t",
                      label=_quoted(root.name), fontsize="20", fontname=_quoted(FONT))  # fmt: skip
    graph.set_node_defaults(fontname=_quoted(FONT), fontsize="10")
    graph.set_edge_defaults(fontname=_quoted(FONT), fontsize="9")
    endpoint: dict[int, str] = endpoints if endpoints is not None else {}  # id(behaviour) -> its graph node or box
    entries: dict[str, str] = {}  # entry id -> same
    hidden: dict[str, int] = {}  # collapsed box -> how many nodes it stands for
    triggers: list[Trigger] = []
    box, visible = "", 0
    for depth, node in walk(root):
        if max_depth is not None and depth > max_depth:
            hidden[box] = hidden.get(box, 0) + 1
            name = box
        else:
            name, visible = f"n{visible}", visible + 1
            graph.add_node(_node(name, node))
            if node.parent is not None and node is not root:
                attrs = SELECTED_EDGE if is_selected(node.parent, node) else {}
                graph.add_edge(pydot.Edge(endpoint[id(node.parent)], name, **attrs))
            if depth == max_depth and node.children:
                box = f"{name}_more"
                graph.add_edge(pydot.Edge(name, box, style="dashed"))
        endpoint[id(node)] = name
        entry = getattr(node, "btgen_entry", None)
        if entry is not None:
            entries[entry.id] = name
        if isinstance(node, Trigger):
            triggers.append(node)
    for name, count in hidden.items():
        more = f"… {count} more node" + ("s" if count > 1 else "")
        graph.add_node(pydot.Node(name, **dict(STYLES["collapsed"], label=_quoted(more))))
    _add_wait_edges(graph, triggers, endpoint, entries)
    if legend:
        _add_legend(graph, collapsed=bool(hidden))
    return graph


def _add_wait_edges(graph: pydot.Dot, triggers: list[Trigger], endpoint: dict[int, str], entries: dict[str, str]) -> None:
    """One dashed edge per (entry waited for, trigger), between whatever shows them."""
    seen: set[tuple[str, str]] = set()
    for trigger in triggers:
        target = endpoint[id(trigger)]
        for waited in trigger.waits_for:
            source = entries.get(waited)
            if source is None or source == target or (source, target) in seen:
                continue
            seen.add((source, target))
            tooltip = _quoted(f"{trigger.name} waits for {waited} (join {trigger.join})")
            graph.add_edge(pydot.Edge(source, target, tooltip=tooltip, **WAIT_EDGE))


def dot_source(root: py_trees.behaviour.Behaviour, *, max_depth: int | None = None) -> str:
    """The review picture of *root* as Graphviz DOT text (deterministic)."""
    return dot_graph(root, max_depth=max_depth).to_string()


GRAPHVIZ_TIMEOUT = 60.0
"""Seconds Graphviz may take to lay out a picture; a 10,000-wide tree took 300 s and then failed."""


class GraphvizTimeout(GraphvizMissing):
    """Graphviz did not finish within :data:`GRAPHVIZ_TIMEOUT`; ``str()`` is a one-line hint.

    A kind of :class:`GraphvizMissing` (the picture cannot be made here), so every caller that
    turns that into one line and exit 2 does the same for this.
    """

    def __init__(self, fmt: str, timeout: float, nodes: int):
        RuntimeError.__init__(
            self,
            f"--format {fmt}: Graphviz did not finish laying out {nodes} nodes within {timeout:g} s; draw less "
            "with --max-depth N, or use --format dot (no layout)",
        )
        self.fmt = fmt


def graphviz_render(source: str, fmt: str, *, timeout: float = GRAPHVIZ_TIMEOUT) -> bytes:
    """Lay out DOT *source* with Graphviz's ``dot`` and return the *fmt* (``svg``/``png``) bytes.

    Raises:
        GraphvizMissing: ``dot`` is not installed (the DOT text still works elsewhere)
        GraphvizTimeout: ``dot`` took longer than *timeout* seconds (it is stopped)
        RuntimeError: ``dot`` failed; the message is its first line of complaint
    """
    if fmt not in IMAGE_FORMATS:
        raise ValueError(f"fmt must be one of {IMAGE_FORMATS}, not {fmt!r}")
    program = shutil.which("dot")
    if program is None:
        raise GraphvizMissing(fmt)
    try:
        done = subprocess.run([program, f"-T{fmt}"], input=source.encode("utf-8"), capture_output=True,
                              timeout=timeout, check=False)  # fmt: skip
    except subprocess.TimeoutExpired:  # subprocess.run has killed dot
        raise GraphvizTimeout(fmt, timeout, len(re.findall(r"^n\d+ \[", source, re.M))) from None
    if done.returncode != 0:
        complaint = done.stderr.decode("utf-8", "replace").strip().splitlines()
        raise RuntimeError(f"Graphviz dot failed: {complaint[0] if complaint else f'exit status {done.returncode}'}")
    return done.stdout


def format_dot(root: py_trees.behaviour.Behaviour, graph: nx.DiGraph, max_depth: int | None = None, **_: Any) -> str:
    return dot_source(root, max_depth=max_depth)


def format_svg(root: py_trees.behaviour.Behaviour, graph: nx.DiGraph, max_depth: int | None = None, **_: Any) -> str:
    return xml_safe(graphviz_render(dot_source(root, max_depth=max_depth), "svg").decode("utf-8"))


PNG_MAX_NODES = 150
"""Most nodes a PNG shows without ``--max-depth``: past that, Graphviz's image would outgrow its
32,767-pixel limit and be scaled down until no text can be read (a 500-entry case: 32,767 x 229 px)."""


def png_depth(root: py_trees.behaviour.Behaviour, max_depth: int | None = None) -> int | None:
    """The depth a PNG of *root* is drawn to: *max_depth* when given, else the deepest depth that
    shows at most :data:`PNG_MAX_NODES` nodes (``None``: the whole tree)."""
    return max_depth if max_depth is not None else depth_for(root, PNG_MAX_NODES)


def format_png(root: py_trees.behaviour.Behaviour, graph: nx.DiGraph, max_depth: int | None = None, **_: Any) -> bytes:
    """The PNG picture; a tree over :data:`PNG_MAX_NODES` nodes is collapsed by :func:`png_depth` unless *max_depth* says."""
    return graphviz_render(dot_source(root, max_depth=png_depth(root, max_depth)), "png")
