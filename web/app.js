// SPDX-License-Identifier: AGPL-3.0-or-later
// app.js - the infilld portal (docs/portal.md): sign in with an API key,
// upload a part and look at it, configure a job from GET /v1/engines,
// follow its progress, preview its layers, read its metrics, download it;
// the admin key sees tenants and the queue.  Everything goes through the
// public REST API (api.js).  Text from the server or from files is set
// with textContent only.

import * as api from "./api.js";
import { parseMesh } from "./meshfile.js";
import { metricPlots } from "./plots.js";
import { MeshView } from "./view3d.js";

const $ = (id) => document.getElementById(id);

const state = {
  engines: null, // GET /v1/engines
  mesh: null, // the uploaded mesh record
  job: null, // the job on show
  follow: null, // AbortController of the event stream
  layerUrl: null, // object URL of the layer image on show
  layerTimer: 0,
  cursors: [], // job list: cursors of the pages before the one shown
  cursor: null, // cursor of the page shown (null = first)
  view: null,
};

function clear(node) {
  while (node.firstChild) node.removeChild(node.firstChild);
}

function cell(row, text, header) {
  const c = document.createElement(header ? "th" : "td");
  if (header) c.scope = "row";
  c.textContent = text;
  row.appendChild(c);
  return c;
}

function fmtNum(v) {
  if (typeof v !== "number") return String(v);
  if (Number.isInteger(v)) return String(v);
  return Math.abs(v) >= 1000 ? v.toFixed(1) : String(Number(v.toPrecision(5)));
}

function fmtBytes(n) {
  if (!n) return "0";
  const u = ["B", "KiB", "MiB", "GiB", "TiB"];
  let i = 0;
  while (n >= 1024 && i < u.length - 1) {
    n /= 1024;
    i++;
  }
  return (i ? n.toFixed(1) : String(n)) + " " + u[i];
}

// Rows "a.b.c: value" for a nested object, arrays of scalars joined.
function flatten(obj, prefix, out) {
  for (const [k, v] of Object.entries(obj || {})) {
    const key = prefix ? prefix + "." + k : k;
    if (v && typeof v === "object" && !Array.isArray(v)) flatten(v, key, out);
    else if (Array.isArray(v) && v.some((x) => x && typeof x === "object")) out.push([key, v.length + " entries"]);
    else if (Array.isArray(v)) out.push([key, v.map(fmtNum).join(", ")]);
    else out.push([key, v === null ? "-" : fmtNum(v)]);
  }
  return out;
}

function fillTable(tbody, rows) {
  clear(tbody);
  for (const [k, v] of rows) {
    const tr = document.createElement("tr");
    cell(tr, k, true);
    cell(tr, v);
    tbody.appendChild(tr);
  }
}

// ---- sign in ----

async function signIn(key) {
  api.setKey(key);
  try {
    state.engines = await api.getJSON("/v1/engines");
    $("who").textContent = "Signed in with a tenant key.";
    $("tenant-ui").hidden = false;
    $("admin").hidden = true;
    buildForm();
    listJobs(null);
  } catch (e) {
    if (!(e instanceof api.ApiError) || e.status !== 401) throw e;
    await api.getJSON("/v1/tenants"); // the admin key, or a bad key (throws)
    $("who").textContent = "Signed in with the admin key.";
    $("tenant-ui").hidden = true;
    $("admin").hidden = false;
    refreshAdmin();
  }
  $("signin").hidden = true;
  $("app").hidden = false;
  $("signout").hidden = false;
}

function signOut() {
  if (state.follow) state.follow.abort();
  api.setKey("");
  location.reload();
}

// ---- admin: tenants and queue ----

async function refreshAdmin() {
  const t = await api.getJSON("/v1/tenants");
  const body = $("tenant-table").tBodies[0];
  clear(body);
  for (const x of t.tenants) {
    const tr = document.createElement("tr");
    cell(tr, x.name, true);
    cell(tr, String(x.max_jobs));
    cell(tr, fmtBytes(x.max_upload_bytes));
    cell(tr, x.quota_bytes ? fmtBytes(x.quota_bytes) : "none");
    cell(tr, fmtBytes(x.used_bytes));
    body.appendChild(tr);
  }
  // The queue: the public /metrics gauges (no per-tenant figures).
  const text = await (await fetch("/metrics")).text();
  const rows = [];
  for (const m of text.matchAll(/^infilld_jobs\{state="(\w+)"\} (\d+)$/gm)) rows.push([m[1], m[2]]);
  const depth = /^infilld_queue_depth (\d+)$/m.exec(text);
  if (depth) rows.push(["waiting to run", depth[1]]);
  const workers = /^infilld_workers\{kind="alive"\} (\d+)$/m.exec(text);
  if (workers) rows.push(["workers alive", workers[1]]);
  fillTable($("queue-table").tBodies[0], rows);
}

