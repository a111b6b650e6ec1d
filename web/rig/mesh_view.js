// A rig builder viewport (template, target or result): a Viewport sized by its box, click picking
// of the nearest vertex of the picked triangle, marker spheres that can be dragged over the mesh.

import * as THREE from 'three';
import { restBox } from '../avatar.js';
import { Viewport } from '../viewport.js';

export class MeshView extends Viewport {
  /**
   * `onPick(vertex, point)` is called for a click (not a drag) on the mesh; `onDrag(pair, vertex)`
   * while a marker of a pair is dragged (the mesh's vertex nearest to the pointer).
   */
  constructor(el, { onPick, onDrag } = {}) {
    super(el.querySelector('canvas'), { sizeOf: el, fov: 25, near: 0.01 });
    this.el = el;
    this.pendingEl = el.querySelector('.pending');
    this.root = null;
    this.markers = new THREE.Group();
    this.scene.add(this.markers);
    this.offsets = new Map(); // position attribute -> index offset of its first vertex
    this.radius = 1;
    this.onPick = onPick;
    this.onDrag = onDrag;
    this.dragging = null; // the pair whose marker follows the pointer
    const down = { x: 0, y: 0, t: 0 };
    this.canvas.addEventListener('pointerdown', (e) => {
      Object.assign(down, { x: e.clientX, y: e.clientY, t: performance.now() });
      const marker = this.onDrag && this.hitAt(e.clientX, e.clientY, this.markers)[0]?.object;
      if (marker?.userData.pair === undefined) return;
      this.dragging = marker.userData.pair;
      this.controls.enabled = false;
      this.canvas.setPointerCapture(e.pointerId);
    });
    this.canvas.addEventListener('pointermove', (e) => {
      if (this.dragging === null) return;
      const v = this.vertexAt(e.clientX, e.clientY);
      if (v) this.onDrag(this.dragging, v.vertex);
    });
    this.canvas.addEventListener('pointerup', (e) => {
      if (this.dragging !== null) {
        this.dragging = null;
        this.controls.enabled = true;
        return;
      }
      const moved = Math.hypot(e.clientX - down.x, e.clientY - down.y);
      if (moved < 5 && performance.now() - down.t < 600 && this.onPick) this.pickAt(e.clientX, e.clientY);
    });
    this.observeSize();
  }

  setObject(root) {
    if (this.root) this.scene.remove(this.root);
    this.root = root;
    this.scene.add(root);
    this.offsets = new Map();
    let off = 0;
    root.traverse((o) => {
      if (o.isMesh && !this.offsets.has(o.geometry.attributes.position)) {
        this.offsets.set(o.geometry.attributes.position, off);
        off += o.geometry.attributes.position.count;
      }
    });
    this.vertexCount = off;
    const box = restBox(root);
    const size = box.getSize(new THREE.Vector3());
    const center = box.getCenter(new THREE.Vector3());
    this.radius = 0.5 * size.length();
    const dist = this.fitDistance(size, { margin: 1.15, widthShare: 0.5 });
    this.camera.near = dist / 100;
    this.camera.far = dist * 50;
    this.camera.position.set(center.x, center.y, center.z + dist);
    this.camera.updateProjectionMatrix();
    this.controls.target.copy(center);
    this.controls.update();
    this.clearMarkers();
    this.dirty = true;
  }

  /** The world position of vertex index i (over all position attributes, in traversal order). */
  vertexPosition(i, target = new THREE.Vector3()) {
    let found = null;
    this.root?.traverse((o) => {
      if (found || !o.isMesh) return;
      const attr = o.geometry.attributes.position;
      const off = this.offsets.get(attr);
      if (i >= off && i < off + attr.count) found = o;
    });
    if (!found) return null;
    const off = this.offsets.get(found.geometry.attributes.position);
    found.getVertexPosition(i - off, target);
    return found.localToWorld(target);
  }

  /** The ray's hits on `object` (and its children) under a client position. */
  hitAt(clientX, clientY, object) {
    const r = this.canvas.getBoundingClientRect();
    const ndc = new THREE.Vector2(((clientX - r.left) / r.width) * 2 - 1, -((clientY - r.top) / r.height) * 2 + 1);
    const ray = new THREE.Raycaster();
    ray.setFromCamera(ndc, this.camera);
    return ray.intersectObject(object, true).filter((h) => h.face && h.object.isMesh);
  }

  /** The client position of vertex i on the canvas (for the browser tests' drags). */
  screenOf(i) {
    const p = this.vertexPosition(i);
    if (!p) return null;
    p.project(this.camera);
    const r = this.canvas.getBoundingClientRect();
    return { x: r.left + ((p.x + 1) / 2) * r.width, y: r.top + ((1 - p.y) / 2) * r.height };
  }

  pickAt(clientX, clientY) {
    const v = this.vertexAt(clientX, clientY);
    if (v) this.onPick(v.vertex, v.point);
  }

  /** The vertex nearest to where the ray under a client position meets the mesh, or null. */
  vertexAt(clientX, clientY) {
    if (!this.root) return null;
    const hits = this.hitAt(clientX, clientY, this.root);
    if (!hits.length) return null;
    const h = hits[0];
    const mesh = h.object;
    const off = this.offsets.get(mesh.geometry.attributes.position) || 0;
    let best = -1;
    let bestD = Infinity;
    const p = new THREE.Vector3();
    for (const v of [h.face.a, h.face.b, h.face.c]) {
      mesh.getVertexPosition(v, p);
      mesh.localToWorld(p);
      const d = p.distanceToSquared(h.point);
      if (d < bestD) {
        bestD = d;
        best = v;
      }
    }
    return { vertex: best + off, point: h.point };
  }

  clearMarkers() {
    for (const m of [...this.markers.children]) {
      this.markers.remove(m);
      m.geometry.dispose();
      m.material.dispose();
    }
    this.dirty = true;
  }

  addMarker(vertex, color, { pending = false, pair = undefined } = {}) {
    const p = this.vertexPosition(vertex);
    if (!p) return;
    const s = new THREE.Mesh(
      new THREE.SphereGeometry(this.radius * (pending ? 0.018 : 0.014), 16, 12),
      new THREE.MeshBasicMaterial({ color, depthTest: false, transparent: true, opacity: pending ? 0.7 : 1 }),
    );
    s.renderOrder = 10;
    s.userData.pair = pair;
    s.position.copy(p);
    this.markers.add(s);
    this.dirty = true;
  }

  render() {
    this.controls.update();
    if (!this.dirty) return;
    this.dirty = false;
    this.renderer.render(this.scene, this.camera);
  }
}
