// The timeline strip of the Annotate view: each key's thumbnail at its output frame, each segment's ease
// between its keys, and the structural edits (add a key from an image file at a frame, remove one, move one in
// time). Those edits are made by the server on the saved shot (POST /api/keys, DELETE /api/keys/{k},
// POST /api/keys/{k}/move); the page then reopens the shot. Selecting a key shows it in the Annotate panes.

import { V2, keyCount, keyFramesOf } from './skeleton.js';

const EASES = ['linear', 'in', 'out', 'in-out'];  // ops/types.py EASES
const EDGE_PX = 34;  // the first and the last key's thumbnails stay inside the strip
const DRAG_PX = 4;   // a press on a key that moves less than this is a click (select)
const $ = (id) => document.getElementById(id);

/** Output frame of each key: v2 key_frames; v1 0 and the last output frame (frames, else one per pose). */
export function keyFrames(shot) {
  const kf = keyFramesOf(shot);
  if (kf) return kf.slice(0, keyCount(shot));
  const n = Number.isInteger(shot.frames) ? shot.frames : (Array.isArray(shot.poses) ? shot.poses.length : 2);
  return [0, Math.max(1, n - 1)];
}

/** The last output frame: the last key's, or for one drawing the last pose's. */
export function lastFrame(shot) {
  const kf = keyFrames(shot);
  if (kf.length > 1) return kf[kf.length - 1];
  const frames = (Array.isArray(shot.poses) ? shot.poses : []).map((p) => +p?.frame).filter(Number.isFinite);
  return Math.max(0, ...frames);
}

export class Timeline {
  constructor(app) {
    this.app = app;
    this.track = $('tl-track');
    $('key-frame').addEventListener('change', () => {
      const v = $('key-frame').value.trim();
      if (v !== '') this.app.moveKey(this.app.focusedKey, Number(v));
    });
    $('key-remove').addEventListener('click', () => this.app.removeKey(this.app.focusedKey));
    $('key-add').addEventListener('click', () => { $('key-file').value = ''; $('key-file').click(); });
    $('key-file').addEventListener('change', () => {
      const file = $('key-file').files[0];
      if (file) this.app.addKey(Number($('add-frame').value), file);
    });
  }

  /** Key i's thumbnail, fetched once per version of the saved shot (the server does not let it be cached). */
  _thumb(i) {
    const url = `/api/keyframes/${i}.png?v=${encodeURIComponent(this.app.etag || '')}`;
    if (this.thumbVersion !== this.app.etag) { this.thumbs = new Map(); this.thumbVersion = this.app.etag; }
    if (!this.thumbs.has(url)) {
      const img = document.createElement('img');
      img.alt = `key${i}`;
      img.src = url;
      this.thumbs.set(url, img);
    }
    return this.thumbs.get(url);
  }

  /** A free frame to suggest for a new key: between the selected key and the next, else after the last. */
  _suggestion(kf, k, last) {
    if (k + 1 < kf.length && kf[k + 1] - kf[k] > 1) return Math.floor((kf[k] + kf[k + 1]) / 2);
    for (let i = 0; i + 1 < kf.length; i++) if (kf[i + 1] - kf[i] > 1) return Math.floor((kf[i] + kf[i + 1]) / 2);
    return Math.max(last, kf[kf.length - 1]) + 8;
  }

  /** Drag key i's thumbnail along the strip to move it in time (released: one move edit); key0 stays. */
  _press(e, i, btn, kf, last) {
    if (i === 0 || e.button !== 0) return;
    const box = this.track.getBoundingClientRect();
    const lo = kf[i - 1] + 1, hi = i + 1 < kf.length ? kf[i + 1] - 1 : 999;  // ops/shotio/load.py MAX_FRAMES - 1
    const frameAt = (x) => Math.min(hi, Math.max(lo, Math.round(((x - box.left - EDGE_PX) / (box.width - 2 * EDGE_PX)) * last)));
    const x0 = e.clientX;
    let frame = kf[i];
    btn.setPointerCapture(e.pointerId);
    const move = (ev) => {
      if (!this.dragging && Math.abs(ev.clientX - x0) < DRAG_PX) return;
      this.dragging = true;
      frame = frameAt(ev.clientX);
      btn.style.left = this._at(frame, last);
      btn.querySelector('span').textContent = `key${i} → ${frame}`;
    };
    const up = () => {
      btn.removeEventListener('pointermove', move);
      btn.removeEventListener('pointerup', up);
      btn.removeEventListener('pointercancel', up);
      const dragged = this.dragging;
      this.dragging = false;
      if (dragged && frame !== kf[i]) this.app.moveKey(i, frame);
      else if (dragged) this.render();
    };
    btn.addEventListener('pointermove', move);
    btn.addEventListener('pointerup', up);
    btn.addEventListener('pointercancel', up);
  }

