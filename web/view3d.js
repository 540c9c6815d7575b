// SPDX-License-Identifier: AGPL-3.0-or-later
// view3d.js - the portal's turnable 3D view of an uploaded part, with
// three.js (vendored: web/vendor/three.module.min.js, MIT).  The file's
// +z points up (as in the printer before `up` is applied); the part is
// centred and scaled to the view.  Drag with a pointer, or use the arrow
// keys (and + / -) while the canvas has focus.

import * as THREE from "./three.module.min.js";

export class MeshView {
  constructor(canvas) {
    this.canvas = canvas;
    this.yaw = 0.6;
    this.pitch = 0.4;
    this.zoom = 1;
    try {
      this.renderer = new THREE.WebGLRenderer({ canvas, antialias: true });
    } catch {
      this.renderer = null; // no WebGL: the analysis table still shows
      return;
    }
    this.renderer.setClearColor(0x202024);
    this.scene = new THREE.Scene();
    this.camera = new THREE.PerspectiveCamera(35, canvas.width / canvas.height, 0.01, 100);
    this.scene.add(new THREE.AmbientLight(0xffffff, 0.5));
    const sun = new THREE.DirectionalLight(0xffffff, 1.6);
    sun.position.set(1, 2, 3);
    this.scene.add(sun);
    this.pivot = new THREE.Group();
    this.scene.add(this.pivot);
    this.bindInput();
    this.render();
  }

  bindInput() {
    let drag = null;
    this.canvas.addEventListener("pointerdown", (ev) => {
      drag = { x: ev.clientX, y: ev.clientY };
      this.canvas.setPointerCapture(ev.pointerId);
    });
    this.canvas.addEventListener("pointermove", (ev) => {
      if (!drag) return;
      this.turn((ev.clientX - drag.x) * 0.01, (ev.clientY - drag.y) * 0.01);
      drag = { x: ev.clientX, y: ev.clientY };
    });
    this.canvas.addEventListener("pointerup", () => {
      drag = null;
    });
    this.canvas.addEventListener("keydown", (ev) => {
      const step = 0.15;
      const keys = {
        ArrowLeft: [-step, 0], ArrowRight: [step, 0], ArrowUp: [0, -step], ArrowDown: [0, step],
      };
      if (keys[ev.key]) {
        this.turn(keys[ev.key][0], keys[ev.key][1]);
      } else if (ev.key === "+" || ev.key === "=") {
        this.zoom = Math.min(this.zoom * 1.15, 8);
        this.render();
      } else if (ev.key === "-") {
        this.zoom = Math.max(this.zoom / 1.15, 0.2);
        this.render();
      } else {
        return;
      }
      ev.preventDefault();
    });
  }

  turn(dYaw, dPitch) {
    this.yaw += dYaw;
    this.pitch = Math.max(-1.5, Math.min(1.5, this.pitch + dPitch));
    this.render();
  }

  // positions: Float32Array of x, y, z per triangle corner (file units).
  show(positions) {
    if (!this.renderer) return false;
    this.pivot.clear();
    if (!positions || positions.length < 9) {
      this.render();
      return false;
    }
    const geo = new THREE.BufferGeometry();
    geo.setAttribute("position", new THREE.BufferAttribute(positions, 3));
    geo.computeBoundingBox();
    const box = geo.boundingBox;
    const size = new THREE.Vector3();
    const centre = new THREE.Vector3();
    box.getSize(size);
    box.getCenter(centre);
    const s = 1 / Math.max(size.x, size.y, size.z, 1e-9);
    geo.translate(-centre.x, -centre.y, -centre.z);
    geo.scale(s, s, s);
    geo.computeVertexNormals();
    const mat = new THREE.MeshStandardMaterial({ color: 0xff8c38, roughness: 0.6, flatShading: true });
    const mesh = new THREE.Mesh(geo, mat);
    mesh.rotation.x = -Math.PI / 2; // file +z up -> three's +y up
    this.pivot.add(mesh);
    this.render();
    return true;
  }

  render() {
    if (!this.renderer) return;
    const d = 2.2 / this.zoom;
    this.camera.position.set(
      d * Math.cos(this.pitch) * Math.sin(this.yaw),
      d * Math.sin(this.pitch),
      d * Math.cos(this.pitch) * Math.cos(this.yaw),
    );
    this.camera.lookAt(0, 0, 0);
    this.renderer.render(this.scene, this.camera);
  }
}
