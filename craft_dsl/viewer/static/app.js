"use strict";
// craft-dsl viewer: fetches the JSON API of craft_dsl/viewer/server.py and draws the page.
const $ = (id) => document.getElementById(id);
const state = { video: null, question: null, filters: {} };

async function api(path) {
  const response = await fetch(path);
  const body = await response.json();
  if (!response.ok) throw new Error(body.error || response.statusText);
  return body;
}

function el(tag, attrs = {}, text = "") {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) node.setAttribute(k, v);
  if (text) node.textContent = text;
  return node;
}

function query() {
  const params = new URLSearchParams();
  for (const [k, v] of Object.entries(state.filters)) if (v) params.set(k, v);
  return params.toString();
}

async function loadSummary() {
  const s = await api("/api/summary");
  $("dataset-name").textContent = s.name;
  $("dataset-counts").textContent = `${s.videos} videos, ${s.questions} questions`;
  for (const [name, values] of Object.entries(s.filters)) {
    const select = $("f-" + name);
    for (const v of values) select.appendChild(el("option", { value: v }, name === "scene" ? `scene ${v}` : v));
    select.addEventListener("change", () => { state.filters[name] = select.value; loadVideos(); });
  }
  await loadVideos();
}

async function loadVideos() {
  const videos = await api("/api/videos?" + query());
  const list = $("videos");
  list.replaceChildren();
  $("video-count").textContent = `${videos.length} videos match`;
  for (const v of videos) {
    const item = el("li", { "data-video": v.video_index },
      `${String(v.video_index).padStart(6, "0")} · scene ${v.scene} · ${v.matched}/${v.questions} questions`);
    if (v.video_index === state.video) item.classList.add("active");
    item.addEventListener("click", () => showVideo(v.video_index));
    list.appendChild(item);
  }
  if (state.video !== null) showVideo(state.video, false);
}

async function showVideo(index, reloadMedia = true) {
  const v = await api(`/api/video/${index}?` + query());
  const switched = state.video !== index;
  state.video = index;
  if (switched) state.question = null;
  for (const li of $("videos").children) li.classList.toggle("active", Number(li.dataset.video) === index);
  $("placeholder").hidden = true;
  $("video-view").hidden = false;
  $("video-title").textContent = `Video ${String(index).padStart(6, "0")} (scene ${v.scene}) — ${v.video_file_path}`;
  if (reloadMedia || switched) {
    const player = $("factual");
    $("factual-msg").textContent = "";
    player.onerror = async () => {
      const r = await fetch(`/media/video/${index}.mp4`);
      const body = await r.json().catch(() => ({}));
      $("factual-msg").textContent = body.error || "the video cannot be played";
    };
    player.src = `/media/video/${index}.mp4`;
    const select = $("cf-object");
    select.replaceChildren();
    for (const id of v.counterfactual.objects) {
      const o = v.objects.find((x) => x.id === id);
      select.appendChild(el("option", { value: id }, o.label));
    }
    $("counterfactual").hidden = true;
    $("counterfactual").removeAttribute("src");
    $("cf-msg").textContent = v.counterfactual.video ? "" : v.counterfactual.reason;
    $("cf-events").replaceChildren();
    $("cf-graph").hidden = true;
    $("cf-graph-title").hidden = true;
  }
  const list = $("questions");
  list.replaceChildren();
  for (const q of v.questions) {
    const item = el("li", { "data-question": q.question_index });
    item.appendChild(el("div", {}, q.question));
    const answer = el("span", { class: "answer" }, q.answer);
    const meta = el("span", { class: "meta" }, ` · ${q.template_id} · ${q.category} · ${q.question_type}`);
    item.append(answer, meta);
    if (!q.matches) item.classList.add("dim");
    if (q.question_index === state.question) item.classList.add("active");
    item.addEventListener("click", () => showTrace(q.question_index));
    list.appendChild(item);
  }
  drawGraph($("graph"), v.graph, []);
  state.graph = v.graph;
  if (state.question !== null) showTrace(state.question);
  else { $("program").textContent = "Choose a question."; $("trace").tBodies[0].replaceChildren(); $("trace-answer").textContent = ""; }
}

async function showTrace(qi) {
  state.question = qi;
  for (const li of $("questions").children) li.classList.toggle("active", Number(li.dataset.question) === qi);
  const body = $("trace").tBodies[0];
  body.replaceChildren();
  try {
    const t = await api(`/api/trace/${state.video}/${qi}`);
    $("program").textContent = t.program;
    $("trace-answer").textContent = `recomputed answer: ${t.answer} · recorded answer: ${t.recorded_answer}`;
    for (const e of t.trace) {
      const row = el("tr", { "data-node": e.index });
      for (const cell of [String(e.index), e.expression, e.type, e.value]) row.appendChild(el("td", {}, cell));
      if (e.events.length) {
        row.classList.add("clickable");
        row.addEventListener("click", () => {
          for (const r of body.rows) r.classList.remove("selected");
          row.classList.add("selected");
          drawGraph($("graph"), state.graph, e.events);
        });
      }
      body.appendChild(row);
    }
  } catch (err) {
    $("program").textContent = String(err.message);
  }
}

