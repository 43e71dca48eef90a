// The results view: the output frames (scrubber, play at a chosen fps, onion skin), the image matrix
// I(alpha, t) with the chosen and diagonal paths and the abrupt transitions, and any stage's preview.

import { getJSON, loadImage } from './api.js';
import { keyFrames } from './timeline.js';
import { fitCanvas } from './viewport.js';

const THUMB = 48;   // matrix cell size requested from the server, pixels
const PAD = 2;      // editor/results.py MATRIX_PAD
const cell = (t, a) => [PAD + t * (THUMB + PAD), PAD + a * (THUMB + PAD)];

function tinted(img, colour) {
  const c = document.createElement('canvas');
  c.width = img.naturalWidth; c.height = img.naturalHeight;
  const cx = c.getContext('2d');
  cx.drawImage(img, 0, 0);
  cx.globalCompositeOperation = 'source-in';
  cx.fillStyle = colour;
  cx.fillRect(0, 0, c.width, c.height);
  return c;
}

export class ResultsView {
  constructor(app) {
    this.app = app;
    this.player = document.getElementById('player');
    this.matrixCanvas = document.getElementById('matrix');
    this.scrub = document.getElementById('scrub');
    this.label = document.getElementById('frame-label');
    this.badge = document.getElementById('frames-badge');
    this.msg = document.getElementById('results-msg');
    this.info = null;
    this.paths = null;
    this.seg = undefined;  // the segment whose matrix is shown (null: one drawing, none)
    this.frames = [];
    this.onion = [];
    this.matrixImg = null;
    this.index = 0;
    this.timer = null;
    this.scrub.addEventListener('input', () => this.show(+this.scrub.value));
    document.getElementById('play').addEventListener('click', () => this.togglePlay());
    document.getElementById('fps').addEventListener('change', () => { if (this.timer) { this.togglePlay(); this.togglePlay(); } });
    document.getElementById('onion').addEventListener('change', () => this.draw());
    this.matrixCanvas.addEventListener('click', (e) => this._pickColumn(e));
    this._previews();
  }

  /** Reload frames and matrix (after a rerun); keeps the current frame index. */
  async refresh() {
    let info;
    try {
      info = await getJSON('/api/frames');
    } catch {
      this.msg.hidden = false;
      this.msg.textContent = 'No frames yet: save or press Run.';
      this.badge.dataset.version = '';
      return;
    }
    const v = info.version;
    const frames = await Promise.all(info.times.map((_, i) => loadImage(`/api/frames/${i}.png?v=${v}`)));
    this.info = info;
    this.frames = frames;
    this.onion = frames.map((f) => [tinted(f, '#e5484d'), tinted(f, '#2ca02c')]);
    this.msg.hidden = true;
    this.scrub.max = String(frames.length - 1);
    this.index = Math.min(this.index, frames.length - 1);
    this.scrub.value = String(this.index);
    this.badge.dataset.version = v;
    this.seg = undefined;  // the matrix of the current frame's segment is fetched again
    await this._loadSegment(this._segmentOf(this.index));
    this.setStale(this.app.stale('inbetween_frames'));
    this.draw();
  }

  /** The segment (k, k + 1) that output frame i lies in (a key's frame: the segment it ends), null for one drawing. */
  _segmentOf(i) {
    const kf = keyFrames(this.app.doc.shot);
    if (kf.length < 2) return null;
    for (let s = 0; s < kf.length - 2; s++) if (i <= kf[s + 1]) return s;
    return kf.length - 2;
  }

  /** Segment s's image matrix and paths (its columns are output frames key_frames[s] ... key_frames[s + 1]). */
  async _loadSegment(s) {
    if (s === this.seg) return;
    this.seg = s;
    let paths = null, img = null;
    if (s !== null) {
      try {
        paths = await getJSON(`/api/matrix?seg=${s}`);
        img = await loadImage(`/api/matrix.png?thumb=${THUMB}&seg=${s}&v=${paths.matrix_version}`);
      } catch {
        paths = null; img = null;
      }
    }
    if (this.seg !== s) return;  // another segment was asked for meanwhile
    this.paths = paths; this.matrixImg = img;
    this._matrixInfo();
    this.draw();
  }

  /** Output frame of the current segment's first column. */
  _segStart() { return this.seg === null ? 0 : keyFrames(this.app.doc.shot)[this.seg]; }