// ---- upload and the part ----

async function upload(file) {
  const bar = $("upload-progress");
  const status = $("upload-status");
  bar.value = 0;
  status.textContent = "Uploading " + file.name + " …";
  $("mesh-info").hidden = true;
  $("configure").hidden = true;
  const viewing = file.arrayBuffer().then((buf) => parseMesh(file.name, buf));
  try {
    state.mesh = await api.uploadMesh(file, (f) => {
      bar.value = Math.round(f * 100);
    });
  } catch (e) {
    status.textContent = "Upload failed: " + e.message;
    return;
  }
  bar.value = 100;
  status.textContent = "Uploaded " + state.mesh.name + " (" + fmtBytes(state.mesh.size_bytes) + ").";
  showAnalysis();
  $("mesh-info").hidden = false;
  $("configure").hidden = false;
  if (!state.view) state.view = new MeshView($("view"));
  const positions = await viewing;
  if (!state.view.show(positions)) $("view-help").textContent = "No 3D view for this file.";
}

function showAnalysis() {
  const a = state.mesh.analysis || {};
  const m = a.mesh || {};
  const s = a.size_mm || {};
  const r = m.repairs || {};
  const rows = [
    ["name", state.mesh.name],
    ["format", m.format || state.mesh.format],
    ["triangles", fmtNum(m.triangles)],
    ["size (mm, as uploaded)", [s.x, s.y, s.z].map(fmtNum).join(" × ")],
    ["volume (mm³)", fmtNum(m.volume_mm3)],
    ["watertight", m.watertight ? "yes" : "no"],
    ["components", fmtNum(m.components)],
    ["repairs", "welded " + (r.welded_vertices || 0) + ", dropped " + (r.dropped_triangles || 0) +
      ", reoriented " + (r.reoriented_faces || 0) + (r.flipped ? ", flipped" : "")],
  ];
  for (const w of a.warnings || []) rows.push(["warning", w]);
  fillTable($("analysis").tBodies[0], rows);
  showFits();
}

function setting(printer, name) {
  const s = printer.settings.find((x) => x.name === name);
  return s ? s.default : undefined;
}

// Whether the part fits each printer at the height the form asks for
// (or as uploaded); the server checks again at submission.
function showFits() {
  const ul = $("fits");
  clear(ul);
  if (!state.mesh || !state.engines) return;
  const s = (state.mesh.analysis || {}).size_mm;
  if (!s) return;
  const h = Number(($("p-height_mm") || {}).value) || 0;
  const k = h > 0 && s.z > 0 ? h / s.z : 1;
  for (const p of state.engines.printers) {
    let lim;
    if (p.kind === "fdm") lim = [setting(p, "bed_x_mm"), setting(p, "bed_y_mm"), setting(p, "max_z_mm")];
    else lim = [setting(p, "display_mm_x"), setting(p, "display_mm_y"), Infinity];
    const dims = [s.x * k, s.y * k, s.z * k];
    const fits = dims.every((d, i) => !(lim[i] > 0) || d <= lim[i]);
    const li = document.createElement("li");
    li.textContent = p.name + " (" + p.kind + "): " + (fits ? "fits" : "too large") + " at " +
      dims.map(fmtNum).join(" × ") + " mm";
    ul.appendChild(li);
  }
}

// ---- the job form, from GET /v1/engines ----

