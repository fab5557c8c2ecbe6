"""The replay page (``run --replay run.html``): one self-contained HTML file to step through a run.

It shows the generated tree as the SVG view draws it
(:mod:`btgen_pytrees.render.dot`, laid out by Graphviz), a time slider over
every tick, each node coloured by its status at the slider's tick, every
signal's value at that tick with its curve and a cursor, and the verdicts with
the report's explanation. ←/→ step one tick, Home/End jump to the ends.
Everything is drawn from the run's :class:`~.trace.RunTrace` and
:class:`~.report.Report`.

Self-contained: one file, no network, no server, no external script, style or
font; it opens from disk (``file://``). The data is one JSON block the page's
own script reads; every ``<``, ``>`` and ``&`` in it is a JSON escape, so no
text of the test (names, messages, signal values) can end the block or become
markup, and the script writes text with ``textContent`` only.

Large trees: Graphviz lays out the tree once, at export time. Above
:data:`MAX_NODES` nodes the picture collapses deep subtrees as
``--max-depth`` does (the deepest depth that keeps at most that many nodes); a
collapsed box takes the most telling status of the nodes inside it (failure,
then running, then success). ``--max-depth N`` chooses the depth instead.

>>> from btgen_pytrees import generate, load
>>> root = generate(load("examples/fig1.json"))  # 27 nodes; 1, 2, 3 and 5 at depths 0 to 3
>>> auto_depth(root) is None, auto_depth(root, max_nodes=10)
(True, 2)
"""

from __future__ import annotations

import html
import json
import math
import re
import shutil
from collections import Counter
from typing import Any

import py_trees

from ..model import TestCase
from ..render.dot import GraphvizMissing, dot_graph, graphviz_render
from ..render.info import walk
from .report import Report
from .trace import ENDED, RunTrace

__all__ = ["replay_html", "auto_depth", "require_graphviz", "MAX_NODES"]

MAX_NODES = 400
"""The most nodes the page draws before it collapses deep subtrees (Graphviz lays 400 out in about a second)."""

_UNSAFE_SVG = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f]")


def require_graphviz() -> None:
    """Raise :class:`GraphvizMissing` (a one-line hint naming ``--replay``) unless ``dot`` is on PATH."""
    if shutil.which("dot") is None:
        raise GraphvizMissing("svg", option="--replay")


def auto_depth(root: py_trees.behaviour.Behaviour, max_nodes: int = MAX_NODES) -> int | None:
    """The deepest ``max_depth`` that draws at most *max_nodes* nodes (``None``: the whole tree fits)."""
    depths = Counter(depth for depth, _ in walk(root))
    if sum(depths.values()) <= max_nodes:
        return None
    total, depth = 0, 0
    for d in sorted(depths):
        total += depths[d]
        if total > max_nodes:
            break
        depth = d
    return depth


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


def _page_data(report: Report, case: TestCase, trace: RunTrace | None, graph_of: list[int],
               names: list[str], depth: int | None) -> dict[str, Any]:  # fmt: skip
    index = {n.id: i for i, n in enumerate(trace.nodes)} if trace is not None else {}
    headline = f"{report.test}: {report.verdict.upper()} after {report.duration:g} s ({report.ticks} ticks)"
    data: dict[str, Any] = {
        "test": report.test,
        "verdict": report.verdict,
        "headline": headline,
        "message": report.message,
        "explanation": [str(line) for line in getattr(report, "explanation", None) or ()],
        "times": trace.times if trace is not None else [],
        "graph": graph_of,
        "graphNames": names,
        "transitions": trace.to_data()["transitions"] if trace is not None else [],
        "signals": {name: [[k] if v is ENDED else [k, _value(v)] for k, v in zip(*trace.signals[name])]  # [k]: ended
                    for name in sorted(trace.signals)} if trace is not None else {},  # fmt: skip
        "oracles": [{"id": o.id, "type": o.type, "expect": o.expect, "verdict": o.verdict, "at": o.at,
                     "message": o.message, "node": index.get(o.id, -1)} for o in report.oracles],  # fmt: skip
        "execute": [{"id": e.id, "kind": e.kind, "status": e.status, "start": e.start, "end": e.end,
                     "message": e.message, "node": index.get(e.id, -1)} for e in report.execute],  # fmt: skip
        "truncated": trace.truncated if trace is not None else None,
        "collapsedBelow": depth,
    }
    return data


