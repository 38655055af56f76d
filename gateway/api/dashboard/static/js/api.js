// The REST client of the dashboard: the public API under /api/v1, with the session's token.
// Every answer that is not 2xx becomes an ApiError carrying the problem+json body, so the
// page can show the field, the rule and the detail the gateway gives (never a broken page).

export const API = "/api/v1";
const TOKEN_KEY = "rc233.token";

// The token is kept for the browser session only (sessionStorage), never in localStorage.
export function token() {
  return sessionStorage.getItem(TOKEN_KEY);
}

export function setToken(value) {
  if (value) sessionStorage.setItem(TOKEN_KEY, value);
  else sessionStorage.removeItem(TOKEN_KEY);
}

export class ApiError extends Error {
  constructor(status, problem) {
    super(describe(status, problem));
    this.status = status;
    this.problem = problem || {};
  }
}

function describe(status, problem) {
  if (!problem) return `HTTP ${status}`;
  if (status === 401) return "Not logged in, or the token is not known (401).";
  if (status === 403) {
    return `Not allowed for your role (403)${problem.required_role ? `: needs ${problem.required_role}` : ""}.`;
  }
  const where = problem.step != null ? `step ${problem.step}: ` : "";
  return `${where}${problem.detail || problem.title || `HTTP ${status}`}`;
}

// One request: JSON in, JSON out. `body` undefined sends no body. Every request that acts is
// declared JSON, bodyless too: the gateway refuses one declared otherwise (415), since a page
// of another site can send those without asking.
export async function call(method, path, body, { signal } = {}) {
  const headers = { Accept: "application/json, application/problem+json" };
  const tok = token();
  if (tok) headers.Authorization = `Bearer ${tok}`;
  if (body !== undefined || method !== "GET") headers["Content-Type"] = "application/json";
  let response;
  try {
    response = await fetch(API + path, {
      method,
      headers,
      body: body === undefined ? undefined : JSON.stringify(body),
      signal,
      cache: "no-store",
    });
  } catch (err) {
    if (err.name === "AbortError") throw err;
    throw new ApiError(0, { detail: "the gateway cannot be reached" });
  }
  const text = await response.text();
  let data = null;
  if (text) {
    try {
      data = JSON.parse(text);
    } catch {
      data = { detail: text };
    }
  }
  if (!response.ok) throw new ApiError(response.status, data);
  return data;
}

export const get = (path, opts) => call("GET", path, undefined, opts);
export const post = (path, body, opts) => call("POST", path, body, opts);
export const put = (path, body, opts) => call("PUT", path, body, opts);

// Ids are loop.body.motor: dots and names are safe in a path segment once encoded.
export const seg = (id) => encodeURIComponent(id);
