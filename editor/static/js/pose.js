// The pose view: live re-pose of an in-between pose on the last run's textured template, and
// "Add as pose at t" to put the dragged pose into the motion.

import { ApiError, postForPixels, sendJSON } from './api.js';
import { V2 } from './skeleton.js';
import { keyFrames, lastFrame } from './timeline.js';
import { Viewport, fitCanvas } from './viewport.js';

const HIT_PX = 10;
const round1 = (v) => Math.round(v * 10) / 10;

export class PoseView {
  constructor(app) {
    this.app = app;
    this.canvas = document.getElementById('pose-canvas');
    this.ctx = this.canvas.getContext('2d');
    this.msg = document.getElementById('pose-msg');
    this.stats = document.getElementById('pose-stats');
    this.slider = document.getElementById('pose-t');
    this.number = document.getElementById('pose-t-num');
    this.view = new Viewport();
    this.t = 0.5;
    this.pose = null;        // (J, 3) the pose shown, edited by dragging
    this.image = null;       // the last rendered template (ImageBitmap at display scale)
    this.inflight = false;
    this.pending = false;
    this.updates = 0;
    this.drag = null;
    this.slider.addEventListener('input', () => this.setT(+this.slider.value));
    this.number.addEventListener('change', () => this.setT(+this.number.value));
    document.getElementById('pose-key').addEventListener('change', () => this.render());
    document.getElementById('pose-add').addEventListener('click', () => this.addPose());
    document.getElementById('pose-reset').addEventListener('click', () => this.setT(this.t));
    const c = this.canvas;
    c.addEventListener('pointerdown', (e) => this._down(e));
    c.addEventListener('pointermove', (e) => this._move(e));
    c.addEventListener('pointerup', (e) => this._up(e));
    c.addEventListener('pointercancel', (e) => this._up(e));
  }

  /** v2: the clock is the output frame (0 .. the last), the template a key of the frame's segment; v1: t in [0, 1]. */
  get v2() { return this.app.doc.shot.format === V2; }

  /** The segment the shown time lies in and its own time there: {seg, local, keys: [first, last key]}. */
  get where() {
    if (!this.v2) return { seg: 0, local: this.t, keys: [0, 1] };
    const kf = keyFrames(this.app.doc.shot);
    if (kf.length < 2) return { seg: 0, local: this.t / Math.max(1, lastFrame(this.app.doc.shot)), keys: [0, 0] };
    let s = 0;
    while (s < kf.length - 2 && this.t > kf[s + 1]) s++;
    return { seg: s, local: (this.t - kf[s]) / (kf[s + 1] - kf[s]), keys: [s, s + 1] };
  }

  get key() {
    const v = document.getElementById('pose-key').value;
    const { local, keys } = this.where;
    return v === 'auto' ? keys[local < 0.5 ? 0 : 1] : keys[+v];
  }

  /** The slider, the template menu and the "Add" button for the shot's clock. */
  _clock() {
    const last = this.v2 ? Math.max(1, lastFrame(this.app.doc.shot)) : 1;
    for (const el of [this.slider, this.number]) {
      el.min = '0'; el.max = String(last); el.step = this.v2 ? '1' : '0.005';
    }
    const { keys } = this.where;
    const sel = document.getElementById('pose-key');
    sel.options[1].textContent = this.v2 ? `key${keys[0]} (segment's first)` : 'key0';
    sel.options[2].textContent = this.v2 ? `key${keys[1]} (its last)` : 'key1';
    document.getElementById('pose-add').textContent = this.v2 ? 'Add as pose at this frame' : 'Add as pose at t';
    return last;
  }

  async enter() {
    const last = this._clock();
    if (this.v2 && !Number.isInteger(this.t)) this.t = Math.floor(last / 2);  // from t in [0, 1] to frames
    if (!this.v2 && this.t > 1) this.t = 0.5;
    document.getElementById('pose-clock').textContent = this.v2 ? 'frame' : 't';
    try {
      await this._ticks();
      await this.setT(this.t);
    } catch (e) {
      // no skeleton or poses yet (or a motion the loader refuses): say so instead of a stale view
      this.pose = null;
      this.image = null;
      this.msg.hidden = false;
      this.msg.textContent = `no motion to pose: ${e.message}`;
      this.draw();
    }
  }

