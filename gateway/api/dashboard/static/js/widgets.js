// Small pieces the views share: the position readout, badges, the soft-limit bar, latched
// errors with their acknowledge button, the operation line, stop and hold-to-jog buttons.

import { html } from "../vendor/preact-htm/standalone.module.js";
import { acknowledge, holdEnd, holdStart, stopAxis } from "./actions.js";
import { can, isCurrent, store } from "./store.js";

// One formatter per digit count, made once: toLocaleString builds one per call (slow at 600
// readings a second).
const FORMATS = new Map();

export function fmt(value, digits = 3) {
  if (value == null || !isFinite(value)) return "—";
  let format = FORMATS.get(digits);
  if (!format) {
    format = new Intl.NumberFormat("en-US", { minimumFractionDigits: digits, maximumFractionDigits: digits });
    FORMATS.set(digits, format);
  }
  return format.format(value);
}

// Digits for a user unit: pulses are whole, mm and degrees to the thousandth.
export function digitsOf(unit) {
  return unit === "pulse" || unit === "pulses" ? 0 : 3;
}

// One clock for the whole page: 24-hour, with milliseconds where frames are told apart
// (the trace). Never the locale's 12-hour form.
export function clock(t, ms = false) {
  if (t == null) return "";
  const d = new Date(t * 1000);
  const two = (n) => String(n).padStart(2, "0");
  const hms = `${two(d.getHours())}:${two(d.getMinutes())}:${two(d.getSeconds())}`;
  return ms ? `${hms}.${String(d.getMilliseconds()).padStart(3, "0")}` : hms;
}

export function age(updated) {
  if (updated == null) return "never read";
  const s = Math.max(0, Date.now() / 1000 - updated);
  if (s < 1) return "now";
  if (s < 60) return `${s.toFixed(0)} s ago`;
  return `${(s / 60).toFixed(0)} min ago`;
}

export function Badge({ kind, children, title }) {
  return html`<span class="badge ${kind}" title=${title}>${children}</span>`;
}

// The readout says what the gateway knows, never more: a position never read is "—" (not 0);
// while the origin is lost the user unit is unknown (the view's position_user is null), so the
// pulses are the number shown; a counter that wrapped below 0 (EP0) shows the negative position
// it is, with the controller's raw 24-bit counter beside it.
export function Position({ axis, big = true }) {
  const pulseUnit = axis.unit === "pulse" || axis.unit === "pulses";
  const userKnown = axis.position_user != null;
  const neverRead = axis.position == null && !userKnown;
  const shownInPulses = !userKnown && axis.position != null;
  const digits = shownInPulses ? 0 : digitsOf(axis.unit);
  const wrapped = axis.counter != null && axis.position != null && axis.counter !== axis.position;
  return html`<div class="pos ${big ? "big" : ""}">
    <span class="digits" data-testid="position">${fmt(userKnown ? axis.position_user : axis.position, digits)}</span>
    <span class="unit">${shownInPulses ? "pulses" : axis.unit}</span>
  </div>
  <div class="pulses">
    ${neverRead
      ? html`<span class="unread" data-testid="position-note" title="the gateway has not read this axis's position yet">not read yet</span>`
      : shownInPulses
        ? null
        : html`<span data-testid="pulses">${fmt(axis.position, 0)}</span> pulses`}
    ${shownInPulses && !pulseUnit
      ? html`<span class="unknownuser" data-testid="user-unknown" title="the origin is lost: ${axis.unit} from an origin that is gone are not known">${axis.unit} unknown until homed</span>`
      : null}
    ${wrapped
      ? html`${shownInPulses && pulseUnit ? "" : " · "}<span class="counter" data-testid="counter"
          title="the controller's raw 24-bit counter; it wrapped below 0, and the position follows it through the wrap">counter ${fmt(axis.counter, 0)}</span>`
      : null}
  </div>`;
}

// What the gateway knows of the origin: homed (a quiet ok), unknown (no origin search seen
// since the gateway started: moves pass, so only a quiet note), lost (a controller reset was
// seen: moves that need the origin are refused until homed). The cause is the view's (the
// gateway keeps it while the origin is lost), else the origin event's the page saw.
export function OriginLine({ axis }) {
  if (axis.origin === "homed") {
    return html`<div class="origin homed" data-testid="origin" title="an origin search ended and no controller reset since">homed</div>`;
  }
  if (axis.origin === "lost") {
    const seen = store.origins.get(axis.id);
    const heard = seen && seen.origin === "lost" ? seen.cause : null;
    const cause = axis.origin_cause || heard || "a controller reset was seen";
    return html`<div class="origin lost" role="alert" data-testid="origin">
      <strong>origin lost — home first</strong> <span class="why" data-testid="origin-cause">${cause}</span>
    </div>`;
  }
  return html`<div class="origin unknown" data-testid="origin" title="no origin search seen since the gateway started; moves are not refused">origin unknown</div>`;
}

