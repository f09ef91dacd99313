// window.rigfit: read-only state for tests and the console, and replay of recorded traces.
// Everything returned is a fresh plain copy; changing it changes nothing on the page.

export function installTestHook({ editor, input, viewport, xr, ready }) {
  const character = (id) => (id === undefined ? editor.selected : editor.characters.find((c) => c.id === id));
  const hook = {
    ready,
    get status() {
      return editor.status;
    },
    get message() {
      return editor.message;
    },
    get selected() {
      return editor.selected?.id ?? null;
    },
    get frame() {
      return editor.frame;
    },
    get playing() {
      return !!editor.playing;
    },
    get method() {
      return editor.method;
    },
    get rootMode() {
      return editor.rootMode;
    },
    get characters() {
      return editor.characters.map((c) => ({
        id: c.id,
        name: c.name,
        format: c.format,
        height: c.height,
        hasModel: c.model !== null,
        joints: c.joints.map((j) => j.name),
        placement: {
          position: c.placement.position.toArray(),
          quaternion: c.placement.quaternion.toArray(),
          scale: c.placement.scale.x,
        },
      }));
    },
    /** Joint positions by name on the page ('world', default) or in the file's space ('file'). */
    joints(id, space = 'world') {
      const c = character(id);
      if (!c) return null;
      const positions = space === 'file' ? c.filePositions : c.worldPositions();
      return Object.fromEntries(c.joints.map((j, i) => [j.name, positions[i].toArray()]));
    },
    /** Strokes (file space) of a character. */
    strokes(id) {
      return character(id)?.strokes.map((s) => s.points.map((p) => [...p])) ?? null;
    },
    /** Keyed frames of a character. */
    keys(id) {
      return character(id)?.keys.map((k) => k.frame) ?? null;
    },
    /** A page-space point to canvas pixels [x, y] (CSS px from the canvas's top left) and depth. */
    project(point) {
      return viewport.project(point);
    },
    /** The canvas's place in the window (to turn canvas pixels into page.mouse coordinates). */
    canvasRect() {
      const r = viewport.renderer.domElement.getBoundingClientRect();
      return { left: r.left, top: r.top, width: r.width, height: r.height };
    },
    get xr() {
      return { presenting: xr.presenting, origin: xr.origin.toArray(), tips: xr.tips() };
    },
    /** Drives the input layer with a trace (see input.js); resolves when its solves are done. */
    replay(trace) {
      return input.replay(trace);
    },
    startRecording() {
      input.startRecording();
    },
    stopRecording() {
      return input.stopRecording();
    },
    /** Resolves when no solve is in flight or waiting. */
    idle() {
      return editor.solves.idle();
    },
    get lastActions() {
      return [...input.log];
    },
  };
  Object.defineProperty(window, 'rigfit', { value: Object.freeze(hook), writable: false });
}
