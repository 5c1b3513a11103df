// The dashboard: loads the twin, the plan and the workers once, then follows the live stream (no reload).
import "./style.css";
import { Unauthorized, follow, getBlob, getBytes, getJson, postJson, setToken, takeToken } from "./api.js";
import { el, setSourcesNow } from "./format.js";
import { drawBanner, drawGauges } from "./gauges.js";
import { drawPlan, recolour } from "./plan.js";
import { drawProgress } from "./progress.js";
import { drawDeviations, drawDetail, timelineItem } from "./tables.js";
import { TwinView } from "./view3d.js";

const $ = (id) => document.getElementById(id);
const state = { elements: new Map(), workers: [], role: null, view: null, selected: null, timeline: [], at: null, names: new Map(), clock: null };
const MAX_TIMELINE = 200;
const FORECAST = "hav.eav_predicted"; // the gauges show the time to the EAV; the timeline keeps what happened

async function start() {
  if (!takeToken()) return askToken();
  try {
    const me = await getJson("/api/me");
    state.role = me.role;
    $("who").textContent = `${me.name} · ${me.role}`;
  } catch (error) {
    if (error instanceof Unauthorized) return askToken();
    throw error;
  }
  follow(onMessage, onConnection).catch(() => askToken());
  await startClock();
  await Promise.all([loadTwin(), loadWorkers(), loadEvents()]);
  await loadProgress();
  wireDownloads();
}

// The sources' one clock (the demo's simulated day, or the wall clock): the header and the time bar run on it.
async function startClock() {
  const answer = await getJson("/api/clock").catch(() => ({ now: Date.now() / 1000, speed: 1, simulated: false }));
  const wallStart = Date.now() / 1000;
  state.clock = () => answer.now + answer.speed * (Date.now() / 1000 - wallStart);
  setSourcesNow(state.clock);
  const show = () => {
    $("clock").textContent = `${new Date(state.clock() * 1000).toISOString().slice(11, 19)} UTC${answer.simulated ? ` (simulated, ${answer.speed}×)` : ""}`;
  };
  show();
  setInterval(show, 1000);
}

function askToken() {
  const dialog = $("login");
  dialog.addEventListener("close", () => {
    setToken($("token-input").value.trim());
    location.reload();
  }, { once: true });
  dialog.showModal();
}

async function loadTwin() {
  try {
    const [elements, plan] = await Promise.all([getJson("/api/elements"), getJson("/api/plan")]);
    for (const e of elements) state.elements.set(e.global_id, e);
    state.plan = plan;
    drawPlan($("plan"), plan, pick);
    drawLegend(plan.palette);
    drawDeviations($("deviations"), state.elements, pick);
    updateCounts();
    state.view = new TwinView($("view3d"), pick);
    wireBuiltView();
    await loadModel();
    await wireTimebar();
  } catch (error) {
    if (String(error).includes("503")) $("plan-card").append(el("p", { class: "empty" }, "This server has no twin."));
    else throw error;
  }
}

// Progress against the work schedule (the card stays hidden for a server without a twin); follows the time bar.
async function loadProgress(at = null) {
  let record;
  try {
    record = await getJson(`/api/progress${at === null ? "" : `?at=${at}`}`);
  } catch (error) {
    if (String(error).includes("503")) return;
    throw error;
  }
  state.progress = record;
  $("progress-card").hidden = false;
  drawProgress($("progress"), record);
  if ($("built-view").checked) state.view?.colourBuilt(record.structure, record.state_colours);
}

function wireBuiltView() {
  $("built-view").addEventListener("change", (event) => {
    if (event.target.checked && state.progress) state.view?.colourBuilt(state.progress.structure, state.progress.state_colours);
    else for (const element of state.elements.values()) state.view?.colour(element);
  });
}

async function loadModel() {
  await state.view.load(await getBytes("/api/model.glb"), state.elements);
  document.body.dataset.model = "loaded";
}

async function loadWorkers() {
  try {
    onWorkers(await getJson("/api/workers"));
  } catch (error) {
    if (!String(error).includes("503")) throw error;
  }
}

async function loadEvents() {
  const [events, records] = await Promise.all([
    getJson("/api/events?limit=100").catch(() => []),
    getJson("/api/observations?limit=100").catch(() => []),
  ]);
  const entries = [...events.filter((e) => e.kind !== FORECAST).map((event) => ({ type: "safety", time: event.time, event })),
    ...records.map((record) => ({ type: "twin", time: record.time, record }))];
  entries.sort((a, b) => b.time - a.time);
  state.timeline = entries.slice(0, MAX_TIMELINE);
  $("timeline").replaceChildren(...state.timeline.map(timelineItem));
}

function onMessage(message) {
  if (message.kind === "workers") onWorkers(message.data);
  else if (message.kind === "safety") onSafety(message.data);
  else if (message.kind === "element") onElement(message.data);
}

function onWorkers(workers) {
  state.workers = workers;
  drawGauges($("gauges"), workers, state.role === "safety", reveal, state.names);
  drawBanner($("banner"), workers);
}

function onSafety(event) {
  if (event.kind !== FORECAST) addTimeline({ type: "safety", time: event.time, event });
  if (event.kind === "hav.eav_reached" || event.kind === "hav.elv_reached") {
    // the banner shows the moment the monitor says so, before the next exposure update
    const workers = state.workers.map((w) => w.subject !== event.subject ? w : {
      ...w, risk: event.kind === "hav.elv_reached" ? "above_elv" : (w.risk === "above_elv" ? w.risk : "above_eav"),
      a8: Math.max(w.a8 ?? 0, event.data.day_a8 ?? 0),
      [event.kind === "hav.elv_reached" ? "elv_at" : "eav_at"]: event.time,
    });
    onWorkers(workers);
  }
}

