// The edited shot: shot.json as an object, the mask layers of each keyframe, and undo/redo over both.

import { keyCount, keyPoseIndices } from './skeleton.js';

const clone = (x) => JSON.parse(JSON.stringify(x));

export class Doc {
  constructor(shot, size) {
    this.shot = shot;              // the shot.json object being edited (masks come from `structure` on save)
    this.size = size;              // [H, W] of the keyframes
    this.structure = Array.from({ length: keyCount(shot) }, () => ({ fg: null, occ: [] }));  // layer ids per keyframe
    this.layers = new Map();       // id -> MaskLayer (kept after removal, so undo can bring one back)
    this.fileOwner = new Map();    // mask file name -> id of the layer whose pixels the file holds
    this.saved = JSON.stringify(shot);
    this.hadMasks = 'masks' in shot;
  }

  /** Index into shot.poses of keyframe k's pose (-1: the shot has none yet). */
  keyPoseIndex(k) { const i = keyPoseIndices(this.shot)[k]; return i === undefined ? -1 : i; }
  /** Keyframe k's joints [[x, y, z], ...] ([] while the shot has no skeleton or pose). */
  keyPose(k) {
    const pose = this.shot.poses?.[this.keyPoseIndex(k)];
    return Array.isArray(pose?.joints) ? pose.joints : [];
  }
  /** The joint names ([] while there is no skeleton). */
  jointNames() { return Array.isArray(this.shot.skeleton?.joints) ? this.shot.skeleton.joints : []; }
  /** The parents (aligned with jointNames). */
  parents() { return Array.isArray(this.shot.skeleton?.parents) ? this.shot.skeleton.parents : []; }
  layer(id) { return this.layers.get(id); }

  addLayer(layer) { this.layers.set(layer.id, layer); return layer.id; }

  /** Layers of keyframe k: [{id, kind: 'fg'|'occ', index}] in display order. */
  layersOf(k) {
    const s = this.structure[k];
    return [...(s.fg ? [{ id: s.fg, kind: 'fg', index: 0 }] : []),
      ...s.occ.map((id, i) => ({ id, kind: 'occ', index: i }))];
  }

  /** File names for layers not yet saved: key{k}_fg.png, key{k}_occ{n}.png with n unused by other layers. */
  assignNames() {
    const used = new Set();
    for (const s of this.structure) for (const id of [s.fg, ...s.occ]) if (id && this.layer(id).name) used.add(this.layer(id).name);
    this.structure.forEach((s, k) => {
      if (s.fg && !this.layer(s.fg).name) {
        // after keys were added or removed, key{k}_fg.png may be another key's file
        let name = `key${k}_fg.png`;
        for (let n = 2; used.has(name); n++) name = `key${k}_fg${n}.png`;
        this.layer(s.fg).name = name;
        used.add(name);
      }
      for (const id of s.occ) {
        const layer = this.layer(id);
        if (layer.name) continue;
        let n = 0;
        while (used.has(`key${k}_occ${n}.png`)) n++;
        layer.name = `key${k}_occ${n}.png`;
        used.add(layer.name);
      }
    });
  }

  /** The shot.json object to save: `masks` names the layers; absent when the shot never had masks and has none. */
  toShot() {
    const out = clone(this.shot);
    const any = this.structure.some((s) => s.fg || s.occ.length);
    if (any || this.hadMasks) {
      out.masks = {
        foreground: this.structure.map((s) => (s.fg ? this.layer(s.fg).name : null)),
        occlusion: this.structure.map((s) => s.occ.map((id) => this.layer(id).name)),
      };
    }
    return out;
  }

  /** Layers whose pixels are not in the file they will be saved as. */
  toUpload() {
    const out = [];
    for (const s of this.structure) {
      for (const id of [s.fg, ...s.occ]) {
        if (!id) continue;
        const layer = this.layer(id);
        if (layer.dirty || this.fileOwner.get(layer.name) !== id) out.push(layer);
      }
    }
    return out;
  }

  markSaved(shot, uploaded) {
    for (const layer of uploaded) { layer.dirty = false; this.fileOwner.set(layer.name, layer.id); }
    this.saved = JSON.stringify(shot);
    this.hadMasks = 'masks' in shot;
  }

  isDirty() {
    return this.structure.some((s) => [s.fg, ...s.occ].some((id) => id && this.layer(id).dirty))
      || JSON.stringify(this.toShotNamed()) !== this.saved;
  }