  /** Show the pose at time t, interpolated per bone from the poses being edited (saved or not). */
  async setT(t) {
    const last = this._clock();
    this.t = this.v2 ? Math.min(last, Math.max(0, Math.round(t))) : Math.min(1, Math.max(0, Math.round(t * 1000) / 1000));
    this.slider.value = this.number.value = String(this.t);
    this._clock();  // the template menu names the keys of this frame's segment
    const got = await sendJSON('POST', '/api/motion', { shot: this.app.doc.toShot(), times: [this.t] });
    this.pose = got.poses[0];
    const isKey = this.v2 ? keyFrames(this.app.doc.shot).includes(this.t) : this.t <= 0 || this.t >= 1;
    document.getElementById('pose-add').disabled = isKey || (this.v2 && keyFrames(this.app.doc.shot).length === 1 && this.t >= last);
    this._list();
    this.render();
  }

  async _ticks() {
    const got = await sendJSON('POST', '/api/motion', { shot: this.app.doc.toShot() });
    const span = this.v2 ? Math.max(1, got.times.length - 1) : 1;
    const ticks = document.getElementById('pose-ticks');
    ticks.replaceChildren(...got.times.map((t) => { const s = document.createElement('span'); s.style.left = `${(t / span) * 100}%`; return s; }));
  }

  _list() {
    const ol = document.getElementById('pose-list');
    const poses = this.app.doc.shot.poses;
    const clock = this.v2 ? 'frame' : 't';
    const kf = this.v2 ? keyFrames(this.app.doc.shot) : null;
    const keyOf = (p, i) => (this.v2 ? kf.indexOf(p.frame) : i === 0 ? 0 : i === poses.length - 1 ? 1 : -1);
    ol.replaceChildren(...poses.map((p, i) => {
      const li = document.createElement('li');
      const k = keyOf(p, i);
      li.textContent = `${clock} = ${this.v2 ? +p.frame : (+p.t).toFixed(3)}${k >= 0 ? ` (key${k})` : ''} `;
      if (Math.abs(p[clock] - this.t) < 1e-9) li.className = 'near';
      li.addEventListener('click', () => this.setT(p[clock]));
      if (k < 0) {
        const del = document.createElement('button');
        del.textContent = '×';
        del.title = 'remove this pose from the motion';
        del.addEventListener('click', (e) => {
          e.stopPropagation();
          this.app.edit('remove pose', () => this.app.doc.shot.poses.splice(i, 1));
          this.setT(this.t);
        });
        li.append(del);
      }
      return li;
    }));
  }

  /** Ask the server for the template deformed into this.pose; at most one request in flight, the latest wins.
   *  While a joint is dragged the solve is bounded (the view keeps up); the update after the drag settles it. */
  async render() {
    if (!this.pose) return;
    if (this.inflight) { this.pending = true; return; }
    this.inflight = true;
    this.pending = false;
    const settle = !this.drag;
    const [, , dpr] = fitCanvas(this.canvas);
    this._fit();
    const t0 = performance.now();
    try {
      const { seg, local } = this.where;
      const { bitmap, headers } = await postForPixels('/api/repose', {
        k: this.key, seg, t: Math.min(1, Math.max(0, local)), joints: this.pose, scale: Math.min(1, this.view.zoom * dpr), settle,
      });
      this.image = bitmap;
      this.updates += 1;
      const ms = performance.now() - t0;
      this.stats.textContent = `${this.v2 ? `seg${seg}/` : ''}key${this.key} template · update ${ms.toFixed(0)} ms (solve ${headers.get('X-Solve-Ms')} ms, `
        + `render ${headers.get('X-Render-Ms')} ms, ${headers.get('X-Iterations')} iterations)`;
      this.stats.dataset.updates = String(this.updates);
      this.stats.dataset.ms = ms.toFixed(1);
      this.msg.hidden = true;
    } catch (e) {
      this.image = null;
      this.msg.hidden = false;
      this.msg.textContent = e instanceof ApiError && e.status === 409 ? e.message : `re-pose failed: ${e.message}`;
    } finally {
      this.inflight = false;
    }
    this.draw();
    if (this.pending) this.render();
  }

