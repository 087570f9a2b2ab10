// The browser view of a run: the same page for a live run, a replay and a saved .html file.
// Data: a header (the tree, the world), tick records, an end record (docs/trace.md).
"use strict";

const SVG_NS = "http://www.w3.org/2000/svg";
// Each plot: its name, unit, value in a tick, and the value at which it wraps round to 0 (or 0).
const PLOTS = [
  ["front distance", "mm", (t) => t.status.front_distance_mm, 0],
  ["heading", "deg", (t) => t.status.heading_deg, 360],
  ["tilt", "deg", (t) => t.status.tilt_deg, 0],
  ["speed", "mm/s", (t) => t.mean_speed_mm_s, 0, "mean of 0.25 s"],
  ["battery", "/255", (t) => t.battery, 0],
];
// The odometer counts whole millimetres: at 20 Hz a steady 210 mm/s reads 200 and 220 in turn, so
// the speed is plotted as its mean over this long, a line rather than a zig-zag band.
const SPEED_WINDOW_S = 0.25;
const CHECKPOINT_EVERY = 100;
// the mean speed of a tick is over at most this many ticks before it (0.25 s at 200 Hz is 50)
const SPEED_WINDOW_TICKS = 400;
const RENDER_EVERY_MS = 50;
const BURST_RENDER_EVERY_MS = 1000;
const BURST_FULL_RENDER_EVERY_MS = 3000;
const MAX_PLOT_POINTS = 400;  // a plot is about 400 px wide
const MAX_PATH_POINTS = 3000;
const NEXT_RUN_FIRST_WAIT_MS = 1000;
const NEXT_RUN_MOST_WAIT_MS = 10000;

const view = {
  mode: "live", header: null, ticks: [], end: null, index: -1,
  playing: false, speed: 1, playTime: 0, lastFrame: 0, lastRender: 0, burst: false, dirty: false, frameAsked: false, timerSet: false, lastFullRender: 0,
  checkpoints: [], events: [], collisions: [], logKey: null,
  // per tick, filled as ticks arrive, so that drawing never walks every record
  times: [], values: [], wraps: [], lo: [], hi: [], dr: [], truth: [], bounds: [0, 0, 0, 0],
};

const $ = (id) => document.getElementById(id);
// Text of the run's own (a mission's names, a behaviour's words) with its control and formatting
// characters shown as \ufffd, as every other view shows it (autonomy/views/lines.py printable): a
// right-to-left override or a bell in a log message is seen, not obeyed.
const UNPRINTABLE = /(?![\n ])[\p{C}\p{Zl}\p{Zp}\p{Zs}]/gu;  // a line's end and a space are kept
const printable = (text) => String(text).replace(UNPRINTABLE, "\ufffd");

// The tree and map pictures come as SVG text. Only pictures are taken from it: drawing elements
// and their plain attributes; a script, a link, an event handler or a foreign object is dropped,
// whatever served this port (a page stays open while another server takes the port).
const SVG_TAGS = new Set(["svg", "g", "rect", "circle", "ellipse", "line", "polyline", "polygon", "path", "text", "tspan", "title"]);
function safeSvg(markup) {
  if (!markup) return [];
  const parsed = new DOMParser().parseFromString(markup, "image/svg+xml");
  const root = parsed.documentElement;
  if (!root || root.localName !== "svg" || root.namespaceURI !== SVG_NS) return [];
  for (const el of [root, ...root.querySelectorAll("*")]) {
    if (!SVG_TAGS.has(el.localName) || el.namespaceURI !== SVG_NS) { el.remove(); continue; }
    for (const attribute of [...el.attributes]) {
      const name = attribute.name.toLowerCase();
      if (name.startsWith("on") || name.includes("href") || name === "style") el.removeAttribute(attribute.name);
    }
  }
  return [document.importNode(root, true)];
}

function svgEl(name, attrs, parent) {
  const el = document.createElementNS(SVG_NS, name);
  for (const [k, v] of Object.entries(attrs || {})) el.setAttribute(k, v);
  if (parent) parent.appendChild(el);
  return el;
}

// ------------------------------------------------------------------ loading

