// A three.js view on a canvas: renderer, scene with studio lighting, perspective camera with orbit
// controls, kept at the size of an element. The speak page's AvatarView and the rig builder's
// MeshView are Viewports; both draw only when `dirty`.

import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { RoomEnvironment } from 'three/addons/environments/RoomEnvironment.js';

let software = null;
/**
 * Whether this browser's WebGL runs in software (no GPU: SwiftShader, llvmpipe, softpipe), asked
 * once per page of a throwaway context.
 */
function softwareWebGL() {
  if (software !== null) return software;
  const gl = document.createElement('canvas').getContext('webgl2');
  software = false;
  if (gl) {
    const ext = gl.getExtension('WEBGL_debug_renderer_info');
    const name = String(gl.getParameter(ext ? ext.UNMASKED_RENDERER_WEBGL : gl.RENDERER));
    software = /swiftshader|llvmpipe|softpipe|software/i.test(name);
    gl.getExtension('WEBGL_lose_context')?.loseContext();
  }
  return software;
}

function makeRenderer(canvas, software) {
  // Multisampling multiplies the fragment work; in software WebGL (SwiftShader) that work is the
  // frame: with it a 1400x860 view of the avatar took 0.4-0.9 s per frame while speaking.
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: !software, preserveDrawingBuffer: true });
  renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
  renderer.outputColorSpace = THREE.SRGBColorSpace;
  // Neutral tone mapping keeps the materials' hues (ACES bleaches skin).
  renderer.toneMapping = THREE.NeutralToneMapping;
  renderer.toneMappingExposure = 1.0;
  return renderer;
}

/** Key, fill and rim lights plus a soft room environment for the standard materials. */
function addStudioLights(scene, renderer) {
  const pmrem = new THREE.PMREMGenerator(renderer);
  scene.environment = pmrem.fromScene(new RoomEnvironment(), 0.04).texture;
  scene.environmentIntensity = 0.45;
  pmrem.dispose();
  const hemi = new THREE.HemisphereLight(0xdfe8ff, 0x2a2420, 0.6);
  const key = new THREE.DirectionalLight(0xfff1e0, 2.2);
  key.position.set(0.6, 0.8, 1.0);
  const fill = new THREE.DirectionalLight(0xcfe0ff, 0.7);
  fill.position.set(-1.0, 0.2, 0.6);
  const rim = new THREE.DirectionalLight(0xffffff, 1.3);
  rim.position.set(0.0, 0.6, -1.2);
  scene.add(hemi, key, fill, rim);
}

export class Viewport {
  /**
   * `canvas` is drawn at the size of `sizeOf` (the canvas itself by default); the camera has the
   * vertical field of view `fov` (degrees) and near plane `near` until frame() sets them.
   */
  constructor(canvas, { sizeOf = canvas, fov, near, background = 0x272a33 }) {
    this.canvas = canvas;
    this.sizeOf = sizeOf;
    this.software = softwareWebGL();
    this.renderer = makeRenderer(canvas, this.software);
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(background);
    this.camera = new THREE.PerspectiveCamera(fov, 1, near, 1000);
    this.controls = new OrbitControls(this.camera, canvas);
    this.controls.enableDamping = true;
    this.controls.addEventListener('change', () => (this.dirty = true));
    addStudioLights(this.scene, this.renderer);
    this.dirty = true; // render only when something changed
  }

  /** Call at the end of the subclass's constructor: sizes the view now and on every resize. */
  observeSize() {
    this.resize();
    new ResizeObserver(() => this.resize()).observe(this.sizeOf);
  }

  resize() {
    const w = Math.max(1, this.sizeOf.clientWidth);
    const h = Math.max(1, this.sizeOf.clientHeight);
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.dirty = true;
  }

  /**
   * The camera distance from the front of a box of `size` at which its height, and `widthShare` of
   * its width, fill the view, times `margin`.
   */
  fitDistance(size, { margin, widthShare }) {
    const tan = Math.tan(THREE.MathUtils.degToRad(this.camera.fov / 2));
    return margin * Math.max((0.5 * size.y) / tan, (widthShare * size.x) / (tan * this.camera.aspect)) + 0.5 * size.z;
  }
}
