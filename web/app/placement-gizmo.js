// Move / rotate the selected character on the page with three's TransformControls gizmo.
// It changes only the character's placement, never its pose or its file-space data.

import { TransformControls } from 'three/addons/controls/TransformControls.js';

export class PlacementGizmo {
  constructor(viewport, editor) {
    this.editor = editor;
    this.mode = null; // 'translate' | 'rotate' | null
    this.controls = new TransformControls(viewport.camera, viewport.renderer.domElement);
    this.controls.setSize(0.8);
    viewport.scene.add(this.controls.getHelper());
    this.controls.addEventListener('dragging-changed', (event) => {
      viewport.controls.enabled = !event.value;
    });
    this.controls.addEventListener('objectChange', () => editor.changed());
    editor.addEventListener('select', () => this.follow());
  }

  /** Turns `mode` on, or off if it is already on. */
  toggle(mode) {
    this.mode = this.mode === mode ? null : mode;
    this.follow();
  }

  off() {
    this.mode = null;
    this.follow();
  }

  follow() {
    const character = this.editor.selected;
    if (this.mode && character) {
      this.controls.setMode(this.mode);
      this.controls.showX = this.mode === 'translate';
      this.controls.showZ = this.mode === 'translate';
      this.controls.attach(character.placement);
    } else {
      this.controls.detach();
    }
    this.editor.changed();
  }

  /** The toolbar command of the mode that is on, or null. */
  modeCommand() {
    return { translate: 'move', rotate: 'rotate' }[this.mode] ?? null;
  }

  /** True while the gizmo has the pointer (hovered handle or dragging): no stroke then. */
  active() {
    return this.mode !== null && (this.controls.dragging || this.controls.axis !== null);
  }
}