function load(payload) {
  view.mode = payload.mode;
  view.run = payload.run;
  view.header = payload.header;
  view.ticks = [];
  view.end = null;
  view.checkpoints = [];
  // a checkpoint holds a state of every node: one every as many ticks as there are nodes (100 at least)
  // keeps them all together no larger than the ticks themselves
  view.checkpointEvery = Math.max(CHECKPOINT_EVERY, payload.header ? payload.header.nodes.length : 0);
  view.events = [];
  view.logKey = null;
  view.collisions = [];
  view.times = [];
  view.values = PLOTS.map(() => []);
  view.wraps = PLOTS.map(() => []);  // per tick: how many times the value wrapped round so far
  view.lo = PLOTS.map(() => 0);
  view.hi = PLOTS.map(() => 1);
  view.dr = [];
  view.truth = [];
  view.bounds = [0, 0, 0, 0];
  $("mission").textContent = payload.header ? printable(payload.header.mission) : "waiting for the run";
  document.title = "autonomy: " + (payload.header ? printable(payload.header.mission) : "a run");
  $("tree").replaceChildren(...safeSvg(payload.tree_svg));
  view.treeFocus = null;
  fitTree();
  for (const g of document.querySelectorAll("#tree .node")) {
    const rect = g.querySelector("rect");
    const y = parseFloat(rect.getAttribute("y")) + parseFloat(rect.getAttribute("height")) + 11;
    const x = parseFloat(rect.getAttribute("x")) + parseFloat(rect.getAttribute("width")) / 2;
    svgEl("text", { x, y, "text-anchor": "middle", class: "feedback" }, g);
  }
  setupMap(payload);
  setupPlots();
  const h = payload.header;
  if (h) {
    const world = h.world ? `world ${h.world.name}` : "world unknown (dead reckoning only)";
    const parts = h.telemetry === false
      ? ["a BehaviorTree.CPP log: node statuses only, no telemetry", h.date]
      : [world, h.port, `${h.clock} time`, h.date];
    $("where").textContent = printable(parts.filter(Boolean).join(" · "));
  }
  // A recording without telemetry has no path or plots to show: none are made up.
  const noTelemetry = Boolean(h && h.telemetry === false);
  $("map-panel").hidden = noTelemetry;
  $("plots-panel").hidden = noTelemetry;
  for (const t of payload.ticks || []) addTick(t);
  for (const row of payload.rows || []) addTick(fromRow(payload.row_fields, row));
  if (payload.end) addEnd(payload.end);
  $("controls").hidden = view.mode !== "replay";
  // a replay opens on its first tick, or on its last when the page was made to show how a run ended
  const first = payload.open_at_end ? view.ticks.length - 1 : 0;
  view.index = view.mode === "replay" ? (view.ticks.length ? first : -1) : view.ticks.length - 1;
  view.playTime = view.index >= 0 ? view.ticks[view.index].time_s : 0;
  render();
}

// A replay's ticks come as rows (autonomy/views/page.py): arrays of what is drawn, named by the
// payload's row_fields; a row is made a tick record again, with the status's fields in its status.
const STATUS_FIELDS = new Set(["front_distance_mm", "heading_deg", "tilt_deg"]);
function fromRow(names, row) {
  const t = { status: {} };
  names.forEach((name, i) => { if (STATUS_FIELDS.has(name)) t.status[name] = row[i]; else t[name] = row[i]; });
  return t;
}

