// The line trace of a loop, for admins: switch it on, watch tx/rx with timestamps in ASCII or
// hex, pause the view, download what is shown. Read with GET /loops/{loop}/trace twice a second
// while it is on and not paused.

import { html, useEffect, useLayoutEffect, useRef, useState } from "../vendor/preact-htm/standalone.module.js";
import { get, put, seg } from "./api.js";
import { can, store, toast } from "./store.js";
import { clock } from "./widgets.js";

const stamp = (t) => clock(t, true);
// Within this many pixels of the bottom the view counts as following the tail.
const TAIL_SLACK_PX = 24;

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
  // Every change of the settings counts one up, at its start and at its answer: a read that
  // began before (an answer from before the switch moved) is dropped, so the refresh never
  // puts the old state back into a box the user just changed.
  const settingsChange = useRef(0);
  const pending = useRef(0);
  const box = useRef(null);
  const following = useRef(true);
  useEffect(() => {
    if (!name || !can("admin")) return undefined;
    let alive = true;
    const read = () => {
      const began = settingsChange.current;
      return get(path).then(
        (t) => {
          if (!alive || pending.current > 0 || began !== settingsChange.current) return;
          setTrace(t);
          setError(null);
        },
        (err) => alive && setError(err.message),
      );
    };
    read();
    const timer = paused ? null : setInterval(read, 500);
    return () => {
      alive = false;
      clearInterval(timer);
    };
  }, [name, paused]);
  // Follow the newest frames unless the user scrolled up to read older ones.
  useLayoutEffect(() => {
    const el = box.current;
    if (el && following.current) el.scrollTop = el.scrollHeight;
  });
  if (!can("admin")) return html`<p class="muted">The line trace is for admins.</p>`;
  if (!name) return html`<p class="muted">No loop.</p>`;
  const set = async (settings) => {
    const before = trace;
    const wanted = { enabled: trace?.enabled ?? false, hex: trace?.hex ?? false, ...settings };
    setTrace({ lines: [], ...trace, ...wanted }); // the switch shows what was asked at once
    settingsChange.current += 1;
    pending.current += 1;
    try {
      const answer = await put(path, wanted);
      pending.current -= 1;
      settingsChange.current += 1;
      if (pending.current === 0) setTrace(answer);
    } catch (err) {
      pending.current -= 1;
      settingsChange.current += 1;
      if (pending.current === 0) setTrace(before);
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
      <label class="check"><input type="checkbox" checked=${!!trace?.enabled} onChange=${(e) => set({ enabled: e.currentTarget.checked })} data-testid="trace-on" /> trace on</label>
      <label class="check"><input type="checkbox" checked=${!!trace?.hex} onChange=${(e) => set({ hex: e.currentTarget.checked })} data-testid="trace-hex" /> hex</label>
      <button onClick=${() => setPaused(!paused)}>${paused ? "Resume view" : "Pause view"}</button>
      <button onClick=${() => set({ clear: true })}>Clear</button>
      <button onClick=${() => download(name, lines)} disabled=${!lines.length}>Download</button>
      <span class="muted">${lines.length} records</span>
    </div>
    ${error ? html`<p class="problem">${error}</p>` : null}
    <div class="trace" role="log" ref=${box} data-testid="trace-log"
      onScroll=${(e) => {
        const el = e.currentTarget;
        following.current = el.scrollHeight - el.scrollTop - el.clientHeight <= TAIL_SLACK_PX;
      }}>
      ${lines.length === 0
        ? html`<p class="muted">${trace?.enabled ? "Waiting for the line…" : "The trace is off: switch it on to record the line's frames."}</p>`
        : null}
      ${lines.slice(-400).map(
        (l) => html`<div class="tl ${l.direction}"><span class="ts">${stamp(l.time)}</span><span class="dir">${l.direction}</span><span class="who">${l.controller || ""}</span><code>${l.text}</code><span class="note">${l.note}</span></div>`,
      )}
    </div>
  </div>`;
}
