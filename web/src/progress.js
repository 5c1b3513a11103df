// Progress against the work schedule: the task table coloured by status with a bar per task over the schedule's
// dates (Gantt-like), the S-curve of planned against observed, and the structure built / not built (in 3-D).
import { el, num, svg } from "./format.js";

const percent = (value) => (value == null ? "–" : `${num(value, 1)} %`);
const time = (text) => new Date(text).getTime() / 1000;

export function drawProgress(host, record) {
  if (!record.progress) {
    host.replaceChildren(el("p", { class: "empty" }, "The model has no work schedule: progress by storey and class."),
      groupTable(record.groups));
    return;
  }
  const { progress, colours } = record;
  host.replaceChildren(el("p", { class: "muted" }, `${progress.schedule.name || progress.schedule.global_id} at ${progress.date.slice(0, 19).replace("T", " ")} UTC`),
    taskTable(progress, colours), sCurve(record.curve, progress.date));
}

function depths(tasks) {
  const parents = new Map(tasks.flatMap((t) => t.children.map((c) => [c, t.global_id])));
  const depth = new Map();
  for (const t of tasks) {
    let level = 0, node = t.global_id;
    while (parents.has(node) && level < 64) { node = parents.get(node); level += 1; }
    depth.set(t.global_id, level);
  }
  return depth;
}

function taskTable(progress, colours) {
  const tasks = progress.tasks;
  const dates = tasks.flatMap((t) => [t.planned_start, t.planned_finish]).filter(Boolean).map(time);
  const first = Math.min(...dates), last = Math.max(...dates);
  const x = (seconds) => Math.max(0, Math.min(100, (100 * (seconds - first)) / (last - first || 1)));
  const depth = depths(tasks);
  const head = el("tr", {}, ["task", "schedule", "planned", "observed", "status", "built / not built / not seen"].map((h) => el("th", {}, h)));
  const rows = tasks.map((t) => {
    const colour = colours[t.status] || "#8c8c8c";
    const bar = el("div", { class: "gantt" });
    if (t.planned_start && t.planned_finish) {
      const span = el("span", { class: "span" });
      const left = x(time(t.planned_start)), right = x(time(t.planned_finish));
      Object.assign(span.style, { left: `${left}%`, width: `${Math.max(right - left, 0.5)}%`, borderColor: colour });
      const fill = el("i");
      Object.assign(fill.style, { width: `${t.observed_percent ?? 0}%`, background: colour });
      span.append(fill);
      const now = el("b");
      now.style.left = `${x(time(progress.date))}%`;
      bar.append(span, now);
    }
    const status = el("td", { class: "status" }, t.status);
    status.style.background = colour;
    const p = t.products;
    const name = el("td", { class: "task" }, `${t.identification || ""} ${t.name || ""}`.trim());
    // CSSOM, not a style attribute: the server's Content-Security-Policy refuses inline style attributes
    Object.assign(name.style, { paddingLeft: `${6 + 14 * depth.get(t.global_id)}px`, fontWeight: t.children.length ? "600" : "400" });
    return el("tr", { "data-task": t.global_id, "data-status": t.status }, name,
      el("td", { class: "bar" }, bar), el("td", { class: "n" }, percent(t.planned_percent)),
      el("td", { class: "n" }, percent(t.observed_percent)), status,
      el("td", { class: "n" }, `${p["as planned"] + p.deviating} / ${p["not built"]} / ${p["not observed"]}`));
  });
  return el("table", { id: "tasks" }, el("thead", {}, head), el("tbody", {}, rows));
}

function sCurve(points, nowText) {
  const width = 520, height = 170, pad = { l: 34, r: 8, t: 8, b: 22 };
  const dates = points.map((p) => time(p.date));
  const t0 = Math.min(...dates), t1 = Math.max(...dates);
  const X = (t) => pad.l + ((width - pad.l - pad.r) * (t - t0)) / (t1 - t0 || 1);
  const Y = (v) => height - pad.b - ((height - pad.t - pad.b) * v) / 100;
  const line = (key, step) => {
    const kept = points.filter((p) => p[key] != null);
    return kept.map((p, i) => {
      const here = `${X(time(p.date)).toFixed(1)},${Y(p[key]).toFixed(1)}`;
      if (!step || i === 0) return `${i ? "L" : "M"}${here}`;
      return `H${X(time(p.date)).toFixed(1)}V${Y(p[key]).toFixed(1)}`;
    }).join("");
  };
  const chart = svg("svg", { id: "s-curve", viewBox: `0 0 ${width} ${height}`, role: "img", "aria-label": "S-curve: planned against observed" });
  for (const v of [0, 50, 100]) {
    chart.append(svg("line", { x1: pad.l, x2: width - pad.r, y1: Y(v), y2: Y(v), stroke: "#d8dee6" }));
    const label = svg("text", { x: pad.l - 4, y: Y(v) + 4, "text-anchor": "end", "font-size": 10, fill: "#66717e" });
    label.textContent = `${v}%`;
    chart.append(label);
  }
  chart.append(svg("path", { d: line("planned_percent", false), fill: "none", stroke: "#1f77b4", "stroke-width": 2, class: "curve-planned" }));
  chart.append(svg("path", { d: line("observed_percent", true), fill: "none", stroke: "#d62728", "stroke-width": 2, class: "curve-observed" }));
  chart.append(svg("line", { x1: X(time(nowText)), x2: X(time(nowText)), y1: pad.t, y2: height - pad.b, stroke: "#1d2733", "stroke-dasharray": "3 3" }));
  for (const [t, anchor] of [[t0, "start"], [t1, "end"]]) {
    const label = svg("text", { x: X(t), y: height - 6, "text-anchor": anchor, "font-size": 10, fill: "#66717e" });
    label.textContent = new Date(t * 1000).toISOString().slice(0, 10);
    chart.append(label);
  }
  const swatch = (colour) => { const node = el("i"); node.style.background = colour; return node; };
  const legend = el("p", { class: "legend" }, el("span", {}, swatch("#1f77b4"), "planned"),
    el("span", {}, swatch("#d62728"), "observed"));
  return el("div", {}, chart, legend);
}

function groupTable(groups) {
  const head = el("tr", {}, ["by", "group", "observed", "built / not built / not seen"].map((h) => el("th", {}, h)));
  const rows = groups.map((g) => el("tr", {}, el("td", {}, g.by), el("td", {}, g.name), el("td", { class: "n" }, percent(g.observed_percent)),
    el("td", { class: "n" }, `${g.products["as planned"] + g.products.deviating} / ${g.products["not built"]} / ${g.products["not observed"]}`)));
  return el("table", {}, el("thead", {}, head), el("tbody", {}, rows));
}
