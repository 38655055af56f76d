// One axis: the big readout, move (absolute or relative, in the user unit by default, the unit
// always shown), home (method chosen), hold-to-jog, step, stop, the plot, the speed profile.

import { html, useEffect, useState } from "../vendor/preact-htm/standalone.module.js";
import { home, move, step } from "./actions.js";
import { get, put, seg } from "./api.js";
import { PositionPlot } from "./plot.js";
import { can, isCurrent, store, toast } from "./store.js";
import {
  Errors,
  HoldButton,
  LimitBar,
  OpLine,
  OriginLine,
  Position,
  SensorBadges,
  StateBadges,
  StopButton,
  fmt,
  homeFirst,
} from "./widgets.js";

const HOME_METHODS = [
  ["0", "0: Low speed, search 1"],
  ["0A", "0A: High speed, search 2 (stops at once on ORG)"],
  ["0H", "0H: High speed, search 1 (decelerates on ORG)"],
  ["0R", "0R: search 2"],
  ["0Z", "0Z: Z phase + ORG"],
];

function MoveForm({ axis }) {
  const [value, setValue] = useState("");
  const [unit, setUnit] = useState("user");
  const [relative, setRelative] = useState(false);
  const submit = (e) => {
    e.preventDefault();
    const position = Number(value);
    if (value.trim() === "" || !isFinite(position)) {
      toast("Type a number to move to", "error");
      return;
    }
    move(axis.id, position, { relative, unit });
  };
  const unitName = unit === "user" ? axis.unit : "pulses";
  // Refused by the gateway now (409 "home first"): the button says so instead of trying.
  const refused = homeFirst(axis, { unit, relative });
  return html`<form class="move" onSubmit=${submit} data-testid="move-form">
    <label>${relative ? "Move by" : "Move to"}
      <input type="number" step="any" inputmode="decimal" value=${value} required data-testid="move-value"
        onInput=${(e) => setValue(e.currentTarget.value)} aria-label="position in ${unitName}" />
    </label>
    <select value=${unit} onChange=${(e) => setUnit(e.currentTarget.value)} data-testid="move-unit" aria-label="unit">
      <option value="user">${axis.unit}</option>
      <option value="pulse">pulses</option>
    </select>
    <label class="check"><input type="checkbox" checked=${relative} onChange=${(e) => setRelative(e.currentTarget.checked)}
      data-testid="move-relative" /> relative</label>
    <button type="submit" class="go" data-testid="move-go" aria-label="move ${axis.name || axis.id}" disabled=${!!refused}
      title=${refused || undefined}>Move</button>
    ${refused && !homeFirst(axis) ? html`<p class="refusal" data-testid="move-refused">${refused}</p>` : null}
  </form>`;
}

function HomeForm({ axis }) {
  const [method, setMethod] = useState("0");
  return html`<form class="home" onSubmit=${(e) => (e.preventDefault(), home(axis.id, method))}>
    <select value=${method} onChange=${(e) => setMethod(e.currentTarget.value)} aria-label="homing method">
      ${HOME_METHODS.map(([v, label]) => html`<option value=${v}>${label}</option>`)}
    </select>
    <button type="submit" aria-label="home ${axis.name || axis.id}">Home</button>
  </form>`;
}

const SPEED_FIELDS = [
  ["oh", "OH High speed", "high_speed_pps", "pps"],
  ["ol", "OL Low speed", "low_speed_pps", "pps"],
  ["os", "OS acceleration", "acceleration_pps2", "pps/s"],
  ["oc", "OC S-curve %", "s_curve_time_s", "s"],
  ["ox", "OX multiplier", "multiplier", "×"],
];

