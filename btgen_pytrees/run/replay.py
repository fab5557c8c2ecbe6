"""The replay page (``run --replay run.html``): one self-contained HTML file to step through a run.

It shows the generated tree, laid out by the page's own script (no Graphviz,
nothing to install besides this package), with zoom and pan, a click on a node
to collapse or expand its subtree, and a search by id or name; a time slider
over every tick, each node coloured by its status at the slider's tick; every
signal's value at that tick with its curve and a cursor; the verdicts with the
report's explanation; and, for a system that offers a scene (SUMO does;
:mod:`.scene`), a bird's-eye view of the road and every vehicle at that tick.
←/→ step one tick, Home/End jump to the ends. Everything is drawn from the
run's :class:`~.trace.RunTrace` and :class:`~.report.Report`.

Self-contained: one file, no network, no server, no external script, style or
font; it opens from disk (``file://``). The data is one JSON block the page's
own script reads; every ``<``, ``>`` and ``&`` in it is a JSON escape, so no
text of the test (names, messages, signal values) can end the block or become
markup, and the script writes text with ``textContent`` only.

Large trees: the page holds every node, but a tree of more than
:data:`MAX_NODES` nodes opens breadth first: a node is open when its children
still fit in that many shown nodes, else collapsed; ``--max-depth N`` collapses
below depth N instead. A collapsed node shows how many
nodes it hides and the most telling status inside it (failure, then running,
then success); a click expands it.

>>> from btgen_pytrees import generate, load
>>> root = generate(load("examples/fig1.json"))  # 27 nodes; 1, 2, 3 and 5 at depths 0 to 3
>>> auto_depth(root) is None, auto_depth(root, max_nodes=10)
(True, 2)
"""

from __future__ import annotations

import functools
import html
import json
import math
import re
from importlib import resources
from typing import Any, Sequence

import py_trees
from py_trees.composites import Parallel, Selector
from py_trees.composites import Sequence as PySequence

from ..errors import plural
from ..model import TestCase
from ..render.dot import STYLES, style_key
from ..render.nodes import annotation, depth_for, role, type_name, walk
from .export import select
from .report import Report
from .trace import ENDED

__all__ = ["replay_html", "auto_depth", "asset", "MAX_NODES"]

MAX_NODES = 100
"""The most nodes the page shows when it opens (breadth first); the rest start collapsed (a click expands them)."""


def auto_depth(root: py_trees.behaviour.Behaviour, max_nodes: int = MAX_NODES) -> int | None:
    """The deepest ``max_depth`` that draws at most *max_nodes* nodes (``None``: the whole tree fits)."""
    return depth_for(root, max_nodes)


def _script_json(data: Any) -> str:
    """*data* as JSON that is safe inside ``<script>``: ASCII only, ``<``, ``>``, ``&`` escaped."""
    text = json.dumps(data, ensure_ascii=True, separators=(",", ":"), allow_nan=False, default=_jsonable)
    return text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


def _jsonable(value: Any) -> Any:
    return str(value)


def _value(value: Any) -> Any:
    """A signal value for the page: non-finite floats as text (JSON has no NaN), containers as they are."""
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    if isinstance(value, (bool, int, float, str)) or value is None:
        return value
    try:
        return json.loads(json.dumps(value, allow_nan=False, default=_jsonable))
    except ValueError:
        return str(value)


def _tree_data(root: py_trees.behaviour.Behaviour) -> list[list[Any]]:
    """Every node in pre-order: ``[name, style, note, parent, id]``."""
    rows: list[list[Any]] = []
    stack: list[int] = []  # indices of the open ancestors, by depth
    for depth, node in walk(root):
        del stack[depth:]
        note = annotation(node)
        if role(node) == "composite" and isinstance(node, (Parallel, PySequence, Selector)):
            note = f"{type_name(node)}: {note}" if note else type_name(node)
        item = getattr(node, "btgen_entry", None) or getattr(node, "btgen_criterion", None)
        if len(note) > 80 and getattr(item, "control", None) is None:  # (an entry's control keys are shown whole:
            note = note[:80] + "…"  # its stops and race are said nowhere else on the page; the tooltip shows them)
        rows.append([node.name, style_key(node), note, stack[-1] if stack else -1, item.id if item is not None else ""])
        stack.append(len(rows) - 1)
    return rows


