// WebXR: the "Enter VR" button (only where immersive-vr is supported), the controllers drawn
// from local profile assets, and controller input turned into input-layer actions:
//
//   trigger (either hand)   draw: stroke points are the controller's tip
//   grip (either hand)      grab the nearest character and move / turn it with the hand
//   right thumbstick        up solve, down clear strokes, left undo stroke, right reset pose
//   left thumbstick         up play / stop, down insert key, left / right previous / next frame
//   A / B (right)           undo stroke / solve          X / Y (left)   insert key / play
//
// (the thumbstick layout is the paper's trackpad layout). Labels above the controllers show the
// status and the selected character (right) and the frame, yellow when keyed (left).

import * as THREE from 'three';
import { XRControllerModelFactory } from 'three/addons/webxr/XRControllerModelFactory.js';

/** Where ink comes out: this far ahead of the controller along its pointing ray (m). */
const TIP_DISTANCE = 0.03;
/** The user stands this far in front of the selected character when entering VR (m). */
const VIEWING_DISTANCE = 1.6;
const STICK = { on: 0.7, off: 0.3 };

const STICK_COMMANDS = {
  right: { up: 'solve', down: 'clear', left: 'undo', right: 'reset' },
  left: { up: 'play', down: 'key', left: 'prev-frame', right: 'next-frame' },
};
/** xr-standard gamepad buttons 4 and 5: A / B on the right controller, X / Y on the left. */
const BUTTON_COMMANDS = {
  right: { 4: 'undo', 5: 'solve' },
  left: { 4: 'key', 5: 'play' },
};

function makeLabel() {
  const canvas = document.createElement('canvas');
  canvas.width = 512;
  canvas.height = 96;
  const texture = new THREE.CanvasTexture(canvas);
  const mesh = new THREE.Mesh(
    new THREE.PlaneGeometry(0.16, 0.03),
    new THREE.MeshBasicMaterial({ map: texture, transparent: true, depthTest: false }),
  );
  mesh.position.set(0, 0.06, 0.02);
  mesh.rotation.x = -0.6;
  mesh.renderOrder = 30;
  let last = '';
  mesh.userData.set = (text, colour) => {
    if (text + colour === last) return;
    last = text + colour;
    const g = canvas.getContext('2d');
    g.clearRect(0, 0, canvas.width, canvas.height);
    g.fillStyle = 'rgba(20, 22, 28, 0.8)';
    g.fillRect(0, 0, canvas.width, canvas.height);
    g.fillStyle = colour;
    g.font = 'bold 44px sans-serif';
    g.textBaseline = 'middle';
    g.fillText(text, 16, canvas.height / 2);
    texture.needsUpdate = true;
  };
  return mesh;
}

export class XrSketching {
  constructor(viewport, editor, input, button) {
    this.viewport = viewport;
    this.editor = editor;
    this.input = input;
    this.button = button;
    this.session = null;
    this.origin = new THREE.Vector3(); // where the XR reference space's origin is on the page
    this.hands = [];
    const renderer = viewport.renderer;
    const factory = new XRControllerModelFactory();
    factory.setPath('/vendor/webxr-input-profiles/profiles');

    for (let i = 0; i < 2; i++) {
      const ray = renderer.xr.getController(i);
      const grip = renderer.xr.getControllerGrip(i);
      grip.add(factory.createControllerModel(grip));
      const tip = new THREE.Mesh(
        new THREE.SphereGeometry(0.006, 12, 8),
        new THREE.MeshBasicMaterial({ color: 0x38e1a0 }),
      );
      tip.position.set(0, 0, -TIP_DISTANCE);
      ray.add(tip);
      const label = makeLabel();
      grip.add(label);
      const hand = { ray, grip, tip, label, handedness: null, drawing: false, grabbing: false, stick: null, buttons: [] };
      ray.addEventListener('connected', (event) => {
        hand.inputSource = event.data;
        hand.handedness = event.data.handedness;
      });
      ray.addEventListener('disconnected', () => {
        hand.inputSource = null;
        if (hand.drawing) this.input.dispatch({ type: 'strokeEnd' });
        if (hand.grabbing) this.input.dispatch({ type: 'grabEnd' });
        hand.drawing = hand.grabbing = false;
      });
      ray.addEventListener('selectstart', () => {
        if (this.hands.some((h) => h.drawing)) return;
        hand.drawing = true;
        this.input.dispatch({ type: 'strokeBegin', point: this.tipOf(hand) });
      });
      ray.addEventListener('selectend', () => {
        if (!hand.drawing) return;
        hand.drawing = false;
        this.input.dispatch({ type: 'strokeEnd' });
      });
      ray.addEventListener('squeezestart', () => {
        hand.grabbing = true;
        this.input.dispatch({ type: 'grabBegin', matrix: this.matrixOf(hand), point: this.tipOf(hand) });
      });
      ray.addEventListener('squeezeend', () => {
        if (!hand.grabbing) return;
        hand.grabbing = false;
        this.input.dispatch({ type: 'grabEnd' });
      });
      viewport.user.add(ray, grip);
      this.hands.push(hand);
    }
    viewport.beforeRender.push(() => this.update());
  }

