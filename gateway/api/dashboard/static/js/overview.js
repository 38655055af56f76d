// The cell at a glance: every loop (in the sticky bar, with its stop-all), every controller
// with its stop-all, every axis with its position, state, limits, errors, plot, jog and stop.

import { Component, html } from "../vendor/preact-htm/standalone.module.js";
import { stopController, stopLoop } from "./actions.js";
import { PositionPlot } from "./plot.js";
import { axesOf, can, isCurrent, loopDown, store } from "./store.js";
import {
  Badge,
  Errors,
  HoldButton,
  LimitBar,
  OpLine,
  OriginLine,
  Position,
  StateBadges,
  StopButton,
  clock,
  latchName,
} from "./widgets.js";

const PROGRAM = { 1: "running", 0: "ended", P: "paused", E: "error" };
const MODE = { 0: "pulse", 1: "encoder", 2: "servo" };

export function LoopStrip() {
  const loops = [...store.loops.values()];
  return html`<div class="loops">
    ${loops.map((loop) => {
      const rate = store.rates.get(loop.name);
      const known = store.ws.state === "open"; // else the last state seen, not the state now
      return html`<div class="loop ${known ? (loop.up ? "up" : "down") : "grey"}" data-testid="loop-${loop.name}">
        <span class="loopname">${loop.name}</span>
        ${!known
          ? html`<${Badge} kind="stale" title="not connected to the gateway">UNKNOWN<//>`
          : loop.up
            ? html`<${Badge} kind="up">UP<//>`
            : html`<${Badge} kind="down" title=${loop.cause}>DOWN<//><span class="cause" data-testid="loop-cause">${loop.cause || ""}</span>`}
        <span class="metric" title="line utilisation">${rate ? `${(rate.utilisation * 100).toFixed(0)} %` : "…"} line</span>
        <span class="metric" title="requests waiting">queue ${loop.queue_depth ?? "—"}</span>
        <span class="metric" title="retries and time-outs per minute">${rate ? `${rate.retriesPerMin.toFixed(0)} retries, ${rate.timeoutsPerMin.toFixed(0)} t/o /min` : ""}</span>
        ${can("operator")
          ? html`<button class="stop loopstop" data-testid="stop-loop-${loop.name}" onClick=${() => stopLoop(loop.name)}
              aria-label="stop every axis of loop ${loop.name}" title="Stop every axis of loop ${loop.name}">STOP LOOP ${loop.name}</button>`
          : null}
      </div>`;
    })}
  </div>`;
}

// The head changes with the controller's view, the connection and the role alone.
class ControllerHead extends Component {
  shouldComponentUpdate(next) {
    const key = [next.ctl, store.ws.state, store.session?.role];
    const changed = !this.key || key.some((v, i) => v !== this.key[i]);
    this.key = key;
    return changed;
  }

  render({ ctl }) {
    return html`<${ControllerHeadBody} ctl=${ctl} />`;
  }
}

// Why a controller is in local control (motion and settings from the network refused; stop
// never): the admin's setting of the controller or its loop, or its key switch.
function localWhy(control) {
  const why = (control.sources || []).map((s) => `${s.kind}: ${s.by}`);
  return "local control: motion and settings refused, stop accepted" + (why.length ? ` (${why.join("; ")})` : "");
}

