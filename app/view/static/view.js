// mcl view: renders the page's data (embedded in the page as JSON, or polled from data.json
// while a run goes on) at the instant the slider, the time box or ?t=SECONDS chooses.
"use strict";

let data = JSON.parse(document.getElementById("data").textContent);
let chosen = null;  // the block or line the user picked
const SVG = "http://www.w3.org/2000/svg";

function el(tag, attrs, ...kids) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
  for (const kid of kids) e.append(kid);
  return e;
}

function seconds(x) {
  return x === null || x === undefined ? "∞" : `${Number(x).toFixed(1)} s`;
}

function renderTree(node, parent) {
  const li = el("li", {class: "block", "data-block": node.id, "data-kind": node.kind,
                       "data-line": node.line, "data-state": "waiting"});
  const head = el("div", {class: "head"});
  if (node.slot) head.append(el("span", {class: "slot"}, node.slot));
  head.append(el("span", {class: "title"}, node.title),
              el("span", {class: "state waiting"}, "waiting"),
              el("a", {class: "line", href: `#L${node.line}`}, `line ${node.line}`));
  const bound = data.bounds.blocks[node.id];
  if (bound) head.append(el("span", {class: "bound"}, `[${seconds(bound[0])}, ${seconds(bound[1])}]`));
  head.addEventListener("click", () => choose(node.line, li));
  li.append(head);
  if (node.children.length) {
    const ul = el("ul");
    for (const child of node.children) renderTree(child, ul);
    li.append(ul);
  }
  parent.append(li);
}

function renderSource() {
  const ol = document.getElementById("source");
  ol.replaceChildren(...data.source.map((text, i) => el("li", {id: `L${i + 1}`}, text || " ")));
  document.getElementById("file").textContent = data.file;
}

function renderTimeline() {
  const ol = document.getElementById("timeline");
  ol.replaceChildren(...data.timeline.map((entry) => {
    const link = entry.line ? el("a", {href: `#L${entry.line}`}, `line ${entry.line}`) : "";
    const li = el("li", {class: `entry ${entry.kind}`, "data-t": entry.t},
                  el("span", {class: "t"}, seconds(entry.t)), el("span", {}, entry.text),
                  el("span", {}, link));
    if (entry.line) li.addEventListener("click", () => choose(entry.line, null));
    return li;
  }));
}

function choose(line, block) {
  document.querySelectorAll(".chosen").forEach((e) => e.classList.remove("chosen"));
  const row = document.getElementById(`L${line}`);
  if (row) { row.classList.add("chosen"); row.scrollIntoView({block: "nearest"}); }
  const node = block || document.querySelector(`.block[data-line="${line}"]`);
  if (node) node.classList.add("chosen");
  chosen = line;
}

function statesAt(t) {
  const states = {};
  for (const [when, id, state] of data.changes) {
    if (when > t) break;
    states[id] = state;
  }
  return states;
}

function trackView(points) {
  // the wall seen from the vehicle (along-wall y, depth z down) when the track keeps close to
  // a wall plane, else the plan (x east, y north up); the spans leave out the first and last
  // twentieth of each coordinate's values (the way to the wall and back is not the survey)
  const span = (i) => {
    const v = points.map((p) => p[i]).sort((a, b) => a - b);
    return v[Math.floor(0.95 * (v.length - 1))] - v[Math.floor(0.05 * (v.length - 1))];
  };
  return span(1) < 0.25 * span(2) ? {h: 2, v: 3, down: true, names: ["along the wall y (m)", "depth z (m)"]}
                                  : {h: 1, v: 2, down: false, names: ["x (m)", "y (m)"]};
}

const COLOURS = ["#2f7de1", "#d2691e", "#2e8b57", "#8a2be2", "#c71585", "#008b8b"];

function svgEl(tag, attrs) {
  const e = document.createElementNS(SVG, tag);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
  return e;
}