function onElement({ record, state: element }) {
  addTimeline({ type: "twin", time: record.time, record });
  if (!element) return;
  const before = state.elements.get(element.global_id);
  state.elements.set(element.global_id, element);
  $("at").max = String(Math.max(Number($("at").max), Math.ceil(record.time)));
  if (state.at !== null) return; // looking at the past: the present is kept and shown on "back to now"
  drawDeviations($("deviations"), state.elements, pick);
  updateCounts();
  if (!before || JSON.stringify(before.pose) !== JSON.stringify(element.pose)) {
    scheduleReload();  // a new or moved object: the plan and the model change shape
  } else {
    recolour($("plan"), element);
    state.view?.colour(element);
  }
  if (state.selected === element.global_id) pick(element.global_id);
}

let reloading = null;
function scheduleReload() {
  clearTimeout(reloading);
  reloading = setTimeout(async () => {
    state.plan = await getJson("/api/plan");
    drawPlan($("plan"), state.plan, pick);
    if (state.view) await loadModel();
  }, 500);
}

// The time bar: the plan, the table and the 3-D colours as the twin was at a past time (GET ...?at=), or live.
async function wireTimebar() {
  const { span } = await getJson("/api/state");
  const slider = $("at");
  if (!span) return;
  slider.min = String(Math.floor(span[0]) - 60);
  slider.max = String(Math.ceil(Math.max(span[1], state.clock())));
  slider.value = slider.max;
  let pending = null;
  slider.addEventListener("input", () => {
    clearTimeout(pending);
    pending = setTimeout(() => showAt(Number(slider.value) >= Number(slider.max) ? null : Number(slider.value)), 250);
  });
  $("at-now").addEventListener("click", () => { slider.value = slider.max; showAt(null); });
}

async function showAt(at) {
  state.at = at;
  $("at-now").hidden = at === null;
  $("at-label").textContent = at === null ? "now (live)" : `${new Date(at * 1000).toISOString().replace("T", " ").slice(0, 19)} UTC`;
  document.body.dataset.at = at === null ? "" : String(at);
  const query = at === null ? "" : `?at=${at}`;
  const [plan, past] = await Promise.all([getJson(`/api/plan${query}`), getJson(`/api/state${query}`)]);
  const shown = at === null ? state.elements : new Map(past.elements.map((e) => [e.global_id, e]));
  if (at === null) for (const e of past.elements) state.elements.set(e.global_id, e);
  drawPlan($("plan"), plan, pick);
  drawDeviations($("deviations"), shown, pick);
  updateCounts(shown);  // the header follows the time bar
  for (const element of shown.values()) state.view?.colour(element);
  await loadProgress(at);
}

// Newest first by event time: a live event goes where its time puts it (a late batch's events arrive after newer ones).
function addTimeline(entry) {
  let index = state.timeline.findIndex((other) => other.time < entry.time);
  if (index < 0) index = state.timeline.length;
  if (index >= MAX_TIMELINE) return;
  state.timeline.splice(index, 0, entry);
  state.timeline.length = Math.min(state.timeline.length, MAX_TIMELINE);
  const list = $("timeline");
  list.insertBefore(timelineItem(entry), list.children[index] ?? null);
  while (list.children.length > MAX_TIMELINE) list.lastChild.remove();
}

async function pick(gid) {
  state.selected = gid;
  state.view?.select(gid);
  for (const row of document.querySelectorAll("#deviations tr.selected")) row.classList.remove("selected");
  document.querySelector(`#deviations tr[data-gid="${CSS.escape(gid)}"]`)?.classList.add("selected");
  const detail = await getJson(`/api/elements/${encodeURIComponent(gid)}`);
  drawDetail($("detail"), detail, () => {
    $("detail").hidden = true;
    state.selected = null;
    state.view?.select(null);
  });
}

async function reveal(subject) {
  const reason = prompt(`Why do you need to know who ${subject} is? (written to the audit log)`);
  if (!reason || reason.trim().length < 3) return;
  const answer = await postJson(`/api/workers/${encodeURIComponent(subject)}/identity`, { reason: reason.trim() });
  state.names.set(subject, answer.worker); // kept in this tab only; the server logged the reveal
  onWorkers(state.workers);
}

function updateCounts(elements = state.elements) {
  const counts = {};
  for (const e of elements.values()) counts[e.status] = (counts[e.status] || 0) + 1;
  $("counts").textContent = ["deviating", "missing", "new", "as planned"].filter((s) => counts[s]).map((s) => `${counts[s]} ${s}`).join(" · ") || "nothing observed yet";
}

function drawLegend(palette) {
  const items = Object.entries(palette).map(([status, colour]) => {
    const swatch = el("i");
    swatch.style.background = colour;
    return el("span", {}, swatch, status);
  });
  $("legend").replaceChildren(...items, el("span", {}, el("i", { class: "dash" }), "BIM position"),
    el("span", {}, el("i", { class: "route" }), "robot path"), el("span", {}, el("i", { class: "hatched" }), "off limits"));
}

function wireDownloads() {
  for (const [id, path, name] of [["dl-bcf", "/api/exports/twin.bcf", "twin.bcf"], ["dl-ifc", "/api/exports/twin.ifc", "twin.ifc"]]) {
    $(id).addEventListener("click", async (event) => {
      event.preventDefault();
      const url = URL.createObjectURL(await getBlob(path));
      const link = el("a", { href: url, download: name });
      link.click();
      setTimeout(() => URL.revokeObjectURL(url), 10000);
    });
  }
}

function onConnection(connection) {
  $("connection").dataset.state = connection;
  $("connection").textContent = connection === "live" ? "live" : "reconnecting…";
}

start();
