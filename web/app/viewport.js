// The 3D view: renderer, scene, lights, floor, the orbit camera, and the frame loop.
// Page space is metres-ish, y up; each character sits in it under its own placement.

import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

export class Viewport {
  constructor(container) {
    this.container = container;
    this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
    this.renderer.xr.enabled = true;
    this.renderer.domElement.id = 'view';
    // Pointer events of every kind (mouse, pen, touch) draw; the page never scrolls under them.
    this.renderer.domElement.style.touchAction = 'none';
    container.appendChild(this.renderer.domElement);

    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0x24272e);
    this.scene.add(new THREE.HemisphereLight(0xe8eef8, 0x3a3530, 2.2));
    const sun = new THREE.DirectionalLight(0xffffff, 1.6);
    sun.position.set(2, 4, 3);
    this.scene.add(sun);
    const grid = new THREE.GridHelper(20, 40, 0x555b66, 0x3a3f48);
    grid.name = 'floor';
    this.scene.add(grid);

    // In VR the headset and controllers are placed by the XR reference space, under `user`:
    // moving `user` moves where the person stands on the page. On the desktop it stays at the
    // origin, so the orbit camera inside it works in page space.
    this.user = new THREE.Group();
    this.user.name = 'user';
    this.scene.add(this.user);
    this.camera = new THREE.PerspectiveCamera(40, 1, 0.01, 200);
    this.camera.position.set(0, 1.2, 4.2);
    this.user.add(this.camera);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.target.set(0, 0.95, 0);
    // The left button, a pen and one finger draw; the right button (or two fingers) orbits,
    // the middle button pans, the wheel zooms.
    this.controls.mouseButtons = {
      LEFT: null,
      MIDDLE: THREE.MOUSE.PAN,
      RIGHT: THREE.MOUSE.ROTATE,
    };
    this.controls.touches = { ONE: null, TWO: THREE.TOUCH.DOLLY_ROTATE };
    this.controls.update();
    this.renderer.domElement.addEventListener('contextmenu', (e) => e.preventDefault());

    this.beforeRender = [];
    new ResizeObserver(() => this.resize()).observe(container);
    this.resize();
    this.renderer.setAnimationLoop((time, frame) => this.renderFrame(time, frame));
  }

  resize() {
    const { clientWidth: w, clientHeight: h } = this.container;
    if (w === 0 || h === 0 || this.renderer.xr.isPresenting) return;
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
  }

  renderFrame(time, frame) {
    for (const f of this.beforeRender) f(time, frame);
    this.renderer.render(this.scene, this.camera);
  }

  /** Points the camera at a box (page space) from the front (+z), the whole box in view. */
  frame(box) {
    if (box.isEmpty()) return;
    box = box.clone();
    box.max.y += 0.35 * (box.max.y - box.min.y); // room for raised arms
    const centre = box.getCenter(new THREE.Vector3());
    const size = box.getSize(new THREE.Vector3());
    const fov = THREE.MathUtils.degToRad(this.camera.fov);
    const fitHeight = size.y / 2 / Math.tan(fov / 2);
    const fitWidth = size.x / 2 / Math.tan(fov / 2) / this.camera.aspect;
    const distance = 1.1 * Math.max(fitHeight, fitWidth) + size.z / 2;
    this.controls.target.copy(centre);
    this.camera.position.set(centre.x, centre.y + 0.1 * size.y, centre.z + distance);
    this.camera.near = distance / 100;
    this.camera.far = distance * 100;
    this.camera.updateProjectionMatrix();
    this.controls.update();
  }

  /** Canvas pixel (CSS px from its top left) to normalised device coordinates. */
  ndc(screen) {
    const rect = this.renderer.domElement.getBoundingClientRect();
    return new THREE.Vector2((screen[0] / rect.width) * 2 - 1, -(screen[1] / rect.height) * 2 + 1);
  }

  /** Page-space point to canvas pixel (CSS px) and its depth in normalised device coordinates. */
  project(point) {
    const rect = this.renderer.domElement.getBoundingClientRect();
    const p = new THREE.Vector3(...point).project(this.camera);
    return [((p.x + 1) / 2) * rect.width, ((1 - p.y) / 2) * rect.height, p.z];
  }
}
