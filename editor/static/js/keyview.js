// One keyframe in the annotation view: the drawing, its overlays, the stages' warnings at what they name, and
// the pointer tools (move joints and T-junctions, add T-junctions, build the skeleton, place a template, paint
// and erase masks, zoom and pan).

import { FOREGROUND_COLOUR, regionColour } from './masks.js';
import { Viewport, fitCanvas } from './viewport.js';

const HIT_PX = 9;          // screen pixels within which a joint or a T-junction is picked
const JOINT_R = 5;
const TJ_R = 6;
const PROP_R = 7;          // a proposal's hollow diamond (half its diagonal, screen pixels)
const PROP_COLOUR = '#0a9bb5';
const DRAG_PX = 4;         // a press that moves less than this is a click
const WARN_COLOUR = '#f0a030';
const WARN_RING_PX = 13;  // the pointer this near a warning's ring opens its bubble
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
    this.notes = pane.querySelector('.notes');
    this.ctx = this.canvas.getContext('2d');
    this.view = new Viewport();
    this.fitted = false;
    this.drag = null;
    this.hover = null;
    this.pointer = null;   // last pointer position, image pixels (brush cursor)
    this.openWarning = null;  // the warning bubble shown whole (stage + '\n' + text), the others compact
    this._listen();
  }

  get doc() { return this.app.doc; }

  /** Show keyframe k in this pane (the timeline's selection and its neighbour). */
  setKey(k) {
    this.pane.querySelector('.keytitle').textContent = `key${k} · frame ${this.app.keyFrame(k)}`;
    if (k === this.k) return;
    this.k = k;
    this.pane.dataset.k = String(k);
    this.drag = null;
    this.hover = null;
    this.openWarning = null;
    this.fitted = false;
  }

  fit() {
    const [w, h] = fitCanvas(this.canvas);
    const [H, W] = this.doc.size;
    this.view.fit(W, H, w, h);
    this.fitted = true;
    this.draw();
  }

  // ---------------------------------------------------------------- drawing

  draw() {
    if (this.pane.hidden) return;
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
    this._proposals();
    this._gesture();
    this._brushCursor();
    this._bubbles();
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
    const parents = this.doc.parents();
    const names = this.doc.jointNames();
    const allNames = this.app.tool === 'skeleton';  // building the skeleton: every joint says which it is
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
      if (selected || hovered || allNames) {
        ctx.font = '12px system-ui';
        const label = selected || hovered ? `${names[j]}  z=${(+z).toFixed(2)}` : names[j];
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

  /** T-junction proposals: hollow dashed diamonds with a tick along the covered outline (the stem); the hovered
   *  one says its score. Distinct from T-junctions (solid red rings with a cross). */
  _proposals() {
    const ctx = this.ctx;
    this.proposalsShown = this.app.proposals.visible(this.k);
    this.proposalsShown.forEach((p, i) => {
      const [sx, sy] = this.view.toScreen(p.x, p.y);
      const hovered = this.hover && this.hover.kind === 'prop' && this.hover.index === i;
      const r = PROP_R + (hovered ? 2 : 0);
      ctx.beginPath();
      ctx.moveTo(sx, sy - r); ctx.lineTo(sx + r, sy); ctx.lineTo(sx, sy + r); ctx.lineTo(sx - r, sy); ctx.closePath();
      ctx.setLineDash([]); ctx.lineWidth = 4; ctx.strokeStyle = '#ffffffcc'; ctx.stroke();
      ctx.setLineDash([3, 2]); ctx.lineWidth = 2; ctx.strokeStyle = PROP_COLOUR; ctx.stroke();
      ctx.setLineDash([]);
      const [dx, dy] = p.stem;
      ctx.beginPath(); ctx.moveTo(sx + dx * r, sy + dy * r); ctx.lineTo(sx + dx * (r + 6), sy + dy * (r + 6));
      ctx.lineWidth = 2; ctx.stroke();
      if (hovered) {
        const label = `proposal ${p.score.toFixed(2)} · click to accept`;
        ctx.font = '12px system-ui';
        ctx.fillStyle = '#000b';
        ctx.fillRect(sx + 11, sy - 22, ctx.measureText(label).width + 8, 17);
        ctx.fillStyle = '#fff';
        ctx.fillText(label, sx + 15, sy - 9);
      }
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

  /** The bone being drawn (Skeleton tool) or the template's box being dragged (Template tool). */
  _gesture() {
    const d = this.drag;
    if (!d || !d.moved || (d.kind !== 'bone' && d.kind !== 'box')) return;
    const ctx = this.ctx;
    ctx.setLineDash([6, 4]);
    ctx.lineWidth = 2;
    ctx.strokeStyle = '#ffeb3b';
    const [ax, ay] = this.view.toScreen(...d.a), [bx, by] = this.view.toScreen(...d.b);
    ctx.beginPath();
    if (d.kind === 'bone') { ctx.moveTo(ax, ay); ctx.lineTo(bx, by); } else ctx.rect(ax, ay, bx - ax, by - ay);
    ctx.stroke();
    ctx.setLineDash([]);
    if (d.kind === 'box' && this.app.template) {
      const [x0, y0] = d.a, [x1, y1] = d.b;
      ctx.fillStyle = '#ffeb3b';
      for (const [u, v] of this.app.template.positions) {
        const [sx, sy] = this.view.toScreen(x0 + u * (x1 - x0), y0 + v * (y1 - y0));
        ctx.fillRect(sx - 2, sy - 2, 4, 4);
      }
    }
  }

  /** A bubble at screen point (sx, sy), kept inside the pane, on the side with more room. */
  _bubble(sx, sy, cls, parts, data) {
    const b = document.createElement('div');
    b.className = `bubble ${cls}`;
    Object.assign(b.dataset, data);
    for (const [c, text] of parts) {
      if (!text) continue;
      const span = document.createElement('span');
      span.className = c;
      span.textContent = text;
      b.append(span);
    }
    const { width, height } = this.canvas.getBoundingClientRect();
    const x = Math.min(Math.max(sx, 0), width);
    const left = x > width - x;  // the side with more room; never wider than that room
    if (left) b.classList.add('left');
    b.style.maxWidth = `${Math.max(120, Math.min(320, (left ? x : width - x) - 24))}px`;
    b.style.left = `${x}px`;
    b.style.top = `${Math.min(Math.max(sy, 30), height - 30)}px`;
    this.bubbles.append(b);
    return b;
  }

  /** The save error next to the item it names, and the stages' warnings at what they name (if on this keyframe);
   *  warnings about the keyframe as a whole in its notes. */
  _bubbles() {
    this.bubbles.replaceChildren();
    const ctx = this.ctx;
    const placed = [];
    if (this.app.overlays.has('warnings')) {
      const notes = [];
      for (const { w, at, subject } of this.app.warningsFor(this.k)) {
        if (!at) { notes.push(w); continue; }
        const [sx, sy] = this.view.toScreen(at[0], at[1]);
        ctx.beginPath();
        ctx.arc(sx, sy, 11, 0, 2 * Math.PI);
        ctx.lineWidth = 2.5; ctx.strokeStyle = WARN_COLOUR; ctx.setLineDash(w.stale ? [3, 3] : []); ctx.stroke();
        ctx.setLineDash([]);
        // compact (what it is about and the problem, in two lines) so that several leave the drawing visible;
        // the pointer on its ring or on the bubble opens it whole (the fix, the stage)
        const id = `${w.stage}\n${w.text}`;
        const b = this._bubble(sx, sy, `warning${w.stale ? ' stale' : ''}${id === this.openWarning ? ' open' : ''}`,
          [['subject', subjectLabel(w)], ['what', w.problem], ['fix', w.fix ? `fix: ${w.fix}` : ''],
            ['from', `${w.stage}${w.stale ? ' · before your last change' : ''}`]],
          { stage: w.stage, kind: w.kind || '', subject: subject || '', at: `${at[0].toFixed(1)},${at[1].toFixed(1)}` });
        b.ring = [sx, sy];
        b.id_ = id;
        placed.push(b);
      }
      this.notes.replaceChildren(...notes.map((w) => {
        const div = document.createElement('div');
        div.className = `note${w.stale ? ' stale' : ''}`;
        div.dataset.stage = w.stage;
        div.textContent = `${w.stage}: ${w.problem}${w.fix ? `; fix: ${w.fix}` : ''}`;
        return div;
      }));
      this.notes.hidden = !notes.length;
    } else {
      this.notes.hidden = true;
    }
    const err = this.app.errorItem;
    if (err && err.k === this.k) {
      const shot = this.doc.shot;
      const p = err.kind === 'joint' ? shot.poses?.[err.pose]?.joints?.[err.index] : shot.t_junctions?.[this.k]?.[err.index];
      if (p) {
        const [sx, sy] = this.view.toScreen(p[0], p[1]);
        ctx.beginPath();
        ctx.arc(sx, sy, 13, 0, 2 * Math.PI);
        ctx.lineWidth = 3; ctx.strokeStyle = '#e5484d'; ctx.stroke();
        placed.push(this._bubble(sx, sy, 'error', [['what', err.message]], { field: err.field }));
      }
    }
    // one under the other where they would overlap, in the order of their points from the top (an open one is
    // placed at its compact size: opening it lays it over its neighbours, not them further down)
    for (const b of placed) b.classList.toggle('measuring', b.classList.contains('open'));
    placed.sort((a, b) => parseFloat(a.style.top) - parseFloat(b.style.top));
    const taken = [];
    for (const b of placed) {
      for (let moved = true; moved;) {
        moved = false;
        const r = b.getBoundingClientRect();
        for (const t of taken) {
          if (r.left < t.right && t.left < r.right && r.top < t.bottom + 3 && t.top < r.bottom + 3) {
            b.style.top = `${parseFloat(b.style.top) + (t.bottom + 4 - r.top)}px`;
            moved = true;
          }
        }
      }
      taken.push(b.getBoundingClientRect());
    }
    // a stack that runs past the pane's foot moves up, the lowest first, each above the one below it
    let floor = this.bubbles.getBoundingClientRect().bottom - 4;
    for (const b of [...placed].reverse()) {
      const r = b.getBoundingClientRect();
      if (r.bottom > floor) b.style.top = `${parseFloat(b.style.top) - (r.bottom - floor)}px`;
      floor = Math.min(floor, b.getBoundingClientRect().top - 4);
    }
    for (const b of placed) b.classList.remove('measuring');
    this._keepOpenInside();
    // a bubble stacked away from its ring is tied to it by a thin line to the tip of its arrow
    const c = this.canvas.getBoundingClientRect();
    for (const b of placed) {
      if (!b.ring) continue;
      const r = b.getBoundingClientRect();
      const tip = [(b.classList.contains('left') ? r.right + 7 : r.left - 7) - c.left, (r.top + r.bottom) / 2 - c.top];
      if (Math.hypot(tip[0] - b.ring[0], tip[1] - b.ring[1]) < 20) continue;
      ctx.beginPath();
      ctx.moveTo(...b.ring);
      ctx.lineTo(...tip);
      ctx.lineWidth = 1; ctx.strokeStyle = WARN_COLOUR; ctx.setLineDash(b.classList.contains('stale') ? [3, 3] : []);
      ctx.stroke();
      ctx.setLineDash([]);
    }
  }

  /** Open the warning bubble whose ring or box is under screen point (sx, sy) of the canvas (none there: close it);
   *  redraws when that changes. */
  _openWarningAt(sx, sy) {
    const c = this.canvas.getBoundingClientRect();
    let id = null;
    for (const b of this.bubbles.querySelectorAll('.bubble.warning')) {
      const r = b.getBoundingClientRect();
      const onBox = sx + c.left >= r.left && sx + c.left <= r.right && sy + c.top >= r.top && sy + c.top <= r.bottom;
      if (onBox || (b.ring && Math.hypot(b.ring[0] - sx, b.ring[1] - sy) <= WARN_RING_PX)) id = b.id_;
      if (id === b.id_ && b.classList.contains('open')) break;  // the open one keeps the pointer over its box
    }
    if (id === this.openWarning) return;
    this.openWarning = id;
    this.draw();  // the bubbles again, that one open (and its line to its ring where it moved)
  }

  /** The open warning bubble, taller than its compact self, moved inside the pane. */
  _keepOpenInside() {
    const b = this.bubbles.querySelector('.bubble.warning.open');
    if (!b) return;
    const pane = this.bubbles.getBoundingClientRect(), r = b.getBoundingClientRect();
    const shift = r.bottom > pane.bottom - 4 ? pane.bottom - 4 - r.bottom : r.top < pane.top + 4 ? pane.top + 4 - r.top : 0;
    if (shift) b.style.top = `${parseFloat(b.style.top) + shift}px`;
  }

  // ---------------------------------------------------------------- picking

  _pick(sx, sy) {
    let best = null, bestD = HIT_PX;
    const consider = (kind, pts) => pts.forEach(([x, y], i) => {
      const [px, py] = this.view.toScreen(x, y);
      const d = Math.hypot(px - sx, py - sy);
      if (d < bestD) { best = { kind, index: i }; bestD = d; }
    });
    // proposals too (Move and T-junction tools): the nearest item within HIT_PX is picked
    if (['select', 'tjunction'].includes(this.app.tool)) consider('prop', (this.proposalsShown || []).map((p) => [p.x, p.y]));
    if (this.app.overlays.has('tjunctions') && this.app.tool !== 'skeleton') consider('tj', this.doc.shot.t_junctions?.[this.k] || []);
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
    c.addEventListener('pointerleave', () => { this.pointer = null; this.hover = null; this.openWarning = null; this.draw(); });
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
    if (tool === 'skeleton' || tool === 'template') {
      // skeleton: press on a joint and drag onto another (re-parent) or onto paper (a new child); click: add / select.
      // template: drag the box the template's unit box is placed in
      const hit = tool === 'skeleton' ? this._pick(sx, sy) : null;
      this.drag = { kind: tool === 'skeleton' ? 'bone' : 'box', from: hit ? hit.index : null, sx, sy, moved: false,
        a: hit ? this._itemXY(hit) : [x, y], b: [x, y] };
      return;
    }
    const hit = this._pick(sx, sy);
    if (hit && hit.kind === 'prop') {  // a click accepts a proposal: a T-junction there, one undo step
      app.acceptProposal(this.k, this.proposalsShown[hit.index]);
      return;
    }
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
      this._openWarningAt(sx, sy);
      const hover = this._pick(sx, sy);
      if (JSON.stringify(hover) !== JSON.stringify(this.hover)) this.hover = hover;
      this.canvas.style.cursor = hover && hover.kind === 'prop' ? 'pointer'
        : hover && this.app.tool !== 'paint' && this.app.tool !== 'erase' ? 'grab'
        : ['tjunction', 'skeleton', 'template'].includes(this.app.tool) ? 'crosshair' : 'default';
      if (this.app.tool === 'paint' || this.app.tool === 'erase' || hover || this.hover) this.draw();
      return;
    }
    if (d.kind === 'pan') {
      this.view.panX = d.panX + sx - d.sx;
      this.view.panY = d.panY + sy - d.sy;
      this.draw();
    } else if (d.kind === 'bone' || d.kind === 'box') {
      d.b = [x, y];
      d.moved = d.moved || Math.hypot(sx - d.sx, sy - d.sy) >= DRAG_PX;
      if (d.kind === 'bone' && d.from === null && d.moved) {  // a drag from paper pans, as with the other tools
        this.drag = { kind: 'pan', sx: d.sx, sy: d.sy, panX: this.view.panX, panY: this.view.panY };
        this._move(e);
        return;
      }
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
    if (d.kind === 'bone') {
      const [sx, sy] = this._local(e);
      const target = this._pick(sx, sy);
      this.app.skeletonGesture(this.k, d.from, d.moved ? d.b : d.a, target && target.kind === 'joint' ? target.index : null, d.moved);
      this.draw();
      return;
    }
    if (d.kind === 'box') {
      if (d.moved) this.app.placeTemplate(this.k, [...d.a, ...d.b]);
      this.draw();
      return;
    }
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

/** What a warning is about, as its bubble names it: "joint r_hand", "occlusion region 0", "T-junction". */
function subjectLabel(w) {
  if (!w.kind) return '';
  if (w.names && w.names.length) return `${w.kind} ${w.names.join(' / ')}`;
  return w.index !== null && w.index !== undefined ? `${w.kind} ${w.index}` : w.kind;
}

function union(a, b) {
  const x0 = Math.min(a[0], b[0]), y0 = Math.min(a[1], b[1]);
  const x1 = Math.max(a[0] + a[2], b[0] + b[2]), y1 = Math.max(a[1] + a[3], b[1] + b[3]);
  return [x0, y0, x1 - x0, y1 - y0];
}
