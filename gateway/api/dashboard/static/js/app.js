// The dashboard's shell: log-in, the sticky bar (connection, role, every loop with its stop),
// the disconnected banner, the views by URL hash, messages, and the keyboard.
//
// Keyboard: Escape stops the axis that holds the focus (its card or page); Shift+Escape stops
// every loop. Tab reaches every control; jog buttons jog while Space or Enter is held.

import { html, render, useEffect, useState } from "../vendor/preact-htm/standalone.module.js";
import { installHoldGuards, stopAxis, stopEverything } from "./actions.js";
import { ApiError, get, setToken, token } from "./api.js";
import { AxisPage } from "./axis.js";
import { ControllerPage } from "./controller.js";
import { connect, disconnect, onClose, pollAxes, pollLoops, resetRates } from "./feed.js";
import { LoopStrip, Overview } from "./overview.js";
import { ProgramPage } from "./program.js";
import { can, notify, store, subscribe } from "./store.js";
import { TracePage } from "./trace.js";

let loopTimer = null;

let asked = false; // the first answer of /session came (until then: no log-in form flashes)

async function start() {
  try {
    store.session = await get("/session");
    store.authProblem = null;
    asked = true;
  } catch (err) {
    asked = true;
    store.session = null;
    if (err instanceof ApiError && (err.status === 401 || err.status === 403)) {
      store.authProblem = token() ? err.message : null;
      disconnect();
      notify();
      return;
    }
    store.ws.state = "closed";
    store.ws.error = err.message;
    notify();
    setTimeout(start, 2000);
    return;
  }
  resetRates();
  connect();
  clearInterval(loopTimer);
  pollLoops();
  loopTimer = setInterval(() => {
    pollLoops();
    pollAxes();
  }, 2000);
  notify();
}

function logout() {
  setToken(null);
  disconnect();
  clearInterval(loopTimer);
  store.session = null;
  store.authProblem = null;
  notify();
}

function Login() {
  const [value, setValue] = useState("");
  const submit = (e) => {
    e.preventDefault();
    setToken(value.trim());
    start();
  };
  return html`<form class="login" onSubmit=${submit} data-testid="login">
    <h2>Log in</h2>
    <p>This gateway asks for an API token (ask whoever runs it). It is kept for this browser session only.</p>
    ${store.authProblem ? html`<p class="problem" role="alert">${store.authProblem}</p>` : null}
    <input type="password" autocomplete="off" placeholder="token" value=${value} data-testid="token"
      onInput=${(e) => setValue(e.currentTarget.value)} aria-label="API token" required />
    <button type="submit">Log in</button>
  </form>`;
}

function useHash() {
  const [hash, setHash] = useState(location.hash);
  useEffect(() => {
    const on = () => setHash(location.hash);
    addEventListener("hashchange", on);
    return () => removeEventListener("hashchange", on);
  }, []);
  return hash;
}

function Banner() {
  if (store.ws.state === "open") return null;
  const text =
    store.ws.state === "connecting"
      ? "Connecting to the gateway…"
      : `Disconnected from the gateway (${store.ws.error || "no connection"}): the values shown are old; reconnecting…`;
  return html`<div class="banner" role="alert" data-testid="banner">${text}</div>`;
}

function Toasts() {
  return html`<div class="toasts" aria-live="polite">
    ${store.toasts.map((t) => html`<div class="toast ${t.kind}">${t.text}</div>`)}
  </div>`;
}

function Nav({ hash }) {
  const at = (prefix) => (hash === prefix || hash.startsWith(`${prefix}/`) ? "active" : "");
  const firstCtl = [...store.controllers.keys()][0];
  return html`<nav>
    <a href="#/" class=${hash === "" || hash === "#/" ? "active" : ""}>Cell</a>
    ${firstCtl ? html`<a href="#/controller/${firstCtl}" class=${at("#/controller")}>Settings</a>` : null}
    ${firstCtl && can("operator") ? html`<a href="#/program/${firstCtl}" class=${at("#/program")}>Programs</a>` : null}
    ${can("admin") ? html`<a href="#/trace" class=${at("#/trace")}>Line trace</a>` : null}
    <a href="/api/v1/docs" target="_blank" rel="noopener">API</a>
  </nav>`;
}

function View({ hash }) {
  const [, what, id] = hash.replace(/^#/, "").split("/").map(decodeURIComponent);
  switch (what) {
    case "axis":
      return html`<${AxisPage} id=${id} />`;
    case "controller":
      return html`<${ControllerPage} id=${id} />`;
    case "program":
      return html`<${ProgramPage} id=${id} />`;
    case "trace":
      return html`<${TracePage} loop=${id} />`;
    default:
      return html`<${Overview} />`;
  }
}

function App() {
  const [, setTick] = useState(0);
  const hash = useHash();
  useEffect(() => subscribe(() => setTick((n) => n + 1)), []);
  const session = store.session;
  const offline = store.ws.state !== "open";
  return html`<div class="shell ${offline ? "offline" : ""}">
    <header class="top">
      <div class="brand"><a href="#/">rc233-gateway</a></div>
      ${session ? html`<${Nav} hash=${hash} />` : null}
      <div class="who">
        <span class="conn ${store.ws.state}" data-testid="connection">${store.ws.state === "open" ? "live" : store.ws.state}</span>
        ${session
          ? html`<span class="role" data-testid="role">${session.authentication ? `${session.name} · ${session.role}` : "no authentication (loopback demo)"}</span>
              ${session.authentication ? html`<button class="link" onClick=${logout}>log out</button>` : null}`
          : null}
        ${session && can("operator")
          ? html`<button class="stop stopall" data-testid="stop-all" onClick=${stopEverything} title="Stop every axis of every loop (Shift+Escape)">STOP ALL</button>`
          : null}
      </div>
      ${session ? html`<${LoopStrip} />` : null}
    </header>
    ${session ? html`<${Banner} />` : null}
    <main>${session
      ? html`<${View} hash=${hash} />`
      : !asked
        ? html`<p class="loading">Connecting to the gateway…</p>`
        : html`${store.ws.error && !store.authProblem ? html`<p class="problem">${store.ws.error}</p>` : null}<${Login} />`}</main>
    <${Toasts} />
  </div>`;
}

function onKey(e) {
  if (e.key !== "Escape" || !can("operator")) return;
  if (e.shiftKey) {
    e.preventDefault();
    stopEverything();
    return;
  }
  const holder = document.activeElement?.closest?.("[data-axis]") || document.querySelector(".axispage[data-axis]");
  if (holder) {
    e.preventDefault();
    stopAxis(holder.dataset.axis);
  }
}

addEventListener("keydown", onKey);
installHoldGuards(onClose);
// Ages ("3 s ago") and the plots' time windows move on even when nothing changes.
setInterval(notify, 1000);
const root = document.getElementById("app");
root.textContent = ""; // the "Loading" line of index.html
render(html`<${App} />`, root);
start();
