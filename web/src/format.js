// Small formatting and DOM helpers shared by the page's parts.

export function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [key, value] of Object.entries(attrs)) {
    if (value === undefined || value === null || value === false) continue;
    if (key === "class") node.className = value;
    else if (key.startsWith("on")) node.addEventListener(key.slice(2), value);
    else node.setAttribute(key, value === true ? "" : value);
  }
  for (const child of children.flat()) {
    if (child === null || child === undefined) continue;
    node.append(child instanceof Node ? child : document.createTextNode(String(child)));
  }
  return node;
}

export const svg = (tag, attrs = {}) => {
  const node = document.createElementNS("http://www.w3.org/2000/svg", tag);
  for (const [key, value] of Object.entries(attrs)) if (value !== undefined && value !== null) node.setAttribute(key, value);
  return node;
};

export const utc = (seconds) => (seconds == null ? "–" : new Date(seconds * 1000).toISOString().slice(11, 19));
export const day = (seconds) => (seconds == null ? "–" : new Date(seconds * 1000).toISOString().slice(0, 10));
// the sources' clock (the demo's simulated day, or the wall clock); main.js sets it from /api/clock
let sourcesNow = () => Date.now() / 1000;
export const setSourcesNow = (now) => { sourcesNow = now; };
// a time of the sources' today as HH:MM:SS, of another day with its date before it (the timeline mixes days)
export const when = (seconds) => (day(seconds) === day(sourcesNow()) ? utc(seconds) : `${day(seconds).slice(5)} ${utc(seconds)}`);
export const num = (value, digits = 2) => (value == null ? "–" : Number(value).toFixed(digits));

export function duration(seconds) {
  if (seconds == null) return "–";
  if (seconds < 60) return `${Math.round(seconds)} s`;
  if (seconds < 3600) return `${Math.round(seconds / 60)} min`;
  return `${Math.floor(seconds / 3600)} h ${String(Math.round((seconds % 3600) / 60)).padStart(2, "0")} min`;
}

export const STATUS_ORDER = ["deviating", "missing", "new", "unverified", "as planned", "not observed"];