  _at(f, last) { return `calc(${EDGE_PX}px + (100% - ${2 * EDGE_PX}px) * ${f / last})`; }

  render() {
    if (this.dragging) return;  // a key is being dragged: its place is the pointer's
    const shot = this.app.doc.shot;
    const kf = keyFrames(shot);
    const n = kf.length;
    const last = Math.max(1, lastFrame(shot));
    const v2 = shot.format === V2;
    const at = (f) => this._at(Math.min(last, f), last);
    const k = this.app.focusedKey;
    const shown = this.app.shownKeys();
    const items = [];
    const segments = Math.max(1, n - 1);
    const ease = Array.isArray(shot.ease) ? shot.ease : [];
    for (let s = 0; s < segments; s++) {
      const a = kf[s], b = n > 1 ? kf[s + 1] : last;
      const seg = document.createElement('div');
      seg.className = 'tl-seg';
      seg.dataset.s = String(s);
      seg.style.left = at(a);
      seg.style.width = `calc((100% - ${2 * EDGE_PX}px) * ${(b - a) / last})`;
      const sel = document.createElement('select');
      sel.className = 'tl-ease';
      sel.title = v2 ? `segment ${s}'s ease (frames ${a} to ${b})` : 'a v1 shot has no eases: adding, removing or moving a key makes it v2';
      sel.disabled = !v2;
      sel.replaceChildren(...EASES.map((e) => { const o = document.createElement('option'); o.value = o.textContent = e; return o; }));
      sel.value = ease[s] || 'linear';
      sel.addEventListener('change', () => this.app.edit(`segment ${s} ease`, () => {
        const now = this.app.doc.shot;
        const list = Array.from({ length: segments }, (_, i) => (Array.isArray(now.ease) && now.ease[i]) || 'linear');
        list[s] = sel.value;
        now.ease = list;
      }));
      seg.append(sel);
      items.push(seg);
    }
    if (n === 1) {  // a one-drawing shot: the end of its motion
      const end = document.createElement('div');
      end.className = 'tl-end';
      end.style.left = at(last);
      end.textContent = `frame ${last}`;
      items.push(end);
    }
    kf.forEach((f, i) => {
      const btn = document.createElement('button');
      btn.className = `tl-key${i === k ? ' active' : ''}${shown.includes(i) ? ' shown' : ''}`;
      btn.dataset.k = String(i);
      btn.dataset.frame = String(f);
      btn.style.left = at(f);
      btn.title = `key${i}: ${shot.keyframes?.[i] ?? '?'} at frame ${f}${i ? ' (drag to move it in time)' : ''}`;
      const img = this._thumb(i);
      const label = document.createElement('span');
      label.textContent = `key${i} · ${f}`;
      btn.append(img, label);
      btn.addEventListener('click', () => this.app.focusKey(i));
      btn.addEventListener('pointerdown', (e) => this._press(e, i, btn, kf, last));
      items.push(btn);
    });
    this.track.replaceChildren(...items);
    $('tl-selected').textContent = `key${k}`;
    const frame = $('key-frame');
    if (document.activeElement !== frame) frame.value = String(kf[k] ?? 0);
    frame.disabled = k === 0;
    frame.title = k === 0 ? 'key0 stays at frame 0' : 'the key\'s output frame: its pose moves with it (saves and reruns)';
    $('key-remove').disabled = n <= 1;
    const add = $('add-frame');
    if (document.activeElement !== add) add.value = String(this._suggestion(kf, k, lastFrame(shot)));
    $('key-add').disabled = n >= 16;  // ops/shotio/load.py MAX_KEYS
  }
}