  setStale(stale) {
    this.badge.textContent = stale ? 'stale' : '';
    this.badge.className = stale ? 'badge stale' : 'badge';
    this.badge.title = stale ? 'the saved shot changed since these frames were made; they update when its rerun is done' : '';
  }

  show(i) {
    if (!this.frames.length) return;
    this.index = (i + this.frames.length) % this.frames.length;
    this.scrub.value = String(this.index);
    const s = this._segmentOf(this.index);
    if (s !== this.seg) this._loadSegment(s);
    this.draw();
  }

  togglePlay() {
    const btn = document.getElementById('play');
    if (this.timer) { clearInterval(this.timer); this.timer = null; btn.textContent = 'Play'; return; }
    const fps = Math.max(1, Math.min(60, +document.getElementById('fps').value || 8));
    this.timer = setInterval(() => this.show(this.index + 1), 1000 / fps);
    btn.textContent = 'Pause';
  }

  draw() { this._drawPlayer(); this._drawMatrix(); }

  _drawPlayer() {
    const [cw, ch, dpr] = fitCanvas(this.player);
    const ctx = this.player.getContext('2d');
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.clearRect(0, 0, this.player.width, this.player.height);
    if (!this.frames.length) return;
    const f = this.frames[this.index];
    const s = Math.min(cw / f.naturalWidth, (ch - 24) / f.naturalHeight) * 0.96;
    const w = f.naturalWidth * s, h = f.naturalHeight * s;
    const x = (cw - w) / 2, y = (ch - 24 - h) / 2 + 24;
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.fillStyle = '#fff';
    ctx.fillRect(x, y, w, h);
    if (document.getElementById('onion').checked) {
      ctx.globalAlpha = 0.35;
      if (this.index > 0) ctx.drawImage(this.onion[this.index - 1][0], x, y, w, h);
      if (this.index < this.frames.length - 1) ctx.drawImage(this.onion[this.index + 1][1], x, y, w, h);
      ctx.globalAlpha = 1;
    }
    ctx.drawImage(f, x, y, w, h);
    const t = this.info.times[this.index], a = this.info.alphas[this.index];
    // v2 times are output frames; a key's frame shows its drawing (its segment's alpha 0 or 1)
    const v2 = this.app.doc.shot.format === 'inbetween-shot/2';
    const key = keyFrames(this.app.doc.shot).indexOf(this.index);
    const where = `${v2 ? '' : `   t = ${t.toFixed(3)}`}${key >= 0 ? `   key${key}` : ''}`;
    this.label.textContent = `frame ${this.index} / ${this.frames.length - 1}${where}   alpha = ${a.toFixed(3)}`;
    this.label.dataset.frame = String(this.index);
    ctx.fillStyle = '#e4e6eb';
    ctx.font = '12px system-ui';
    ctx.fillText(`frame ${this.index}${where}`, x, 16);
  }

  _matrixLayout() {
    const [cw, ch, dpr] = fitCanvas(this.matrixCanvas);
    const img = this.matrixImg;
    const s = Math.min((cw - 40) / img.naturalWidth, (ch - 40) / img.naturalHeight);
    return { s, ox: 34, oy: 26, dpr };
  }

