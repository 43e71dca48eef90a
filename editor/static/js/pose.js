// The pose view: live re-pose of an in-between pose on the last run's textured template, and
// "Add as pose at t" to put the dragged pose into the motion.

import { ApiError, postForPixels, sendJSON } from './api.js';
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

  get key() {
    const v = document.getElementById('pose-key').value;
    return v === 'auto' ? (this.t < 0.5 ? 0 : 1) : +v;
  }

  async enter() {
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
    this.t = Math.min(1, Math.max(0, Math.round(t * 1000) / 1000));
    this.slider.value = this.number.value = String(this.t);
    const got = await sendJSON('POST', '/api/motion', { shot: this.app.doc.toShot(), times: [this.t] });
    this.pose = got.poses[0];
    document.getElementById('pose-add').disabled = this.t <= 0 || this.t >= 1;
    this._list();
    this.render();
  }

  async _ticks() {
    const got = await sendJSON('POST', '/api/motion', { shot: this.app.doc.toShot() });
    const ticks = document.getElementById('pose-ticks');
    ticks.replaceChildren(...got.times.map((t) => { const s = document.createElement('span'); s.style.left = `${t * 100}%`; return s; }));
  }

  _list() {
    const ol = document.getElementById('pose-list');
    const poses = this.app.doc.shot.poses;
    ol.replaceChildren(...poses.map((p, i) => {
      const li = document.createElement('li');
      li.textContent = `t = ${(+p.t).toFixed(3)}${i === 0 ? ' (key0)' : i === poses.length - 1 ? ' (key1)' : ''} `;
      if (Math.abs(p.t - this.t) < 1e-9) li.className = 'near';
      li.addEventListener('click', () => this.setT(p.t));
      if (i > 0 && i < poses.length - 1) {
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
      const { bitmap, headers } = await postForPixels('/api/repose', {
        k: this.key, t: this.t, joints: this.pose, scale: Math.min(1, this.view.zoom * dpr), settle,
      });
      this.image = bitmap;
      this.updates += 1;
      const ms = performance.now() - t0;
      this.stats.textContent = `key${this.key} template · update ${ms.toFixed(0)} ms (solve ${headers.get('X-Solve-Ms')} ms, `
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
    if (!this.pose || this.t <= 0 || this.t >= 1) return;
    const t = this.t;
    const joints = this.pose.map((j) => [round1(j[0]), round1(j[1]), +(+j[2]).toFixed(4)]);
    this.app.edit(`add pose at t = ${t}`, () => {
      const poses = this.app.doc.shot.poses;
      const same = poses.findIndex((p) => Math.abs(p.t - t) < 1e-9);
      if (same >= 0) poses[same] = { t, joints };
      else poses.splice(poses.findIndex((p) => p.t > t), 0, { t, joints });
    });
    this.app.flash(`pose added at t = ${t}; save to rerun`);
    this._list();
    this._ticks();
  }
}