  _fit() {
    const [cw, ch] = fitCanvas(this.canvas);
    const [H, W] = this.app.doc.size;
    this.view.fit(W, H, cw, ch);
  }

  draw() {
    const [, , dpr] = fitCanvas(this.canvas);
    const ctx = this.ctx;
    const [H, W] = this.app.doc.size;
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.clearRect(0, 0, this.canvas.width, this.canvas.height);
    this.view.apply(ctx, dpr);
    ctx.fillStyle = '#fff';
    ctx.fillRect(-0.5, -0.5, W, H);
    if (this.image) ctx.drawImage(this.image, -0.5, -0.5, W, H);
    if (!this.pose) return;
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    const parents = this.app.doc.parents();
    ctx.strokeStyle = '#333c';
    ctx.lineWidth = 2;
    parents.forEach((p, c) => {
      if (p < 0) return;
      const [ax, ay] = this.view.toScreen(this.pose[p][0], this.pose[p][1]);
      const [bx, by] = this.view.toScreen(this.pose[c][0], this.pose[c][1]);
      ctx.beginPath(); ctx.moveTo(ax, ay); ctx.lineTo(bx, by); ctx.stroke();
    });
    this.pose.forEach(([x, y], j) => {
      const [sx, sy] = this.view.toScreen(x, y);
      ctx.beginPath();
      ctx.arc(sx, sy, this.drag && this.drag.j === j ? 7 : 5, 0, 2 * Math.PI);
      ctx.fillStyle = '#ffeb3b';
      ctx.fill();
      ctx.lineWidth = 1.5; ctx.strokeStyle = '#111'; ctx.stroke();
    });
  }

  _local(e) {
    const r = this.canvas.getBoundingClientRect();
    return [e.clientX - r.left, e.clientY - r.top];
  }

  _down(e) {
    if (!this.pose) return;
    const [sx, sy] = this._local(e);
    let best = -1, bestD = HIT_PX;
    this.pose.forEach(([x, y], j) => {
      const [px, py] = this.view.toScreen(x, y);
      const d = Math.hypot(px - sx, py - sy);
      if (d < bestD) { best = j; bestD = d; }
    });
    if (best < 0) return;
    this.canvas.setPointerCapture(e.pointerId);
    const [x, y] = this.view.toImage(sx, sy);
    this.drag = { j: best, grab: [x, y], start: [...this.pose[best]] };
  }

  _move(e) {
    if (!this.drag) return;
    const [x, y] = this.view.toImage(...this._local(e));
    const d = this.drag;
    this.pose[d.j][0] = round1(d.start[0] + x - d.grab[0]);
    this.pose[d.j][1] = round1(d.start[1] + y - d.grab[1]);
    this.draw();
    this.render();
  }

  _up(e) {
    if (this.canvas.hasPointerCapture(e.pointerId)) this.canvas.releasePointerCapture(e.pointerId);
    const dragged = this.drag;
    this.drag = null;
    this.draw();
    if (dragged) this.render();  // the settling update
  }

  /** Insert the shown pose into the motion at t (replacing a pose at the same t); save to rerun. */
  addPose() {
    if (!this.pose || document.getElementById('pose-add').disabled) return;
    const t = this.t;
    const clock = this.v2 ? 'frame' : 't';
    const joints = this.pose.map((j) => [round1(j[0]), round1(j[1]), +(+j[2]).toFixed(4)]);
    this.app.edit(`add pose at ${clock} = ${t}`, () => {
      const poses = this.app.doc.shot.poses;
      const same = poses.findIndex((p) => Math.abs(p[clock] - t) < 1e-9);
      const after = poses.findIndex((p) => p[clock] > t);
      if (same >= 0) poses[same] = { [clock]: t, joints };
      else poses.splice(after < 0 ? poses.length : after, 0, { [clock]: t, joints });
    });
    this.app.flash(`pose added at ${clock} = ${t}; save to rerun`);
    this._list();
    this._ticks();
  }
}
