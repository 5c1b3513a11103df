// The deviation table, the events timeline and the element detail panel.
import { STATUS_ORDER, duration, el, num, utc, when } from "./format.js";

export function drawDeviations(table, elements, onPick) {
  const seen = [...elements.values()].filter((e) => e.status !== "not observed");
  seen.sort((a, b) => STATUS_ORDER.indexOf(a.status) - STATUS_ORDER.indexOf(b.status)
    || (b.deviation?.translation ?? 0) - (a.deviation?.translation ?? 0));
  const head = el("tr", {}, ["element", "status", "shift\u00a0cm", "tilt\u00a0°", "yaw\u00a0°", "tolerance", "fitness"].map((h) => el("th", {}, h)));
  const rows = seen.map((e) => {
    const d = e.deviation, t = e.tolerance;
    const over = (value, limit) => (d && t && value > limit ? "n out" : "n");
    return el("tr", { "data-gid": e.global_id, onclick: () => onPick(e.global_id) },
      el("td", { class: "name", title: e.global_id }, e.name || e.family || e.global_id),
      el("td", {}, chip(e)),
      el("td", { class: over(d?.translation, t?.translation) }, d ? num(100 * d.translation, 1) : "–"),
      el("td", { class: over(d?.tilt_deg, t?.rotation_deg) }, d ? num(d.tilt_deg, 1) : "–"),
      el("td", { class: over(Math.abs(d?.yaw_deg ?? 0), t?.rotation_deg) }, d ? num(d.yaw_deg, 1) : "–"),
      el("td", { title: t ? t.name : "" }, t ? `${num(100 * t.translation, 0)} cm / ${num(t.rotation_deg, 1)}°` : "–"),
      el("td", { class: "n" }, e.fit ? num(e.fit.fitness, 2) : "–"));
  });
  table.replaceChildren(el("thead", {}, head), el("tbody", {}, rows.length ? rows : el("tr", {}, el("td", { colspan: 7 }, "Nothing observed yet."))));
}

export function chip(element) {
  const node = el("span", { class: "chip" }, element.status);
  node.style.background = element.colour;
  return node;
}

const LABELS = {
  "hav.activity_started": "tool on", "hav.activity_ended": "tool off", "hav.eav_reached": "EAV reached",
  "hav.elv_reached": "ELV reached", "hav.eav_predicted": "EAV forecast", "hav.gap": "data gap", "hav.artefact": "artefact",
};

export function timelineItem(entry) {
  if (entry.type === "safety") {
    const e = entry.event;
    const level = e.kind === "hav.elv_reached" ? "alarm" : e.kind === "hav.eav_reached" ? "warning" : "";
    const extra = e.kind === "hav.eav_predicted" ? ` in ${duration(e.data.seconds_to_eav)}`
      : e.kind === "hav.activity_ended" ? ` · A(8) ${num(e.data.day_a8)} m/s²`
      : e.kind.endsWith("_reached") ? ` · ${num(e.data.day_a8)} m/s²` : "";
    return el("li", { class: `safety ${level}`, "data-kind": e.kind }, el("time", {}, when(e.time)),
      el("span", { class: "kind" }, LABELS[e.kind] || e.kind), ` ${e.subject}${extra}`);
  }
  const r = entry.record;
  const what = r.kind === "status" ? `${r.data.from} → ${r.data.to}` : r.kind === "missing" ? "seen missing" : `observed: ${r.data.status}`;
  return el("li", { class: `twin ${r.kind}`, "data-kind": r.kind }, el("time", {}, when(r.time)),
    el("span", { class: "kind" }, r.kind), ` ${r.data.family || r.global_id} ${what} (${r.source})`);
}

export function drawDetail(panel, detail, onClose) {
  const d = detail.deviation, t = detail.tolerance;
  const history = detail.history.map((r) => el("li", {}, el("time", {}, `${utc(r.time)}`), ` ${r.kind} `,
    r.kind === "status" ? `${r.data.from} → ${r.data.to}` : r.kind === "safety" ? r.data.kind : r.data.status || "", ` · ${r.source}`));
  panel.replaceChildren(
    el("button", { class: "close", onclick: onClose, "aria-label": "close" }, "×"),
    el("h3", {}, detail.name || detail.family || detail.global_id),
    el("p", {}, chip(detail), ` ${detail.ifc_class || "not in the BIM"} · ${detail.global_id}`),
    el("dl", {},
      el("dt", {}, "shift"), el("dd", {}, d ? `${num(100 * d.translation, 1)} cm` : "–"),
      el("dt", {}, "tilt / yaw"), el("dd", {}, d ? `${num(d.tilt_deg, 1)}° / ${num(d.yaw_deg, 1)}°` : "–"),
      el("dt", {}, "tolerance"), el("dd", {}, t ? `${t.name}: ${num(100 * t.translation, 0)} cm, ${num(t.rotation_deg, 1)}°` : "–"),
      el("dt", {}, "fit"), el("dd", {}, detail.fit ? `fitness ${num(detail.fit.fitness)} · rmse ${num(1000 * detail.fit.rmse, 1)} mm · ${detail.fit.points} points` : "–"),
      el("dt", {}, "seen"), el("dd", {}, detail.evidence ? `${utc(detail.evidence.time)} UTC from station ${detail.evidence.station ?? "–"} by ${detail.robot}` : "–")),
    el("h4", {}, "History"),
    el("ol", { class: "history" }, history.length ? history : el("li", {}, "nothing recorded")));
  panel.hidden = false;
}