function addTick(t) {
  const i = view.ticks.length;
  view.ticks.push(t);
  for (const e of t.events || []) {
    view.events.push([i, e]);
    if (e.kind === "collision") view.collisions.push(i);
  }
  if (i % view.checkpointEvery === 0) view.checkpoints.push(stateAt(i, true));
  view.times.push(t.time_s);
  let sum = 0, count = 0;
  // at most SPEED_WINDOW_TICKS back: a recording whose times stand still costs no more than one that moves
  for (let k = i; k >= 0 && i - k < SPEED_WINDOW_TICKS && t.time_s - view.ticks[k].time_s < SPEED_WINDOW_S; k--) {
    sum += view.ticks[k].speed_mm_s; count++;
  }
  t.mean_speed_mm_s = count ? sum / count : t.speed_mm_s;
  PLOTS.forEach(([, , get, wrap], p) => {
    const v = get(t), values = view.values[p], wraps = view.wraps[p];
    const before = values.length ? values[values.length - 1] : v;
    wraps.push((wraps.length ? wraps[wraps.length - 1] : 0) + (wrap && Math.abs(v - before) > wrap / 2 ? 1 : 0));
    values.push(v);
    if (v < view.lo[p]) view.lo[p] = v;
    if (v > view.hi[p]) view.hi[p] = v;
  });
  const [x, y] = t.dead_reckoning, b = view.bounds;
  view.bounds = [Math.min(b[0], x), Math.min(b[1], y), Math.max(b[2], x), Math.max(b[3], y)];
  view.dr.push(`${x},${y}`);
  if (t.truth) view.truth.push(`${t.truth[0]},${t.truth[1]}`);
}

// Indexes 0..upto, every step-th so that there are at most `most`, the last always included.
function sampled(upto, most) {
  const step = Math.max(1, Math.ceil((upto + 1) / most));
  const out = [];
  for (let k = 0; k <= upto; k += step) out.push(k);
  if (upto >= 0 && out[out.length - 1] !== upto) out.push(upto);
  return out;
}

function addEnd(end) {
  view.end = end;
  for (const e of end.events || []) view.events.push([view.ticks.length, e]);
}

// Every node's [status, feedback] after tick i.
function stateAt(i, building) {
  const cp = Math.floor(i / view.checkpointEvery);
  let state, from;
  if (!building && cp < view.checkpoints.length) {
    state = Object.assign({}, view.checkpoints[cp]);
    from = cp * view.checkpointEvery + 1;
  } else if (building && cp > 0) {
    state = Object.assign({}, view.checkpoints[cp - 1]);
    from = (cp - 1) * view.checkpointEvery + 1;
  } else {
    state = {};
    from = 0;
  }
  for (let k = from; k <= i && k < view.ticks.length; k++) Object.assign(state, view.ticks[k].nodes);
  return state;
}

// ------------------------------------------------------------------ map

function setupMap(payload) {
  const box = $("map");
  const pictured = safeSvg(payload.map_svg);
  if (pictured.length && pictured[0].querySelector("#paths")) {
    box.replaceChildren(...pictured);
  } else {
    box.innerHTML = "";
    const svg = svgEl("svg", { viewBox: "-500 -500 1000 1000", class: "map" }, box);
    const g = svgEl("g", { id: "world", transform: "scale(1,-1)" }, svg);
    svgEl("g", { id: "paths" }, g);
  }
  const paths = box.querySelector("#paths");
  const common = { fill: "none", "vector-effect": "non-scaling-stroke", "stroke-linejoin": "round" };
  svgEl("polyline", { ...common, id: "path-dr", stroke: "#1c7ed6", "stroke-width": 2.5 }, paths);
  svgEl("polyline", { ...common, id: "path-truth", stroke: "#2b8a3e", "stroke-width": 2, "stroke-dasharray": "6 4" }, paths);
  svgEl("g", { id: "collisions" }, paths);
  svgEl("g", { id: "judged" }, paths);
  // What a grader judged of the run beside the records (a student's feedback page): each beep and
  // each turn in place, [time_s, x_mm, y_mm(, degrees)], drawn once the replay reaches its time.
  view.marks = payload.marks || null;
  const legend = document.querySelector("#map-panel .legend .judged");
  if (legend) legend.remove();
  if (view.marks) {
    const note = document.createElement("span");
    note.className = "judged";
    note.textContent = " ● beep ○ turn in place";
    document.querySelector("#map-panel .legend").appendChild(note);
  }
  const robot = svgEl("g", { id: "robot" }, paths);
  svgEl("circle", { r: 60, fill: "rgba(250,176,5,.35)", stroke: "#e67700", "vector-effect": "non-scaling-stroke" }, robot);
  svgEl("line", { x1: 0, y1: 0, x2: 90, y2: 0, stroke: "#e67700", "stroke-width": 3, "vector-effect": "non-scaling-stroke" }, robot);
}

