// SPDX-License-Identifier: AGPL-3.0-or-later
// plots.js - small SVG figures of a job's metrics (docs/metrics.md):
// material fraction, volume reduction and, where the engine measured it,
// compliance against the solid part's, as labelled bars; a rhombic
// optimisation history as a line.  Built with DOM calls (no markup text).

const NS = "http://www.w3.org/2000/svg";

function el(name, attrs, text) {
  const e = document.createElementNS(NS, name);
  for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, String(v));
  if (text !== undefined) e.textContent = text;
  return e;
}

function fmt(v) {
  return Math.abs(v) >= 100 ? v.toFixed(0) : v.toPrecision(3);
}

// bars: [{label, value, max, text}]
function barChart(title, bars) {
  const w = 320;
  const rowH = 22;
  const h = 24 + rowH * bars.length;
  const svg = el("svg", { width: w, height: h, viewBox: `0 0 ${w} ${h}`, role: "img" });
  svg.appendChild(el("title", {}, title));
  svg.appendChild(el("text", { x: 0, y: 14, class: "plot-title" }, title));
  bars.forEach((b, i) => {
    const y = 22 + i * rowH;
    const frac = b.max > 0 ? Math.max(0, Math.min(1, b.value / b.max)) : 0;
    svg.appendChild(el("text", { x: 0, y: y + 14, class: "plot-label" }, b.label));
    svg.appendChild(el("rect", { x: 120, y: y + 3, width: 150, height: 14, class: "plot-track" }));
    svg.appendChild(el("rect", { x: 120, y: y + 3, width: (150 * frac).toFixed(1), height: 14, class: "plot-bar" }));
    svg.appendChild(el("text", { x: 276, y: y + 14, class: "plot-label" }, b.text));
  });
  return svg;
}

function lineChart(title, values) {
  const w = 320;
  const h = 120;
  const svg = el("svg", { width: w, height: h, viewBox: `0 0 ${w} ${h}`, role: "img" });
  svg.appendChild(el("title", {}, title));
  svg.appendChild(el("text", { x: 0, y: 14, class: "plot-title" }, title));
  const lo = Math.min(...values);
  const hi = Math.max(...values);
  const pts = values.map((v, i) => {
    const x = 30 + (values.length > 1 ? (i / (values.length - 1)) * 280 : 0);
    const y = 110 - (hi > lo ? ((v - lo) / (hi - lo)) * 80 : 40);
    return x.toFixed(1) + "," + y.toFixed(1);
  });
  svg.appendChild(el("polyline", { points: pts.join(" "), class: "plot-line" }));
  svg.appendChild(el("text", { x: 0, y: 34, class: "plot-label" }, fmt(hi)));
  svg.appendChild(el("text", { x: 0, y: 110, class: "plot-label" }, fmt(lo)));
  return svg;
}

export function metricPlots(metrics, engine) {
  const out = [];
  if (!metrics) return out;
  const mf = metrics.material_fraction;
  if (typeof mf === "number") {
    out.push(barChart("Material", [
      { label: "material fraction", value: mf, max: 1, text: (mf * 100).toFixed(1) + " %" },
      { label: "volume reduction", value: 1 - mf, max: 1, text: ((1 - mf) * 100).toFixed(1) + " %" },
    ]));
  }
  const e = metrics[engine] || {};
  const c = e.compliance_nmm;
  const c0 = e.compliance_solid_nmm;
  if (typeof c === "number" && typeof c0 === "number" && c0 > 0) {
    const m = Math.max(c, c0);
    out.push(barChart("Compliance (N mm, lower is stiffer)", [
      { label: "this part", value: c, max: m, text: fmt(c) },
      { label: "solid part", value: c0, max: m, text: fmt(c0) },
    ]));
  }
  if (Array.isArray(e.history)) {
    const vals = e.history.map((h) => (h && typeof h.compliance_nmm === "number" ? h.compliance_nmm : null))
      .filter((v) => v !== null);
    if (vals.length > 1) out.push(lineChart("Compliance per solve", vals));
  }
  return out;
}