function paramInput(p) {
  const id = "p-" + p.name;
  const row = document.createElement("div");
  row.className = "row param";
  row.dataset.param = p.name;
  const label = document.createElement("label");
  label.htmlFor = id;
  label.textContent = p.name + (p.unit && p.unit !== "path" ? " (" + p.unit + ")" : "");
  row.appendChild(label);
  let input;
  if (p.type === "enum" || p.type === "bool") {
    input = document.createElement("select");
    const choices = p.type === "bool" ? ["true", "false"] : p.choices;
    const def = document.createElement("option");
    def.value = "";
    def.textContent = "default (" + String(p.default) + ")";
    input.appendChild(def);
    for (const c of choices) {
      const o = document.createElement("option");
      o.value = c;
      o.textContent = c;
      input.appendChild(o);
    }
  } else if (p.name === "loads") {
    input = document.createElement("textarea");
    input.rows = 3;
    input.placeholder = '{"material": …, "fixed": […], "forces": […]}';
  } else {
    input = document.createElement("input");
    input.type = p.type === "number" || p.type === "int" ? "number" : "text";
    if (p.type === "int") input.step = "1";
    if (p.type === "number") input.step = "any";
    if (typeof p.min === "number" && p.type !== "vec3") input.min = String(p.min);
    if (typeof p.max === "number" && p.type !== "vec3") input.max = String(p.max);
    const d = Array.isArray(p.default) ? p.default.join(", ") : String(p.default);
    input.placeholder = d === "" ? "(none)" : d;
  }
  input.id = id;
  input.name = p.name;
  const help = document.createElement("p");
  help.className = "help";
  help.id = id + "-help";
  let range = "";
  if (typeof p.min === "number" && typeof p.max === "number") {
    range = " Range " + (p.min_exclusive ? "(" : "[") + p.min + ", " + p.max + (p.max_exclusive ? ")" : "]") + ".";
  }
  help.textContent = (p.help || "") + range + (p.zero_means_auto ? " 0 = automatic." : "");
  const err = document.createElement("p");
  err.className = "error field-error";
  err.id = id + "-error";
  input.setAttribute("aria-describedby", help.id + " " + err.id);
  row.appendChild(input);
  row.appendChild(help);
  row.appendChild(err);
  return row;
}

function group(title, params, open) {
  const d = document.createElement("details");
  d.open = open;
  const s = document.createElement("summary");
  s.textContent = title;
  d.appendChild(s);
  for (const p of params) if (!p.cli_only) d.appendChild(paramInput(p));
  return d;
}

function currentPrinter() {
  const name = $("f-printer").value;
  return state.engines.printers.find((p) => p.name === name);
}

function buildParams() {
  const fs = $("params");
  const keep = {};
  for (const el of fs.querySelectorAll("input, select, textarea")) if (el.value) keep[el.name] = el.value;
  for (const d of Array.from(fs.querySelectorAll("details"))) d.remove();
  const eng = state.engines.engines.find((e) => e.name === $("f-engine").value);
  fs.appendChild(group("Placement and common", state.engines.common_params, true));
  fs.appendChild(group("Engine " + eng.name, eng.params, true));
  const pr = currentPrinter();
  if (pr) fs.appendChild(group("Printer " + pr.name + " settings", pr.settings, false));
  for (const el of fs.querySelectorAll("input, select, textarea")) if (keep[el.name]) el.value = keep[el.name];
  $("f-engine-help").textContent = eng.summary + (eng.paper ? " (" + eng.paper + ")" : "");
  $("p-height_mm").addEventListener("input", showFits);
}

function fillPrinters() {
  const fmt = state.engines.formats.find((f) => f.name === $("f-format").value);
  const kind = fmt.kind === "gcode" ? "fdm" : fmt.kind === "mesh" ? null : "resin";
  const sel = $("f-printer");
  const was = sel.value;
  clear(sel);
  for (const p of state.engines.printers) {
    if (kind && p.kind !== kind) continue;
    const o = document.createElement("option");
    o.value = p.name;
    o.textContent = p.name + " (" + p.kind + ")";
    sel.appendChild(o);
  }
  const def = fmt.default_printer || (kind ? null : "sl1");
  sel.value = Array.from(sel.options).some((o) => o.value === was) ? was : def || sel.options[0].value;
}

function buildForm() {
  const sel = $("f-engine");
  clear(sel);
  for (const e of state.engines.engines) {
    const o = document.createElement("option");
    o.value = e.name;
    o.textContent = e.name;
    sel.appendChild(o);
  }
  fillPrinters();
  buildParams();
}

function describe(name) {
  const eng = state.engines.engines.find((e) => e.name === $("f-engine").value);
  const pr = currentPrinter();
  const all = state.engines.common_params.concat(eng.params, pr ? pr.settings : []);
  return all.find((p) => p.name === name);
}

function showFieldError(name, msg) {
  const err = $("p-" + name + "-error") || $("f-" + name + "-error");
  const input = $("p-" + name) || $("f-" + name);
  if (err) err.textContent = msg;
  if (input) {
    input.setAttribute("aria-invalid", "true");
    const d = input.closest("details");
    if (d) d.open = true;
    input.focus();
  }
  return !!err;
}

function clearErrors() {
  for (const e of document.querySelectorAll(".field-error")) e.textContent = "";
  for (const i of document.querySelectorAll("[aria-invalid]")) i.removeAttribute("aria-invalid");
  $("form-error").textContent = "";
}

