// SPDX-License-Identifier: AGPL-3.0-or-later
// api.js - the portal's client of the infilld REST API (openapi.yaml): the
// key (sessionStorage, sent only in the Authorization header, never in a
// URL), JSON requests with RFC 9457 problems as errors, uploads with
// progress (XMLHttpRequest), and the job event stream read with fetch()
// (EventSource cannot send the Authorization header).

const KEY_SLOT = "infilld.apiKey";

export function getKey() {
  return sessionStorage.getItem(KEY_SLOT) || "";
}

export function setKey(key) {
  if (key) sessionStorage.setItem(KEY_SLOT, key);
  else sessionStorage.removeItem(KEY_SLOT);
}

// An error carrying the server's problem document (type, title, detail, field).
export class ApiError extends Error {
  constructor(status, problem) {
    super((problem && (problem.detail || problem.title)) || "HTTP " + status);
    this.status = status;
    this.problem = problem || {};
  }
  get slug() {
    return String(this.problem.type || "").replace("/problems/", "");
  }
  // The parameter a 422 names, without a "params." prefix.
  get field() {
    return String(this.problem.field || "").replace(/^params\./, "");
  }
}

function authHeaders(extra) {
  const h = Object.assign({}, extra || {});
  const key = getKey();
  if (key) h.Authorization = "Bearer " + key;
  return h;
}

async function problemOf(resp) {
  let body = null;
  try {
    body = await resp.json();
  } catch {
    body = null;
  }
  return new ApiError(resp.status, body);
}

// fetch() with the key; throws ApiError unless the status is 2xx.
export async function request(method, path, body, headers) {
  const init = { method, headers: authHeaders(headers) };
  if (body !== undefined) {
    init.body = JSON.stringify(body);
    init.headers["Content-Type"] = "application/json";
  }
  const resp = await fetch(path, init);
  if (!resp.ok) throw await problemOf(resp);
  return resp;
}

export async function getJSON(path) {
  return (await request("GET", path)).json();
}

export async function sendJSON(method, path, body) {
  const resp = await request(method, path, body);
  return resp.status === 204 ? null : resp.json();
}

// POST a mesh file; onProgress(fraction) as it uploads.  Resolves to the
// mesh record (201), rejects with ApiError.
export function uploadMesh(file, onProgress) {
  return new Promise((resolve, reject) => {
    const dot = file.name.lastIndexOf(".");
    const format = dot >= 0 ? file.name.slice(dot + 1).toLowerCase() : "";
    const q = new URLSearchParams({ format, name: file.name });
    const xhr = new XMLHttpRequest();
    xhr.open("POST", "/v1/meshes?" + q.toString());
    xhr.setRequestHeader("Authorization", "Bearer " + getKey());
    xhr.setRequestHeader("Content-Type", "application/octet-stream");
    xhr.upload.addEventListener("progress", (ev) => {
      if (ev.lengthComputable) onProgress(ev.loaded / ev.total);
    });
    xhr.addEventListener("load", () => {
      let body = null;
      try {
        body = JSON.parse(xhr.responseText);
      } catch {
        body = null;
      }
      if (xhr.status === 201) resolve(body);
      else reject(new ApiError(xhr.status, body));
    });
    xhr.addEventListener("error", () => reject(new ApiError(0, { detail: "network error" })));
    xhr.send(file);
  });
}

// Follow GET /v1/jobs/{id}/events (SSE) until the job is final or the
// signal aborts: onEvent(type, job snapshot) per event.  Reconnects with
// Last-Event-ID when the connection drops.
export async function followEvents(jobId, onEvent, signal) {
  let lastId = null;
  for (let attempt = 0; attempt < 20 && !signal.aborted; attempt++) {
    const headers = authHeaders({ Accept: "text/event-stream" });
    if (lastId !== null) headers["Last-Event-ID"] = lastId;
    let resp;
    try {
      resp = await fetch("/v1/jobs/" + encodeURIComponent(jobId) + "/events", { headers, signal });
    } catch (e) {
      if (signal.aborted) return;
      await new Promise((r) => setTimeout(r, 1000));
      continue;
    }
    if (!resp.ok) throw await problemOf(resp);
    const reader = resp.body.getReader();
    const dec = new TextDecoder();
    let text = "";
    let ended = false;
    try {
      for (;;) {
        const { value, done } = await reader.read();
        if (done) {
          ended = true;
          break;
        }
        text += dec.decode(value, { stream: true });
        let cut;
        while ((cut = text.indexOf("\n\n")) >= 0) {
          const block = text.slice(0, cut);
          text = text.slice(cut + 2);
          const ev = { id: null, event: "message", data: "" };
          for (const line of block.split("\n")) {
            if (line.startsWith(":")) continue;
            const colon = line.indexOf(":");
            const name = colon < 0 ? line : line.slice(0, colon);
            const val = colon < 0 ? "" : line.slice(colon + 1).replace(/^ /, "");
            if (name === "id") ev.id = val;
            else if (name === "event") ev.event = val;
            else if (name === "data") ev.data += (ev.data ? "\n" : "") + val;
          }
          if (ev.id !== null) lastId = ev.id;
          if (ev.data) onEvent(ev.event, JSON.parse(ev.data));
        }
      }
    } catch (e) {
      if (signal.aborted) return;
    }
    if (ended) return; // the server ends the stream after the final event
  }
}

// Layer k of a finished job as an object URL of its PNG (caller revokes)
// and the job's layer count.
export async function layerImage(jobId, k) {
  const resp = await request("GET", "/v1/jobs/" + encodeURIComponent(jobId) + "/layers/" + k);
  const count = Number(resp.headers.get("X-Layer-Count") || "0");
  const blob = await resp.blob();
  return { url: URL.createObjectURL(blob), count };
}

// Download a job's output: fetch it with the key, then hand the browser a
// blob URL with the file name of Content-Disposition.
export async function download(jobId) {
  const resp = await request("GET", "/v1/jobs/" + encodeURIComponent(jobId) + "/output");
  const disp = resp.headers.get("Content-Disposition") || "";
  const m = /filename="([^"]+)"/.exec(disp);
  const blob = await resp.blob();
  const url = URL.createObjectURL(blob);
  const a = document.createElement("a");
  a.href = url;
  a.download = m ? m[1] : jobId;
  document.body.appendChild(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 60000);
}
