// Per-worker gauges: A(8) against the EAV and ELV on one bar, points, time to the EAV at the running tool's level,
// and what the worker's devices do now. The safety role can reveal who is behind a pseudonym (audited).
import { duration, el, num, utc } from "./format.js";

const SCALE = 6.0; // m/s² A(8) at the bar's right end (ELV 5 × 1.2)

export function drawGauges(root, workers, canReveal, onReveal, names = new Map()) {
  if (!workers.length) {
    root.replaceChildren(el("p", { class: "empty" }, "No worker is wearing a sensor today."));
    return;
  }
  root.replaceChildren(...workers.map((w) => gauge(w, canReveal, onReveal, names.get(w.subject))));
}

function gauge(worker, canReveal, onReveal, name) {
  const a8 = worker.a8 ?? 0;
  const level = worker.risk === "above_elv" ? "alarm" : worker.risk === "above_eav" ? "warning" : "ok";
  const fill = el("div", { class: `fill ${level}` });
  fill.style.width = `${Math.min(100, (100 * a8) / SCALE)}%`;
  const mark = (value, label) => {
    const tick = el("div", { class: "mark" }, el("span", {}, label));
    tick.style.left = `${(100 * value) / SCALE}%`;
    return tick;
  };
  const tools = worker.devices.map((d) => el("span", { class: d.active ? "tool active" : "tool", "data-device": d.device },
    `${d.tool}${d.active ? ` · ${num(d.a_hv, 1)} m/s²` : " · idle"}${d.estimate ? " (estimate)" : ""}`,
    d.counters?.malformed ? el("span", { class: "refused", title: "messages from this device the monitor refused (malformed): never counted as exposure" },
      ` · ${d.counters.malformed} refused`) : null));
  const next = worker.risk === "below_eav"
    ? (worker.seconds_to_eav == null ? "EAV: not while idle" : `EAV in ${duration(worker.seconds_to_eav)} of tool time`)
    : worker.risk === "above_eav"
      ? `EAV reached ${utc(worker.eav_at)} UTC · ELV in ${worker.seconds_to_elv == null ? "– (idle)" : duration(worker.seconds_to_elv)}`
      : `ELV reached ${utc(worker.elv_at)} UTC — stop work`;
  const reveal = canReveal ? el("button", { class: "reveal", onclick: () => onReveal(worker.subject) }, "identify…") : null;
  return el("div", { class: `gauge ${level}`, "data-subject": worker.subject, "data-risk": worker.risk },
    el("div", { class: "who" }, el("strong", {}, worker.subject), el("span", { class: "name" }, name ?? ""), name ? null : reveal),
    el("div", { class: "value" }, el("span", { class: "a8" }, num(a8, 2)), " m/s² A(8)", el("span", { class: "points" }, `${Math.round(worker.points ?? 0)} points`)),
    el("div", { class: "bar" }, fill, mark(worker.eav, "EAV 2.5"), mark(worker.elv, "ELV 5")),
    el("div", { class: "next" }, next),
    el("div", { class: "tools" }, tools));
}

// The banner: a warning the moment any worker crosses the EAV, the alarm state at the ELV.
export function drawBanner(root, workers) {
  const over = (risk) => workers.filter((w) => w.risk === risk);
  const elv = over("above_elv");
  const eav = over("above_eav");
  if (elv.length) {
    root.dataset.level = "alarm";
    root.replaceChildren(el("strong", {}, "ALARM — exposure limit value reached. "),
      `${elv.map((w) => `${w.subject} (A(8) ${num(w.a8)} m/s² at ${utc(w.elv_at)} UTC)`).join(", ")}: stop work on vibrating tools now.`,
      eav.length ? ` Above the action value: ${eav.map((w) => w.subject).join(", ")}.` : "");
  } else if (eav.length) {
    root.dataset.level = "warning";
    root.replaceChildren(el("strong", {}, "Warning — exposure action value crossed. "),
      `${eav.map((w) => `${w.subject} (A(8) ${num(w.a8)} m/s², since ${utc(w.eav_at)} UTC)`).join(", ")}: intervention due (rotate tasks, safety instruction).`);
  } else {
    delete root.dataset.level;
    root.hidden = true;
    return;
  }
  root.hidden = false;
}
