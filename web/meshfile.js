// SPDX-License-Identifier: AGPL-3.0-or-later
// meshfile.js - triangles of a mesh file for the portal's 3D view only
// (the server's readers, engine/mesh/, are what jobs use): STL (binary
// and ASCII), OBJ, OFF and ASCII PLY, polygons fanned into triangles.
// Returns a Float32Array of x, y, z per corner, or null for a format or
// a file this viewer does not read.

const MAX_TRIANGLES = 5000000;

function fan(faceIdx, verts, out) {
  for (let i = 1; i + 1 < faceIdx.length; i++) {
    for (const j of [faceIdx[0], faceIdx[i], faceIdx[i + 1]]) {
      if (j < 0 || j * 3 + 2 >= verts.length) return false;
      out.push(verts[j * 3], verts[j * 3 + 1], verts[j * 3 + 2]);
    }
  }
  return true;
}

function numbers(line) {
  return line.trim().split(/\s+/).map(Number);
}

function parseSTL(buf) {
  const dv = new DataView(buf);
  if (buf.byteLength >= 84) {
    const n = dv.getUint32(80, true);
    if (84 + n * 50 === buf.byteLength && n <= MAX_TRIANGLES) {
      const out = new Float32Array(n * 9);
      for (let t = 0; t < n; t++) {
        for (let k = 0; k < 9; k++) out[t * 9 + k] = dv.getFloat32(84 + t * 50 + 12 + k * 4, true);
      }
      return out;
    }
  }
  const text = new TextDecoder().decode(buf);
  const out = [];
  const re = /vertex\s+(\S+)\s+(\S+)\s+(\S+)/g;
  let m;
  while ((m = re.exec(text)) !== null) out.push(Number(m[1]), Number(m[2]), Number(m[3]));
  return out.length ? Float32Array.from(out) : null;
}

function parseOBJ(text) {
  const verts = [];
  const out = [];
  for (const line of text.split("\n")) {
    if (line.startsWith("v ")) {
      verts.push(...numbers(line.slice(2)).slice(0, 3));
    } else if (line.startsWith("f ")) {
      const n = verts.length / 3;
      const idx = line.slice(2).trim().split(/\s+/).map((w) => {
        const i = parseInt(w, 10);
        return i < 0 ? n + i : i - 1;
      });
      if (!fan(idx, verts, out)) return null;
    }
  }
  return out.length ? Float32Array.from(out) : null;
}

function parseOFF(text) {
  const lines = text.split("\n").map((l) => l.replace(/#.*/, "").trim()).filter((l) => l);
  if (!lines.length || !/^[CN]*OFF/.test(lines[0])) return null;
  let at = 0;
  let head = lines[0].replace(/^[CN]*OFF/, "").trim();
  if (!head) head = lines[++at];
  const [nv, nf] = numbers(head);
  if (!(nv > 0 && nf > 0) || nf > MAX_TRIANGLES) return null;
  const verts = [];
  for (let i = 0; i < nv; i++) verts.push(...numbers(lines[++at] || "").slice(0, 3));
  const out = [];
  for (let i = 0; i < nf; i++) {
    const f = numbers(lines[++at] || "");
    if (!fan(f.slice(1, 1 + f[0]), verts, out)) return null;
  }
  return Float32Array.from(out);
}

function parsePLY(text) {
  const lines = text.split("\n");
  if (!lines[0].startsWith("ply") || !/format ascii/.test(text.slice(0, 400))) return null;
  let nv = 0;
  let nf = 0;
  let at = 0;
  while (at < lines.length && lines[at].trim() !== "end_header") {
    const w = lines[at].trim().split(/\s+/);
    if (w[0] === "element" && w[1] === "vertex") nv = Number(w[2]);
    if (w[0] === "element" && w[1] === "face") nf = Number(w[2]);
    at++;
  }
  const verts = [];
  for (let i = 0; i < nv; i++) verts.push(...numbers(lines[++at] || "").slice(0, 3));
  const out = [];
  for (let i = 0; i < nf; i++) {
    const f = numbers(lines[++at] || "");
    if (!fan(f.slice(1, 1 + f[0]), verts, out)) return null;
  }
  return out.length ? Float32Array.from(out) : null;
}

export function parseMesh(name, buf) {
  const ext = name.slice(name.lastIndexOf(".") + 1).toLowerCase();
  try {
    if (ext === "stl") return parseSTL(buf);
    const text = new TextDecoder().decode(buf);
    if (ext === "obj") return parseOBJ(text);
    if (ext === "off") return parseOFF(text);
    if (ext === "ply") return parsePLY(text);
  } catch {
    return null;
  }
  return null;
}