// A number as the page shows it: to a tenth at most (a trace holds numbers in full).
function tenths(value) { return Math.round(value * 10) / 10; }

function pose(t) { return t.truth || t.dead_reckoning; }

function renderMap(i) {
  const path = (list) => sampled(Math.min(i, list.length - 1), MAX_PATH_POINTS).map((k) => list[k]).join(" ");
  $("path-dr").setAttribute("points", path(view.dr));
  $("path-truth").setAttribute("points", path(view.truth));
  const marks = $("collisions");
  marks.innerHTML = "";
  for (const k of view.collisions) {
    if (k > i) break;
    const [x, y] = pose(view.ticks[k]);
    svgEl("path", { d: `M${x - 50},${y - 50}L${x + 50},${y + 50}M${x - 50},${y + 50}L${x + 50},${y - 50}`,
      stroke: "#e03131", "stroke-width": 3, "vector-effect": "non-scaling-stroke", class: "collision" }, marks);
  }
  const judged = $("judged");
  judged.innerHTML = "";
  if (view.marks && i >= 0) {
    const now = i === view.ticks.length - 1 ? Infinity : view.ticks[i].time_s;
    const dot = { "vector-effect": "non-scaling-stroke" };
    for (const [t, x, y] of view.marks.beeps || []) {
      if (t <= now) svgEl("circle", { ...dot, cx: x, cy: y, r: 14, fill: "#f59f00", stroke: "#e67700", class: "beep" }, judged);
    }
    for (const [t, x, y] of view.marks.turns || []) {
      if (t <= now) svgEl("circle", { ...dot, cx: x, cy: y, r: 22, fill: "none", stroke: "#1971c2", "stroke-width": 2, class: "turn" }, judged);
    }
  }
  const robot = $("robot");
  if (i < 0) { robot.setAttribute("visibility", "hidden"); return; }
  const [x, y, h] = pose(view.ticks[i]);
  robot.setAttribute("visibility", "visible");
  robot.setAttribute("transform", `translate(${x},${y}) rotate(${h})`);
  if (!view.header || !view.header.world) {  // no arena: frame the path
    const [x0, y0, x1, y1] = view.bounds;
    const minX = x0 - 300, maxX = x1 + 300, minY = y0 - 300, maxY = y1 + 300;
    const side = Math.max(maxX - minX, maxY - minY);
    document.querySelector("#map svg").setAttribute("viewBox", `${minX} ${-maxY} ${side} ${side}`);
  }
}

// ------------------------------------------------------------------ plots

function setupPlots() {
  const box = $("plots");
  box.innerHTML = "";
  for (const [name, unit, , , note] of PLOTS) {
    const svg = svgEl("svg", { viewBox: "0 0 420 64", class: "plot", "data-name": name }, box);
    svgEl("rect", { x: 0, y: 0, width: 420, height: 64, fill: "#fff", stroke: "#dee2e6" }, svg);
    svgEl("text", { x: 4, y: 11, "font-size": 10 }, svg).textContent = `${name} (${unit})${note ? ", " + note : ""}`;
    svgEl("text", { x: 416, y: 11, "font-size": 10, "text-anchor": "end", class: "value" }, svg);
    svgEl("text", { x: 210, y: 11, "font-size": 8, fill: "#868e96", "text-anchor": "middle", class: "range" }, svg);
    svgEl("path", { fill: "none", stroke: "#1c7ed6", "stroke-width": 1.5, class: "series" }, svg);
  }
}

function renderPlots(i) {
  const times = view.times;
  const tMax = Math.max(1, times.length ? times[times.length - 1] : 1);
  const shown = sampled(Math.min(i, times.length - 1), MAX_PLOT_POINTS);
  PLOTS.forEach(([name, unit], p) => {
    const svg = $("plots").children[p];
    const values = view.values[p], wraps = view.wraps[p], lo = view.lo[p], hi = view.hi[p];
    // The pen is lifted where the value wrapped round since the point before (a heading from 359
    // to 0), whatever ticks the sampling skipped: no line across the plot.
    const steps = shown.map((k, n) => {
      const x = 4 + (times[k] / tMax) * 412;
      const y = 60 - ((values[k] - lo) / (hi - lo || 1)) * 44;
      const lift = n === 0 || wraps[k] !== wraps[shown[n - 1]];
      return `${lift ? "M" : "L"}${x.toFixed(1)},${y.toFixed(1)}`;
    });
    svg.querySelector(".series").setAttribute("d", steps.join(" "));
    svg.querySelector(".value").textContent = i >= 0 ? `${tenths(values[i])} ${unit}` : "";
    svg.querySelector(".range").textContent = `${tenths(lo)} .. ${tenths(hi)} ${unit}, 0 .. ${tMax.toFixed(1)} s`;
  });
}

