// The API client: the bearer token (from the URL's #token=..., kept in sessionStorage, never sent in a URL),
// JSON and binary reads, and the live stream read with fetch (EventSource cannot send an Authorization header).

const KEY = "bim2rdt-token";

export function takeToken() {
  const match = location.hash.match(/token=([^&]+)/);
  if (match) {
    sessionStorage.setItem(KEY, decodeURIComponent(match[1]));
    history.replaceState(null, "", location.pathname + location.search);
  }
  return sessionStorage.getItem(KEY);
}

export function setToken(token) {
  sessionStorage.setItem(KEY, token);
}

export class Unauthorized extends Error {}

async function request(path, options = {}) {
  const headers = { Authorization: `Bearer ${sessionStorage.getItem(KEY) || ""}`, ...(options.headers || {}) };
  const response = await fetch(path, { ...options, headers });
  if (response.status === 401) throw new Unauthorized(path);
  if (!response.ok) throw new Error(`${path}: ${response.status} ${await response.text()}`);
  return response;
}

export const getJson = async (path) => (await request(path)).json();
export const getBytes = async (path) => (await request(path)).arrayBuffer();
export const getBlob = async (path) => (await request(path)).blob();
export const postJson = async (path, body) =>
  (await request(path, { method: "POST", body: JSON.stringify(body), headers: { "Content-Type": "application/json" } })).json();

// Reads /api/stream for ever: onMessage({id, kind, sent, data}) per event, onState("live" | "reconnecting");
// reconnects after a second with Last-Event-ID, so nothing published meanwhile is missed.
export async function follow(onMessage, onState) {
  let lastId = null;
  for (;;) {
    try {
      const headers = lastId ? { "Last-Event-ID": String(lastId) } : {};
      const response = await request("/api/stream", { headers, cache: "no-store" });
      onState("live");
      const reader = response.body.pipeThrough(new TextDecoderStream()).getReader();
      let buffer = "";
      for (;;) {
        const { value, done } = await reader.read();
        if (done) break;
        buffer += value;
        let end;
        while ((end = buffer.indexOf("\n\n")) >= 0) {
          const block = buffer.slice(0, end);
          buffer = buffer.slice(end + 2);
          const data = block.split("\n").filter((l) => l.startsWith("data: ")).map((l) => l.slice(6)).join("\n");
          if (!data) continue;
          const message = JSON.parse(data);
          lastId = message.id;
          onMessage(message);
        }
      }
    } catch (error) {
      if (error instanceof Unauthorized) throw error;
    }
    onState("reconnecting");
    await new Promise((resolve) => setTimeout(resolve, 1000));
  }
}