  /** toShot with provisional names for unsaved layers (for comparisons only). */
  toShotNamed() {
    const out = this.toShot();
    if (out.masks) {
      out.masks.foreground = out.masks.foreground.map((n, k) => (this.structure[k].fg && !n ? `new` : n));
      out.masks.occlusion = out.masks.occlusion.map((l) => l.map((n) => n || 'new'));
    }
    return out;
  }

  /** The source assets (assets/graph.py SOURCES) that differ from the saved shot: what a save would rerun from. */
  changedSources() {
    const saved = JSON.parse(this.saved);
    const now = this.toShotNamed();
    const eq = (a, b) => JSON.stringify(a) === JSON.stringify(b);
    const changed = new Set();
    const skeleton = !eq(saved.skeleton, now.skeleton);
    const pose = (s, k) => s.poses?.[keyPoseIndices(s)[k]]?.joints ?? null;
    for (let k = 0; k < this.structure.length; k++) {
      if (!eq(saved.t_junctions?.[k], now.t_junctions?.[k])) changed.add(`key${k}/t_junctions`);
      if (skeleton || !eq(pose(saved, k), pose(now, k))) changed.add(`key${k}/pose`);
      const masksOf = (s) => [s.masks?.foreground?.[k] ?? null, s.masks?.occlusion?.[k] ?? []];
      const pixels = [this.structure[k].fg, ...this.structure[k].occ].some((id) => id && this.layer(id).dirty);
      if (pixels || !eq(masksOf(saved), masksOf(now)) || !eq(saved.keyframes?.[k], now.keyframes?.[k])) changed.add(`key${k}/drawing`);
    }
    if (skeleton || !eq(saved.poses, now.poses) || saved.frames !== now.frames || !eq(saved.ease, now.ease)) {
      for (let s = 0; s < Math.max(1, this.structure.length - 1); s++) changed.add(`seg${s}/motion`);
    }
    return changed;
  }

  snapshot() { return { shot: JSON.stringify(this.shot), structure: JSON.stringify(this.structure) }; }
  restore(snap) { this.shot = JSON.parse(snap.shot); this.structure = JSON.parse(snap.structure); }
}

/** Undo/redo: each entry holds the document before and after, plus pixel patches of the mask layers it painted. */
export class History {
  constructor(doc, onChange) {
    this.doc = doc;
    this.onChange = onChange;
    this.done = [];
    this.undone = [];
    this.open = null;
  }

  begin(label) {
    if (this.open) this.commit();
    this.open = { label, before: this.doc.snapshot(), patches: [] };
    return this.open;
  }

  /** Record that `layer` changed inside rect [x, y, w, h]; `before` is the layer's full ImageData before the change. */
  patch(layer, rect, before) {
    if (!this.open) return;
    const [x, y, w, h] = clip(rect, layer.canvas);
    if (w <= 0 || h <= 0) return;
    const prev = crop(before, x, y, w, h);
    const next = layer.ctx.getImageData(x, y, w, h);
    this.open.patches.push({ id: layer.id, x, y, before: prev, after: next, dirty: layer.dirty });
    layer.dirty = true;
  }

  commit() {
    const tx = this.open;
    this.open = null;
    if (!tx) return;
    tx.after = this.doc.snapshot();
    if (tx.after.shot === tx.before.shot && tx.after.structure === tx.before.structure && !tx.patches.length) return;
    this.done.push(tx);
    this.undone = [];
    this.onChange(tx);
  }

  undo() {
    this.commit();
    const tx = this.done.pop();
    if (!tx) return;
    this.doc.restore(tx.before);
    for (const p of [...tx.patches].reverse()) this._put(p, p.before, true);
    this.undone.push(tx);
    this.onChange(tx);
  }

  redo() {
    const tx = this.undone.pop();
    if (!tx) return;
    this.doc.restore(tx.after);
    for (const p of tx.patches) this._put(p, p.after, true);
    this.done.push(tx);
    this.onChange(tx);
  }

  _put(p, data, dirty) {
    const layer = this.doc.layer(p.id);
    layer.ctx.putImageData(data, p.x, p.y);
    layer.dirty = dirty;
    layer.changed();
  }
}

function clip([x, y, w, h], canvas) {
  const x0 = Math.max(0, x), y0 = Math.max(0, y);
  const x1 = Math.min(canvas.width, x + w), y1 = Math.min(canvas.height, y + h);
  return [x0, y0, x1 - x0, y1 - y0];
}

function crop(img, x, y, w, h) {
  const out = new ImageData(w, h);
  for (let r = 0; r < h; r++) {
    const s = ((y + r) * img.width + x) * 4;
    out.data.set(img.data.subarray(s, s + w * 4), r * w * 4);
  }
  return out;
}
