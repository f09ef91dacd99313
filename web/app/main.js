// Starts the page: the view, the editor, the one input layer and everything that feeds it
// (pointer, keyboard, toolbar, timeline, file picker, XR controllers), and window.rigfit.

import { DrawingPlane } from './drawing-plane.js';
import { Editor } from './editor.js';
import { InputLayer } from './input.js';
import { PlacementGizmo } from './placement-gizmo.js';
import { installTestHook } from './test-hook.js';
import { PageUi } from './ui.js';
import { Viewport } from './viewport.js';
import { XrSketching } from './xr.js';

const viewport = new Viewport(document.getElementById('viewport'));
const editor = new Editor(viewport);
const drawingPlane = new DrawingPlane(viewport, () => editor.selected);
const gizmo = new PlacementGizmo(viewport, editor); // before the pointer input: it sees clicks first
const picker = document.getElementById('file-picker');

/** What each command does; the keyboard, buttons, timeline, XR controllers and traces send them. */
const commands = {
  solve: () => editor.solve(),
  undo: () => editor.undo(),
  clear: () => editor.clear(),
  reset: () => editor.resetPose('stored'),
  rest: () => editor.resetPose('rest'),
  next: () => editor.select(editor.selectedIndex + 1),
  previous: () => editor.select(editor.selectedIndex - 1),
  select: (id) => editor.selectById(id),
  move: () => gizmo.toggle('translate'),
  rotate: () => gizmo.toggle('rotate'),
  'place-off': () => gizmo.off(),
  key: () => editor.insertKey(),
  unkey: () => editor.deleteKey(),
  'prev-frame': () => editor.setFrame(editor.frame - 1),
  'next-frame': () => editor.setFrame(editor.frame + 1),
  'prev-key': () => editor.jumpToKey(-1),
  'next-key': () => editor.jumpToKey(+1),
  frame: (frame) => editor.setFrame(Number(frame)),
  play: () => (editor.playing ? editor.stop() : editor.play()),
  open: () => picker.click(),
  'export-glb': () => editor.exportSelected('glb'),
  'export-bvh': () => editor.exportSelected('bvh'),
  'frame-all': () => editor.frameAll(),
  root: (mode) => {
    editor.rootMode = mode ?? (editor.rootMode === 'fixed' ? 'free' : 'fixed');
    editor.changed();
  },
  method: (name) => {
    editor.method = name ?? (editor.method === 'rigfit' ? 'paper' : 'rigfit');
    editor.changed();
  },
};

const input = new InputLayer(editor, drawingPlane, commands);

/** The character under a canvas pixel: inside the screen box of its joints, nearest joint first. */
function pickAt(screen) {
  let best = null;
  let bestDistance = Infinity;
  const margin = 24;
  for (const c of editor.characters) {
    const points = c.worldPositions().map((p) => viewport.project([p.x, p.y, p.z]));
    const xs = points.map((p) => p[0]);
    const ys = points.map((p) => p[1]);
    const inside =
      screen[0] > Math.min(...xs) - margin &&
      screen[0] < Math.max(...xs) + margin &&
      screen[1] > Math.min(...ys) - margin &&
      screen[1] < Math.max(...ys) + margin;
    if (!inside) continue;
    for (const p of points) {
      const d = Math.hypot(p[0] - screen[0], p[1] - screen[1]);
      if (d < bestDistance) [best, bestDistance] = [c.id, d];
    }
  }
  return best;
}

input.attachPointer(viewport.renderer.domElement, { pickAt, gizmoActive: () => gizmo.active() });
input.attachKeyboard(window);
picker.addEventListener('change', async () => {
  const files = [...picker.files];
  picker.value = '';
  await editor.openFiles(files);
});

const ui = new PageUi(editor, input, gizmo);
const xr = new XrSketching(viewport, editor, input, ui.vrButton);
viewport.beforeRender.push(() => editor.tick(performance.now()));

const ready = (async () => {
  await editor.loadFromServer();
  await xr.offer();
  document.body.dataset.ready = 'true';
})().catch((error) => editor.fail(error.message));

installTestHook({ editor, input, viewport, xr, ready });