  /** Shows the Enter VR button if this browser can run an immersive-vr session. */
  async offer() {
    const supported = (await navigator.xr?.isSessionSupported('immersive-vr').catch(() => false)) ?? false;
    this.button.hidden = !supported;
    this.button.onclick = () => (this.session ? this.session.end() : this.enter());
    return supported;
  }

  async enter() {
    const session = await navigator.xr.requestSession('immersive-vr', {
      optionalFeatures: ['local-floor', 'bounded-floor'],
    });
    const xr = this.viewport.renderer.xr;
    xr.setReferenceSpaceType('local-floor');
    await xr.setSession(session);
    // Stand the user in front of the selected character, facing it (-z).
    const box = this.editor.selected?.worldBox() ?? new THREE.Box3(new THREE.Vector3(), new THREE.Vector3());
    const centre = box.getCenter(new THREE.Vector3());
    this.origin.set(centre.x, 0, box.max.z + VIEWING_DISTANCE);
    this.viewport.user.position.copy(this.origin);
    this.session = session;
    this.button.textContent = 'Exit VR';
    session.addEventListener('end', () => {
      this.session = null;
      this.viewport.user.position.set(0, 0, 0);
      this.button.textContent = 'Enter VR';
      this.viewport.resize();
    });
    this.editor.changed();
  }

  get presenting() {
    return this.viewport.renderer.xr.isPresenting;
  }

  tipOf(hand) {
    hand.ray.updateMatrixWorld(true);
    return hand.tip.getWorldPosition(new THREE.Vector3()).toArray();
  }

  matrixOf(hand) {
    hand.ray.updateMatrixWorld(true);
    return hand.ray.matrixWorld.toArray();
  }

  /** Page positions of the connected controllers' tips, by handedness. */
  tips() {
    return Object.fromEntries(
      this.hands.filter((h) => h.inputSource).map((h) => [h.handedness, this.tipOf(h)]),
    );
  }

  /** Every frame in VR: stroke points and grab moves from the controllers' poses; buttons. */
  update() {
    if (!this.presenting) return;
    for (const hand of this.hands) {
      if (!hand.inputSource) continue;
      if (hand.drawing) this.input.dispatch({ type: 'strokePoint', point: this.tipOf(hand) });
      if (hand.grabbing) this.input.dispatch({ type: 'grabMove', matrix: this.matrixOf(hand) });
      this.readGamepad(hand);
      this.updateLabel(hand);
    }
  }

  readGamepad(hand) {
    const gamepad = hand.inputSource.gamepad;
    if (!gamepad) return;
    const side = hand.handedness === 'left' ? 'left' : 'right';
    for (const [index, name] of Object.entries(BUTTON_COMMANDS[side])) {
      const pressed = !!gamepad.buttons[index]?.pressed;
      if (pressed && !hand.buttons[index]) this.input.command(name);
      hand.buttons[index] = pressed;
    }
    const [x, y] = [gamepad.axes[2] ?? 0, gamepad.axes[3] ?? 0];
    if (hand.stick && Math.max(Math.abs(x), Math.abs(y)) < STICK.off) hand.stick = null;
    if (!hand.stick && Math.max(Math.abs(x), Math.abs(y)) > STICK.on) {
      hand.stick = Math.abs(x) > Math.abs(y) ? (x > 0 ? 'right' : 'left') : y > 0 ? 'down' : 'up';
      this.input.command(STICK_COMMANDS[side][hand.stick]);
    }
  }

  updateLabel(hand) {
    const e = this.editor;
    if (hand.handedness === 'left') {
      const keyed = e.isKeyed();
      hand.label.userData.set(`frame ${e.frame} ${keyed ? '◆ keyed' : '◇'}`, keyed ? '#ffd23f' : '#b8bcc4');
    } else {
      hand.label.userData.set(`${e.status} · ${e.selected?.name ?? '-'}`, '#e8ecf2');
    }
  }
}