  _drawMatrix() {
    const canvas = this.matrixCanvas;
    const ctx = canvas.getContext('2d');
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    if (!this.matrixImg || !this.paths) return;
    const { s, ox, oy, dpr } = this._matrixLayout();
    const P = this.paths;
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.drawImage(this.matrixImg, ox, oy, this.matrixImg.naturalWidth * s, this.matrixImg.naturalHeight * s);
    const centre = (t, a) => { const [x, y] = cell(t, a); return [ox + (x + THUMB / 2) * s, oy + (y + THUMB / 2) * s]; };
    const box = (t, a, inset) => { const [x, y] = cell(t, a); return [ox + x * s + inset, oy + y * s + inset, THUMB * s - 2 * inset, THUMB * s - 2 * inset]; };
    // current frame's column
    const [cx] = cell(this.index - this._segStart(), 0);
    ctx.fillStyle = '#ffffff22';
    ctx.fillRect(ox + (cx - PAD) * s, oy, (THUMB + 2 * PAD) * s, this.matrixImg.naturalHeight * s);
    // axis labels
    ctx.fillStyle = '#9aa0ab';
    ctx.font = '10px system-ui';
    P.times.forEach((t, i) => { const [x] = centre(i, 0); ctx.fillText(t.toFixed(2), x - 10, oy - 6); });
    P.alphas.forEach((a, j) => { const [, y] = centre(0, j); ctx.fillText(a.toFixed(2), 2, y + 3); });
    const chosen = this.info && this.info.blend === 'diagonal' ? P.diagonal : P.optimal;
    const other = chosen === P.optimal ? P.diagonal : P.optimal;
    const path = (p, colour, inset, dash) => {
      ctx.strokeStyle = colour; ctx.lineWidth = 2; ctx.setLineDash(dash);
      p.alpha_index.forEach((a, t) => ctx.strokeRect(...box(t, a, inset)));
      ctx.beginPath();
      p.alpha_index.forEach((a, t) => { const [x, y] = centre(t, a); t ? ctx.lineTo(x, y) : ctx.moveTo(x, y); });
      ctx.stroke();
      ctx.setLineDash([]);
    };
    path(other, '#1e6bff', 4, [5, 3]);
    path(chosen, '#ff2020', 0, []);
    // abrupt transitions of the chosen path: the step, thick, and both of its cells
    ctx.strokeStyle = '#ff9f1a';
    chosen.abrupt.forEach((abrupt, t) => {
      if (!abrupt) return;
      const [x0, y0] = centre(t, chosen.alpha_index[t]);
      const [x1, y1] = centre(t + 1, chosen.alpha_index[t + 1]);
      ctx.lineWidth = 6;
      ctx.beginPath(); ctx.moveTo(x0, y0); ctx.lineTo(x1, y1); ctx.stroke();
      ctx.lineWidth = 3;
      ctx.strokeRect(...box(t, chosen.alpha_index[t], -3));
      ctx.strokeRect(...box(t + 1, chosen.alpha_index[t + 1], -3));
    });
  }

  _matrixInfo() {
    const el = document.getElementById('matrix-info');
    const P = this.paths;
    if (!P) { el.textContent = this.seg === null ? 'one drawing: no blending, no image matrix' : 'no image matrix yet'; return; }
    const chosen = this.info && this.info.blend === 'diagonal' ? P.diagonal : P.optimal;
    const abrupt = chosen.abrupt.map((a, i) => (a ? `t ${P.times[i].toFixed(2)}→${P.times[i + 1].toFixed(2)}` : null)).filter(Boolean);
    const s = this.seg;
    const seg = this.app.info.keys > 2 ? `segment ${s} (key${s} to key${s + 1})\n` : '';
    el.textContent = `${seg}cost: chosen ${chosen.cost.toFixed(4)}, diagonal ${P.diagonal.cost.toFixed(4)}\n`
      + `abrupt: ${abrupt.length ? abrupt.join(', ') : 'none'}`;
    el.dataset.abrupt = String(abrupt.length);
  }

  _pickColumn(e) {
    if (!this.matrixImg) return;
    const r = this.matrixCanvas.getBoundingClientRect();
    const { s, ox } = this._matrixLayout();
    const t = Math.floor(((e.clientX - r.left - ox) / s - PAD) / (THUMB + PAD));
    if (t >= 0 && t < this.paths.times.length) this.show(this._segStart() + t);
  }

  /** The stage menu of the previews, for the graph of the shot's keys. */
  setGraph(info) {
    const sel = document.getElementById('preview-stage');
    const none = document.createElement('option');
    none.value = ''; none.textContent = '(choose a stage)';
    const keep = sel.value;
    sel.replaceChildren(none, ...info.stages.map((s) => { const o = document.createElement('option'); o.value = o.textContent = s; return o; }));
    sel.value = info.stages.includes(keep) ? keep : '';
  }

  _previews() {
    const sel = document.getElementById('preview-stage');
    const img = document.getElementById('preview-img');
    this.setGraph(this.app.info);
    sel.addEventListener('change', () => this.showPreview(sel.value));
    img.addEventListener('error', () => {
      img.hidden = true;
      img.closest('.results-stage').classList.remove('with-preview');
      this.draw();
      this.app.flash(`no preview of ${sel.value} yet`);
    });
  }

  /** The stored preview PNG of a stage, fetched when asked for. */
  showPreview(stage) {
    const img = document.getElementById('preview-img');
    img.closest('.results-stage').classList.toggle('with-preview', !!stage);
    if (!stage) { img.hidden = true; this.draw(); return; }
    img.hidden = false;
    img.onload = () => this.draw();
    img.src = `/api/previews/${stage}.png?v=${Date.now()}`;
    img.alt = `preview of ${stage}`;
  }
}
