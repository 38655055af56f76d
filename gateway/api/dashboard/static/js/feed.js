// One WebSocket to /api/v1/ws: a snapshot of every loop, controller and axis, then their
// changes and the events. On a reconnect it sends `since` (the last seq) and `stream`, so the
// gateway replays what was missed or sends a fresh snapshot. While it is down the page says
// so (banner) and greys every value: never silently old.

import { API, get, token } from "./api.js";
import {
  applyAxisRead,
  applyChange,
  applyOperation,
  applyOrigin,
  applyProgramOutput,
  applySnapshot,
  notify,
  store,
} from "./store.js";

const TOPICS = ["loop:*", "controller:*", "axis:*", "events"];
const BACKOFF = [500, 1000, 2000, 5000];

let socket = null;
let attempt = 0;
let timer = null;
let stopped = false;
const closeListeners = new Set();

// Called when the socket goes away (hold-to-jog stops its axis then).
export function onClose(fn) {
  closeListeners.add(fn);
  return () => closeListeners.delete(fn);
}

function url() {
  const scheme = location.protocol === "https:" ? "wss:" : "ws:";
  const tok = token();
  return `${scheme}//${location.host}${API}/ws${tok ? `?token=${encodeURIComponent(tok)}` : ""}`;
}

export function connect() {
  stopped = false;
  clearTimeout(timer);
  if (socket) socket.close();
  store.ws.state = "connecting";
  notify();
  const ws = new WebSocket(url());
  socket = ws;
  ws.onopen = () => {
    const subscribe = { type: "subscribe", topics: TOPICS };
    if (store.ws.since != null) {
      subscribe.since = store.ws.since;
      subscribe.stream = store.ws.stream;
    }
    ws.send(JSON.stringify(subscribe));
  };
  ws.onmessage = (event) => {
    if (ws !== socket) return;
    handle(JSON.parse(event.data));
  };
  ws.onclose = (event) => {
    if (ws !== socket) return;
    socket = null;
    const wasOpen = store.ws.state === "open";
    store.ws.state = "closed";
    store.ws.closedAt = Date.now();
    if (event.code === 4401 || event.code === 4403) {
      store.ws.error = event.code === 4401 ? "the gateway does not know the token (4401)" : "the token's role may not subscribe (4403)";
      store.authProblem = store.ws.error;
      store.session = null; // back to the log-in, with the reason
      stopped = true;
    } else {
      store.ws.error = event.reason || (wasOpen ? "connection lost" : "cannot connect");
    }
    for (const fn of closeListeners) fn();
    notify();
    if (!stopped) {
      timer = setTimeout(connect, BACKOFF[Math.min(attempt, BACKOFF.length - 1)]);
      attempt += 1;
    }
  };
}

export function disconnect() {
  stopped = true;
  clearTimeout(timer);
  if (socket) {
    const ws = socket;
    socket = null;
    ws.close();
  }
}

function handle(message) {
  if (message.seq != null) store.ws.since = message.seq;
  switch (message.type) {
    case "snapshot":
      store.ws.stream = message.stream;
      applySnapshot(message);
      opened();
      break;
    case "subscribed":
      store.ws.stream = message.stream;
      opened();
      break;
    case "change":
      applyChange(message);
      break;
    case "event":
      if (message.kind === "operation") applyOperation(message.data);
      else if (message.kind === "program_output") applyProgramOutput(message.data, message.time);
      else if (message.kind === "origin") applyOrigin(message.data, message.time);
      break;
    case "error":
      store.ws.error = message.detail;
      break;
    default:
      break;
  }
  notify();
}

function opened() {
  store.ws.state = "open";
  store.ws.error = null;
  attempt = 0;
}

// Loop counters (utilisation, retries, time-outs per minute) from GET /loops, every 2 s:
// rates are differences of the scheduler's counters over wall time.
let last = new Map();

export async function pollLoops() {
  try {
    const loops = await get("/loops");
    const now = performance.now() / 1000;
    for (const loop of loops) {
      const before = last.get(loop.name);
      if (before) {
        const dt = now - before.at;
        const d = (key) => Math.max(0, (loop.counters[key] ?? 0) - (before.counters[key] ?? 0));
        store.rates.set(loop.name, {
          utilisation: Math.min(1, d("busy_time") / dt),
          retriesPerMin: (d("retries") * 60) / dt,
          timeoutsPerMin: (d("timeouts") * 60) / dt,
        });
      }
      last.set(loop.name, { at: now, counters: loop.counters });
      const cached = store.loops.get(loop.name);
      // The REST view has the queue depth and link state as of now.
      store.loops.set(loop.name, { ...(cached || {}), ...loop });
    }
    notify();
  } catch {
    // the banner and the feed say when the gateway is away
  }
}

// The age of each reading as the gateway has it: GET /axes (its cache, no line traffic) every
// 2 s, for the readings that changed nothing and so were not published on the feed.
export async function pollAxes() {
  if (store.ws.state !== "open") return;
  try {
    for (const axis of await get("/axes")) applyAxisRead(axis);
    notify();
  } catch {
    // the banner and the feed say when the gateway is away
  }
}

export function resetRates() {
  last = new Map();
}