// ------------------------------------------------------------------ tree, log, header

// A wide tree is shrunk to the panel, but never below MIN_TREE_SCALE of its size, where its
// words are still read: past that the panel scrolls, and follows the node that runs.
const MIN_TREE_SCALE = 0.7;

function fitTree() {
  const svg = document.querySelector("#tree svg");
  const natural = svg ? parseFloat(svg.getAttribute("width")) : 0;
  const room = $("tree").clientWidth;
  if (natural > 0 && room > 0) svg.style.width = `${Math.max(Math.min(natural, room), natural * MIN_TREE_SCALE)}px`;
}
window.addEventListener("resize", fitTree);

function renderTree(i) {
  const state = i >= 0 ? stateAt(i, false) : {};
  let running = null;
  for (const g of document.querySelectorAll("#tree .node")) {
    const s = state[g.dataset.node] || ["INVALID"];
    g.setAttribute("data-status", s[0]);
    const fb = g.querySelector(".feedback");
    fb.textContent = s[0] === "RUNNING" || s[0] === "FAILURE" ? printable(s[1] || "") : "";
    // the highest id that runs: ids go parents before children, so the deepest, the latest of a sequence
    if (s[0] === "RUNNING" && (!running || +g.dataset.node > +running.dataset.node)) running = g;
  }
  if (running && running.id !== view.treeFocus) {  // only when it moves on: a person may scroll meanwhile
    view.treeFocus = running.id;
    follow(running);
  }
}

function follow(g) {
  const box = $("tree"), r = g.getBoundingClientRect(), b = box.getBoundingClientRect();
  if (r.left < b.left || r.right > b.right) box.scrollLeft += (r.left + r.right - b.left - b.right) / 2;
  if (r.top < b.top || r.bottom > b.bottom) box.scrollTop += (r.top + r.bottom - b.top - b.bottom) / 2;
}

function renderLog(i) {
  const list = $("log");
  const atEnd = view.end && i === view.ticks.length - 1;
  const shown = view.events.filter(([k]) => k <= i || atEnd).slice(-200);
  // the list is drawn again only when what it shows changed: drawing it makes the page lay itself out
  const last = shown.length ? shown[shown.length - 1][0] : -1;
  const key = `${shown.length} ${last} ${view.events.length} ${!!atEnd}`;
  if (key === view.logKey && list.childElementCount === shown.length) return;
  view.logKey = key;
  list.innerHTML = "";
  for (const [k, e] of shown) {
    const li = document.createElement("li");
    const t = view.ticks[Math.min(k, view.ticks.length - 1)];
    li.value = k + 1;
    li.className = e.kind;
    li.textContent = `${t ? t.time_s.toFixed(2) : "end"} s  ${e.kind}: ${printable(e.message)}`;
    list.appendChild(li);
  }
  list.scrollTop = list.scrollHeight;
  $("summary").textContent = atEnd ? printable(view.end.paragraph) : "";
}

function renderHeader(i) {
  const t = i >= 0 ? view.ticks[i] : null;
  $("clock").textContent = `${t ? t.time_s.toFixed(1) : "0.0"} s`;
  $("tickno").textContent = `tick ${t ? t.tick : 0}`;
  const badge = $("state");
  let state = view.end ? view.end.outcome : (view.header ? "running" : "waiting");
  if (view.mode === "replay") state = view.end && i === view.ticks.length - 1 ? view.end.outcome : "replay";
  badge.textContent = state;
  badge.className = "badge " + state.split(" ")[0];
  $("slider").max = Math.max(0, view.ticks.length - 1);
  $("slider").value = Math.max(0, i);
  $("slider-label").textContent = `tick ${t ? t.tick : 0} / ${view.ticks.length}`;
}