async function showCounterfactual() {
  const id = $("cf-object").value;
  if (id === "") return;
  const video = state.video;
  $("cf-msg").textContent = "";
  try {
    const c = await api(`/api/counterfactual/${video}/${id}`);
    const events = $("cf-events");
    events.replaceChildren();
    events.appendChild(el("div", {}, `${c.kept_events} events kept; ${c.removed_events.length} gone, ${c.new_events.length} new`));
    for (const text of c.removed_events) events.appendChild(el("div", { class: "gone" }, "− " + text));
    for (const text of c.new_events) events.appendChild(el("div", { class: "new" }, "+ " + text));
    drawGraph($("cf-graph"), c.graph, []);
    $("cf-graph").hidden = false;
    $("cf-graph-title").hidden = false;
    const player = $("counterfactual");
    if (c.video) {
      player.hidden = false;
      player.onerror = async () => {
        const r = await fetch(`/media/counterfactual/${video}/${id}.mp4`);
        const body = await r.json().catch(() => ({}));
        $("cf-msg").textContent = body.error || "the counterfactual video cannot be played";
      };
      player.src = `/media/counterfactual/${video}/${id}.mp4`;
      $("factual").currentTime = 0;
      player.addEventListener("loadeddata", () => { $("factual").play(); player.play(); }, { once: true });
    } else {
      player.hidden = true;
      $("cf-msg").textContent = c.reason;
    }
  } catch (err) {
    $("cf-msg").textContent = String(err.message);
  }
}

function drawGraph(svg, graph, highlight) {
  const NS = "http://www.w3.org/2000/svg";
  const dx = 42, dy = 30, left = 150, top = 20;
  const lanes = Math.max(1, ...graph.nodes.map((n) => n.y));
  svg.replaceChildren();
  svg.setAttribute("width", left + dx * (graph.columns + 1));
  svg.setAttribute("height", top * 2 + dy * lanes);
  const defs = document.createElementNS(NS, "defs");
  defs.innerHTML = '<marker id="arrow" viewBox="0 0 10 10" refX="10" refY="5" markerWidth="6" markerHeight="6" orient="auto-start-reverse"><path d="M 0 0 L 10 5 L 0 10 z" fill="#888"/></marker>';
  svg.appendChild(defs);
  const pos = (n) => [left + dx * n.x + dx / 2, top + dy * (n.y - 1) + dy / 2];
  for (const lane of graph.lanes) {
    const y = top + dy * (lane.y - 1) + dy / 2;
    const line = document.createElementNS(NS, "line");
    Object.entries({ x1: left, x2: left + dx * (graph.columns + 1), y1: y, y2: y, class: "laneline" })
      .forEach(([k, v]) => line.setAttribute(k, v));
    svg.appendChild(line);
    const label = document.createElementNS(NS, "text");
    Object.entries({ x: 4, y: y + 3, class: "lane" }).forEach(([k, v]) => label.setAttribute(k, v));
    label.textContent = lane.label;
    svg.appendChild(label);
  }
  const byId = new Map(graph.nodes.map((n) => [n.id, n]));
  for (const [a, b] of graph.edges) {
    const [x1, y1] = pos(byId.get(a));
    const [x2, y2] = pos(byId.get(b));
    const path = document.createElementNS(NS, "path");
    const mx = (x1 + x2) / 2;
    const r = 11, len = Math.hypot(x2 - x1, y2 - y1) || 1;
    path.setAttribute("d", `M ${x1} ${y1} C ${mx} ${y1}, ${mx} ${y2}, ${x2 - r * (x2 - x1) / len} ${y2 - r * (y2 - y1) / len}`);
    path.setAttribute("class", "edge");
    svg.appendChild(path);
  }
  const marked = new Set(highlight);
  for (const n of graph.nodes) {
    const [x, y] = pos(n);
    const g = document.createElementNS(NS, "g");
    g.setAttribute("class", "node" + (marked.has(n.id) ? " highlight" : ""));
    g.setAttribute("data-event", n.id);
    const c = document.createElementNS(NS, "circle");
    Object.entries({ cx: x, cy: y, r: 11 }).forEach(([k, v]) => c.setAttribute(k, v));
    const title = document.createElementNS(NS, "title");
    title.textContent = n.title;
    const t = document.createElementNS(NS, "text");
    Object.entries({ x, y }).forEach(([k, v]) => t.setAttribute(k, v));
    t.textContent = n.label;
    g.append(c, t, title);
    svg.appendChild(g);
  }
}

$("cf-run").addEventListener("click", showCounterfactual);
loadSummary().catch((err) => { $("placeholder").textContent = "cannot load the dataset: " + err.message; });
