// One controller's settings: the position table (§10 A), the I/O bits (§10 C, CO, D) and the
// sensors of its axes (live states from the feed, input logic from §10 EA). Every read here
// uses the line, so it is done on request, not polled.

import { html, useEffect, useState } from "../vendor/preact-htm/standalone.module.js";
import { stopController } from "./actions.js";
import { get, put, seg } from "./api.js";
import { axesOf, can, store, toast } from "./store.js";
import { ControllerPicker, SensorBadges } from "./widgets.js";

function PositionTable({ ctl }) {
  const [start, setStart] = useState(0);
  const [rows, setRows] = useState([]);
  const [busy, setBusy] = useState(false);
  // What is typed and not yet written, per entry: a redraw (every second) never puts the
  // device's old value back under the user's fingers.
  const [drafts, setDrafts] = useState({});
  const read = async () => {
    setBusy(true);
    const out = [];
    for (let n = start; n < Math.min(1000, start + 10); n += 1) {
      try {
        out.push(await get(`/controllers/${seg(ctl.id)}/positions/${n}`));
      } catch (err) {
        out.push({ number: n, error: err.message });
      }
    }
    setRows(out);
    setDrafts({});
    setBusy(false);
  };
  // The row shows what the device holds: read back after the write (and after a refusal,
  // so the field never keeps a value the device does not have).
  const write = async (n, value) => {
    const path = `/controllers/${seg(ctl.id)}/positions/${n}`;
    try {
      await put(path, { position: Number(value) });
      toast(`Position ${n} written`, "ok");
    } catch (err) {
      toast(`Position ${n}: ${err.message}`, "error", 9000);
    }
    let row;
    try {
      row = await get(path);
    } catch (err) {
      row = { number: n, error: err.message };
    }
    setRows((before) => before.map((r) => (r.number === n ? row : r)));
    setDrafts(({ [n]: _, ...rest }) => rest);
  };
  return html`<div class="postable">
    <label>from number <input type="number" min="0" max="990" value=${start} onInput=${(e) => setStart(Number(e.currentTarget.value))} /></label>
    <button onClick=${read} disabled=${busy}>${busy ? "reading…" : "Read 10 entries"}</button>
    ${rows.length
      ? html`<table><thead><tr><th>No.</th><th>pulses</th><th></th></tr></thead><tbody>
          ${rows.map(
            (r) => html`<tr>
              <td>${String(r.number).padStart(3, "0")}</td>
              <td>${r.error
                ? html`<span class="problem">${r.error}</span>`
                : can("operator")
                  ? html`<input type="number" value=${drafts[r.number] ?? r.position}
                      onInput=${(e) => setDrafts({ ...drafts, [r.number]: e.currentTarget.value })}
                      onChange=${(e) => write(r.number, e.currentTarget.value)} aria-label="position ${r.number} in pulses" data-testid="position-entry-${r.number}" />`
                  : r.position}</td>
              <td></td>
            </tr>`,
          )}
        </tbody></table>`
      : null}
  </div>`;
}

// Outputs are switches (buttons, when the role may switch them); inputs are lamps: read-only
// indicators that look like no control.
function Bits({ port, editable, onToggle, label, kind }) {
  return html`<div class="bits ${kind}" role="group" aria-label=${label} data-testid="${kind}-bits"><span class="bitlabel">${label}</span>
    ${[0, 1, 2, 3, 4, 5, 6, 7].map((bit) => {
      const on = port.on.includes(bit);
      const name = `${kind === "inputs" ? "input" : "output"} ${bit} ${on ? "on" : "off"}`;
      if (kind === "inputs") {
        return html`<span class="lamp ${on ? "on" : ""}" role="img" aria-label=${name} title=${name} data-testid="input-${bit}">${bit}</span>`;
      }
      return editable
        ? html`<button class="bit ${on ? "on" : ""}" onClick=${() => onToggle(bit, !on)} aria-pressed=${on}
            aria-label="output ${bit}" title="switch output ${bit} ${on ? "off" : "on"}">${bit}</button>`
        : html`<span class="bit ${on ? "on" : ""}" role="img" aria-label=${name} title=${name}>${bit}</span>`;
    })}
  </div>`;
}

function Io({ ctl }) {
  const [io, setIo] = useState(null);
  const [error, setError] = useState(null);
  const read = () => get(`/controllers/${seg(ctl.id)}/io`).then((v) => (setIo(v), setError(null)), (err) => setError(err.message));
  useEffect(() => {
    read();
  }, [ctl.id]);
  const toggle = async (bit, on) => {
    try {
      await put(`/controllers/${seg(ctl.id)}/io/outputs/${bit}`, { on });
      read();
    } catch (err) {
      toast(`Output ${bit}: ${err.message}`, "error", 9000);
    }
  };
  if (error) return html`<p class="problem">${error}</p>`;
  if (!io) return html`<p class="muted">Reading the I/O…</p>`;
  return html`<div class="io">
    <${Bits} port=${io.inputs} label="inputs" kind="inputs" />
    <${Bits} port=${io.outputs} label="outputs" kind="outputs" editable=${can("operator")} onToggle=${toggle} />
    <p class="muted">${["inp1", "inp2", "clr1", "clr2"].filter((k) => io[k] != null).map((k) => `${k.toUpperCase()} ${io[k] ? "ON" : "off"}`).join(" · ")}</p>
    <button onClick=${read}>Read again</button>
  </div>`;
}

function SensorLogic({ ctl, motor }) {
  const [logic, setLogic] = useState(null);
  useEffect(() => {
    get(`/controllers/${seg(ctl.id)}/sensor-logic/${motor}`).then(setLogic, () => setLogic(null));
  }, [ctl.id, motor]);
  if (!logic) return null;
  return html`<span class="muted">logic: limit ${logic.limit}, ORG ${logic.org}, EMS ${logic.emergency_stop}, step-out ${logic.step_out_sensor}, INP ${logic.inp} (A: normally open)</span>`;
}

export function ControllerPage({ id }) {
  const ctl = store.controllers.get(id) || [...store.controllers.values()].find((c) => c.name === id);
  if (!ctl) return html`<p class="muted">No controller ${id} (yet).</p>`;
  const reads = can("operator");
  return html`<div class="ctlpage">
    <header class="axishead">
      <a href="#/">← cell</a>
      <h2>${ctl.name || ctl.id}</h2>
      <${ControllerPicker} view="controller" id=${ctl.id} />
      <span class="muted">${ctl.id} · mode ${ctl.mode ?? "?"} · ${ctl.version || ""}</span>
      ${reads ? html`<button class="stop" onClick=${() => stopController(ctl.id)} aria-label="stop both axes of ${ctl.name || ctl.id}">STOP ${ctl.name || ctl.id}</button>` : null}
      <a class="button" href="#/program/${ctl.id}">Program…</a>
    </header>
    <h3>Sensors</h3>
    ${axesOf(ctl.id).map(
      (axis) => html`<div class="sensors"><a href="#/axis/${axis.id}">${axis.name || axis.id}</a>
        <${SensorBadges} axis=${axis} />
        ${reads ? html`<${SensorLogic} ctl=${ctl} motor=${axis.motor} />` : null}
      </div>`,
    )}
    ${reads
      ? html`<h3>I/O</h3><${Io} ctl=${ctl} /><h3>Position table</h3><${PositionTable} ctl=${ctl} />`
      : html`<p class="muted">The I/O and the position table are read from the line: operator role.</p>`}
  </div>`;
}