// light: the tree, the log and the header only (the map and plots are the costly part to paint).
function render(light) {
  const i = view.index;
  renderTree(i);
  if (!light) {
    renderMap(i);
    renderPlots(i);
    view.lastFullRender = performance.now();
  }
  renderLog(i);
  renderHeader(i);
  view.dirty = false;
}

// Shows tick index i (0-based); returns how long it took in ms.
function show(i) {
  const started = performance.now();
  view.index = Math.max(-1, Math.min(i, view.ticks.length - 1));
  view.playTime = view.index >= 0 ? view.ticks[view.index].time_s : 0;
  render();
  return performance.now() - started;
}

// ------------------------------------------------------------------ replay controls

function frame(now) {
  if (view.playing) {
    const dt = view.lastFrame ? (now - view.lastFrame) / 1000 : 0;
    view.playTime += dt * view.speed;
    let i = view.index;
    while (i + 1 < view.ticks.length && view.ticks[i + 1].time_s <= view.playTime) i++;
    if (i !== view.index) { view.index = i; view.dirty = true; }
    if (i >= view.ticks.length - 1) setPlaying(false);
  }
  view.lastFrame = now;
  // A run in real time is drawn as each tick comes (within one tick at 20 Hz). A run in
  // virtual time sends ticks in bursts of hundreds: it is drawn once a second, which
  // leaves the machine to the run.
  const every = view.burst ? BURST_RENDER_EVERY_MS : RENDER_EVERY_MS;
  if (view.dirty && now - view.lastRender >= every) {
    view.lastRender = now;
    // in a burst the tree follows every second, the map and plots every few seconds
    render(view.burst && now - view.lastFullRender < BURST_FULL_RENDER_EVERY_MS);
  }
  view.frameAsked = false;
  if (view.playing) wakeUp();
  else if (view.dirty) {  // too soon to draw again: sleep until it is time, rather than ask for every frame
    view.lastFrame = 0;
    if (!view.timerSet) {
      view.timerSet = true;
      setTimeout(() => { view.timerSet = false; wakeUp(); }, every - (now - view.lastRender));
    }
  } else view.lastFrame = 0;
}

// Frames are asked for only while there is something to draw: an idle page costs nothing.
function wakeUp() {
  if (!view.frameAsked) { view.frameAsked = true; requestAnimationFrame(frame); }
}

function setPlaying(on) {
  view.playing = on;
  if (on) wakeUp();
  if (on && view.index >= view.ticks.length - 1) show(0);
  $("play").textContent = on ? "❚❚ pause" : "▶ play";
}

$("play").addEventListener("click", () => setPlaying(!view.playing));
$("speed").addEventListener("change", (e) => { view.speed = parseFloat(e.target.value); });
$("slider").addEventListener("input", (e) => { setPlaying(false); show(parseInt(e.target.value, 10)); });

// ------------------------------------------------------------------ live

// The server's messages come over a WebSocket, each "NAME\nJSON" (autonomy/views/web.py): not
// server-sent events, since a browser keeps six HTTP connections to one server and each page
// held one for as long as it was open. `lost` is called when the server's end goes first.
function openStream(path, handlers) {
  const socket = new WebSocket(new URL(path, location.href).href.replace(/^http/, "ws"));
  socket.addEventListener("message", (m) => {
    const cut = m.data.indexOf("\n");
    const handle = handlers[m.data.slice(0, cut)];
    if (handle) handle(m.data.slice(cut + 1));
  });
  socket.addEventListener("close", () => { if (!socket.ended && handlers.lost) handlers.lost(); });
  socket.end = () => { socket.ended = true; socket.close(); };
  return opened(socket);
}

