// The sketching session: the characters, which one is selected, their strokes, poses and keys,
// the timeline's frame, and what every input action does. Input reaches it only through the
// input layer (input.js); the view reads it and listens to its 'change' events.

import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import * as api from './api.js';
import { Character } from './character.js';
import { clonePose, poseAtFrame, poseToRequest } from './pose.js';
import { SolveQueue } from './solve-queue.js';

export const FPS = 24;
/** Gap between characters placed side by side, in page units. */
const SIDE_BY_SIDE_GAP = 0.5;

export class Editor extends EventTarget {
  constructor(viewport) {
    super();
    this.viewport = viewport;
    this.loader = new GLTFLoader();
    this.characters = [];
    this.selectedIndex = -1;
    this.frame = 0;
    this.lastFrame = 48; // the timeline's end; grows with the keys
    this.playing = false;
    this.drawing = false;
    this.method = 'rigfit';
    /**
     * 'fixed': solves leave each root joint where it is (the character is placed with Move and
     * Rotate; strokes pose its limbs and spine); 'free': the root may move and turn too.
     */
    this.rootMode = 'fixed';
    this.message = '';
    this.lastSolve = null;
    this.grab = null;
    this.solves = new SolveQueue({
      onPose: (character, pose, answer) => {
        character.applyPose(pose);
        this.lastSolve = { iterations: answer.iterations, energy: answer.energy, seconds: answer.seconds };
        this.changed();
      },
      onError: (message) => this.fail(message),
      onBusyChange: () => this.changed(),
      method: () => this.method,
      bones: (character) => this.movableBones(character),
    });
  }

  get selected() {
    return this.characters[this.selectedIndex] ?? null;
  }

  get status() {
    if (this.drawing) return 'drawing';
    if (this.solves.busy) return 'solving';
    if (this.playing) return 'playing';
    return 'idle';
  }

  changed() {
    this.dispatchEvent(new Event('change'));
  }

  fail(message) {
    this.message = message;
    console.warn(`rigfit: ${message}`);
    this.changed();
  }

  // ---- characters ------------------------------------------------------------------------

  /** Adds a character from the server's CHARACTER, to the right of the others, and selects it. */
  async addCharacter(info) {
    const character = new Character(info);
    try {
      await character.loadModel(this.loader, api.modelUrl(info.id));
    } catch (error) {
      this.fail(`${info.name}: no model to show (${error.message}); showing its skeleton`);
    }
    const others = this.characters.map((c) => c.worldBox());
    this.viewport.scene.add(character.placement);
    const box = character.worldBox();
    const right = others.length ? Math.max(...others.map((b) => b.max.x)) : null;
    const centre = box.getCenter(new THREE.Vector3());
    character.placement.position.x +=
      right === null ? -centre.x : right + SIDE_BY_SIDE_GAP - box.min.x;
    character.placement.position.z -= centre.z;
    character.placement.position.y -= box.min.y; // feet on the floor
    this.characters.push(character);
    this.select(this.characters.length - 1);
    this.frameAll();
    return character;
  }

  /** Loads every character the server holds. */
  async loadFromServer() {
    for (const info of await api.listCharacters()) await this.addCharacter(info);
  }

  /** Uploads files the user picked and adds each as a character. */
  async openFiles(files) {
    for (const file of files) {
      this.message = `opening ${file.name}...`;
      this.changed();
      try {
        await this.addCharacter(await api.uploadCharacter(file));
        this.message = `opened ${file.name}`;
      } catch (error) {
        this.fail(error.message);
      }
    }
    this.changed();
  }

  select(index) {
    if (this.characters.length === 0) return;
    this.selectedIndex = ((index % this.characters.length) + this.characters.length) % this.characters.length;
    this.characters.forEach((c, i) => c.setSelected(i === this.selectedIndex));
    this.dispatchEvent(new Event('select'));
    this.changed();
  }

  selectById(id) {
    const index = this.characters.findIndex((c) => c.id === id);
    if (index >= 0) this.select(index);
  }

