// The user-program editor of a controller: one statement a line (the line number is the step
// GN counts), checked as you type by the gateway's own parser (POST /programs/check: the step,
// the field and the rule of chapters 11-12), upload, read back, run/pause/resume/stop, and
// the program's output (the feed's program_output events) as a console.

import { html, useEffect, useRef, useState } from "../vendor/preact-htm/standalone.module.js";
import { get, post, put, seg } from "./api.js";
import { can, consoleOf, store, toast } from "./store.js";
import { ControllerPicker, clock } from "./widgets.js";

// The wire text has no line breaks: each '/' starts a statement.
export const toWire = (text) => text.replace(/[\r\n]+/g, "");
export const toLines = (wire) => wire.split("/").slice(1).map((s) => `/${s}`).join("\n");

const EXAMPLE = "/D00\n/0\n/22000\n/3\n/T10\n/4\n/END";
const STATES = { 1: "running", 0: "ended", P: "paused", E: "ended by an error" };
// While a program runs or is paused its state and next step are read again this often
// (GSS and GN, one short transaction); an ended program is not read again.
const STATUS_EVERY_MS = 1000;
const LIVE = new Set(["1", "P"]);

// GSS and GN of the controller, read after every action and again while the program runs,
// so the head never says "running" about a program that has printed its last line.
function useStatus(base) {
  const [status, setStatus] = useState(null);
  const read = () =>
    get(`${base}/status`).then(
      (s) => (setStatus({ ...s, at: Date.now() / 1000 }), s),
      () => null,
    );
  useEffect(() => {
    setStatus(null);
  }, [base]);
  useEffect(() => {
    if (!status || !LIVE.has(status.state)) return undefined;
    const timer = setTimeout(read, STATUS_EVERY_MS);
    return () => clearTimeout(timer);
  }, [base, status]);
  return [status, read];
}

// What the check refused, in full: the step, the statement, what is wrong (the gateway's
// detail names the target and why) and the rule of the manual it breaks.
function refusal(check) {
  const detail = (check.detail || check.message || "").replace(/^step \d+: /, "");
  const rule = check.rule && !detail.includes(check.rule) ? ` (rule: ${check.rule})` : "";
  return `✗ ${check.step ? `step ${check.step}: ` : ""}${detail}${rule}`;
}

function useCheck(text) {
  const [result, setResult] = useState(null);
  useEffect(() => {
    const wire = toWire(text);
    if (!wire) {
      setResult(null);
      return undefined;
    }
    const abort = new AbortController();
    const timer = setTimeout(() => {
      post("/programs/check", { text: wire }, { signal: abort.signal }).then(
        (ok) => setResult({ ok: true, ...ok }),
        (err) => {
          if (err.name !== "AbortError") setResult({ ok: false, status: err.status, ...err.problem, message: err.message });
        },
      );
    }, 250);
    return () => {
      clearTimeout(timer);
      abort.abort();
    };
  }, [text]);
  return result;
}

// The page's own status read when it has one (read again while the program runs, and when
// the poller's GSS in the controller's view changes), else the view's; the next step only
// while the program runs or is paused (an ended program has none to run).
function programState(ctl, status) {
  const state = status ? status.state : ctl.program;
  const step = status && LIVE.has(status.state) ? `, next step ${status.step}` : "";
  return `state ${STATES[state] || state || "?"}${step}`;
}

export function ProgramPage({ id }) {
  const ctl = store.controllers.get(id) || [...store.controllers.values()].find((c) => c.name === id);
  const [text, setText] = useState(EXAMPLE);
  const area = useRef(null);
  const gutter = useRef(null);
  const check = useCheck(text);
  const base = `/controllers/${seg(ctl?.id || id)}/program`;
  const [status, readStatus] = useStatus(base);
  useEffect(() => {
    if (ctl && can("operator")) readStatus();
  }, [base, ctl?.program]);
  if (!ctl) return html`<p class="muted">No controller ${id} (yet).</p>`;
  if (!can("operator")) return html`<p class="muted">Programs need the operator role.</p>`;
  const act = async (what, fn) => {
    try {
      const r = await fn();
      if (r && r.outcome && r.outcome !== "done") toast(`${what}: ${r.outcome}`, "error", 9000);
      else toast(`${what}: done`, "ok");
      await readStatus();
    } catch (err) {
      toast(`${what}: ${err.message}`, "error", 12000);
    }
  };
  const lines = text.split("\n");
  const badStep = check && !check.ok ? check.step : null;
  const output = consoleOf(ctl);
  return html`<div class="programpage">
    <header class="axishead">
      <a href="#/controller/${ctl.id}">← ${ctl.name || ctl.id}</a>
      <h2>Program of ${ctl.name || ctl.id}</h2>
      <${ControllerPicker} view="program" id=${ctl.id} />
      <span class="muted" data-testid="program-state">${programState(ctl, status)}</span>
    </header>
    <div class="editor">
      <div class="gutter" ref=${gutter} aria-hidden="true">
        ${lines.map((_, i) => html`<div class=${badStep === i + 1 ? "bad" : ""}>${i + 1}</div>`)}
      </div>
      <textarea ref=${area} spellcheck="false" data-testid="program-text" value=${text} aria-label="program, one statement a line"
        onInput=${(e) => setText(e.currentTarget.value)}
        onScroll=${(e) => (gutter.current.scrollTop = e.currentTarget.scrollTop)}></textarea>
    </div>
    <div class="check ${check ? (check.ok ? "ok" : "bad") : ""}" data-testid="program-check" role="status">
      ${!check
        ? "…"
        : check.ok
          ? `✓ ${check.steps} steps, ${check.bytes} bytes`
          : refusal(check)}
    </div>
    <div class="programbuttons">
      ${can("admin")
        ? html`<button disabled=${!check || !check.ok} onClick=${() => act("Upload", () => put(base, { text: toWire(text) }))}>Upload</button>`
        : null}
      <button onClick=${() => act("Read back", async () => setText(toLines((await get(base)).text)))}>Read back</button>
      <button onClick=${() => act("Run", () => post(`${base}/run`))}>Run</button>
      <button onClick=${() => act("Pause", () => post(`${base}/pause`))}>Pause</button>
      <button onClick=${() => act("Resume", () => post(`${base}/resume`))}>Resume</button>
      <button class="stop" onClick=${() => act("Stop program", () => post(`${base}/stop`, { mode: "immediate" }))}>Stop program</button>
    </div>
    <h3>Output</h3>
    <pre class="console" data-testid="program-console">${output.length
      ? output.map((l) => `${clock(l.time)}  ${l.body ? "" : "(loop) "}${l.text}\n`).join("")
      : "(nothing yet)"}</pre>
  </div>`;
}
