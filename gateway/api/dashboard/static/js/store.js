// What the page knows, in one place: the views the WebSocket feed published (loops,
// controllers, axes), the operations it reported, each axis's recent positions for the plots,
// program output, and the connection's state. Components read it and re-render on `notify`,
// at most once a frame (30 axes at 20 updates/s would otherwise render 600 times a second).

export const HISTORY_SECONDS = 60;
const HISTORY_MAX = 2400; // points kept per axis (60 s at 40 updates/s)
const HISTORY_SLACK = 240;
const CONSOLE_MAX = 500;

export const store = {
  session: null, // {name, role, authentication}
  authProblem: null, // why the gateway refused us (401/403), shown with the log-in
  ws: { state: "connecting", since: null, stream: null, closedAt: null, error: null },
  loops: new Map(),
  controllers: new Map(),
  axes: new Map(),
  axisOrder: [],
  ops: new Map(), // axis id -> its latest operation view
  history: new Map(), // axis id -> {t: [], v: []} (seconds since epoch, user unit)
  rates: new Map(), // loop name -> {utilisation, retriesPerMin, timeoutsPerMin}
  consoles: new Map(), // controller id -> [{time, text}]
  origins: new Map(), // axis id -> its latest origin event's data ({origin, homed, cause, time})
  toasts: [],
};

const listeners = new Set();
let scheduled = false;
let lastRender = 0;
// Numbers change 20 times a second at most on a display anyone reads; rendering more often
// would only take the main thread from the browser (bench/dashboard.py).
const MIN_INTERVAL_MS = 50;

export function subscribe(fn) {
  listeners.add(fn);
  return () => listeners.delete(fn);
}

function run() {
  scheduled = false;
  lastRender = performance.now();
  for (const fn of listeners) fn();
}

export function notify() {
  if (scheduled) return;
  scheduled = true;
  const wait = lastRender + MIN_INTERVAL_MS - performance.now();
  if (wait <= 0) requestAnimationFrame(run);
  else setTimeout(() => requestAnimationFrame(run), wait);
}

// ------------------------------------------------------------------ roles

const RANK = { viewer: 1, operator: 2, admin: 3 };

export function can(role) {
  return !!store.session && RANK[store.session.role] >= RANK[role];
}

// ------------------------------------------------------------------ views from the feed

export function applySnapshot(message) {
  store.loops = new Map(message.loops.map((l) => [l.name, l]));
  store.controllers = new Map(message.controllers.map((c) => [c.id, c]));
  store.axes = new Map();
  for (const axis of message.axes) setAxis(axis, message.time);
  store.axisOrder = message.axes.map((a) => a.id);
}

export function applyChange(message) {
  const [kind] = message.topic.split(":", 1);
  const data = message.data;
  if (kind === "axis") {
    if (!store.axes.has(data.id)) store.axisOrder.push(data.id);
    setAxis(data, message.time);
  } else if (kind === "controller") {
    store.controllers.set(data.id, data);
  } else if (kind === "loop") {
    store.loops.set(data.name, data);
  }
}

// A view read with GET /axes: the feed publishes an axis only when a value changes, so an
// idle axis's reading time moves on only here. Taken when it is newer than what the page has.
export function applyAxisRead(axis) {
  const known = store.axes.get(axis.id);
  if (!known) return;
  if (axis.updated != null && (known.updated == null || axis.updated > known.updated)) {
    setAxis(axis, axis.updated);
  }
}

function setAxis(axis, time) {
  store.axes.set(axis.id, axis);
  // The plot is in the user unit: while the origin is lost that is unknown (position_user
  // null), and pulses drawn on a millimetre scale would be a jump that never happened.
  const pulseUnit = axis.unit === "pulse" || axis.unit === "pulses";
  if (axis.position_user == null && (axis.position == null || !pulseUnit)) return;
  let h = store.history.get(axis.id);
  if (!h) {
    h = { t: [], v: [] };
    store.history.set(axis.id, h);
  }
  const value = axis.position_user ?? axis.position;
  const t = axis.updated ?? time;
  if (h.t.length && t <= h.t[h.t.length - 1]) return; // a repeat of a reading already drawn
  h.t.push(t);
  h.v.push(value);
  // Trimmed in chunks: shifting 2,400 values at every one of 600 readings a second is work
  // (and garbage) for nothing.
  if (h.t.length > HISTORY_MAX + HISTORY_SLACK) {
    h.t.splice(0, h.t.length - HISTORY_MAX);
    h.v.splice(0, h.v.length - HISTORY_MAX);
  }
}

export function applyOperation(op) {
  const current = store.ops.get(op.axis);
  // Events can arrive after the POST's answer: never go back to an older state of one op.
  if (current && current.id === op.id && current.updated > op.updated) return;
  if (current && current.id !== op.id && current.created > op.created) return;
  store.ops.set(op.axis, op);
}

// The origin found or lost (a controller reset): kept per axis for the cause, which the axis
// view does not carry, and said at once.
export function applyOrigin(data, time) {
  store.origins.set(data.axis, { ...data, time });
  const name = store.axes.get(data.axis)?.name || data.axis;
  if (data.origin === "lost") toast(`${name}: origin lost — home first (${data.cause || "controller reset"})`, "error", 20000);
  else if (data.origin === "homed") toast(`${name}: homed${data.cause ? ` (${data.cause})` : ""}`, "ok");
}

// Output with a body number belongs to its controller; `/CO` text carries none (§12 /CO),
// so it is kept per loop and shown with every controller of that loop.
export function applyProgramOutput(data, time) {
  const key = data.controller || `loop:${data.loop}`;
  const lines = store.consoles.get(key) || [];
  const text = typeof data.data === "string" ? data.data : JSON.stringify(data.data);
  lines.push({ time, text, body: !!data.controller });
  if (lines.length > CONSOLE_MAX) lines.splice(0, lines.length - CONSOLE_MAX);
  store.consoles.set(key, lines);
}

export function consoleOf(ctl) {
  const own = store.consoles.get(ctl.id) || [];
  const loop = store.consoles.get(`loop:${ctl.loop}`) || [];
  return [...own, ...loop].sort((a, b) => a.time - b.time);
}

// ------------------------------------------------------------------ derived

// The loop an axis or controller is on is down: its values are not current.
export function loopDown(loopName) {
  const loop = store.loops.get(loopName);
  return !!loop && !loop.up;
}

// Whether a value may be shown as current: connected, the loop up, the reading fresh.
export function isCurrent(axis) {
  return store.ws.state === "open" && !axis.stale && !loopDown(axis.loop);
}

export function axesOf(controllerId) {
  return store.axisOrder.map((id) => store.axes.get(id)).filter((a) => a && a.controller === controllerId);
}

// ------------------------------------------------------------------ messages

let toastId = 0;

export function toast(text, kind = "info", ms = 6000) {
  const id = ++toastId;
  store.toasts = [...store.toasts, { id, text, kind }];
  notify();
  setTimeout(() => {
    store.toasts = store.toasts.filter((t) => t.id !== id);
    notify();
  }, ms);
}