function renderPlan(t) {
  // a fleet: every vehicle's track on one plan (x east, y north up) over the scene its logs
  // name (the dam wall, the mine and the clutter), each vehicle where it was at t, named
  const box = document.getElementById("track");
  const tracks = Object.entries(data.tracks).filter(([, pts]) => pts.length);
  if (!tracks.length) { box.textContent = "no track in these logs"; return; }
  const scene = data.scene || {lines: {}, points: {}};
  const box0 = (pts) => [Math.min(...pts.map((p) => p[0])), Math.max(...pts.map((p) => p[0])),
                         Math.min(...pts.map((p) => p[1])), Math.max(...pts.map((p) => p[1]))];
  const seen = [...tracks.flatMap(([, pts]) => pts.map((p) => [p[1], p[2]])),
                ...Object.values(scene.points).flat()];
  let [x0, x1, y0, y1] = box0(seen);  // the lines count where they pass near (a wall is long)
  const near = Object.values(scene.lines).flat().filter(
    (p) => p[0] > x0 - 5 && p[0] < x1 + 5 && p[1] > y0 - 5 && p[1] < y1 + 5);
  [x0, x1, y0, y1] = box0([...seen, ...near]);
  const pad = 2;
  let w = Math.max(x1 - x0, 1) + 2 * pad;
  const h = Math.max(y1 - y0, 1) + 2 * pad;
  if (h > 0.8 * w) {  // no taller than wide, by much: wider, on the same scale
    const grow = (h / 0.8 - w) / 2;
    [x0, x1, w] = [x0 - grow, x1 + grow, h / 0.8];
  }
  const X = (x) => (x - x0 + pad) * 600 / w, Y = (y) => (y1 - y + pad) * 600 / w;
  const at = (pts) => pts.map((p) => `${X(p[0]).toFixed(1)},${Y(p[1]).toFixed(1)}`).join(" ");
  const height = Math.ceil(h * 600 / w);
  const svg = svgEl("svg", {viewBox: `0 0 600 ${height + 20}`, id: "plan"});
  for (const [name, pts] of Object.entries(scene.lines)) {
    svg.append(svgEl("polyline", {class: "scene-line", "data-name": name, points: at(pts),
                                  fill: "none", stroke: "#7a6a58", "stroke-width": "4"}));
  }
  for (const [name, pts] of Object.entries(scene.points)) {
    for (const p of pts) {
      svg.append(svgEl("circle", {class: "scene-point", "data-name": name, cx: X(p[0]),
                                  cy: Y(p[1]), r: name === "mine" ? "6" : "3",
                                  fill: name === "mine" ? "#222" : "#a8a29a"}));
    }
  }
  tracks.forEach(([name, pts], i) => {
    const colour = COLOURS[i % COLOURS.length];
    const xy = (list) => at(list.map((p) => [p[1], p[2]]));
    svg.append(svgEl("polyline", {class: "planned", "data-vehicle": name, points: xy(pts),
                                  fill: "none", stroke: "#c3c9d4", "stroke-width": "2"}));
    const done = pts.filter((p) => p[0] <= t);
    if (!done.length) return;
    svg.append(svgEl("polyline", {class: "travelled", "data-vehicle": name, points: xy(done),
                                  "data-points": done.length, fill: "none", stroke: colour,
                                  "stroke-width": "2"}));
    const last = done[done.length - 1];
    svg.append(svgEl("circle", {class: "vehicle", "data-vehicle": name, "data-t": last[0],
                                "data-x": last[1], "data-y": last[2], cx: X(last[1]).toFixed(1),
                                cy: Y(last[2]).toFixed(1), r: "6", fill: colour}));
    const label = svgEl("text", {class: "vehicle-name", "data-vehicle": name, "font-size": "13",
                                 x: (X(last[1]) + 8).toFixed(1), y: (Y(last[2]) - 8).toFixed(1)});
    label.textContent = name;
    svg.append(label);
  });
  const label = svgEl("text", {x: "4", y: String(height + 15), "font-size": "12"});
  label.textContent = `x (m) ${x0.toFixed(1)} to ${x1.toFixed(1)}; y (m) ${y0.toFixed(1)} to ` +
    `${y1.toFixed(1)} (${[...new Set(Object.values(data.tracks_from || {}).filter((s) => s))].join("; ")})` +
    [...Object.keys(scene.lines).map((n) => `; ${n}: brown line`),
     ...Object.entries(scene.points).map(([n, pts]) =>
       `; ${n}: ${n === "mine" ? "black" : "grey"} dot${pts.length === 1 ? "" : "s"}`)].join("");
  svg.append(label);
  box.replaceChildren(svg);
}

function renderTrack(t) {
  if (data.tracks) { renderPlan(t); return; }
  const box = document.getElementById("track");
  const points = data.track;
  if (!points.length) { box.textContent = "no track in this log"; return; }
  const view = trackView(points);
  const xs = points.map((p) => p[view.h]), ys = points.map((p) => p[view.v]);
  const [x0, x1, y0, y1] = [Math.min(...xs), Math.max(...xs), Math.min(...ys), Math.max(...ys)];
  const pad = 1, w = Math.max(x1 - x0, 1) + 2 * pad, h = Math.max(y1 - y0, 1) + 2 * pad;
  const X = (x) => (x - x0 + pad) * 600 / w;
  const Y = (y) => view.down ? (y - y0 + pad) * 600 / w : (y1 - y + pad) * 600 / w;
  const svg = document.createElementNS(SVG, "svg");
  svg.setAttribute("viewBox", `0 0 600 ${Math.ceil(h * 600 / w) + 20}`);
  const line = (pts, cls, colour) => {
    const pl = document.createElementNS(SVG, "polyline");
    pl.setAttribute("points", pts.map((p) => `${X(p[view.h]).toFixed(1)},${Y(p[view.v]).toFixed(1)}`).join(" "));
    pl.setAttribute("class", cls);
    pl.setAttribute("fill", "none");
    pl.setAttribute("stroke", colour);
    pl.setAttribute("stroke-width", "2");
    svg.append(pl);
  };
  line(points, "planned", "#c3c9d4");
  const done = points.filter((p) => p[0] <= t);
  if (done.length) {
    line(done, "travelled", "#2f7de1");
    const last = done[done.length - 1];
    const dot = document.createElementNS(SVG, "circle");
    dot.setAttribute("id", "vehicle");
    dot.setAttribute("cx", X(last[view.h]));
    dot.setAttribute("cy", Y(last[view.v]));
    dot.setAttribute("r", "6");
    dot.setAttribute("fill", "#d23b3b");
    svg.append(dot);
  }
  const label = document.createElementNS(SVG, "text");
  label.setAttribute("x", "4");
  label.setAttribute("y", String(Math.ceil(h * 600 / w) + 15));
  label.setAttribute("font-size", "12");
  label.textContent = `${view.names[0]} ${x0.toFixed(1)} to ${x1.toFixed(1)}; ` +
    `${view.names[1]} ${y0.toFixed(1)} to ${y1.toFixed(1)} (${data.track_from})`;
  svg.append(label);
  box.replaceChildren(svg);
}

