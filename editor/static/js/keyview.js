// One keyframe in the annotation view: the drawing, its overlays, and the pointer tools
// (move joints and T-junctions, add T-junctions, paint and erase masks, zoom and pan).

import { FOREGROUND_COLOUR, regionColour } from './masks.js';
import { Viewport, fitCanvas } from './viewport.js';

const HIT_PX = 9;          // screen pixels within which a joint or a T-junction is picked
const JOINT_R = 5;
const TJ_R = 6;
const Z_STEP = 0.1;        // depth change per wheel notch (Shift: x10)
const round1 = (v) => Math.round(v * 10) / 10;

/** Joint colour by depth: near (small z) blue, far orange, relative to the pose's depth range. */
function depthColour(z, lo, hi) {
  const s = hi > lo ? (z - lo) / (hi - lo) : 0.5;
  const a = [60, 140, 255], b = [255, 150, 40];
  return `rgb(${a.map((c, i) => Math.round(c + s * (b[i] - c))).join(',')})`;
}

export class KeyView {
  constructor(k, pane, app) {
    this.k = k;
    this.pane = pane;
    this.app = app;
    this.canvas = pane.querySelector('canvas');
    this.bubbles = pane.querySelector('.bubbles');
    this.ctx = this.canvas.getContext('2d');
    this.view = new Viewport();
    this.fitted = false;
    this.drag = null;
    this.hover = null;
    this.pointer = null;   // last pointer position, image pixels (brush cursor)
    this._listen();
  }

  get doc() { return this.app.doc; }

  fit() {
    const [w, h] = fitCanvas(this.canvas);
    const [H, W] = this.doc.size;
    this.view.fit(W, H, w, h);
    this.fitted = true;
    this.draw();
  }

  // ---------------------------------------------------------------- drawing