  /** The character nearest a page-space point (by its nearest joint). */
  characterNear(point) {
    const p = new THREE.Vector3(...point);
    let best = null;
    let bestDistance = Infinity;
    for (const c of this.characters) {
      for (const q of c.worldPositions()) {
        const d = q.distanceTo(p);
        if (d < bestDistance) [best, bestDistance] = [c, d];
      }
    }
    return best;
  }

  frameAll() {
    const box = new THREE.Box3();
    for (const c of this.characters) box.union(c.worldBox());
    this.viewport.frame(box);
  }

  /**
   * The joints a solve may move, or null for all. With the root fixed: all but the top skin
   * joints (whose ancestors are all helper nodes, or who have none), the helpers above them and
   * the end sites.
   */
  movableBones(character) {
    if (this.rootMode === 'free') return null;
    const joints = character.joints;
    const belowSkin = []; // has a skin joint among its ancestors
    joints.forEach((j, i) => {
      belowSkin[i] = j.parent !== null && (joints[j.parent].kind === 'skin' || belowSkin[j.parent]);
    });
    return joints.filter((j, i) => belowSkin[i] && j.kind !== 'end_site').map((j) => j.name);
  }

  // ---- strokes ---------------------------------------------------------------------------

  strokeBegin(point) {
    const c = this.selected;
    if (!c || !point) return;
    if (this.playing) this.stop();
    if (c.strokes.length === 0) c.strokeBasePose = clonePose(c.pose);
    c.strokes.push({ points: [c.fileFromPage(point).toArray()] });
    this.drawing = true;
    this.message = '';
    c.updateStrokeView(true);
    this.changed();
  }

  strokePoint(point) {
    const c = this.selected;
    if (!c || !this.drawing || !point) return;
    const stroke = c.strokes[c.strokes.length - 1];
    const p = c.fileFromPage(point);
    const last = new THREE.Vector3(...stroke.points[stroke.points.length - 1]);
    if (p.distanceTo(last) < c.height * 0.002) return;
    stroke.points.push(p.toArray());
    c.updateStrokeView(true);
    this.solves.request(c);
  }

  strokeEnd() {
    const c = this.selected;
    if (!c || !this.drawing) return;
    this.drawing = false;
    // A click without a drag leaves a one-point stroke: not a stroke.
    if (c.strokes[c.strokes.length - 1].points.length < 2) {
      c.strokes.pop();
      if (c.strokes.length === 0) c.strokeBasePose = null;
    } else {
      this.solves.request(c);
    }
    c.updateStrokeView();
    this.changed();
  }

  solve() {
    const c = this.selected;
    if (!c) return;
    if (c.strokes.length === 0) {
      this.fail('nothing to solve: draw a stroke first');
      return;
    }
    this.solves.request(c);
  }

  undo() {
    const c = this.selected;
    if (!c || c.strokes.length === 0) return;
    c.strokes.pop();
    c.generation += 1;
    c.updateStrokeView();
    if (c.strokes.length > 0) {
      this.solves.request(c);
    } else {
      c.applyPose(clonePose(c.strokeBasePose));
      c.strokeBasePose = null;
    }
    this.changed();
  }

  /** Removes the strokes, keeps the pose. */
  clear() {
    const c = this.selected;
    if (!c) return;
    c.strokes = [];
    c.strokeBasePose = null;
    c.generation += 1;
    c.updateStrokeView();
    this.changed();
  }

  /** Back to the stored pose (`stored`) or the rest pose; strokes now start from it. */
  resetPose(which = 'stored') {
    const c = this.selected;
    if (!c) return;
    const pose = clonePose(which === 'rest' ? c.restPose : c.storedPose);
    c.generation += 1;
    c.applyPose(pose);
    c.strokeBasePose = c.strokes.length ? clonePose(pose) : null;
    this.changed();
  }

  // ---- placement (XR grip) ---------------------------------------------------------------

  /** Grabs the character nearest `point` with a controller whose page matrix is `matrix`. */
  grabBegin(matrix, point) {
    const c = point ? this.characterNear(point) : this.selected;
    if (!c) return;
    this.selectById(c.id);
    const controller = new THREE.Matrix4().fromArray(matrix);
    c.placement.updateMatrix();
    this.grab = {
      character: c,
      offset: controller.clone().invert().multiply(c.placement.matrix),
    };
  }

