// The line trace of a loop, for admins: switch it on, watch tx/rx with timestamps in ASCII or
// hex, pause the view, download what is shown. Read with GET /loops/{loop}/trace twice a second
// while it is on and not paused.

import { html, useEffect, useState } from "../vendor/preact-htm/standalone.module.js";
import { get, put, seg } from "./api.js";
import { can, store, toast } from "./store.js";

function stamp(t) {
  if (t == null) return "";
  const d = new Date(t * 1000);
  return `${d.toLocaleTimeString("en-GB")}.${String(d.getMilliseconds()).padStart(3, "0")}`;
}

function download(loop, lines) {
  const text = lines.map((l) => `${stamp(l.time)}\t${l.direction}\t${l.controller || ""}\t${l.text}\t${l.note}`).join("\n");
  const a = document.createElement("a");
  a.href = URL.createObjectURL(new Blob([text + "\n"], { type: "text/plain" }));
  a.download = `trace-${loop}-${new Date().toISOString().replaceAll(":", "")}.txt`;
  a.click();
  setTimeout(() => URL.revokeObjectURL(a.href), 1000);
}

export function TracePage({ loop }) {
  const name = loop || [...store.loops.keys()][0];
  const [trace, setTrace] = useState(null);
  const [paused, setPaused] = useState(false);
  const [error, setError] = useState(null);
  const path = `/loops/${seg(name || "")}/trace`;
  useEffect(() => {
    if (!name || !can("admin")) return undefined;
    let alive = true;
    const read = () =>
      get(path).then(
        (t) => alive && (setTrace(t), setError(null)),
        (err) => alive && setError(err.message),
      );
    read();
    const timer = paused ? null : setInterval(read, 500);
    return () => {
      alive = false;
      clearInterval(timer);
    };
  }, [name, paused]);
  if (!can("admin")) return html`<p class="muted">The line trace is for admins.</p>`;
  if (!name) return html`<p class="muted">No loop.</p>`;
  const set = async (settings) => {
    const before = trace;
    const wanted = { enabled: trace?.enabled ?? false, hex: trace?.hex ?? false, ...settings };
    setTrace({ lines: [], ...trace, ...wanted }); // the switch shows what was asked at once
    try {
      setTrace(await put(path, wanted));
    } catch (err) {
      setTrace(before);
      toast(`Trace: ${err.message}`, "error", 9000);
    }
  };
  const lines = trace?.lines || [];
  return html`<div class="tracepage">
    <header class="axishead">
      <a href="#/">← cell</a><h2>Line trace of ${name}</h2>
      <select value=${name} onChange=${(e) => (location.hash = `#/trace/${e.currentTarget.value}`)} aria-label="loop">
        ${[...store.loops.keys()].map((l) => html`<option value=${l}>${l}</option>`)}
      </select>
    </header>
    <div class="tracebar">
      <label class="check"><input type="checkbox" checked=${!!trace?.enabled} onChange=${(e) => set({ enabled: e.currentTarget.checked })} /> trace on</label>
      <label class="check"><input type="checkbox" checked=${!!trace?.hex} onChange=${(e) => set({ hex: e.currentTarget.checked })} /> hex</label>
      <button onClick=${() => setPaused(!paused)}>${paused ? "Resume view" : "Pause view"}</button>
      <button onClick=${() => set({ clear: true })}>Clear</button>
      <button onClick=${() => download(name, lines)} disabled=${!lines.length}>Download</button>
      <span class="muted">${lines.length} records</span>
    </div>
    ${error ? html`<p class="problem">${error}</p>` : null}
    <div class="trace" role="log">
      ${lines.length === 0
        ? html`<p class="muted">${trace?.enabled ? "Waiting for the line…" : "The trace is off: switch it on to record the line's frames."}</p>`
        : null}
      ${lines.slice(-400).map(
        (l) => html`<div class="tl ${l.direction}"><span class="ts">${stamp(l.time)}</span><span class="dir">${l.direction}</span><span class="who">${l.controller || ""}</span><code>${l.text}</code><span class="note">${l.note}</span></div>`,
      )}
    </div>
  </div>`;
}