  draw() {
    const [cw, ch, dpr] = fitCanvas(this.canvas);
    if (!this.fitted && cw > 1) { this.fitted = true; const [H, W] = this.doc.size; this.view.fit(W, H, cw, ch); }
    const ctx = this.ctx;
    const app = this.app;
    const show = app.overlays;
    const [H, W] = this.doc.size;
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.clearRect(0, 0, this.canvas.width, this.canvas.height);
    this.view.apply(ctx, dpr);
    ctx.imageSmoothingEnabled = this.view.zoom < 2;
    ctx.fillStyle = '#fff';
    ctx.fillRect(-0.5, -0.5, W, H);
    const drawing = app.drawings[this.k];
    if (drawing && show.has('drawing')) ctx.drawImage(drawing, -0.5, -0.5, W, H);

    const fill = (layer, colour, alpha) => {
      ctx.globalAlpha = alpha;
      ctx.drawImage(layer.tinted(colour), -0.5, -0.5, W, H);
      ctx.globalAlpha = 1;
    };
    const pred = app.predicted[this.k];
    if (pred && show.has('predicted')) {
      fill(pred.fg, FOREGROUND_COLOUR, 0.25);
      pred.occ.forEach((l, i) => fill(l, regionColour(i), 0.35));
    }
    const ref = app.refined[this.k];
    if (ref && show.has('refined')) ref.occ.forEach((l, i) => fill(l, regionColour(i), 0.4));
    if (show.has('manual')) {
      const s = this.doc.structure[this.k];
      if (s.fg) fill(this.doc.layer(s.fg), FOREGROUND_COLOUR, 0.35);
      s.occ.forEach((id, i) => fill(this.doc.layer(id), regionColour(i), 0.5));
    }

    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);  // from here on: CSS pixels, constant-size marks
    if (ref && show.has('boundaries')) this._boundaries(ref.json);
    if (show.has('skeleton')) this._skeleton();
    if (show.has('tjunctions')) this._tjunctions();
    this._brushCursor();
    this._errorBubble();
  }

  _poly(points, closed) {
    const ctx = this.ctx;
    ctx.beginPath();
    points.forEach(([x, y], i) => { const [sx, sy] = this.view.toScreen(x, y); i ? ctx.lineTo(sx, sy) : ctx.moveTo(sx, sy); });
    if (closed) ctx.closePath();
    ctx.stroke();
  }

  _boundaries(json) {
    const ctx = this.ctx;
    ctx.lineWidth = 1.5;
    ctx.setLineDash([]);
    ctx.strokeStyle = '#2b7a2b';
    for (const outline of json.domain) if (outline.length > 1) this._poly(outline, true);
    json.boundaries.forEach((b, i) => { ctx.strokeStyle = regionColour(i); ctx.lineWidth = 2; this._poly(b, true); });
    ctx.fillStyle = '#d62728';
    for (const pts of json.junctions) {
      for (const [x, y] of pts) { const [sx, sy] = this.view.toScreen(x, y); ctx.fillRect(sx - 2, sy - 2, 4, 4); }
    }
  }

  _skeleton() {
    const ctx = this.ctx;
    const joints = this.doc.keyPose(this.k);
    const parents = this.doc.shot.skeleton.parents;
    const zs = joints.map((j) => j[2]);
    const lo = Math.min(...zs), hi = Math.max(...zs);
    const sel = this.app.selected;
    for (let c = 0; c < parents.length; c++) {
      const p = parents[c];
      if (p < 0 || !joints[p] || !joints[c]) continue;
      const [ax, ay] = this.view.toScreen(joints[p][0], joints[p][1]);
      const [bx, by] = this.view.toScreen(joints[c][0], joints[c][1]);
      for (const [w, col] of [[5, '#ffffffcc'], [2.5, '#333']]) {
        ctx.lineWidth = w; ctx.strokeStyle = col;
        ctx.beginPath(); ctx.moveTo(ax, ay); ctx.lineTo(bx, by); ctx.stroke();
      }
    }
    joints.forEach(([x, y, z], j) => {
      const [sx, sy] = this.view.toScreen(x, y);
      const selected = sel && sel.k === this.k && sel.kind === 'joint' && sel.index === j;
      const hovered = this.hover && this.hover.kind === 'joint' && this.hover.index === j;
      ctx.beginPath();
      ctx.arc(sx, sy, JOINT_R + (selected || hovered ? 2 : 0), 0, 2 * Math.PI);
      ctx.fillStyle = depthColour(z, lo, hi);
      ctx.fill();
      ctx.lineWidth = selected ? 3 : 1.5;
      ctx.strokeStyle = selected ? '#ffeb3b' : '#111';
      ctx.stroke();
      if (selected || hovered) {
        ctx.font = '12px system-ui';
        const label = `${this.doc.shot.skeleton.joints[j]}  z=${(+z).toFixed(2)}`;
        ctx.fillStyle = '#000b';
        ctx.fillRect(sx + 9, sy - 22, ctx.measureText(label).width + 8, 17);
        ctx.fillStyle = '#fff';
        ctx.fillText(label, sx + 13, sy - 9);
      }
    });
  }

  _tjunctions() {
    const ctx = this.ctx;
    const pts = this.doc.shot.t_junctions?.[this.k] || [];
    const sel = this.app.selected;
    pts.forEach(([x, y], i) => {
      const [sx, sy] = this.view.toScreen(x, y);
      const selected = sel && sel.k === this.k && sel.kind === 'tj' && sel.index === i;
      ctx.beginPath();
      ctx.arc(sx, sy, TJ_R, 0, 2 * Math.PI);
      ctx.lineWidth = 4; ctx.strokeStyle = '#fff'; ctx.stroke();
      ctx.lineWidth = 2; ctx.strokeStyle = selected ? '#ffeb3b' : '#d62728'; ctx.stroke();
      ctx.beginPath(); ctx.moveTo(sx - 3, sy); ctx.lineTo(sx + 3, sy); ctx.moveTo(sx, sy - 3); ctx.lineTo(sx, sy + 3);
      ctx.lineWidth = 1; ctx.stroke();
    });
  }

  _brushCursor() {
    const tool = this.app.tool;
    if (!this.pointer || (tool !== 'paint' && tool !== 'erase')) return;
    const [sx, sy] = this.view.toScreen(...this.pointer);
    const ctx = this.ctx;
    ctx.beginPath();
    ctx.arc(sx, sy, Math.max(1, this.app.brush * this.view.zoom), 0, 2 * Math.PI);
    ctx.lineWidth = 1.5;
    ctx.setLineDash([4, 3]);
    ctx.strokeStyle = tool === 'erase' ? '#e5484d' : '#111';
    ctx.stroke();
    ctx.setLineDash([]);
  }

  /** The save error next to the item it names (a joint, a T-junction), if it is on this keyframe. */
  _errorBubble() {
    const err = this.app.errorItem;
    this.bubbles.replaceChildren();
    if (!err || err.k !== this.k) return;
    const shot = this.doc.shot;
    const p = err.kind === 'joint' ? shot.poses[err.pose]?.joints[err.index] : shot.t_junctions?.[this.k]?.[err.index];
    if (!p) return;
    const [sx, sy] = this.view.toScreen(p[0], p[1]);
    const ctx = this.ctx;
    ctx.beginPath();
    ctx.arc(sx, sy, 13, 0, 2 * Math.PI);
    ctx.lineWidth = 3; ctx.strokeStyle = '#e5484d'; ctx.stroke();
    const b = document.createElement('div');
    b.className = 'bubble';
    b.dataset.field = err.field;
    b.textContent = err.message;
    const { width, height } = this.canvas.getBoundingClientRect();
    // kept inside the pane even when the item was dragged off the keyframe; on the side with more room
    const x = Math.min(Math.max(sx, 0), width);
    if (x > width / 2) b.classList.add('left');
    b.style.left = `${x}px`;
    b.style.top = `${Math.min(Math.max(sy, 30), height - 30)}px`;
    this.bubbles.append(b);
  }

  // ---------------------------------------------------------------- picking

  _pick(sx, sy) {
    let best = null, bestD = HIT_PX;
    const consider = (kind, pts) => pts.forEach(([x, y], i) => {
      const [px, py] = this.view.toScreen(x, y);
      const d = Math.hypot(px - sx, py - sy);
      if (d < bestD) { best = { kind, index: i }; bestD = d; }
    });
    if (this.app.overlays.has('tjunctions')) consider('tj', this.doc.shot.t_junctions?.[this.k] || []);
    if (this.app.overlays.has('skeleton')) consider('joint', this.doc.keyPose(this.k));
    return best;
  }

  _local(e) {
    const r = this.canvas.getBoundingClientRect();
    return [e.clientX - r.left, e.clientY - r.top];
  }

  // ---------------------------------------------------------------- pointer tools

  _listen() {
    const c = this.canvas;
    c.addEventListener('pointerdown', (e) => this._down(e));
    c.addEventListener('pointermove', (e) => this._move(e));
    c.addEventListener('pointerup', (e) => this._up(e));
    c.addEventListener('pointercancel', (e) => this._up(e));
    c.addEventListener('pointerleave', () => { this.pointer = null; this.hover = null; this.draw(); });
    c.addEventListener('wheel', (e) => this._wheel(e), { passive: false });
    c.addEventListener('contextmenu', (e) => e.preventDefault());
    c.addEventListener('dblclick', () => this.fit());
  }

  _down(e) {
    const app = this.app;
    app.focusKey(this.k);
    const [sx, sy] = this._local(e);
    const [x, y] = this.view.toImage(sx, sy);
    this.canvas.setPointerCapture(e.pointerId);
    if (e.button === 1 || e.button === 2 || app.spaceHeld) {
      this.drag = { kind: 'pan', sx, sy, panX: this.view.panX, panY: this.view.panY };
      return;
    }
    const tool = app.tool;
    if (tool === 'paint' || tool === 'erase') {
      const layer = app.brushLayer(this.k, app.history.begin(tool === 'paint' ? 'paint' : 'erase'));
      if (!layer) { app.history.commit(); return; }
      const before = layer.ctx.getImageData(0, 0, layer.canvas.width, layer.canvas.height);
      const box = layer.stroke(x, y, x, y, app.brush, tool === 'erase');
      this.drag = { kind: 'brush', layer, before, box, last: [x, y] };
      app.redraw();
      return;
    }
    const hit = this._pick(sx, sy);
    if (hit && e.altKey && hit.kind === 'tj') {
      app.select(null);
      app.edit('delete T-junction', () => this.doc.shot.t_junctions[this.k].splice(hit.index, 1));
      return;
    }
    if (hit) {
      app.select({ k: this.k, ...hit });
      app.history.begin(hit.kind === 'joint' ? 'move joint' : 'move T-junction');
      this.drag = { kind: hit.kind, index: hit.index, dx: 0, dy: 0, start: this._itemXY(hit) , grab: [x, y] };
      return;
    }
    if (tool === 'tjunction') {
      app.history.begin('add T-junction');
      const shot = this.doc.shot;
      shot.t_junctions = shot.t_junctions || [[], []];
      shot.t_junctions[this.k].push([round1(x), round1(y)]);
      const index = shot.t_junctions[this.k].length - 1;
      app.select({ k: this.k, kind: 'tj', index });
      this.drag = { kind: 'tj', index, start: [round1(x), round1(y)], grab: [x, y] };
      app.changed();
      return;
    }
    app.select(null);
    this.drag = { kind: 'pan', sx, sy, panX: this.view.panX, panY: this.view.panY };
  }

  _itemXY(hit) {
    const p = hit.kind === 'joint' ? this.doc.keyPose(this.k)[hit.index] : this.doc.shot.t_junctions[this.k][hit.index];
    return [p[0], p[1]];
  }

  _move(e) {
    const [sx, sy] = this._local(e);
    const [x, y] = this.view.toImage(sx, sy);
    this.pointer = [x, y];
    const d = this.drag;
    if (!d) {
      const hover = this._pick(sx, sy);
      if (JSON.stringify(hover) !== JSON.stringify(this.hover)) this.hover = hover;
      this.canvas.style.cursor = hover && this.app.tool !== 'paint' && this.app.tool !== 'erase' ? 'grab'
        : this.app.tool === 'tjunction' ? 'crosshair' : 'default';
      if (this.app.tool === 'paint' || this.app.tool === 'erase' || hover || this.hover) this.draw();
      return;
    }
    if (d.kind === 'pan') {
      this.view.panX = d.panX + sx - d.sx;
      this.view.panY = d.panY + sy - d.sy;
      this.draw();
    } else if (d.kind === 'brush') {
      const box = d.layer.stroke(d.last[0], d.last[1], x, y, this.app.brush, this.app.tool === 'erase');
      d.box = union(d.box, box);
      d.last = [x, y];
      this.app.redraw();
    } else {
      // joints and T-junctions follow the pointer without limits: a joint dragged off the keyframe is
      // refused at save, with the message next to it
      const nx = round1(d.start[0] + x - d.grab[0]), ny = round1(d.start[1] + y - d.grab[1]);
      const target = d.kind === 'joint' ? this.doc.keyPose(this.k)[d.index] : this.doc.shot.t_junctions[this.k][d.index];
      target[0] = nx; target[1] = ny;
      this.app.changed(false);
    }
  }

  _up(e) {
    const d = this.drag;
    this.drag = null;
    if (this.canvas.hasPointerCapture(e.pointerId)) this.canvas.releasePointerCapture(e.pointerId);
    if (!d || d.kind === 'pan') return;
    if (d.kind === 'brush') this.app.history.patch(d.layer, d.box, d.before);
    this.app.history.commit();
    this.app.changed();
  }

  _wheel(e) {
    e.preventDefault();
    const [sx, sy] = this._local(e);
    const hit = this._pick(sx, sy);
    if (hit && hit.kind === 'joint') {
      const step = (e.shiftKey ? 10 : 1) * Z_STEP * (e.deltaY < 0 ? -1 : 1);
      this.app.select({ k: this.k, ...hit });
      this.app.wheelDepth(this.k, hit.index, step);
      return;
    }
    this.view.zoomAt(Math.pow(1.0015, -e.deltaY), sx, sy);
    this.draw();
  }
}

function union(a, b) {
  const x0 = Math.min(a[0], b[0]), y0 = Math.min(a[1], b[1]);
  const x1 = Math.max(a[0] + a[2], b[0] + b[2]), y1 = Math.max(a[1] + a[3], b[1] + b[3]);
  return [x0, y0, x1 - x0, y1 - y0];
}