def _page_data(report: Report, case: TestCase, root: py_trees.behaviour.Behaviour, depth: int | None, open_nodes: int,
               signals: Sequence[str] | None) -> dict[str, Any]:  # fmt: skip
    trace = report.trace
    case_reads = {c.id: set(c.expect.ordered_names) for c in case.criteria if c.type == "temporal"}
    nodes = _tree_data(root)
    index = {row[4]: i for i, row in enumerate(nodes) if row[4]}
    headline = f"{report.test}: {report.verdict.upper()} after {report.duration:g} s ({plural(report.ticks, 'tick')})"
    names = select(sorted(trace.signals), signals) if trace is not None else []
    scene = getattr(trace, "scene", None)
    data: dict[str, Any] = {
        "test": report.test,
        "verdict": report.verdict,
        "headline": headline,
        "message": report.message,
        "explanation": [str(line) for line in getattr(report, "explanation", None) or ()],
        "times": trace.times if trace is not None else [],
        "nodes": nodes,
        "styles": {key: style.get("fillcolor", "white") for key, style in STYLES.items()},
        "transitions": trace.to_data()["transitions"] if trace is not None else [],
        "signals": {name: [[k] if v is ENDED else [k, _value(v)] for k, v in zip(*trace.signals[name])]  # [k]: ended
                    for name in names},
        "oracles": [{"id": o.id, "type": o.type, "expect": o.expect, "verdict": o.verdict, "at": o.at,
                     "message": o.message, "node": index.get(o.id, -1)} for o in report.oracles],  # fmt: skip
        "execute": [{"id": e.id, "kind": e.kind, "status": e.status, "start": e.start, "end": e.end,
                     "message": e.message, "node": index.get(e.id, -1)} for e in report.execute],  # fmt: skip
        "truncated": trace.truncated if trace is not None else None,
        "collapsedBelow": depth,
        "openNodes": open_nodes,
        "scene": scene.to_data() if scene is not None else None,
    }
    for o, shown in zip(report.oracles, data["oracles"]):  # a temporal criterion's sub-formulas' robustness,
        series = []  # drawn as series of their own, and its window (anchor to horizon) as a band on them and
        for source, values in o.terms if trace is not None else ():  # on the signals its formula reads
            changes = [[k, _value(v)] for k, v in enumerate(values) if k == 0 or v != values[k - 1]]
            data["signals"][f"{o.id} robustness: {source}"] = changes
            series.append(f"{o.id} robustness: {source}")
        if o.window is not None and trace is not None:
            start, horizon = o.window
            shown["window"] = [start, report.duration if horizon is None else min(horizon, report.duration)]
            shown["reads"] = [n for n in names if n in case_reads.get(o.id, ())] + series
    return data


def replay_html(report: Report, case: TestCase, root: py_trees.behaviour.Behaviour, *,
                max_depth: int | None = None, max_nodes: int = MAX_NODES,
                signals: Sequence[str] | None = None) -> bytes:  # fmt: skip
    """The replay page of *report* (a run of *case*) as UTF-8 bytes.

    Args:
        root: a tree generated from *case* the same way as the run's (it is
            drawn, not ticked); node *i* of the trace is its *i*-th node in pre-order
        max_depth: open with the subtrees below this depth collapsed (``--max-depth``)
        max_nodes: without *max_depth*, a larger tree opens breadth first with at most this many nodes showing
        signals: shell globs choosing the signals shown (``--signals``; default all)
    """
    trace = report.trace
    count = sum(1 for _ in walk(root))
    if trace is not None and len(trace.nodes) != count:
        raise ValueError("the report's trace is of another tree")
    data = _page_data(report, case, root, max_depth, max_nodes, signals)
    parts = {"TITLE": html.escape(_visible(f"{report.test}: {report.verdict} (replay)")), "STYLE": asset("replay.css"),
             "SCRIPT": asset("replay.js"), "DATA": _script_json(data)}  # fmt: skip
    page = re.sub("@(TITLE|STYLE|SCRIPT|DATA)@", lambda m: parts[m.group(1)], asset("replay.html"))  # one pass: no text is re-read
    return page.encode("utf-8")


@functools.cache
def asset(name: str) -> str:
    """The text of one of the page's files beside this module: ``replay.html`` (the page, with ``@TITLE@``,
    ``@STYLE@``, ``@SCRIPT@`` and ``@DATA@`` where those go), ``replay.css`` and ``replay.js``.

    They are package data (``pyproject.toml``), read with :mod:`importlib.resources` so that they are
    found in a wheel or a zip as well as in a checkout, and so that they can be read, linted and diffed
    as the HTML, CSS and JavaScript they are.
    """
    return resources.files(__package__).joinpath(name).read_text(encoding="utf-8")


def _visible(text: str) -> str:
    return re.sub("[\x00-\x1f\x7f-\x9f]", lambda m: f"\\x{ord(m.group()):02x}", text)