// The params object of the form; throws {field, message} on a value the
// description refuses (the server checks the same and more).
function collectParams() {
  const params = {};
  for (const el of $("params").querySelectorAll("input, select, textarea")) {
    const raw = el.value.trim();
    if (raw === "") continue;
    const p = describe(el.name);
    if (!p) continue;
    let v;
    if (p.type === "bool") v = raw === "true";
    else if (p.type === "enum") v = raw;
    else if (p.name === "loads") {
      try {
        v = JSON.parse(raw);
      } catch {
        throw { field: p.name, message: "not valid JSON" };
      }
    } else if (p.type === "vec3") {
      v = raw.split(/[\s,]+/).map(Number);
      if (v.length !== 3 || v.some((x) => !Number.isFinite(x))) throw { field: p.name, message: "three numbers, e.g. 0.5, 0.5, 0" };
    } else if (p.type === "string") v = raw;
    else {
      v = Number(raw);
      if (!Number.isFinite(v)) throw { field: p.name, message: "must be a number" };
      if (p.type === "int" && !Number.isInteger(v)) throw { field: p.name, message: "must be a whole number" };
    }
    if (typeof v === "number" && typeof p.min === "number" && typeof p.max === "number") {
      const below = p.min_exclusive ? v <= p.min : v < p.min;
      const above = p.max_exclusive ? v >= p.max : v > p.max;
      if ((below || above) && !(p.zero_means_auto && v === 0)) {
        throw { field: p.name, message: "must be in " + (p.min_exclusive ? "(" : "[") + p.min + ", " + p.max + (p.max_exclusive ? ")" : "]") };
      }
    }
    params[p.name] = v;
  }
  return params;
}

async function submitJob(ev) {
  ev.preventDefault();
  clearErrors();
  let params;
  try {
    params = collectParams();
  } catch (e) {
    showFieldError(e.field, e.message);
    return;
  }
  const body = {
    mesh_id: state.mesh.id, engine: $("f-engine").value, format: $("f-format").value,
    printer: $("f-printer").value, params,
  };
  try {
    const job = await api.sendJSON("POST", "/v1/jobs", body);
    showJob(job);
    listJobs(null);
  } catch (e) {
    if (e instanceof api.ApiError && e.status === 422 && e.field && showFieldError(e.field, e.message)) return;
    $("form-error").textContent = e.message;
  }
}

// ---- one job: progress, layers, metrics, download ----

function renderJob(job) {
  state.job = job;
  $("job").hidden = false;
  $("job-id").textContent = job.id;
  $("job-state").textContent = job.state;
  $("job-stage").textContent = job.stage ? "(" + job.stage + ")" : "";
  $("job-progress").value = Math.round((job.progress || 0) * 100);
  $("job-progress").setAttribute("aria-valuetext", Math.round((job.progress || 0) * 100) + " %");
  $("job-layers").textContent = job.layers_total ? "layers " + job.layers_done + " of " + job.layers_total : "";
  $("job-error").textContent = job.error ? job.error.detail : "";
  const running = job.state === "queued" || job.state === "running";
  $("cancel").hidden = !running;
  $("download").hidden = job.state !== "succeeded";
}

async function showJob(job) {
  if (state.follow) state.follow.abort();
  $("result").hidden = true;
  renderJob(job);
  $("job").scrollIntoView();
  if (job.state === "queued" || job.state === "running") {
    const ctl = new AbortController();
    state.follow = ctl;
    try {
      await api.followEvents(job.id, (type, snap) => {
        if (!ctl.signal.aborted) renderJob(snap);
      }, ctl.signal);
    } catch (e) {
      $("job-error").textContent = e.message;
    }
    if (ctl.signal.aborted) return;
    job = await api.getJSON("/v1/jobs/" + encodeURIComponent(job.id));
    renderJob(job);
    listJobs(state.cursor);
  }
  if (job.state === "succeeded") showResult(job);
}

async function showResult(job) {
  const tbody = $("metrics").tBodies[0];
  fillTable(tbody, flatten(job.metrics, "", []));
  const plots = $("plots");
  clear(plots);
  for (const svg of metricPlots(job.metrics, job.engine)) plots.appendChild(svg);
  const slider = $("layer");
  const isMesh = job.format === "stl" || job.format === "obj";
  $("result").hidden = false;
  $("legend").hidden = job.format !== "gcode";
  slider.disabled = isMesh;
  if (isMesh) {
    $("layer-count").textContent = "0 (a mesh output has no layers)";
    return;
  }
  slider.value = "0";
  await showLayer(0);
}