// A page on a finished live run waits for the next one: a later run on this server, or the
// next `autonomy run --view` on the same port (the browser keeps coming back while there is none).
// While no server answers it comes back after 1 s, then less and less often, down to once in
// NEXT_RUN_MOST_WAIT_MS.
function watchForNextRun(run, waitMs = NEXT_RUN_FIRST_WAIT_MS) {
  live.waitingAfter = run;
  if (asleep()) return;
  const socket = openStream(`api/next?run=${encodeURIComponent(run)}`, {
    run: () => { socket.end(); connect(); },
    lost: () => {
      live.retry = setTimeout(() => watchForNextRun(run, Math.min(waitMs * 2, NEXT_RUN_MOST_WAIT_MS)), waitMs);
    },
  });
  socket.addEventListener("open", () => { waitMs = NEXT_RUN_FIRST_WAIT_MS; });
}

// A hidden tab lets go of its stream, and shown again takes up where it was: the run it showed,
// or its wait for the next one.
const live = { stream: null, sleeping: false, retry: null, waitingAfter: null };

function opened(socket) {
  if (live.stream && live.stream !== socket) live.stream.end();  // one stream a page
  live.stream = socket;
  return socket;
}

function asleep() {
  if (document.hidden) live.sleeping = true;
  return live.sleeping;
}

document.addEventListener("visibilitychange", () => {
  // a replay, or a page saved whole, has no stream to let go of: it stays where it is
  if (document.getElementById("run-data") || document.getElementById("run-from-page") || view.mode === "replay") return;
  if (document.hidden) {
    if (live.stream) live.stream.end();
    live.stream = null;
    clearTimeout(live.retry);
    live.sleeping = true;
  } else if (live.sleeping) {
    live.sleeping = false;
    if (live.waitingAfter !== null) watchForNextRun(live.waitingAfter);
    else connect();
  }
});

function connect() {
  if (asleep()) return;
  live.waitingAfter = null;
  fetch("api/run").then((r) => {
    // too many pages asked at once (the server says 503): ask again in a second
    if (r.status === 503) { live.retry = setTimeout(connect, NEXT_RUN_FIRST_WAIT_MS); return null; }
    return r.json();
  }).then((payload) => {
    if (!payload) return;
    load(payload);
    if (payload.mode !== "live") return;
    if (payload.end) { watchForNextRun(payload.run); return; }
    if (asleep()) return;
    let previewed = false;
    const take = (data, preview) => {
      const ticks = JSON.parse(data);
      view.burst = ticks.length > 2 || preview;
      for (const t of ticks) addTick(t);
      view.index = view.ticks.length - 1;
      view.dirty = true;
      wakeUp();
    };
    const socket = openStream(`api/stream?from=${view.ticks.length}&run=${encodeURIComponent(payload.run)}`, {
      // the run it watches goes with it: a browser that comes back to the next server on this
      // port (this one stopped in the middle of the run) is told to start again
      header: () => { socket.end(); connect(); },
      ticks: (data) => take(data, false),
      // a burst of ticks (a run in virtual time) comes as a preview; the whole run is fetched at its end
      preview: (data) => { previewed = true; take(data, true); },
      end: (data) => {
        socket.end();
        if (previewed) { connect(); return; }
        addEnd(JSON.parse(data));
        view.dirty = true;
        wakeUp();
        watchForNextRun(payload.run);
      },
      // the server went in the middle of the run: look again in a second (then wait for a server)
      lost: () => { live.retry = setTimeout(connect, NEXT_RUN_FIRST_WAIT_MS); },
    });
  }, () => watchForNextRun(view.run || ""));  // no server answers (yet): wait for one, and its run
}

window.autonomyView = {
  show, view, safeSvg, stateAt: (i) => stateAt(i, false),
  streaming: () => !!live.stream && live.stream.readyState <= WebSocket.OPEN,
};
const inline = document.getElementById("run-data");
if (inline) load(JSON.parse(inline.textContent));
else if (document.getElementById("run-from-page")) {
  // one of the runs a page holds (a student's feedback page, autonomy/views/page.py): the page
  // it is framed in gives it its run when asked; on its own it has none to show
  addEventListener("message", (event) => {
    if (event.source === window.parent && typeof event.data === "string") load(JSON.parse(event.data));
  });
  if (window.parent !== window) window.parent.postMessage("autonomy-run?", "*");
} else connect();