// Why the gateway would refuse a move now (409 "home first"), or null: while the origin is
// lost every move of an axis with soft limits is refused, and an absolute move in the user
// unit of any axis (docs/api-notes.md "While the origin is lost"). Homing and stops pass.
export function homeFirst(axis, { unit = "pulse", relative = true } = {}) {
  if (axis.origin !== "lost") return null;
  if (axis.soft_min != null || axis.soft_max != null) {
    return "home first: the origin is lost, and moves of an axis with soft limits wait for a home";
  }
  if (unit === "user" && !relative) {
    return `home first: the origin is lost, and absolute moves in ${axis.unit} wait for a home`;
  }
  return null;
}

export function StateBadges({ axis }) {
  const current = isCurrent(axis);
  const op = store.ops.get(axis.id);
  return html`<span class="badges">
    ${!current
      ? null
      : axis.moving
        ? html`<${Badge} kind="moving">MOVING<//>`
        : axis.moving === false
          ? html`<${Badge} kind="idle">STOPPED<//>`
          : null}
    ${axis.moving == null
      ? html`<span data-testid="moving-unknown"><${Badge} kind="unknown" title="not read yet, or the controller says a motor moves but not which">MOTION UNKNOWN<//></span>`
      : null}
    ${axis.stale
      ? html`<${Badge} kind="stale" title=${axis.position == null ? "not read yet" : "no fresh reading: the value is old"}>STALE<//>`
      : null}
    ${!current && !axis.stale ? html`<${Badge} kind="stale">NOT CURRENT<//>` : null}
    <span class="age" data-testid="age" title="last reading at ${clock(axis.updated)}">${age(axis.updated)}</span>
    ${op && op.target_user != null && !["done", "failed", "unknown"].includes(op.state)
      ? html`<span class="target">→ ${fmt(op.target_user, digitsOf(axis.unit))} ${axis.unit}</span>`
      : null}
  </span>`;
}

// Whether the axis's controller counts positions with a sign: mode 1 always does (§10 EP);
// otherwise EP says, and a controller whose EP is not read yet counts as the device's default,
// unsigned (EP0).
export function signedCounting(axis) {
  const ctl = store.controllers.get(axis.controller);
  return !!ctl && (ctl.mode === 1 || ctl.signed_positions === true);
}

// The range the axis can really be sent to: the soft limits, and in unsigned counting no
// position below 0 (a negative target wraps to 16,777,216 minus it there, §7-4).
export function reachable(axis) {
  let { soft_min: lo, soft_max: hi } = axis;
  const floor = signedCounting(axis) ? null : 0;
  const bySign = floor != null && (lo == null || lo < floor);
  if (bySign) lo = floor;
  return { lo, hi, bySign };
}

// The soft limits as a bar with the position (and the target) on it.
export function LimitBar({ axis }) {
  const { lo, hi, bySign } = reachable(axis);
  if (lo == null || hi == null || hi <= lo) return html`<div class="limitbar none">no soft limits</div>`;
  const pos = axis.position_user;
  const op = store.ops.get(axis.id);
  const target = op && !["done", "failed", "unknown"].includes(op.state) ? op.target_user : null;
  const at = (v) => `${Math.min(100, Math.max(0, ((v - lo) / (hi - lo)) * 100))}%`;
  const outside = pos != null && (pos < lo || pos > hi);
  const why = bySign
    ? `${lo} ${axis.unit}: the controller counts unsigned (EP0), no position below 0; soft limits ${axis.soft_min ?? "none"} … ${hi} ${axis.unit}`
    : `soft limits ${lo} … ${hi} ${axis.unit}`;
  return html`<div class="limitbar ${outside ? "outside" : ""}" title=${why} data-testid="limitbar">
    <span class="lim lo" data-testid="limit-low">${lo}</span>
    <div class="track">
      ${target != null ? html`<div class="mark target" style=${{ left: at(target) }}></div>` : null}
      ${pos != null ? html`<div class="mark pos" style=${{ left: at(pos) }}></div>` : null}
    </div>
    <span class="lim hi" data-testid="limit-high">${hi}</span>
  </div>`;
}

// A sensor's state as the manual reads it: a limit or EMS input that is ON stops the motor
// (§8 CWLS/CCWLS, EMS): an alarm. ORG is ON at the origin, and the step-out sensor (EZ) turns
// ON and OFF with every slot of its dog as the motor turns (§10 Q): both states of those are
// normal, shown neutral.
const ALARM_SENSORS = new Set(["cw_limit", "ccw_limit", "emergency_stop"]);
const SENSOR_NAMES = {
  cw_limit: "CW limit",
  ccw_limit: "CCW limit",
  org: "ORG",
  emergency_stop: "EMS",
  step_out_sensor: "step-out sensor",
};

export function SensorBadges({ axis }) {
  return Object.entries(axis.sensors || {}).map(([k, v]) => {
    const kind = !v ? "" : ALARM_SENSORS.has(k) ? "on alarm" : "on normal";
    const name = SENSOR_NAMES[k] || k.replaceAll("_", " ");
    return html`<span class="sensor ${kind}" data-testid="sensor-${k}"
      title="${name} ${v ? "ON" : "OFF"}${v && !ALARM_SENSORS.has(k) ? " (normal)" : ""}">${name} ${v ? "ON" : "off"}</span>`;
  });
}

// A controller's latched errors as people say them (the view's kinds are identifiers).
const LATCH_NAMES = {
  limit_error: "limit error",
  emergency_stop: "emergency stop",
  command_error: "command error",
  communication_error: "communication error",
  program_error: "program error",
};

export function latchName(kind) {
  return LATCH_NAMES[kind] || String(kind).replaceAll("_", " ");
}

const ERROR_NAMES = { limit: "LIMIT", emergency: "EMS", command: "COMMAND", step_out: "STEP-OUT" };

export function Errors({ axis }) {
  const on = Object.entries(axis.errors || {}).filter(([, v]) => v);
  if (on.length === 0) return null;
  const ack = () => {
    const names = on.map(([k]) => ERROR_NAMES[k]).join(", ");
    if (confirm(`Acknowledge ${names} on ${axis.name || axis.id}? The errors stop showing.`)) acknowledge(axis.id);
  };
  return html`<div class="errors" role="alert">
    ${on.map(([k]) => html`<span class="err" data-testid="error-${k}">${ERROR_NAMES[k] || k}</span>`)}
    ${can("operator") ? html`<button class="ack" onClick=${ack}>Acknowledge</button>` : null}
  </div>`;
}

export function OpLine({ axisId }) {
  const op = store.ops.get(axisId);
  if (!op) return html`<div class="op empty"> </div>`;
  const axis = store.axes.get(axisId) || {};
  const what =
    op.kind === "move" && op.target_user != null
      ? `move → ${fmt(op.target_user, digitsOf(axis.unit))} ${axis.unit}`
      : `${op.kind}${op.request?.method ? ` ${op.request.method}` : ""}${op.request?.direction ? ` ${op.request.direction}` : ""}`;
  const end =
    op.state === "done" && op.position_user != null ? ` at ${fmt(op.position_user, digitsOf(axis.unit))} ${axis.unit}` : "";
  const e = op.error;
  const why = e
    ? `: ${e.title || e.kind}${e.detail ? ` (${e.detail})` : ""}${e.outcome ? `, outcome ${e.outcome.replace("_", " ")}` : ""}`
    : "";
  return html`<div class="op ${op.state}" data-testid="op" title=${`${op.state} ${what}${end}${why}${op.frames?.length ? ` [${op.frames.join(" ")}]` : ""}`}>
    <span class="opstate">${op.state}</span> ${what}${end}${why}
  </div>`;
}

export function axisName(axisId) {
  const axis = store.axes.get(axisId);
  return axis?.name || axisId;
}

export function StopButton({ axisId, label = "STOP", cls = "" }) {
  if (!can("operator")) return null;
  return html`<button class="stop ${cls}" data-testid="stop" onClick=${() => stopAxis(axisId)}
    aria-label="stop ${axisName(axisId)}" title="Stop now (Escape)">${label}</button>`;
}

// Press and hold: pointer, or Space/Enter on the focused button. Sliding off the button
// stops too: a finger that wanders never leaves a jog running.
export function HoldButton({ axisId, direction, speed = "low", children }) {
  if (!can("operator")) return null;
  const refused = homeFirst(store.axes.get(axisId) || {});
  const start = (e) => {
    e.preventDefault();
    e.currentTarget.focus();
    holdStart(axisId, direction, speed);
  };
  const key = (e) => {
    if ((e.key === " " || e.key === "Enter") && !e.repeat) {
      e.preventDefault();
      holdStart(axisId, direction, speed);
    }
  };
  const keyUp = (e) => {
    if (e.key === " " || e.key === "Enter") {
      e.preventDefault();
      holdEnd();
    }
  };
  const name = `jog ${axisName(axisId)} ${direction} ${speed} speed`;
  if (refused) {
    return html`<button class="jog" data-testid="jog-${direction}" disabled aria-label=${name} title=${refused}>${children}</button>`;
  }
  return html`<button class="jog" data-testid="jog-${direction}" onPointerDown=${start} onPointerUp=${holdEnd}
    onPointerCancel=${holdEnd} onPointerLeave=${holdEnd} onKeyDown=${key} onKeyUp=${keyUp}
    onContextMenu=${(e) => e.preventDefault()} aria-label=${name} title="hold to ${name}">${children}</button>`;
}

// Another controller, same view (settings or program).
export function ControllerPicker({ view, id }) {
  const ids = [...store.controllers.values()];
  return html`<select value=${id} aria-label="controller" onChange=${(e) => (location.hash = `#/${view}/${e.currentTarget.value}`)}>
    ${ids.map((c) => html`<option value=${c.id}>${c.name ? `${c.name} (${c.id})` : c.id}</option>`)}
  </select>`;
}