function renderPictures() {
  const box = document.getElementById("pictures");
  box.replaceChildren(...Object.entries(data.pictures).map(([name, url]) =>
    el("figure", {}, el("img", {src: url, alt: name}), el("figcaption", {}, name))));
}

function summary(t, states) {
  const end = data.end, b = data.bounds;
  const running = [...document.querySelectorAll('.block[data-kind="task"][data-state="running"] > .head .title')]
    .map((e) => e.textContent);
  let text;
  if (end.status && t >= end.t) {
    text = `ended ${end.status.toUpperCase()} at ${seconds(end.t)}`;
  } else {
    const left = b.worst === null ? "unbounded" : seconds(Math.max(0, b.worst - t));
    text = `t = ${seconds(t)} · time left at most ${left}` +
           ` (at least ${seconds(Math.max(0, (b.best || 0) - t))})`;
  }
  text += ` · proved [best, worst] = [${seconds(b.best)}, ${seconds(b.worst)}]`;
  text += ` · running: ${running.length ? running.join(", ") : "—"}`;
  const progress = Object.entries(data.progress || {});
  if (data.live && progress.length && t >= data.end.t - 0.5) {  // now, as the player says
    text += ` · progress: ${progress.map(([task, how]) => `${task} (${how})`).join(", ")}`;
  }
  document.getElementById("summary").textContent = text;
  document.body.dataset.mission = states.MISSION || "waiting";
}

function show(t) {
  t = Math.max(0, Number.isFinite(t) ? t : 0);
  document.getElementById("time").value = Math.round(t * 10) / 10;
  document.getElementById("slider").value = t;
  const states = statesAt(t);
  document.querySelectorAll(".block").forEach((li) => {
    const state = states[li.dataset.block] || "waiting";
    li.dataset.state = state;
    const badge = li.querySelector(":scope > .head .state");
    badge.className = `state ${state}`;
    badge.textContent = state;
  });
  let now = null;
  document.querySelectorAll("#timeline li").forEach((li) => {
    const future = Number(li.dataset.t) > t;
    li.classList.toggle("future", future);
    li.classList.remove("now");
    if (!future) now = li;
  });
  if (now) now.classList.add("now");
  document.querySelectorAll("#source li.active").forEach((e) => e.classList.remove("active"));
  document.querySelectorAll('.block[data-kind="task"][data-state="running"]').forEach((li) => {
    const row = document.getElementById(`L${li.dataset.line}`);
    if (row) row.classList.add("active");
  });
  renderTrack(t);
  summary(t, states);
  const url = new URL(window.location.href);
  url.searchParams.set("t", String(t));
  window.history.replaceState(null, "", url);
}

function render() {
  document.getElementById("mission").textContent = `mcl view · ${data.mission}`;
  document.title = `mcl view · ${data.mission}`;
  const tree = document.getElementById("tree");
  tree.replaceChildren();
  renderTree(data.tree, tree);
  renderSource();
  renderTimeline();
  renderPictures();
  for (const id of ["time", "slider"]) document.getElementById(id).max = data.end.t;
}

async function poll() {  // a live run: the server keeps data.json up to date
  try {
    const reply = await fetch("data.json", {cache: "no-store"});
    const before = data.end.t;  // the user who was at the newest instant keeps following
    const follow = Number(document.getElementById("time").value) >= before - 0.1;
    data = await reply.json();
    render();
    show(follow || !data.live ? data.end.t : Number(document.getElementById("time").value));
    document.getElementById("live").textContent = data.live ? `live: ${data.link}` : "";
  } catch (err) {  // once a run has ended, its server may stop (mcl run --view)
    document.getElementById("live").textContent = data.end.status
      ? `live: no answer: the run ended ${data.end.status.toUpperCase()} and its server has stopped`
      : `live: no answer (${err})`;
  }
  setTimeout(poll, 1000);
}

render();
const asked = new URL(window.location.href).searchParams.get("t");
show(asked === null ? data.end.t : parseFloat(asked));
document.getElementById("time").addEventListener("change", (e) => show(parseFloat(e.target.value)));
document.getElementById("slider").addEventListener("input", (e) => show(parseFloat(e.target.value)));
if (chosen === null && data.live) setTimeout(poll, 1000);
