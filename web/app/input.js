// The one input layer. Every source of input (mouse, pen and touch through pointer events, the
// keyboard, XR controllers, a recorded trace) becomes the same few actions, and only these reach
// the editor:
//
//   { type: 'strokeBegin', screen: [x, y] } or { type: 'strokeBegin', point: [x, y, z] }
//   { type: 'strokePoint', screen | point }   { type: 'strokeEnd' }   { type: 'strokeCancel' }
//   { type: 'hover', screen: [x, y] }          (moves the cursor marker; not recorded)
//   { type: 'select', id: 'c1' }
//   { type: 'grabBegin', matrix: [16 numbers], point: [x, y, z] }   (XR grip; page space)
//   { type: 'grabMove', matrix }   { type: 'grabEnd' }
//   { type: 'command', name: 'solve', value? }  (names: see COMMAND_KEYS and main.js)
//
// `screen` is in CSS pixels from the canvas's top left corner and lands on the drawing plane
// (drawing-plane.js); `point` is already in page space (XR controller tips). A trace is a list
// of actions, each optionally with `t` (ms from the start) or a { type: 'wait', ms } between.

/** Keyboard shortcuts: [key as in KeyboardEvent.key, shift held?, command name]. */
export const COMMAND_KEYS = [
  ['s', false, 'solve'],
  ['Enter', false, 'solve'],
  ['z', false, 'undo'],
  ['Backspace', false, 'undo'],
  ['c', false, 'clear'],
  ['Delete', false, 'clear'],
  ['r', false, 'reset'],
  ['R', true, 'rest'],
  ['Tab', false, 'next'],
  ['Tab', true, 'previous'],
  ['g', false, 'move'],
  ['t', false, 'rotate'],
  ['Escape', false, 'place-off'],
  ['i', false, 'key'],
  ['k', false, 'key'],
  ['I', true, 'unkey'],
  ['ArrowLeft', false, 'prev-frame'],
  ['ArrowRight', false, 'next-frame'],
  ['ArrowLeft', true, 'prev-key'],
  ['ArrowRight', true, 'next-key'],
  [' ', false, 'play'],
  ['o', false, 'open'],
  ['e', false, 'export-glb'],
  ['E', true, 'export-bvh'],
  ['b', false, 'export-bvh'],
  ['f', false, 'frame-all'],
  ['m', false, 'method'],
  ['h', false, 'root'],
];

/** The first shortcut of a command, for button tooltips. */
export function shortcutOf(name) {
  const entry = COMMAND_KEYS.find((k) => k[2] === name);
  if (!entry) return '';
  const key = { ' ': 'Space', ArrowLeft: '←', ArrowRight: '→' }[entry[0]] ?? entry[0];
  return entry[1] && key.length > 1 ? `Shift+${key}` : key;
}

const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

export class InputLayer {
  /** `commands`: { name: (value) => void }, registered by main.js. */
  constructor(editor, drawingPlane, commands) {
    this.editor = editor;
    this.drawingPlane = drawingPlane;
    this.commands = commands;
    this.recording = null;
    this.log = []; // the last actions, for debugging
  }

  /** The single entry point of every input. */
  dispatch(action) {
    if (this.recording && action.type !== 'hover') {
      this.recording.push({ ...action, t: Math.round(performance.now() - this.recordStart) });
    }
    const e = this.editor;
    const plane = this.drawingPlane;
    switch (action.type) {
      case 'hover':
        plane.hover(action.screen);
        break;
      case 'strokeBegin':
        e.strokeBegin(action.point ?? plane.begin(action.screen)?.toArray());
        if (action.screen) plane.hover(action.screen);
        break;
      case 'strokePoint':
        e.strokePoint(action.point ?? plane.point(action.screen)?.toArray());
        if (action.screen) plane.hover(action.screen);
        break;
      case 'strokeEnd':
        plane.end();
        e.strokeEnd();
        break;
      case 'strokeCancel':
        plane.end();
        e.strokeEnd();
        e.undo();
        break;
      case 'select':
        e.selectById(action.id);
        break;
      case 'grabBegin':
        e.grabBegin(action.matrix, action.point);
        break;
      case 'grabMove':
        e.grabMove(action.matrix);
        break;
      case 'grabEnd':
        e.grabEnd();
        break;
      case 'command': {
        const run = this.commands[action.name];
        if (!run) throw new Error(`unknown command ${action.name}`);
        run(action.value);
        break;
      }
      case 'wait':
        break;
      default:
        throw new Error(`unknown input action ${action.type}`);
    }
    this.log.push(action.type === 'command' ? `${action.name}` : action.type);
    if (this.log.length > 50) this.log.shift();
  }