// The speed data is read only while the controller's motors are known to stand: the gateway
// refuses the read while either moves (409: OC cannot be read, and the other motor cannot be
// selected, §10 F), which would be an error for nothing.
function SpeedProfile({ axis }) {
  const [read, setRead] = useState(null); // {id, speed}: the data and the axis it is of
  const [edit, setEdit] = useState({});
  const [error, setError] = useState(null);
  const ctl = store.controllers.get(axis.controller);
  const stopped = axis.moving === false && ctl?.moving === false;
  const speed = read && read.id === axis.id ? read.speed : null;
  const setSpeed = (s) => setRead({ id: axis.id, speed: s });
  const load = () =>
    get(`/axes/${seg(axis.id)}/speed`)
      .then((s) => (setSpeed(s), setError(null)))
      // 409: it started moving since; read again when it stands, no error.
      .catch((err) => (err.status === 409 ? setRead(null) : setError(err.message)));
  useEffect(() => {
    if (stopped && !speed) load();
  }, [axis.id, stopped, !!speed]);
  const save = async (e) => {
    e.preventDefault();
    const body = {};
    for (const [k, v] of Object.entries(edit)) if (v !== "" && v != null) body[k] = Number(v);
    try {
      setSpeed(await put(`/axes/${seg(axis.id)}/speed`, body));
      setEdit({});
      toast("Speed data written", "ok");
    } catch (err) {
      toast(`Speed: ${err.message}`, "error", 9000);
    }
  };
  if (error) return html`<p class="problem">${error}</p>`;
  if (!speed) {
    return html`<p class="muted" data-testid="speed-wait">${stopped ? "Reading the speed data…" : "The speed data is read when the controller's motors stand (not while one moves)."}</p>`;
  }
  const editable = can("operator");
  return html`<form class="speed" onSubmit=${save}>
    <table>
      <thead><tr><th>data (§7)</th><th>value</th><th>as the motor sees it</th></tr></thead>
      <tbody>
        ${SPEED_FIELDS.map(
          ([key, label, derived, unit]) => html`<tr>
            <td>${label}</td>
            <td>${editable && key !== "ox"
              ? html`<input type="number" value=${edit[key] ?? speed[key]} onInput=${(e) => setEdit({ ...edit, [key]: e.currentTarget.value })} aria-label=${label} />`
              : speed[key]}</td>
            <td>${fmt(speed[derived], unit === "pps" || unit === "pps/s" ? 0 : 3)} ${unit}</td>
          </tr>`,
        )}
        <tr><td>acceleration time</td><td></td><td>${fmt(speed.acceleration_time_s, 3)} s</td></tr>
      </tbody>
    </table>
    ${speed.oc_cached ? html`<p class="muted">OC is the last value read (OC cannot be read while moving).</p>` : null}
    ${editable
      ? html`<button type="submit">Write speed data</button>
          <button type="button" onClick=${load} disabled=${!stopped} title=${stopped ? undefined : "not while a motor of the controller moves"}>Read again</button>`
      : null}
  </form>`;
}

export function AxisPage({ id }) {
  const axis = store.axes.get(id) || [...store.axes.values()].find((a) => a.name === id);
  if (!axis) return html`<p class="muted">No axis ${id} (yet).</p>`;
  const current = isCurrent(axis);
  const refusedAll = homeFirst(axis); // jogs and steps (moves in pulses, relative)
  return html`<div class="axispage ${current ? "" : "grey"}" data-axis=${axis.id} data-testid="axis-page">
    <header class="axishead">
      <a href="#/">← cell</a>
      <h2 class="axisname">${axis.name || axis.id}</h2>
      <span class="muted">${axis.id} · controller <a href="#/controller/${axis.controller}">${axis.controller}</a></span>
      <${StateBadges} axis=${axis} />
    </header>
    <div class="axisgrid">
      <div class="readout">
        <${Position} axis=${axis} />
        <${OriginLine} axis=${axis} />
        <${LimitBar} axis=${axis} />
        <${Errors} axis=${axis} />
        <div class="sensors">
          <${SensorBadges} axis=${axis} />
        </div>
        <${OpLine} axisId=${axis.id} />
      </div>
      ${can("operator")
        ? html`<div class="motion">
            <${StopButton} axisId=${axis.id} cls="huge" />
            ${refusedAll ? html`<p class="refusal" data-testid="home-first">${refusedAll}: Move, jog and step are off; Home (below) is available.</p>` : null}
            <${MoveForm} axis=${axis} />
            <div class="jogrow">
              <${HoldButton} axisId=${axis.id} direction="ccw">◀ jog low<//>
              <${HoldButton} axisId=${axis.id} direction="cw">jog low ▶<//>
              <${HoldButton} axisId=${axis.id} direction="ccw" speed="high">◀◀ high<//>
              <${HoldButton} axisId=${axis.id} direction="cw" speed="high">high ▶▶<//>
            </div>
            <div class="steprow">
              <button onClick=${() => step(axis.id, "ccw")} aria-label="step ${axis.name || axis.id} ccw 1 pulse"
                disabled=${!!refusedAll} title=${refusedAll || undefined}>− 1 pulse</button>
              <button onClick=${() => step(axis.id, "cw")} aria-label="step ${axis.name || axis.id} cw 1 pulse"
                disabled=${!!refusedAll} title=${refusedAll || undefined}>+ 1 pulse</button>
            </div>
            <${HomeForm} axis=${axis} />
          </div>`
        : html`<p class="muted">Viewer: motion controls are for operators.</p>`}
    </div>
    <${PositionPlot} axisId=${axis.id} height=${240} />
    <h3>Speed profile</h3>
    ${can("operator") ? html`<${SpeedProfile} axis=${axis} />` : html`<p class="muted">Reading the speed data needs the operator role.</p>`}
  </div>`;
}