def replay_html(report: Report, case: TestCase, root: py_trees.behaviour.Behaviour, *,
                max_depth: int | None = None, max_nodes: int = MAX_NODES) -> bytes:  # fmt: skip
    """The replay page of *report* (a run of *case*) as UTF-8 bytes.

    Args:
        root: a tree generated from *case* the same way as the run's (it is
            drawn, not ticked); node *i* of the trace is its *i*-th node in pre-order
        max_depth: collapse below this depth (default: :func:`auto_depth`)

    Raises:
        GraphvizMissing: Graphviz's ``dot`` is not installed
    """
    require_graphviz()
    trace = report.trace
    behaviours = [node for _, node in walk(root)]
    if trace is not None and len(trace.nodes) != len(behaviours):
        raise ValueError("the report's trace is of another tree")
    depth = max_depth if max_depth is not None else auto_depth(root, max_nodes)
    endpoints: dict[int, str] = {}
    graph = dot_graph(root, max_depth=depth, endpoints=endpoints)
    svg = graphviz_render(graph.to_string(), "svg").decode("utf-8")
    svg = _UNSAFE_SVG.sub("\ufffd", svg[svg.index("<svg"):])
    names: list[str] = []
    position: dict[str, int] = {}
    graph_of = []
    for node in behaviours:
        name = endpoints[id(node)]
        if name not in position:
            position[name] = len(names)
            names.append(name)
        graph_of.append(position[name])
    data = _page_data(report, case, trace, graph_of, names, depth)
    parts = {"TITLE": html.escape(_visible(f"{report.test}: {report.verdict} (replay)")), "STYLE": _STYLE,
             "SCRIPT": _SCRIPT, "SVG": svg, "DATA": _script_json(data)}  # fmt: skip
    page = re.sub("@(TITLE|STYLE|SCRIPT|SVG|DATA)@", lambda m: parts[m.group(1)], _PAGE)  # one pass: no text is re-read
    return page.encode("utf-8")


def _visible(text: str) -> str:
    return re.sub("[\x00-\x1f\x7f-\x9f]", lambda m: f"\\x{ord(m.group()):02x}", text)


_PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>@TITLE@</title>
<style>@STYLE@</style>
</head>
<body>
<header>
<h1 id="headline"></h1>
<p id="why"></p>
<div id="controls">
<button type="button" id="prev" title="previous tick (←)">◀</button>
<input type="range" id="slider" min="0" max="0" value="0" step="1" aria-label="tick">
<button type="button" id="next" title="next tick (→)">▶</button>
<span id="clock"></span>
<span id="jumps"></span>
<button type="button" id="fit">fit</button>
</div>
<p id="legend"><span class="key st-running">running</span> <span class="key st-success">success</span>
<span class="key st-failure">failure</span> <span class="key st-invalid">not running / halted</span>
<span id="note"></span></p>
</header>
<main>
<section id="tree">
@SVG@
</section>
<aside>
<h2>Oracles</h2>
<table id="oracles"><thead><tr><th>criterion</th><th>expect</th><th>now</th><th>verdict</th><th>at</th><th>message</th></tr></thead><tbody></tbody></table>
<h2>Signals</h2>
<table id="signals"><thead><tr><th>signal</th><th>value</th><th>over the run</th></tr></thead><tbody></tbody></table>
<h2>Execute</h2>
<table id="execute"><thead><tr><th>entry</th><th>now</th><th>result</th><th>start</th><th>end</th><th>message</th></tr></thead><tbody></tbody></table>
</aside>
</main>
<script type="application/json" id="run-data">@DATA@</script>
<script>@SCRIPT@</script>
</body>
</html>
"""

_STYLE = """
body { font-family: Helvetica, Arial, sans-serif; margin: 0; color: #222; }
header { position: sticky; top: 0; background: #fff; border-bottom: 1px solid #ccc; padding: 6px 12px; z-index: 2; }
h1 { font-size: 18px; margin: 2px 0; }
h1.pass { color: #1a7f37; } h1.fail, h1.error, h1.timeout { color: #c62828; }
#why { margin: 2px 0 6px; white-space: pre-wrap; color: #c62828; }
#controls { display: flex; align-items: center; gap: 8px; flex-wrap: wrap; }
#slider { flex: 1 1 320px; }
#clock { font-variant-numeric: tabular-nums; min-width: 16em; }
#legend { margin: 4px 0 0; font-size: 12px; }
.key { padding: 1px 6px; border: 3px solid #999; border-radius: 3px; }
.key.st-running { border-color: #1d4ed8; } .key.st-success { border-color: #15803d; }
.key.st-failure { border-color: #dc2626; } .key.st-invalid { opacity: .5; }
#note { color: #a15c00; }
main { display: flex; gap: 12px; padding: 8px 12px; align-items: flex-start; }
#tree { flex: 3 1 0; overflow: auto; border: 1px solid #ddd; max-height: calc(100vh - 140px); }
#tree.fit svg { width: 100%; height: auto; }
aside { flex: 2 1 0; min-width: 320px; font-size: 12px; }
h2 { font-size: 14px; margin: 10px 0 4px; }
table { border-collapse: collapse; width: 100%; }
th, td { border-bottom: 1px solid #eee; padding: 2px 4px; text-align: left; vertical-align: top; }
td.value { font-variant-numeric: tabular-nums; white-space: nowrap; }
td.msg { white-space: pre-wrap; word-break: break-word; }
.v-pass, .v-success { color: #15803d; } .v-fail, .v-failure { color: #dc2626; font-weight: bold; }
.v-running { color: #1d4ed8; } .v-inconclusive, .v-invalid, .v-stopped, .v-not-started { color: #777; }
svg.curve { display: block; }
svg.curve polyline { fill: none; stroke: #2563eb; stroke-width: 1.2; }
svg.curve line { stroke: #dc2626; stroke-width: 1; }
#tree g.node.st-invalid { opacity: .45; }
#tree g.node.st-running :is(polygon, ellipse, path, polyline) { stroke: #1d4ed8; stroke-width: 4px; }
#tree g.node.st-success :is(polygon, ellipse, path, polyline) { stroke: #15803d; stroke-width: 4px; }
#tree g.node.st-failure :is(polygon, ellipse, path, polyline) { stroke: #dc2626; stroke-width: 5px; }
"""

_SCRIPT = r"""
"use strict";
(function () {
  const data = JSON.parse(document.getElementById("run-data").textContent);
  const STATUS = ["invalid", "running", "success", "failure"];
  const RANK = [0, 2, 1, 3];  // a collapsed box shows failure, then running, then success
  const times = data.times, tr = data.transitions, nNodes = data.graph.length;
  const last = Math.max(times.length - 1, 0);
  const state = new Uint8Array(nNodes);
  let applied = -1, cursor = 0, tick = -1;
  const $ = (id) => document.getElementById(id);
  const el = (tag, text, cls) => { const e = document.createElement(tag); if (text !== undefined) e.textContent = text; if (cls) e.className = cls; return e; };
  const fmt = (v) => {
    if (v === null || v === undefined) return "\u2014";
    if (typeof v === "number") return Number.isInteger(v) ? String(v) : String(Number(v.toPrecision(6)));
    if (typeof v === "string") return v;
    return JSON.stringify(v);
  };
  const secs = (t) => (t === null || t === undefined) ? "" : fmt(t);

  // the tree: graph node name -> its <g> element
  const graphEls = new Array(data.graphNames.length).fill(null);
  const byName = new Map(data.graphNames.map((n, i) => [n, i]));
  for (const g of document.querySelectorAll("#tree g.node")) {
    const title = g.querySelector("title");
    const i = title ? byName.get(title.textContent) : undefined;
    if (i !== undefined) { graphEls[i] = g; g.dataset.graphNode = title.textContent; }
  }

  $("headline").textContent = data.headline;
  $("headline").className = data.verdict;
  const why = [];
  const said = (text) => why.some((line) => line.includes(text));
  if (data.message) why.push(data.message);
  for (const line of data.explanation) if (!said(line)) why.push(line);
  for (const o of data.oracles) if (o.verdict === "fail" && o.message && !said(o.message)) why.push(o.id + ": " + o.message);
  for (const e of data.execute) if (e.status === "failure" && e.message && !said(e.message)) why.push(e.id + ": " + e.message);
  $("why").textContent = why.join("\n");
  const notes = [];
  if (data.collapsedBelow !== null) notes.push("subtrees below depth " + data.collapsedBelow + " are collapsed");
  if (data.truncated !== null) notes.push("the trace was cut at tick " + data.truncated + " (its memory cap): later changes are not shown");
  $("note").textContent = notes.join("; ");

  // oracles, signals, entries
  const rows = (tbodyId, items, cells) => items.map((item) => {
    const tr = document.createElement("tr");
    const made = cells(item).map(([text, cls]) => { const td = el("td", text, cls); tr.appendChild(td); return td; });
    $(tbodyId).querySelector("tbody").appendChild(tr);
    return [tr, made];
  });
  const oracleRows = rows("oracles", data.oracles, (o) => [[o.id], [o.expect], ["", "now"], [o.verdict, "v-" + o.verdict], [secs(o.at)], [o.message, "msg"]]);
  oracleRows.forEach(([tr], i) => { tr.dataset.criterion = data.oracles[i].id; });
  const entryRows = rows("execute", data.execute, (e) => [[e.id], ["", "now"], [e.status, "v-" + e.status], [secs(e.start)], [secs(e.end)], [e.message, "msg"]]);
  entryRows.forEach(([tr], i) => { tr.dataset.entry = data.execute[i].id; });

  const W = 240, H = 36, NS = "http://www.w3.org/2000/svg";
  const span = times.length ? Math.max(times[last], 1e-9) : 1;
  const signals = Object.keys(data.signals).sort().map((name) => {
    const series = data.signals[name];
    const tr = document.createElement("tr");
    tr.dataset.signal = name;
    tr.appendChild(el("td", name));
    const value = el("td", "", "value");
    tr.appendChild(value);
    const curveCell = el("td");
    tr.appendChild(curveCell);
    const isNumber = (item) => item.length > 1 && (typeof item[1] === "number" || typeof item[1] === "boolean");
    const numeric = series.filter(isNumber);
    let cursorLine = null;
    if (numeric.length) {
      const ys = numeric.map(([, v]) => Number(v));
      const lo = Math.min(...ys), hi = Math.max(...ys), dy = hi - lo || 1;
      const x = (k) => 2 + (W - 4) * (times[k] / span), y = (v) => H - 3 - (H - 6) * ((Number(v) - lo) / dy);
      const lines = [];  // one line per stretch with a value: where the signal ended ([tick], no value) its line stops
      let pts = [], prev = null;
      series.forEach((item) => {
        const k = item[0];
        if (item.length < 2) {
          if (prev !== null) { pts.push(x(k) + "," + y(prev)); lines.push(pts); }
          pts = []; prev = null;
          return;
        }
        if (!isNumber(item)) return;
        if (prev !== null) pts.push(x(k) + "," + y(prev));
        pts.push(x(k) + "," + y(item[1]));
        prev = item[1];
      });
      if (prev !== null) { pts.push((W - 2) + "," + y(prev)); lines.push(pts); }
      const svg = document.createElementNS(NS, "svg");
      svg.setAttribute("class", "curve"); svg.setAttribute("width", W); svg.setAttribute("height", H);
      for (const points of lines) {
        const line = document.createElementNS(NS, "polyline");
        line.setAttribute("points", points.join(" "));
        svg.appendChild(line);
      }
      const title = document.createElementNS(NS, "title");
      title.textContent = name + ": " + fmt(lo) + " \u2026 " + fmt(hi);
      svg.appendChild(title);
      cursorLine = document.createElementNS(NS, "line");
      cursorLine.setAttribute("y1", 0); cursorLine.setAttribute("y2", H);
      svg.appendChild(cursorLine);
      curveCell.appendChild(svg);
    }
    $("signals").querySelector("tbody").appendChild(tr);
    return { series, value, cursorLine, x: (k) => 2 + (W - 4) * (times[k] / span) };
  });

  function valueAt(series, k) {  // binary search: the last change at or before tick k
    let lo = 0, hi = series.length - 1, found = null;
    while (lo <= hi) { const mid = (lo + hi) >> 1; if (series[mid][0] <= k) { found = series[mid][1]; lo = mid + 1; } else hi = mid - 1; }
    return found;
  }

  function apply(k) {
    if (k < applied) { state.fill(0); cursor = 0; applied = -1; }
    while (cursor < tr.length && tr[cursor] <= k) { state[tr[cursor + 1]] = tr[cursor + 2]; cursor += 3; }
    applied = k;
  }

  function show(k) {
    k = Math.max(0, Math.min(last, k | 0));
    tick = k;
    apply(k);
    const box = new Int8Array(graphEls.length).fill(-1);
    for (let i = 0; i < nNodes; i++) {
      const g = data.graph[i], s = state[i];
      if (box[g] < 0 || RANK[s] > RANK[box[g]]) box[g] = s;
    }
    graphEls.forEach((g, i) => {
      if (!g) return;
      const s = STATUS[Math.max(box[i], 0)];
      if (g.dataset.status !== s) {
        g.classList.remove("st-invalid", "st-running", "st-success", "st-failure");
        g.classList.add("st-" + s);
        g.dataset.status = s;
      }
    });
    const now = (node) => node >= 0 ? STATUS[state[node]] : "";
    const mark = (cell, s) => {  // only what changed: a 2,000-entry table stays fast
      if (cell.dataset.s === s) return;
      cell.dataset.s = s; cell.textContent = s === "invalid" ? "idle" : s; cell.className = "now v-" + s;
    };
    oracleRows.forEach(([, cells], i) => mark(cells[2], now(data.oracles[i].node)));
    entryRows.forEach(([, cells], i) => mark(cells[1], now(data.execute[i].node)));
    for (const sig of signals) {
      const text = fmt(valueAt(sig.series, k));
      if (sig.value.textContent !== text) sig.value.textContent = text;
      if (sig.cursorLine) { const x = sig.x(k); sig.cursorLine.setAttribute("x1", x); sig.cursorLine.setAttribute("x2", x); }
    }
    const slider = $("slider");
    if (Number(slider.value) !== k) slider.value = k;
    $("clock").textContent = times.length ? "t = " + fmt(times[k]) + " s \u00b7 tick " + k + " of " + last : "no tick ran";
    document.body.dataset.tick = k;
  }

  const slider = $("slider");
  slider.max = last;
  slider.addEventListener("input", () => show(Number(slider.value)));
  $("prev").addEventListener("click", () => show(tick - 1));
  $("next").addEventListener("click", () => show(tick + 1));
  $("fit").addEventListener("click", () => $("tree").classList.toggle("fit"));
  document.addEventListener("keydown", (ev) => {
    const moves = { ArrowLeft: -1, ArrowRight: 1 };
    if (ev.key in moves) { ev.preventDefault(); show(tick + moves[ev.key]); }
    else if (ev.key === "Home") { ev.preventDefault(); show(0); }
    else if (ev.key === "End") { ev.preventDefault(); show(last); }
  });
  // jump buttons: to every failure
  const tickOf = (t) => { let best = 0; times.forEach((s, k) => { if (Math.abs(s - t) < Math.abs(times[best] - t)) best = k; }); return best; };
  const failures = data.oracles.filter((o) => o.verdict === "fail" && o.at !== null).map((o) => [o.id, o.at])
    .concat(data.execute.filter((e) => e.status === "failure" && e.end !== null).map((e) => [e.id, e.end]));
  for (const [id, at] of failures) {
    const b = el("button", id + " failed at " + fmt(at) + " s");
    b.type = "button";
    b.addEventListener("click", () => show(tickOf(at)));
    $("jumps").appendChild(b);
  }
  const svgEl = document.querySelector("#tree svg");
  if (svgEl && svgEl.width.baseVal.value > $("tree").clientWidth) $("tree").classList.add("fit");
  show(last);
  document.body.dataset.ready = "1";
})();
"""