  command(name, value) {
    this.dispatch({ type: 'command', name, value });
  }

  // ---- pointer events: mouse, pen, touch --------------------------------------------------

  /**
   * `canvas`: the view; `pickAt(screen)`: the id of a character under the cursor or null;
   * `gizmoActive()`: true while the move/rotate gizmo has the pointer.
   */
  attachPointer(canvas, { pickAt, gizmoActive }) {
    let drawingPointer = null;
    let touches = 0;
    const screenOf = (event) => {
      const rect = canvas.getBoundingClientRect();
      return [event.clientX - rect.left, event.clientY - rect.top];
    };
    canvas.addEventListener('pointerdown', (event) => {
      if (event.pointerType === 'touch') touches += 1;
      if (touches > 1 && drawingPointer !== null) {
        // A second finger: the user orbits or zooms, not draws.
        drawingPointer = null;
        this.dispatch({ type: 'strokeCancel' });
        return;
      }
      const drawButton = event.pointerType === 'mouse' ? event.button === 0 : event.isPrimary;
      if (!drawButton || drawingPointer !== null || gizmoActive()) return;
      const screen = screenOf(event);
      const picked = pickAt(screen);
      if (picked !== null && picked !== this.editor.selected?.id) {
        this.dispatch({ type: 'select', id: picked });
        this.dispatch({ type: 'hover', screen });
        return;
      }
      drawingPointer = event.pointerId;
      canvas.setPointerCapture(event.pointerId);
      this.dispatch({ type: 'strokeBegin', screen });
    });
    canvas.addEventListener('pointermove', (event) => {
      if (event.pointerId === drawingPointer) {
        const events = event.getCoalescedEvents?.() ?? [];
        for (const e of events.length ? events : [event]) {
          this.dispatch({ type: 'strokePoint', screen: screenOf(e) });
        }
      } else if (drawingPointer === null && event.pointerType !== 'touch') {
        this.dispatch({ type: 'hover', screen: screenOf(event) });
      }
    });
    const end = (event) => {
      if (event.pointerType === 'touch') touches = Math.max(0, touches - 1);
      if (event.pointerId !== drawingPointer) return;
      drawingPointer = null;
      this.dispatch({ type: 'strokeEnd' });
    };
    canvas.addEventListener('pointerup', end);
    canvas.addEventListener('pointercancel', end);
    canvas.addEventListener('pointerleave', () => {
      if (drawingPointer === null) this.drawingPlane.hide();
    });
  }

  // ---- keyboard -----------------------------------------------------------------------------

  attachKeyboard(target) {
    target.addEventListener('keydown', (event) => {
      const tag = event.target?.tagName;
      if (tag === 'INPUT' || tag === 'SELECT' || tag === 'TEXTAREA') return;
      if (event.ctrlKey && event.key === 'z') {
        event.preventDefault();
        this.command('undo');
        return;
      }
      if (event.ctrlKey || event.metaKey || event.altKey) return;
      const entry =
        COMMAND_KEYS.find((k) => k[0] === event.key && k[1] === event.shiftKey) ??
        COMMAND_KEYS.find((k) => k[0] === event.key);
      if (!entry) return;
      event.preventDefault();
      this.command(entry[2]);
    });
  }

  // ---- traces -------------------------------------------------------------------------------

  startRecording() {
    this.recording = [];
    this.recordStart = performance.now();
  }

  stopRecording() {
    const trace = this.recording ?? [];
    this.recording = null;
    return trace;
  }

  /**
   * Plays a trace through `dispatch`, honouring `t` when given (otherwise one 16 ms step between
   * stroke points, as a hand would); resolves when the solves it caused are done.
   */
  async replay(trace) {
    const start = performance.now();
    for (const action of trace) {
      if (action.type === 'wait') {
        await sleep(action.ms ?? 0);
        continue;
      }
      if (action.t !== undefined) {
        await sleep(Math.max(0, start + action.t - performance.now()));
      } else if (action.type === 'strokePoint') {
        await sleep(16);
      }
      const { t, ...rest } = action;
      this.dispatch(rest);
    }
    await this.editor.solves.idle();
    return trace.length;
  }
}
