// The page around the view: toolbar buttons, the status line and the timeline. Buttons and the
// timeline send commands through the input layer, like the keyboard does.

import { FPS } from './editor.js';
import { shortcutOf } from './input.js';

/** Toolbar groups: [command, label, help]. */
const TOOLBAR = [
  [
    ['open', 'Open…', 'Open .glb / .gltf / .bvh files as more characters'],
    ['export-glb', 'Export .glb', 'Download the selected character, posed and keyed, as .glb'],
    ['export-bvh', 'Export .bvh', 'Download the selected character, posed and keyed, as .bvh'],
  ],
  [
    ['solve', 'Solve', 'Pose the selected character to all its strokes'],
    ['undo', 'Undo stroke', 'Remove the last stroke and solve again'],
    ['clear', 'Clear strokes', 'Remove the strokes, keep the pose'],
    ['reset', 'Reset pose', "Back to the file's stored pose (Shift+R: rest pose)"],
  ],
  [
    ['next', 'Next character', 'Select the next character (or click one)'],
    ['move', 'Move', 'Move the selected character (gizmo)'],
    ['rotate', 'Rotate', 'Turn the selected character about the vertical (gizmo)'],
  ],
  [
    ['key', 'Insert key', 'Key the pose of the selected character at this frame'],
    ['prev-frame', '◀', 'Previous frame (Shift: previous key)'],
    ['play', 'Play', 'Play / stop the keyed poses'],
    ['next-frame', '▶', 'Next frame (Shift: next key)'],
  ],
];

export class PageUi {
  constructor(editor, input, gizmo) {
    this.editor = editor;
    this.input = input;
    this.gizmo = gizmo;
    this.toolbar = document.getElementById('toolbar');
    this.status = document.getElementById('status');
    this.timeline = document.getElementById('timeline');
    this.buildToolbar();
    this.buildTimeline();
    editor.addEventListener('change', () => this.schedule());
    this.update();
  }

  buildToolbar() {
    for (const group of TOOLBAR) {
      const box = document.createElement('div');
      box.className = 'group';
      for (const [name, label, help] of group) {
        const button = document.createElement('button');
        button.type = 'button';
        button.dataset.command = name;
        const key = shortcutOf(name);
        button.title = key ? `${help} [${key}]` : help;
        button.innerHTML = `${label}${key ? ` <kbd>${key}</kbd>` : ''}`;
        button.addEventListener('click', () => {
          button.blur(); // keys go to the page's shortcuts, not to the last button clicked
          this.input.command(name);
        });
        box.append(button);
      }
      this.toolbar.append(box);
    }
    const box = document.createElement('div');
    box.className = 'group';
    const method = document.createElement('select');
    method.id = 'method';
    method.title = `Solver: rigfit's, or the paper's matching and aligning [${shortcutOf('method')}]`;
    for (const m of ['rigfit', 'paper']) method.add(new Option(`solver: ${m}`, m));
    method.addEventListener('change', () => {
      method.blur(); // keys back to the shortcuts
      this.input.command('method', method.value);
    });
    this.method = method;
    const root = document.createElement('select');
    root.id = 'root';
    root.title = `Fixed: solving never moves the character's root (place it with Move / Rotate); free: strokes may move and turn the whole character [${shortcutOf('root')}]`;
    for (const m of ['fixed', 'free']) root.add(new Option(`root: ${m}`, m));
    root.addEventListener('change', () => {
      root.blur();
      this.input.command('root', root.value);
    });
    this.root = root;
    const vr = document.createElement('button');
    vr.type = 'button';
    vr.id = 'enter-vr';
    vr.hidden = true;
    vr.textContent = 'Enter VR';
    this.vrButton = vr;
    box.append(method, root, vr);
    this.toolbar.append(box);
  }

  buildTimeline() {
    this.timeline.innerHTML = '<div class="track"><div class="cursor"></div></div>';
    this.track = this.timeline.querySelector('.track');
    this.cursor = this.timeline.querySelector('.cursor');
    const frameAt = (event) => {
      const rect = this.track.getBoundingClientRect();
      const u = Math.min(Math.max((event.clientX - rect.left) / rect.width, 0), 1);
      return Math.round(u * this.editor.lastFrame);
    };
    let dragging = false;
    this.track.addEventListener('pointerdown', (event) => {
      dragging = true;
      this.track.setPointerCapture(event.pointerId);
      this.input.command('frame', frameAt(event));
    });
    this.track.addEventListener('pointermove', (event) => {
      if (dragging && frameAt(event) !== this.editor.frame) this.input.command('frame', frameAt(event));
    });
    this.track.addEventListener('pointerup', () => {
      dragging = false;
    });
  }

  schedule() {
    if (this.pending) return;
    this.pending = requestAnimationFrame(() => {
      this.pending = null;
      this.update();
    });
  }

  update() {
    const e = this.editor;
    const c = e.selected;
    const keyed = e.isKeyed();
    const parts = [
      `<span class="state ${e.status}">${e.status}</span>`,
      c ? `<b>${escapeHtml(c.name)}</b> (${c.id}, ${e.selectedIndex + 1} of ${e.characters.length})` : 'no character',
      `frame <b>${e.frame}</b> <span class="${keyed ? 'keyed' : 'unkeyed'}">${keyed ? '◆ keyed' : '◇ not keyed'}</span>`,
      c ? `${c.strokes.length} stroke${c.strokes.length === 1 ? '' : 's'}` : '',
      e.lastSolve ? `solve ${(e.lastSolve.seconds * 1000).toFixed(0)} ms` : '',
      e.message ? `<span class="message">${escapeHtml(e.message)}</span>` : '',
    ];
    this.status.innerHTML = parts.filter(Boolean).join('<span class="sep">·</span>');
    this.status.dataset.status = e.status;

    for (const button of this.toolbar.querySelectorAll('button[data-command]')) {
      const name = button.dataset.command;
      button.classList.toggle('on', (name === 'play' && !!e.playing) || name === this.gizmo.modeCommand());
    }
    this.toolbar.querySelector('[data-command="play"]').firstChild.textContent = e.playing ? 'Stop ' : 'Play ';
    this.method.value = e.method;
    this.root.value = e.rootMode;
    this.drawTimeline();
  }

  drawTimeline() {
    const e = this.editor;
    const span = Math.max(e.lastFrame, 1);
    for (const old of this.track.querySelectorAll('.key, .tick')) old.remove();
    for (let f = 0; f <= span; f += FPS / 2) {
      const tick = document.createElement('div');
      tick.className = 'tick';
      tick.style.left = `${(f / span) * 100}%`;
      tick.textContent = f % FPS === 0 ? `${f}` : '';
      this.track.append(tick);
    }
    e.characters.forEach((c) => {
      for (const k of c.keys) {
        const key = document.createElement('div');
        key.className = c === e.selected ? 'key selected' : 'key';
        key.style.left = `${(k.frame / span) * 100}%`;
        key.title = `${c.name}: key at frame ${k.frame}`;
        this.track.append(key);
      }
    });
    this.cursor.style.left = `${(e.frame / span) * 100}%`;
    this.cursor.classList.toggle('keyed', e.isKeyed());
  }
}

function escapeHtml(text) {
  return String(text).replace(/[&<>"]/g, (ch) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;' })[ch]);
}
