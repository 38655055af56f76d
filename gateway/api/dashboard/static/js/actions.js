// What the buttons do, all through the public API. Motion answers 202 with an operation; the
// feed's `operation` events carry it on to done or failed. Stops never ask for confirmation;
// acknowledging errors does (the page asks in the component).

import { post, seg } from "./api.js";
import { applyOperation, notify, store, toast } from "./store.js";

function failed(what, err) {
  toast(`${what}: ${err.message}`, "error", 9000);
}

async function motion(axisId, verb, body) {
  try {
    const op = await post(`/axes/${seg(axisId)}/${verb}`, body);
    applyOperation(op);
    notify();
    return op;
  } catch (err) {
    failed(`${verb} ${store.axes.get(axisId)?.name || axisId}`, err);
    return null;
  }
}

// Positions are numbers in JSON and carry their unit: the gateway requires `unit`.
export function move(axisId, position, { relative = false, unit = "user" } = {}) {
  return motion(axisId, "move", { position, relative, unit });
}

export function home(axisId, method) {
  return motion(axisId, "home", { method });
}

export function jog(axisId, direction, speed = "low") {
  return motion(axisId, "jog", { direction, speed });
}

export function step(axisId, direction) {
  return motion(axisId, "step", { direction });
}

export async function stopAxis(axisId, mode = "decelerate") {
  try {
    const result = await post(`/axes/${seg(axisId)}/stop`, { mode });
    if (result.outcome !== "done") toast(`Stop ${axisId}: ${result.outcome}`, "error", 9000);
    return result;
  } catch (err) {
    failed(`STOP ${axisId}`, err);
    return null;
  }
}

function reportStops(what, stops) {
  const bad = stops.filter((s) => s.outcome !== "done");
  if (bad.length === 0) toast(`${what}: stopped (${stops.map((s) => s.frames.join(" ")).join(", ")})`, "ok");
  else {
    for (const s of bad) toast(`${what}: ${s.controller} ${s.outcome}${s.error ? `: ${s.error}` : ""}`, "error", 12000);
  }
}

export async function stopController(controllerId, mode = "decelerate") {
  try {
    const result = await post(`/controllers/${seg(controllerId)}/stop`, { mode });
    reportStops(`Stop ${controllerId}`, [result]);
    return result;
  } catch (err) {
    failed(`STOP ${controllerId}`, err);
    return null;
  }
}

export async function stopLoop(loopName, mode = "decelerate") {
  try {
    const result = await post(`/loops/${seg(loopName)}/stop`, { mode });
    reportStops(`Stop loop ${loopName}`, result.stops);
    return result;
  } catch (err) {
    failed(`STOP loop ${loopName}`, err);
    return null;
  }
}

export async function stopEverything() {
  return Promise.all([...store.loops.keys()].map((name) => stopLoop(name)));
}

export async function acknowledge(axisId) {
  try {
    const view = await post(`/axes/${seg(axisId)}/errors/ack`, {});
    store.axes.set(view.id, view);
    notify();
  } catch (err) {
    failed(`Acknowledge ${axisId}`, err);
  }
}

// ------------------------------------------------------------------ hold-to-jog
// A jog runs while the button, key or pointer is held; release, leaving the button, the page
// losing focus or being hidden, or the WebSocket closing all stop it. The stop goes out at
// once on release, even before the jog's own answer: a stop is never refused.

let held = null; // {axisId}

export function holdStart(axisId, direction, speed) {
  if (held) holdEnd();
  held = { axisId };
  // A release anywhere ends the jog, even off the button (the pointer may have slid away).
  window.addEventListener("pointerup", holdEnd, { once: true });
  window.addEventListener("pointercancel", holdEnd, { once: true });
  jog(axisId, direction, speed);
}

export function holdEnd() {
  if (!held) return;
  const { axisId } = held;
  held = null;
  stopAxis(axisId, "decelerate");
}

export function installHoldGuards(onFeedClose) {
  window.addEventListener("blur", holdEnd);
  document.addEventListener("visibilitychange", () => {
    if (document.hidden) holdEnd();
  });
  onFeedClose(holdEnd);
}