async function showLayer(k) {
  const job = state.job;
  try {
    const { url, count } = await api.layerImage(job.id, k);
    if (state.job !== job) {
      URL.revokeObjectURL(url);
      return;
    }
    if (state.layerUrl) URL.revokeObjectURL(state.layerUrl);
    state.layerUrl = url;
    const img = $("layer-img");
    img.alt = "layer " + k + " of job " + job.id;
    img.src = url;
    img.dataset.layer = String(k);
    $("layer").max = String(Math.max(count - 1, 0));
    $("layer-count").textContent = String(count);
    $("layer-no").textContent = String(k);
  } catch (e) {
    $("job-error").textContent = e.message;
  }
}

// ---- the job list ----

async function listJobs(cursor) {
  const q = new URLSearchParams({ limit: "10" });
  const st = $("jobs-state").value;
  if (st) q.set("state", st);
  if (cursor) q.set("cursor", cursor);
  const page = await api.getJSON("/v1/jobs?" + q.toString());
  state.cursor = cursor;
  const body = $("jobs-table").tBodies[0];
  clear(body);
  for (const j of page.jobs) {
    const tr = document.createElement("tr");
    const th = cell(tr, "", true);
    const b = document.createElement("button");
    b.type = "button";
    b.className = "link";
    b.textContent = j.id;
    b.addEventListener("click", () => showJob(j));
    th.appendChild(b);
    cell(tr, j.mesh_id);
    cell(tr, j.engine);
    cell(tr, j.format);
    cell(tr, j.state);
    cell(tr, Math.round(j.progress * 100) + " %");
    cell(tr, j.created_at);
    body.appendChild(tr);
  }
  $("jobs-prev").disabled = state.cursors.length === 0;
  const next = $("jobs-next");
  next.disabled = !page.next_cursor;
  next.dataset.cursor = page.next_cursor || "";
}

// ---- wiring ----

function wire() {
  $("signin-form").addEventListener("submit", async (ev) => {
    ev.preventDefault();
    const key = $("apikey").value.trim();
    $("apikey-error").textContent = "";
    if (!key) {
      $("apikey-error").textContent = "Enter your API key.";
      return;
    }
    try {
      await signIn(key);
    } catch (e) {
      api.setKey("");
      $("apikey-error").textContent = "Sign-in failed: " + e.message;
      $("apikey").focus();
    }
  });
  $("signout").addEventListener("click", signOut);
  $("admin-refresh").addEventListener("click", refreshAdmin);
  const drop = $("drop");
  drop.addEventListener("dragover", (ev) => {
    ev.preventDefault();
    drop.classList.add("over");
  });
  drop.addEventListener("dragleave", () => drop.classList.remove("over"));
  drop.addEventListener("drop", (ev) => {
    ev.preventDefault();
    drop.classList.remove("over");
    if (ev.dataTransfer.files.length) upload(ev.dataTransfer.files[0]);
  });
  $("file").addEventListener("change", () => {
    if ($("file").files.length) upload($("file").files[0]);
  });
  $("f-engine").addEventListener("change", buildParams);
  $("f-format").addEventListener("change", () => {
    fillPrinters();
    buildParams();
  });
  $("f-printer").addEventListener("change", buildParams);
  $("job-form").addEventListener("submit", submitJob);
  $("cancel").addEventListener("click", async () => {
    try {
      renderJob(await api.sendJSON("DELETE", "/v1/jobs/" + encodeURIComponent(state.job.id)));
    } catch (e) {
      $("job-error").textContent = e.message;
    }
  });
  $("download").addEventListener("click", (ev) => {
    ev.preventDefault();
    api.download(state.job.id).catch((e) => {
      $("job-error").textContent = e.message;
    });
  });
  $("layer").addEventListener("input", () => {
    const k = Number($("layer").value);
    $("layer-no").textContent = String(k);
    clearTimeout(state.layerTimer);
    state.layerTimer = setTimeout(() => showLayer(k), 80);
  });
  $("jobs-state").addEventListener("change", () => {
    state.cursors = [];
    listJobs(null);
  });
  $("jobs-refresh").addEventListener("click", () => listJobs(state.cursor));
  $("jobs-first").addEventListener("click", () => {
    state.cursors = [];
    listJobs(null);
  });
  $("jobs-prev").addEventListener("click", () => {
    if (state.cursors.length) listJobs(state.cursors.pop());
  });
  $("jobs-next").addEventListener("click", () => {
    state.cursors.push(state.cursor);
    listJobs($("jobs-next").dataset.cursor);
  });
  const key = api.getKey();
  if (key) {
    signIn(key).catch(() => {
      api.setKey("");
    });
  }
}

wire();
