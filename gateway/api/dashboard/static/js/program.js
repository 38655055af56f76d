// The user-program editor of a controller: one statement a line (the line number is the step
// GN counts), checked as you type by the gateway's own parser (POST /programs/check: the step,
// the field and the rule of chapters 11-12), upload, read back, run/pause/resume/stop, and
// the program's output (the feed's program_output events) as a console.

import { html, useEffect, useRef, useState } from "../vendor/preact-htm/standalone.module.js";
import { get, post, put, seg } from "./api.js";
import { can, consoleOf, store, toast } from "./store.js";
import { ControllerPicker } from "./widgets.js";

// The wire text has no line breaks: each '/' starts a statement.
export const toWire = (text) => text.replace(/[\r\n]+/g, "");
export const toLines = (wire) => wire.split("/").slice(1).map((s) => `/${s}`).join("\n");

const EXAMPLE = "/D00\n/0\n/22000\n/3\n/T10\n/4\n/END";
const STATES = { 1: "running", 0: "ended", P: "paused", E: "ended by an error" };

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

export function ProgramPage({ id }) {
  const ctl = store.controllers.get(id) || [...store.controllers.values()].find((c) => c.name === id);
  const [text, setText] = useState(EXAMPLE);
  const [status, setStatus] = useState(null);
  const area = useRef(null);
  const gutter = useRef(null);
  const check = useCheck(text);
  if (!ctl) return html`<p class="muted">No controller ${id} (yet).</p>`;
  if (!can("operator")) return html`<p class="muted">Programs need the operator role.</p>`;
  const base = `/controllers/${seg(ctl.id)}/program`;
  const act = async (what, fn) => {
    try {
      const r = await fn();
      if (r && r.outcome && r.outcome !== "done") toast(`${what}: ${r.outcome}`, "error", 9000);
      else toast(`${what}: done`, "ok");
      setStatus(await get(`${base}/status`).catch(() => null));
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
      <span class="muted">state ${STATES[ctl.program] || ctl.program || "?"}${status ? `, next step ${status.step}` : ""}</span>
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
          : `✗ ${check.step ? `step ${check.step}: ` : ""}${check.rule || check.message}${check.field ? ` (${check.field})` : ""}`}
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
      ? output.map((l) => `${new Date(l.time * 1000).toLocaleTimeString()}  ${l.body ? "" : "(loop) "}${l.text}\n`).join("")
      : "(nothing yet)"}</pre>
  </div>`;
}