  grabMove(matrix) {
    if (!this.grab) return;
    const m = new THREE.Matrix4().fromArray(matrix).multiply(this.grab.offset);
    const p = this.grab.character.placement;
    m.decompose(p.position, p.quaternion, p.scale);
    this.changed();
  }

  grabEnd() {
    this.grab = null;
  }

  // ---- timeline --------------------------------------------------------------------------

  isKeyed(character = this.selected, frame = this.frame) {
    return !!character?.keys.some((k) => k.frame === frame);
  }

  insertKey() {
    const c = this.selected;
    if (!c) return;
    c.keys = c.keys.filter((k) => k.frame !== this.frame);
    c.keys.push({ frame: this.frame, pose: clonePose(c.pose) });
    c.keys.sort((a, b) => a.frame - b.frame);
    this.lastFrame = Math.max(this.lastFrame, this.frame + 12);
    this.message = `keyed frame ${this.frame}`;
    this.changed();
  }

  deleteKey() {
    const c = this.selected;
    if (!c) return;
    c.keys = c.keys.filter((k) => k.frame !== this.frame);
    this.changed();
  }

  /** Goes to a frame: every keyed character shows its interpolated pose there. */
  setFrame(frame) {
    this.frame = Math.max(0, Math.round(frame));
    this.lastFrame = Math.max(this.lastFrame, this.frame);
    for (const c of this.characters) {
      const pose = poseAtFrame(c.keys, this.frame);
      if (!pose) continue;
      c.generation += 1;
      c.applyPose(pose);
      c.strokeBasePose = c.strokes.length ? clonePose(pose) : null;
    }
    this.changed();
  }

  /** The next (+1) or previous (-1) keyed frame of the selected character. */
  jumpToKey(direction) {
    const frames = (this.selected?.keys ?? []).map((k) => k.frame);
    const target =
      direction > 0 ? frames.find((f) => f > this.frame) : frames.reverse().find((f) => f < this.frame);
    if (target !== undefined) this.setFrame(target);
  }

  /** Frames that playback loops over: from the first key to the last of any character. */
  playRange() {
    const frames = this.characters.flatMap((c) => c.keys.map((k) => k.frame));
    if (frames.length < 2) return [0, this.lastFrame];
    return [Math.min(...frames), Math.max(...frames)];
  }

  play() {
    if (this.playing) return;
    const [first, last] = this.playRange();
    if (this.frame < first || this.frame >= last) this.setFrame(first);
    this.playing = { startTime: performance.now(), startFrame: this.frame };
    this.changed();
  }

  stop() {
    this.playing = false;
    this.changed();
  }

  /** Called every animation frame: advances playback. */
  tick(now) {
    if (!this.playing) return;
    const [first, last] = this.playRange();
    const span = Math.max(last - first, 1);
    const elapsed = ((now - this.playing.startTime) / 1000) * FPS;
    const frame = first + ((this.playing.startFrame - first + Math.floor(elapsed)) % (span + 1));
    if (frame !== this.frame) this.setFrame(frame);
  }

  // ---- export ----------------------------------------------------------------------------

  /** Exports the selected character (pose and keys) as `format`; the file, downloaded. */
  async exportSelected(format) {
    const c = this.selected;
    if (!c) return;
    this.message = `exporting ${c.name}.${format}...`;
    this.changed();
    try {
      const { blob, filename } = await api.exportCharacter(c.id, {
        format,
        fps: FPS,
        pose: poseToRequest(c.joints, c.pose),
        keys: c.keys.map((k) => ({ frame: k.frame, pose: poseToRequest(c.joints, k.pose) })),
      });
      const url = URL.createObjectURL(blob);
      const link = document.createElement('a');
      link.href = url;
      link.download = filename;
      document.body.append(link);
      link.click();
      link.remove();
      setTimeout(() => URL.revokeObjectURL(url), 10000);
      this.message = `exported ${filename}`;
    } catch (error) {
      this.fail(error.message);
      return;
    }
    this.changed();
  }
}
