"use strict";
(function () {
  const data = JSON.parse(document.getElementById("run-data").textContent);
  const STATUS = ["invalid", "running", "success", "failure"];
  const RANK = [0, 2, 1, 3];  // a collapsed node shows failure, then running, then success
  const NS = "http://www.w3.org/2000/svg";
  const times = data.times, tr = data.transitions, nodes = data.nodes, N = nodes.length;
  const last = Math.max(times.length - 1, 0);
  const state = new Uint8Array(N);
  let applied = -1, cursor = 0, tick = -1;
  const $ = (id) => document.getElementById(id);
  const el = (tag, text, cls) => { const e = document.createElement(tag); if (text !== undefined) e.textContent = text; if (cls) e.className = cls; return e; };
  const svgEl = (tag, attrs) => { const e = document.createElementNS(NS, tag); for (const k in attrs) e.setAttribute(k, attrs[k]); return e; };
  const fmt = (v) => {
    if (v === null || v === undefined) return "\u2014";
    if (typeof v === "number") return Number.isInteger(v) ? String(v) : String(Number(v.toPrecision(6)));
    if (typeof v === "string") return v;
    return JSON.stringify(v);
  };
  const secs = (t) => (t === null || t === undefined) ? "" : fmt(t);

  // ---- pan and zoom, for the tree and the scene --------------------------------------------------
  function panZoom(box, vp, onChange) {
    const view = { s: 1, x: 0, y: 0 };
    const apply = () => { vp.setAttribute("transform", "translate(" + view.x + "," + view.y + ") scale(" + view.s + ")"); if (onChange) onChange(view); };
    const zoomAt = (px, py, f) => {
      const s = Math.min(8, Math.max(0.01, view.s * f));
      view.x = px - (px - view.x) * (s / view.s); view.y = py - (py - view.y) * (s / view.s); view.s = s; apply();
    };
    const local = (ev) => { const r = box.getBoundingClientRect(); return [ev.clientX - r.left, ev.clientY - r.top]; };
    box.addEventListener("wheel", (ev) => { ev.preventDefault(); const [x, y] = local(ev); zoomAt(x, y, Math.exp(-ev.deltaY * (ev.ctrlKey ? 0.01 : 0.0015))); }, { passive: false });
    const down = new Map();
    let moved = 0, pinch = 0;
    box.addEventListener("pointerdown", (ev) => { down.set(ev.pointerId, local(ev)); moved = 0; if (down.size === 2) { const [a, b] = [...down.values()]; pinch = Math.hypot(a[0] - b[0], a[1] - b[1]); } });
    box.addEventListener("pointermove", (ev) => {
      if (!down.has(ev.pointerId)) return;
      const p = local(ev), q = down.get(ev.pointerId);
      if (down.size === 1) {
        const dx = p[0] - q[0], dy = p[1] - q[1];
        moved += Math.abs(dx) + Math.abs(dy);
        if (moved > 3) { if (!box.hasPointerCapture(ev.pointerId)) box.setPointerCapture(ev.pointerId); view.x += dx; view.y += dy; apply(); if (api.onPan) api.onPan(); }
        down.set(ev.pointerId, p);
      } else if (down.size === 2) {
        down.set(ev.pointerId, p);
        const [a, b] = [...down.values()], d = Math.hypot(a[0] - b[0], a[1] - b[1]);
        if (pinch > 0) zoomAt((a[0] + b[0]) / 2, (a[1] + b[1]) / 2, d / pinch);
        pinch = d; moved = 99;
      }
    });
    const up = (ev) => { down.delete(ev.pointerId); if (down.size < 2) pinch = 0; };
    box.addEventListener("pointerup", up); box.addEventListener("pointercancel", up);
    const api = {
      view, apply, zoomAt,
      dragged: () => moved > 3,
      zoom: (f) => zoomAt(box.clientWidth / 2, box.clientHeight / 2, f),
      fit: (x0, y0, x1, y1, most) => {
        const w = Math.max(x1 - x0, 1e-6), h = Math.max(y1 - y0, 1e-6), W = box.clientWidth, H = box.clientHeight;
        view.s = Math.min((W - 20) / w, (H - 20) / h, most || 8);
        view.x = (W - w * view.s) / 2 - x0 * view.s; view.y = (H - h * view.s) / 2 - y0 * view.s; apply();
      },
      centre: (cx, cy, s) => { if (s) view.s = s; view.x = box.clientWidth / 2 - cx * view.s; view.y = box.clientHeight / 2 - cy * view.s; apply(); },
    };
    return api;
  }

  // ---- the tree: structure, layout, collapse ------------------------------------------------------
  const parent = new Int32Array(N), depth = new Int32Array(N), end = new Int32Array(N), kids = [];
  for (let i = 0; i < N; i++) { kids.push([]); parent[i] = nodes[i][3]; depth[i] = parent[i] >= 0 ? depth[parent[i]] + 1 : 0; if (parent[i] >= 0) kids[parent[i]].push(i); }
  for (let i = N - 1; i >= 0; i--) { const k = kids[i]; end[i] = k.length ? end[k[k.length - 1]] : i + 1; }
  const collapsed = new Uint8Array(N);
  if (data.collapsedBelow !== null) { for (let i = 0; i < N; i++) if (depth[i] === data.collapsedBelow && kids[i].length) collapsed[i] = 1; }
  else if (N > data.openNodes) {  // open breadth first, as long as at most openNodes nodes show
    for (let i = 0; i < N; i++) if (kids[i].length) collapsed[i] = 1;
    let open = 1;
    const queue = [0];
    for (let q = 0; q < queue.length; q++) {
      const i = queue[q];
      if (!kids[i].length || open + kids[i].length > data.openNodes) continue;
      collapsed[i] = 0; open += kids[i].length;
      for (const c of kids[i]) queue.push(c);
    }
  }
  const openedCollapsed = collapsed.some((c) => c);
  const rep = new Int32Array(N);  // each node's visible stand-in: itself, or the collapsed node hiding it
  const ROW = 40, GAP = 36, CH = 6.6;
  const label = (i) => nodes[i][0];
  const width = (i) => Math.min(260, 16 + CH * Math.max(label(i).length, (nodes[i][2] || "").length * 0.8));
  const clip = (text, w, size) => { const room = Math.floor((w - 10) / (size * 0.55)); return text.length > room ? text.slice(0, Math.max(room - 1, 1)) + "\u2026" : text; };
  let pos = null, shown = [], gEls = new Map(), bounds = [0, 0, 1, 1], found = -1;
  const treeBox = $("tree"), treeVp = $("tree-vp");
  const tree = panZoom(treeBox, treeVp);

  function layout() {
    shown = [];
    for (let i = 0; i < N;) {  // visible nodes in pre-order; a collapsed node hides its subtree
      shown.push(i);
      for (let j = i; j < (collapsed[i] ? end[i] : i + 1); j++) rep[j] = i;
      i = collapsed[i] ? end[i] : i + 1;
    }
    const colW = [];
    for (const i of shown) colW[depth[i]] = Math.max(colW[depth[i]] || 0, width(i));
    const colX = [0];
    for (let d = 1; d < colW.length; d++) colX[d] = colX[d - 1] + colW[d - 1] + GAP;
    pos = new Map();
    let row = 0;
    const place = (i) => {  // iterative post-order: leaves take rows, a parent sits on its first child's row
      const stack = [[i, 0]];
      while (stack.length) {
        const top = stack[stack.length - 1], [j, c] = top;
        const open = collapsed[j] ? [] : kids[j];
        if (c < open.length) { top[1]++; stack.push([open[c], 0]); continue; }
        stack.pop();
        const y = open.length ? pos.get(open[0])[1] : (row++) * ROW;
        pos.set(j, [colX[depth[j]], y, width(j)]);
      }
    };
    if (N) place(0);
    bounds = [-10, -20, colX[colX.length - 1] + colW[colW.length - 1] + 10, Math.max(row, 1) * ROW];
    draw();
  }

  function draw() {
    const g = $("tree-nodes");
    g.textContent = "";
    gEls = new Map();
    const d = [];
    for (const i of shown) {
      const [x, y, w] = pos.get(i);
      if (parent[i] >= 0) { const [px, py, pw] = pos.get(parent[i]); const mx = (px + pw + x) / 2; d.push("M" + (px + pw) + "," + py + "C" + mx + "," + py + " " + mx + "," + y + " " + x + "," + y); }
      const node = svgEl("g", { class: "node" + (collapsed[i] ? " collapsed" : ""), transform: "translate(" + x + "," + (y - 15) + ")" });
      node.dataset.node = i;
      if (nodes[i][4]) node.dataset.id = nodes[i][4];
      node.appendChild(svgEl("rect", { width: w, height: 30, rx: 5, fill: data.styles[nodes[i][1]] || "#eee" }));
      const name = svgEl("text", { x: 6, y: nodes[i][2] ? 12 : 19 });
      name.textContent = clip(label(i), w, 12);
      node.appendChild(name);
      if (nodes[i][2]) { const note = svgEl("text", { x: 6, y: 25, class: "note" }); note.textContent = clip(nodes[i][2], w, 10); node.appendChild(note); }
      if (collapsed[i]) { const more = svgEl("text", { x: w + 4, y: 19, class: "more" }); more.textContent = "+" + (end[i] - i - 1); node.appendChild(more); }
      const title = svgEl("title", {}); title.textContent = label(i) + (nodes[i][2] ? "\n" + nodes[i][2] : "") + (kids[i].length ? (collapsed[i] ? "\n(click: expand " + (end[i] - i - 1) + " nodes)" : "\n(click: collapse)") : "");
      node.appendChild(title);
      g.appendChild(node);
      gEls.set(i, node);
    }
    $("edges").setAttribute("d", d.join(""));
    if (found >= 0 && gEls.has(found)) gEls.get(found).classList.add("found");
    if (tick >= 0) paint();
  }

  const toggle = (i) => { if (!kids[i].length) return; const [x, y] = pos.get(i); const sx = tree.view.x + x * tree.view.s, sy = tree.view.y + y * tree.view.s;
    collapsed[i] = collapsed[i] ? 0 : 1; layout(); const [nx, ny] = pos.get(i); tree.view.x = sx - nx * tree.view.s; tree.view.y = sy - ny * tree.view.s; tree.apply(); };
  treeBox.addEventListener("click", (ev) => {
    const g = ev.target.closest ? ev.target.closest("g.node") : null;
    if (g && !tree.dragged()) toggle(Number(g.dataset.node));
  });
  const fitTree = () => tree.fit(bounds[0], bounds[1], bounds[2], bounds[3], 1.5);
  const READABLE = 0.85;  // the least zoom at which a node's name (12 px) reads as 10 px or more
  function reveal(i, s) {  // node i in the middle of the view at zoom s, its ancestors opened
    for (let a = parent[i]; a >= 0; a = parent[a]) collapsed[a] = 0;
    layout();
    const [x, y, w] = pos.get(i);
    tree.centre(x + w / 2, y, s);
  }
  $("zoom-in").addEventListener("click", () => tree.zoom(1.25));
  $("zoom-out").addEventListener("click", () => tree.zoom(0.8));
  $("fit").addEventListener("click", fitTree);
  $("actual").addEventListener("click", () => { const cx = (treeBox.clientWidth / 2 - tree.view.x) / tree.view.s, cy = (treeBox.clientHeight / 2 - tree.view.y) / tree.view.s; tree.centre(cx, cy, 1); });
  $("expand-all").addEventListener("click", () => { collapsed.fill(0); layout(); fitTree(); });
  let matches = [], matchAt = -1, query = "";
  function search(q) {
    q = q.trim().toLowerCase();
    if (q !== query) { query = q; matches = []; matchAt = -1; if (q) for (let i = 0; i < N; i++) if (nodes[i][4].toLowerCase() === q || nodes[i][4].toLowerCase().includes(q) || label(i).toLowerCase().includes(q)) matches.push(i);
      matches.sort((a, b) => (nodes[b][4].toLowerCase() === q) - (nodes[a][4].toLowerCase() === q) || a - b); }
    if (!matches.length) { $("found").textContent = q ? "no node matches" : ""; return; }
    matchAt = (matchAt + 1) % matches.length;
    const i = matches[matchAt];
    if (found >= 0 && gEls.has(found)) gEls.get(found).classList.remove("found");
    found = i;
    reveal(i, Math.max(tree.view.s, 1));
    $("found").textContent = (matchAt + 1) + " of " + matches.length + ": " + label(i);
  }
  $("search").addEventListener("keydown", (ev) => { if (ev.key === "Enter") { ev.preventDefault(); search($("search").value); } ev.stopPropagation(); });

  // ---- the page's text ------------------------------------------------------------------------------
  $("headline").textContent = data.headline;
  $("headline").className = data.verdict;
  const why = [];
  const said = (text) => why.some((line) => line.includes(text));
  if (data.message) why.push(data.message);
  for (const line of data.explanation) if (!said(line)) why.push(line);
  for (const o of data.oracles) if (o.verdict === "fail" && o.message && !said(o.message)) why.push(o.id + ": " + o.message);
  for (const e of data.execute) if ((e.status === "failure" || e.status === "error") && e.message && !said(e.message)) why.push(e.id + ": " + e.message);
  $("why").textContent = why.join("\n");
  const notes = [];
  if (data.collapsedBelow !== null) notes.push("opened with the subtrees below depth " + data.collapsedBelow + " collapsed (--max-depth; click a node with +N to expand it)");
  else if (openedCollapsed) notes.push("a large tree: opened with " + data.openNodes + " nodes or fewer showing (click a node with +N to expand it, or find one by name)");
  if (data.truncated !== null) notes.push("the trace was cut at tick " + (data.truncated + 1) + " (its memory cap): later changes are not shown");
  $("note").textContent = notes.join("; ");

  const rows = (tbodyId, items, cells) => items.map((item) => {
    const row = document.createElement("tr");
    const made = cells(item).map(([text, cls]) => { const td = el("td", text, cls); row.appendChild(td); return td; });
    $(tbodyId).querySelector("tbody").appendChild(row);
    return [row, made];
  });
  const oracleRows = rows("oracles", data.oracles, (o) => [[o.id], [o.expect], ["", "now"], [o.verdict, "v-" + o.verdict], [secs(o.at)], [o.message, "msg"]]);
  oracleRows.forEach(([row], i) => { row.dataset.criterion = data.oracles[i].id; });
  const entryRows = rows("execute", data.execute, (e) => [[e.id], ["", "now"], [e.status, "v-" + e.status], [secs(e.start)], [secs(e.end)], [e.message, "msg"]]);
  entryRows.forEach(([row], i) => { row.dataset.entry = data.execute[i].id; });

  const W = 240, H = 36;
  const span = times.length ? Math.max(times[last], 1e-9) : 1;
  const jumps = new Map();  // vehicle -> the ticks on which the system teleported it: no line is drawn across them
  if (data.scene) data.scene.frames.forEach((frame, k) => {
    for (let j = 0; j + 4 < frame.length; j += 5) if (frame[j + 4] & 2) {
      const id = data.scene.vehicles[frame[j]];
      if (!jumps.has(id)) jumps.set(id, new Set());
      jumps.get(id).add(k);
    }
  });
  if (jumps.size) $("teleported-key").hidden = false;
  const signals = Object.keys(data.signals).sort().map((name) => {
    const series = data.signals[name];
    const row = document.createElement("tr");
    row.dataset.signal = name;
    row.appendChild(el("td", name));
    const value = el("td", "", "value");
    row.appendChild(value);
    const curveCell = el("td");
    row.appendChild(curveCell);
    const isNumber = (item) => item.length > 1 && (typeof item[1] === "number" || typeof item[1] === "boolean");
    const numeric = series.filter(isNumber);
    let cursorLine = null;
    if (numeric.length) {
      const ys = numeric.map(([, v]) => Number(v));
      const lo = Math.min(...ys), hi = Math.max(...ys), dy = hi - lo || 1;
      const x = (k) => 2 + (W - 4) * (times[k] / span), y = (v) => H - 3 - (H - 6) * ((Number(v) - lo) / dy);
      const lines = [];  // one line per stretch with a value: where the signal ended ([tick], no value) its line stops
      const jumped = jumps.get(name.slice(0, name.lastIndexOf("."))) || new Set();  // and where its vehicle teleported
      let pts = [], prev = null;
      series.forEach((item) => {
        const k = item[0];
        if (item.length < 2) {
          if (prev !== null) { pts.push(x(k) + "," + y(prev)); lines.push(pts); }
          pts = []; prev = null;
          return;
        }
        if (!isNumber(item)) return;
        if (prev !== null && jumped.has(k)) { pts.push(x(k) + "," + y(prev)); lines.push(pts); pts = []; prev = null; }
        if (prev !== null) pts.push(x(k) + "," + y(prev));
        pts.push(x(k) + "," + y(item[1]));
        prev = item[1];
      });
      if (prev !== null) { pts.push((W - 2) + "," + y(prev)); lines.push(pts); }
      const svg = svgEl("svg", { class: "curve", width: W, height: H });
      for (const o of data.oracles) {  // a temporal criterion's window (anchor to horizon) on what it reads, as --plot draws it
        if (!o.window || !(o.reads || []).includes(name)) continue;
        const x0 = 2 + (W - 4) * Math.min(o.window[0] / span, 1), x1 = 2 + (W - 4) * Math.min(o.window[1] / span, 1);
        const band = svgEl("rect", { class: "window" + (o.verdict === "fail" ? " fail" : ""), x: x0, y: 0, width: Math.max(x1 - x0, 1), height: H });
        band.dataset.criterion = o.id;
        const note = svgEl("title", {}); note.textContent = o.id + " window: " + fmt(o.window[0]) + " \u2026 " + fmt(o.window[1]) + " s";
        band.appendChild(note);
        svg.appendChild(band);
      }
      for (const points of lines) svg.appendChild(svgEl("polyline", { points: points.join(" ") }));
      const title = svgEl("title", {}); title.textContent = name + ": " + fmt(lo) + " \u2026 " + fmt(hi); svg.appendChild(title);
      cursorLine = svgEl("line", { y1: 0, y2: H });
      svg.appendChild(cursorLine);
      curveCell.appendChild(svg);
    }
    $("signals").querySelector("tbody").appendChild(row);
    return { name, series, value, cursorLine, x: (k) => 2 + (W - 4) * (times[k] / span) };
  });
  const byName = new Map(signals.map((s) => [s.name, s]));

  function valueAt(series, k) {  // binary search: the last change at or before tick k
    let lo = 0, hi = series.length - 1, found = null;
    while (lo <= hi) { const mid = (lo + hi) >> 1; if (series[mid][0] <= k) { found = series[mid][1]; lo = mid + 1; } else hi = mid - 1; }
    return found;
  }

  // ---- the scene ------------------------------------------------------------------------------------
  const scene = data.scene;
  let sceneView = null, hovered = null, egoAt = null;
  const cars = new Map();
  if (scene) {
    $("scene-box").hidden = false;
    document.body.classList.add("has-scene");
    const map = $("scene-map");
    let x0 = Infinity, y0 = Infinity, x1 = -Infinity, y1 = -Infinity;
    const pts = (flat) => { const out = []; for (let j = 0; j + 1 < flat.length; j += 2) { out.push(flat[j] + "," + (-flat[j + 1])); x0 = Math.min(x0, flat[j]); x1 = Math.max(x1, flat[j]); y0 = Math.min(y0, -flat[j + 1]); y1 = Math.max(y1, -flat[j + 1]); } return out.join(" "); };
    for (const area of scene.map.areas || []) map.appendChild(svgEl("polygon", { points: pts(area) }));
    for (const [w, flat] of scene.map.lanes || []) map.appendChild(svgEl("polyline", { points: pts(flat), "stroke-width": Math.max(w - 0.25, 0.5) }));
    for (const lane of map.querySelectorAll("polyline")) lane.style.stroke = "#9aa0a6";
    if (!isFinite(x0)) { x0 = -50; y0 = -50; x1 = 50; y1 = 50; }
    const sceneBox = $("scene");
    sceneView = panZoom(sceneBox, $("scene-vp"), (v) => { for (const c of cars.values()) c.text.setAttribute("font-size", 12 / v.s); });
    sceneView.onPan = () => { $("follow").checked = false; };
    sceneView.bounds = [x0, y0, x1, y1];
    const ego = scene.map.ego;
    if (!ego || !scene.vehicles.includes(ego)) { $("follow").checked = false; $("follow").disabled = true; }
    $("scene-in").addEventListener("click", () => { sceneView.zoom(1.25); });
    $("scene-out").addEventListener("click", () => { sceneView.zoom(0.8); });
    $("scene-fit").addEventListener("click", () => { $("follow").checked = false; sceneView.fit(x0, y0, x1, y1); });
    $("follow").addEventListener("change", () => { if ($("follow").checked && egoAt) sceneView.centre(egoAt[0], egoAt[1]); });
    const tip = $("scene-tip");
    sceneBox.addEventListener("pointerover", (ev) => { const g = ev.target.closest ? ev.target.closest("g.car") : null; if (g) { hovered = g.dataset.vehicle; tipAt(ev); } });
    sceneBox.addEventListener("pointerout", (ev) => { const g = ev.target.closest ? ev.target.closest("g.car") : null; if (g) { hovered = null; tip.hidden = true; } });
    sceneBox.addEventListener("pointermove", (ev) => { if (hovered !== null) tipAt(ev); });
    function tipAt(ev) { const r = sceneBox.getBoundingClientRect(); tip.style.left = (ev.clientX - r.left + 14) + "px"; tip.style.top = (ev.clientY - r.top + 10) + "px"; tipText(); tip.hidden = false; }
  }
  function tipText() {
    if (hovered === null) return;
    const lines = [hovered];
    const prefix = hovered + ".";
    for (const s of signals) if (s.name.startsWith(prefix)) lines.push(s.name.slice(prefix.length) + " = " + fmt(valueAt(s.series, tick)));
    if (lines.length === 1) lines.push("(no signals: not tracked, or left out by --signals)");
    if (jumps.has(hovered) && jumps.get(hovered).has(tick)) lines.push("teleported here on this tick (not driven)");
    $("scene-tip").textContent = lines.join("\n");
  }
  function showScene(k) {
    const frames = scene.frames, frame = frames[Math.min(k, frames.length - 1)] || [];
    const here = new Set();
    egoAt = null;
    for (let j = 0; j + 4 < frame.length; j += 5) {
      const v = frame[j], id = scene.vehicles[v], [len, wid] = scene.sizes[v];
      const x = frame[j + 1], y = -frame[j + 2], a = frame[j + 3], hit = frame[j + 4] & 1, jump = frame[j + 4] & 2;
      let car = cars.get(id);
      if (!car) {
        const g = svgEl("g", { class: "car" });
        g.dataset.vehicle = id;
        const body = svgEl("rect", { x: -len, y: -wid / 2, width: len, height: wid, rx: Math.min(0.4, wid / 4) });
        const text = svgEl("text", { "text-anchor": "middle", "font-size": 12 / sceneView.view.s });
        text.textContent = id;
        g.appendChild(body); $("scene-cars").appendChild(g); $("scene-cars").appendChild(text);
        car = { g, body, text }; cars.set(id, car);
      }
      const kind = (hit ? "collided" : id === scene.map.ego ? "ego" : "other") + (jump ? " teleported" : "");
      if (car.kind !== kind) { car.g.setAttribute("class", "car " + kind); car.kind = kind; }
      car.g.setAttribute("transform", "translate(" + x + "," + y + ") rotate(" + (a - 90) + ")");
      const rad = (a - 90) * Math.PI / 180;
      car.text.setAttribute("x", x - Math.cos(rad) * len / 2); car.text.setAttribute("y", y - Math.sin(rad) * len / 2 - wid);
      car.g.style.display = ""; car.text.style.display = "";
      car.g.dataset.x = frame[j + 1]; car.g.dataset.y = frame[j + 2]; car.g.dataset.heading = a;
      here.add(id);
      if (id === scene.map.ego) egoAt = [x - Math.cos(rad) * len / 2, y - Math.sin(rad) * len / 2];
    }
    for (const [id, car] of cars) if (!here.has(id)) { car.g.style.display = "none"; car.text.style.display = "none"; }
    if ($("follow").checked && egoAt) sceneView.centre(egoAt[0], egoAt[1]);
    tipText();
  }

  // ---- one tick -------------------------------------------------------------------------------------
  function apply(k) {
    if (k < applied) { state.fill(0); cursor = 0; applied = -1; }
    while (cursor < tr.length && tr[cursor] <= k) { state[tr[cursor + 1]] = tr[cursor + 2]; cursor += 3; }
    applied = k;
  }

  function paint() {
    const box = new Int8Array(N).fill(-1);
    for (let i = 0; i < N; i++) { const r = rep[i], s = state[i]; if (box[r] < 0 || RANK[s] > RANK[box[r]]) box[r] = s; }
    for (const [i, g] of gEls) {
      const s = STATUS[Math.max(box[i], 0)];
      if (g.dataset.status !== s) { g.classList.remove("st-invalid", "st-running", "st-success", "st-failure"); g.classList.add("st-" + s); g.dataset.status = s; }
    }
  }

  function show(k) {
    k = Math.max(0, Math.min(last, k | 0));
    tick = k;
    apply(k);
    paint();
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
    if (scene) showScene(k);
    const slider = $("slider");
    if (Number(slider.value) !== k) slider.value = k;
    // one count everywhere: tick 1 is the run's first tick, as the headline's "(N ticks)" counts them
    $("clock").textContent = times.length ? "t = " + fmt(times[k]) + " s \u00b7 tick " + (k + 1) + " of " + times.length : "no tick ran";
    document.body.dataset.tick = k;
  }

  const slider = $("slider");
  slider.max = last;
  slider.addEventListener("input", () => show(Number(slider.value)));
  $("prev").addEventListener("click", () => show(tick - 1));
  $("next").addEventListener("click", () => show(tick + 1));
  document.addEventListener("keydown", (ev) => {
    if (ev.target && ev.target.tagName === "INPUT" && ev.target.type !== "range") return;
    const moves = { ArrowLeft: -1, ArrowRight: 1 };
    if (ev.key in moves) { ev.preventDefault(); show(tick + moves[ev.key]); }
    else if (ev.key === "Home") { ev.preventDefault(); show(0); }
    else if (ev.key === "End") { ev.preventDefault(); show(last); }
    else if (ev.key === "+" || ev.key === "=") tree.zoom(1.25);
    else if (ev.key === "-") tree.zoom(0.8);
  });
  const tickOf = (t) => { let best = 0; times.forEach((s, k) => { if (Math.abs(s - t) < Math.abs(times[best] - t)) best = k; }); return best; };
  const failed = (e) => (e.status === "failure" || e.status === "error") && e.end !== null;
  const failures = data.oracles.filter((o) => o.verdict === "fail" && o.at !== null).map((o) => [o.id, o.at, "failed", o.node])
    .concat(data.execute.filter(failed)
      .map((e) => [e.id, e.end, e.status === "error" ? "error" : "failed", e.node]));  // an entry whose leaf raised: error
  for (const [id, at, what, node] of failures) {
    const b = el("button", id + " " + what + " at " + fmt(at) + " s");
    b.type = "button";
    b.addEventListener("click", () => { show(tickOf(at)); if (node >= 0) reveal(node, Math.max(tree.view.s, 1)); });
    $("jumps").appendChild(b);
  }
  // open on what decided the verdict: the first criterion to fail (the earliest), else a failed entry, else the
  // first criterion; the whole tree if it fits readable, else that node in the middle at 100 %
  const earliest = (items, at) => items.reduce((best, item) => best === null || item[at] < best[at] ? item : best, null);
  const first = earliest(data.oracles.filter((o) => o.verdict === "fail" && o.at !== null && o.node >= 0), "at")
    || earliest(data.execute.filter((e) => failed(e) && e.node >= 0), "end") || data.oracles.find((o) => o.node >= 0);
  const focus = first ? first.node : 0;
  layout();
  const fitScale = Math.min((treeBox.clientWidth - 20) / (bounds[2] - bounds[0]), (treeBox.clientHeight - 20) / (bounds[3] - bounds[1]));
  if (fitScale >= READABLE && rep[focus] === focus) fitTree(); else if (N) reveal(focus, 1);
  if (scene) sceneView.centre(0, 0, Math.max(0.5, $("scene").clientWidth / 120));  // about 120 m across
  show(last);
  window.btgenReplay = {  // for tests and the curious: read-only views of the page's state
    view: () => ({ s: tree.view.s, x: tree.view.x, y: tree.view.y }),
    sceneView: () => sceneView ? { s: sceneView.view.s, x: sceneView.view.x, y: sceneView.view.y } : null,
    shown: () => shown.length, collapsed: () => Array.from(collapsed.keys()).filter((i) => collapsed[i]),
    bounds: () => bounds.slice(), focus: () => focus,
  };
  document.body.dataset.ready = "1";
})();
