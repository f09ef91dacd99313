// Solve requests while strokes are drawn: at most one in flight; a request made meanwhile waits
// and is sent, with the strokes as they are by then, when the one in flight comes back (so the
// latest strokes always win and nothing piles up). Answers overtaken by an undo, clear, reset
// or frame change (the character's `generation` moved on) are dropped.

import * as api from './api.js';
import { poseFromSolve, poseToRequest } from './pose.js';

/** Shortest time between two solves of a stroke being drawn, in milliseconds. */
const MIN_INTERVAL_MS = 40;

export class SolveQueue {
  /**
   * `onPose(character, pose, answer)`, `onError(message)`, `onBusyChange(busy)`; `method()`:
   * the solver's name; `bones(character)`: the joints that may move, or null for all.
   */
  constructor({ onPose, onError, onBusyChange, method, bones }) {
    this.onPose = onPose;
    this.onError = onError;
    this.onBusyChange = onBusyChange;
    this.method = method;
    this.bones = bones;
    this.inFlight = null; // Promise
    this.waiting = new Set(); // characters asking for a solve
    this.lastSent = 0;
    this.idleWaiters = [];
  }

  get busy() {
    return this.inFlight !== null || this.waiting.size > 0;
  }

  /** Asks for a solve of `character`'s current strokes (from the pose they were drawn on). */
  request(character) {
    this.waiting.add(character);
    this.onBusyChange(true);
    this.pump();
  }

  /** Resolves when nothing is in flight or waiting. */
  idle() {
    if (!this.busy) return Promise.resolve();
    return new Promise((resolve) => this.idleWaiters.push(resolve));
  }

  pump() {
    if (this.inFlight || this.waiting.size === 0) return;
    const wait = this.lastSent + MIN_INTERVAL_MS - performance.now();
    if (wait > 0) {
      if (!this.timer) {
        this.timer = setTimeout(() => {
          this.timer = null;
          this.pump();
        }, wait);
      }
      return;
    }
    const [character] = this.waiting;
    this.waiting.delete(character);
    this.lastSent = performance.now();
    this.inFlight = this.send(character).finally(() => {
      this.inFlight = null;
      this.pump();
      if (!this.busy) {
        this.onBusyChange(false);
        for (const resolve of this.idleWaiters.splice(0)) resolve();
      }
    });
  }

  async send(character) {
    const strokes = character.strokes.filter((s) => s.points.length >= 2);
    if (strokes.length === 0) return;
    const generation = character.generation;
    const base = character.strokeBasePose;
    const request = {
      pose: poseToRequest(character.joints, base),
      strokes: strokes.map((s) => ({ points: s.points })),
      method: this.method(),
    };
    const bones = this.bones(character);
    if (bones) request.bones = bones;
    try {
      const answer = await api.solve(character.id, request);
      if (character.generation !== generation) return;
      this.onPose(character, poseFromSolve(character.joints, answer, base), answer);
    } catch (error) {
      if (character.generation === generation) this.onError(error.message);
    }
  }
}