function ControllerHeadBody({ ctl }) {
  const online =
    store.ws.state !== "open" ? "unknown" : ctl.online == null ? "probing" : ctl.online ? "online" : "offline";
  return html`<header class="ctlhead">
    <div class="ctltitle">
      <a href="#/controller/${ctl.id}" class="ctlname">${ctl.name || ctl.id}</a>
      <span class="muted">${ctl.id}</span>
      <${Badge} kind=${online}>${online.toUpperCase()}<//>
      ${ctl.control && ctl.control.state === "local"
        ? html`<span data-testid="local-${ctl.id}"><${Badge} kind="local" title=${localWhy(ctl.control)}>LOCAL<//></span>`
        : null}
    </div>
    <div class="ctlfacts">
      <span>mode ${ctl.mode == null ? "?" : `${ctl.mode} ${MODE[ctl.mode] || ""}`}</span>
      <span>${ctl.version ? `V ${ctl.version}` : ""}</span>
      <span>program ${ctl.program == null ? "?" : PROGRAM[ctl.program] || ctl.program}</span>
      ${ctl.communication_error ? html`<span class="err">COMM</span>` : null}
      ${ctl.latched.map((l) => html`<span class="err" data-testid="latched-${l.kind}" title="${l.kind} since ${clock(l.first)} (${l.count}×, ${l.source})">${latchName(l.kind)}</span>`)}
    </div>
    ${can("operator")
      ? html`<button class="stop ctlstop" data-testid="stop-controller-${ctl.id}" onClick=${() => stopController(ctl.id)}
          aria-label="stop both axes of ${ctl.name || ctl.id}" title="Stop both axes of ${ctl.name || ctl.id}">STOP ${ctl.name || ctl.id}</button>`
      : null}
  </header>`;
}

// What an axis card shows depends on these alone: it is re-rendered only when one changes
// (30 cards at 20 changes a second each would otherwise all be diffed on every frame).
function cardKey(axis) {
  return [
    axis,
    store.ops.get(axis.id),
    store.origins.get(axis.id),
    isCurrent(axis),
    store.session?.role,
    Math.floor(Date.now() / 1000), // the reading's age
  ];
}

// A card out of view (and 300 px around it) follows only what changes its look as a whole:
// greyed or not, moving, stale, errors, its operation's state, the role. Its digits, age and
// limit bar catch up as it comes near the view, and at least every 2-3 s. At 1280x800 four of
// 30 cards are in view: the other 26 are not diffed 20 times a second (bench/dashboard.py).
function coarseKey(axis) {
  const op = store.ops.get(axis.id);
  const errors = Object.keys(axis.errors || {}).filter((k) => axis.errors[k]).join();
  return [isCurrent(axis), axis.moving, axis.stale, axis.origin, errors, op?.id, op?.state, store.session?.role];
}

const OUT_OF_VIEW_REFRESH_MS = 2000;
const cards = new Map(); // the card's element -> the card
const nearView = new IntersectionObserver(
  (entries) => {
    for (const entry of entries) {
      const card = cards.get(entry.target);
      if (!card) continue;
      const came = entry.isIntersecting && !card.near;
      card.near = entry.isIntersecting;
      if (came) card.forceUpdate();
    }
  },
  { rootMargin: "300px 0px" },
);

const differs = (a, b) => !a || a.some((v, i) => v !== b[i]);

export class AxisCard extends Component {
  near = true; // until the observer says otherwise: a new card is drawn in full
  // Spread the out-of-view refreshes over time, so they never come all in one frame.
  refreshAfter = OUT_OF_VIEW_REFRESH_MS + Math.random() * 1000;

  componentDidMount() {
    this.observed = this.base;
    cards.set(this.observed, this);
    nearView.observe(this.observed);
  }

  componentWillUnmount() {
    nearView.unobserve(this.observed);
    cards.delete(this.observed);
  }

  shouldComponentUpdate(next) {
    const key = cardKey(next.axis);
    const coarse = coarseKey(next.axis);
    const now = performance.now();
    const changed = this.near
      ? differs(this.key, key)
      : differs(this.coarse, coarse) || now - this.renderedAt > this.refreshAfter;
    if (changed) {
      this.key = key;
      this.coarse = coarse;
      this.renderedAt = now;
    }
    return changed;
  }

  render({ axis }) {
    return html`<${AxisCardBody} axis=${axis} />`;
  }
}

function AxisCardBody({ axis }) {
  const current = isCurrent(axis);
  return html`<section class="axis ${current ? "" : "grey"} ${axis.moving ? "moving" : ""}" data-axis=${axis.id}
    data-testid="axis-${axis.name || axis.id}" tabindex="-1">
    <header class="axishead">
      <a class="axisname" href="#/axis/${axis.id}">${axis.name || axis.id}</a>
      <span class="muted">${axis.id}</span>
      <${StateBadges} axis=${axis} />
    </header>
    <${Position} axis=${axis} />
    <${OriginLine} axis=${axis} />
    <${LimitBar} axis=${axis} />
    <${Errors} axis=${axis} />
    <${PositionPlot} axisId=${axis.id} height=${80} every=${200} />
    <${OpLine} axisId=${axis.id} />
    ${can("operator")
      ? html`<div class="controls">
          <${HoldButton} axisId=${axis.id} direction="ccw">◀ jog<//>
          <${HoldButton} axisId=${axis.id} direction="cw">jog ▶<//>
          <a class="button" href="#/axis/${axis.id}" aria-label="move ${axis.name || axis.id}…">move…</a>
          <${StopButton} axisId=${axis.id} />
        </div>`
      : null}
  </section>`;
}

export function Overview() {
  const controllers = [...store.controllers.values()];
  if (controllers.length === 0) return html`<p class="muted">Waiting for the gateway's snapshot…</p>`;
  return html`<div class="overview">
    ${controllers.map(
      (ctl) => html`<div class="ctl ${loopDown(ctl.loop) || ctl.online === false || store.ws.state !== "open" ? "grey" : ""}" data-testid="controller-${ctl.id}">
        <${ControllerHead} ctl=${ctl} />
        <div class="axes">${axesOf(ctl.id).map((axis) => html`<${AxisCard} key=${axis.id} axis=${axis} />`)}</div>
      </div>`,
    )}
  </div>`;
}
