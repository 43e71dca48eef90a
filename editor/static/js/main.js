// The editor page: loads the shot, wires the three views, the rerun panel, undo/redo, saving and the keyboard;
// the skeleton tools (editor/static/js/skeleton.js) and the stages' warnings at what they name.

import { ApiError, getJSON, getVersioned, loadImage, putPNG, putVersioned, sendBytes, sendJSON } from './api.js';
import { Doc, History } from './doc.js';
import { actionFor, renderHelp } from './help.js';
import { KeyView } from './keyview.js';
import { MaskLayer, layerFromUrl, regionColour, FOREGROUND_COLOUR } from './masks.js';
import { PoseView } from './pose.js';
import { Proposals } from './proposals.js';
import { ResultsView } from './results.js';
import {
  SkeletonError, V2, addJoint, applyTemplate, copyPose, deleteJoint, keyCount, keyPoseIndices, renameJoint, reparent,
} from './skeleton.js';
import { StagesPanel, followStatus } from './stages.js';
import { Timeline, keyFrames } from './timeline.js';

const OVERLAYS = [
  ['drawing', 'Drawing', true], ['skeleton', 'Skeleton', true], ['tjunctions', 'T-junctions', true],
  ['proposals', 'Proposals', false],  // off: still shown for a key without T-junctions (proposals.js)
  ['manual', 'Manual masks', true], ['predicted', 'Predicted masks', false], ['refined', 'Refined masks', false],
  ['boundaries', 'Refined boundaries', true], ['warnings', 'Stage warnings', true],
];
const TJ_FOLLOW_PX = 8;  // a T-junction warning stays with the T-junction nearest where the stage saw it
const $ = (id) => document.getElementById(id);

class App {
  async boot() {
    this.info = await getJSON('/api/info');
    $('shot-name').textContent = this.info.shot_dir;
    this.tool = 'select';
    this.brush = 8;
    this.overlays = new Set(OVERLAYS.filter((o) => o[2]).map((o) => o[0]));
    this.errorItem = null;
    this.plan = null;
    this.status = null;
    this.warnings = [];
    this.templates = await getJSON('/api/templates');
    this.template = null;
    this.stages = new StagesPanel(this.info);
    this.proposals = new Proposals(this);
    this.keys = [...document.querySelectorAll('.keypane')].map((pane) => new KeyView(+pane.dataset.k, pane, this));
    await this._open(null);
    this.results = new ResultsView(this);
    this.pose = new PoseView(this);
    this.timeline = new Timeline(this);
    this._wire();
    this.changed();
    this.keys.forEach((v) => v.fit());
    followStatus((st) => this.onStatus(st));
    await this.checkShot();
    this.refreshPlan();
    this.loadWarnings();
    this.results.refresh();
    document.body.dataset.ready = '1';
  }

  /** The loader's verdict on the saved shot: a shot it refuses opens with the message at the field it names. */
  async checkShot() {
    const got = await getJSON('/api/check');
    if (!got.ok) this.showError(got.error, got.field);
  }

  async loadWarnings() {
    try {
      this.warnings = (await getJSON('/api/warnings')).warnings;
    } catch {
      this.warnings = [];
    }
    const counts = {};
    for (const w of this.warnings) (counts[w.stage] = counts[w.stage] || []).push(w.text);
    this.stages.setWarnings(counts);
    this.redraw();
    this._layers();
    $('warning-count').textContent = this.warnings.length ? `${this.warnings.length} stage warning${this.warnings.length === 1 ? '' : 's'}` : '';
  }

  /** Keyframe k's warnings with where to show them now: [{w (with .stale), at ([x, y] or null), subject}]. */
  warningsFor(k) {
    const names = this.doc.jointNames();
    const pose = this.doc.keyPose(k);
    const joint = (n) => { const j = names.indexOf(n); return j >= 0 && pose[j] ? j : -1; };
    const out = [];
    for (const w of this.warnings) {
      if (w.k !== k) continue;
      let at = w.at, subject = '';
      if ((w.kind === 'joint' || w.kind === 'handle') && joint(w.names[0]) >= 0) {
        const j = joint(w.names[0]);
        at = pose[j].slice(0, 2);  // where the joint is now: the warning follows a drag
        subject = `joint:${names[j]}`;
      } else if (w.kind === 'bone' && w.names.length) {
        const name = w.names[0];
        for (let i = name.indexOf('-'); i >= 0; i = name.indexOf('-', i + 1)) {  // joint names may hold '-'
          const a = joint(name.slice(0, i)), b = joint(name.slice(i + 1));
          if (a >= 0 && b >= 0) { at = [(pose[a][0] + pose[b][0]) / 2, (pose[a][1] + pose[b][1]) / 2]; subject = `bone:${name}`; break; }
        }
      } else if (w.kind === 'T-junction' && at) {
        const pts = this.doc.shot.t_junctions?.[k] || [];
        let best = -1, bestD = TJ_FOLLOW_PX;
        pts.forEach(([x, y], i) => { const d = Math.hypot(x - w.at[0], y - w.at[1]); if (d < bestD) { best = i; bestD = d; } });
        if (best >= 0) { at = pts[best].slice(0, 2); subject = `tj:${best}`; }
      } else if (w.kind === 'manual occlusion mask' && w.index !== null) {
        subject = `mask:${w.index}`;
      } else if (w.kind === 'occlusion region' && w.index !== null) {
        subject = `region:${w.index}`;
      }
      out.push({ w: { ...w, stale: this.stale(w.stage) }, at, subject });
    }
    return out;
  }

  // ---------------------------------------------------------------- loading

  /** Open the saved shot (at boot and after a structural edit): the document, its keys' layers, the panes
   *  showing key k (null: the first two keys, key1 selected). */
  async _open(k) {
    const { data: shot, etag } = await getVersioned('/api/shot');
    this.etag = etag;  // a save refuses to overwrite a shot.json changed on disk since
    // keyframes that cannot be read: the page still opens, with the loader's message at `keyframes`
    this.doc = new Doc(shot, this.info.size || [256, 256]);
    // an edit after a refused save clears its message: the user is fixing it (Save shows it again if not)
    this.history = new History(this.doc, () => { if (this.errorItem) this.clearError(); this.changed(); });
    const n = keyCount(shot);
    this.drawings = Array(n).fill(null);
    this.predicted = Array(n).fill(null);
    this.refined = Array(n).fill(null);
    this.activeLayer = Array(n).fill('fg');  // until the manual masks are in
    this.loading = new Map();  // key -> promise of its drawing and masks, loaded when first shown
    this.proposals.reset();
    this.selected = null;
    $('mask-key').replaceChildren(...[...Array(n).keys()].map((i) => {
      const o = document.createElement('option'); o.value = String(i); o.textContent = `key${i}`; return o;
    }));
    this.focusedKey = k === null ? Math.min(1, n - 1) : Math.max(0, Math.min(k, n - 1));
    await Promise.all([this._showKeys(this._panesFor(k === null ? 0 : this.focusedKey)), this._loadManualMasks()]);
    this.activeLayer = this.doc.structure.map((s) => (s.occ.length ? 0 : 'fg'));
    this.focusKey(this.focusedKey);
  }

  /** The keys the two Annotate panes show for key k: k and the next (the last key: the previous and k). */
  _panesFor(k) {
    const n = keyCount(this.doc.shot);
    if (n === 1) return [0];
    return k >= n - 1 ? [n - 2, n - 1] : [k, k + 1];
  }

  shownKeys() { return this.keys.filter((v) => !v.pane.hidden).map((v) => v.k); }

  /** Output frame of key k (v1: 0 and the last output frame). */
  keyFrame(k) { return keyFrames(this.doc.shot)[k] ?? '?'; }

  _showKeys(list) {
    this.keys.forEach((v, i) => {
      v.pane.hidden = list[i] === undefined;
      if (list[i] !== undefined) v.setKey(list[i]);
    });
    if (this.selected && !list.includes(this.selected.k)) this.selected = null;
    requestAnimationFrame(() => this.keys.forEach((v) => { if (!v.pane.hidden && !v.fitted) v.fit(); }));
    return Promise.all(list.map((k) => this._ensureKey(k)));
  }

  /** Keyframe k's drawing, predicted and refined masks, loaded once (until a rerun ends). */
  _ensureKey(k) {
    if (!this.loading.has(k)) this.loading.set(k, this._loadKey(k).then(() => { this.redraw(); this._layers(); }));
    return this.loading.get(k);
  }

  async _loadKey(k) {
    this.drawings[k] = await loadImage(`/api/keyframes/${k}.png?v=${Date.now()}`).catch(() => null);
    await Promise.all([this._loadPredicted(k), this._loadRefined(k)]);
  }

  async _loadPredicted(k) {
    const [H, W] = this.doc.size;
    try {
      const p = await getJSON(`/api/predicted/${k}`);
      const fg = await layerFromUrl(`/api/predicted/${k}/foreground.png?v=${Date.now()}`, W, H);
      const occ = await Promise.all([...Array(p.regions).keys()].map((i) => layerFromUrl(`/api/predicted/${k}/occlusion/${i}.png?v=${Date.now()}`, W, H)));
      this.predicted[k] = { fg, occ };
    } catch {
      this.predicted[k] = null;
    }
  }

  async _loadRefined(k) {
    const [H, W] = this.doc.size;
    try {
      const json = await getJSON(`/api/refined/${k}`);
      const occ = await Promise.all([...Array(json.regions).keys()].map((i) => layerFromUrl(`/api/refined/${k}/occlusion/${i}.png?v=${json.version}`, W, H)));
      this.refined[k] = { json, occ };
    } catch {
      this.refined[k] = null;
    }
  }

  async _loadManualMasks() {
    const [H, W] = this.doc.size;
    const masks = this.doc.shot.masks || {};
    const load = async (name) => {
      let layer;
      try {
        layer = await layerFromUrl(`/api/masks/${encodeURI(name)}?v=${Date.now()}`, W, H, name);
        this.doc.fileOwner.set(name, layer.id);
      } catch {
        // named by shot.json but unreadable: listed (empty, flagged) so it can be repainted or deleted
        layer = new MaskLayer(W, H, name);
        layer.missing = true;
      }
      return this.doc.addLayer(layer);
    };
    for (let k = 0; k < this.doc.structure.length; k++) {
      const fg = masks.foreground?.[k];
      this.doc.structure[k].fg = fg ? await load(fg) : null;
      this.doc.structure[k].occ = await Promise.all((masks.occlusion?.[k] || []).map(load));
    }
  }

  // ---------------------------------------------------------------- state changes

  /** After any edit: redraw, and update the panels that depend on the document. */
  changed(full = true) {
    this.redraw();
    if (!full) { this._inspector(); return; }
    $('undo').disabled = !this.history.done.length;
    $('redo').disabled = !this.history.undone.length;
    const dirty = this.doc.isDirty();
    $('dirty').textContent = dirty ? 'unsaved changes' : '';
    $('save').dataset.dirty = dirty ? '1' : '';
    this.stages.setWillRun(dirty ? this.stages.downstream(this.doc.changedSources()) : new Set());
    this._layers();
    this._inspector();
    this._skeletonPanel();
    this._shotFields();
    this.proposalPanel();
    if (this.timeline) this.timeline.render();
  }

  redraw() { this.keys.forEach((v) => v.draw()); }

  edit(label, fn) {
    this.history.begin(label);
    fn();
    this.history.commit();
    this.changed();
  }

  select(sel) {
    this.selected = sel;
    this._inspector();
    this.redraw();
  }

  /** Select keyframe k (the timeline, a click on its pane, the Masks menu): the panes show it. */
  focusKey(k) {
    if (!this.shownKeys().includes(k)) { this._showKeys(this._panesFor(k)); this.redraw(); }
    this.focusedKey = k;
    document.querySelectorAll('.keypane').forEach((p) => p.classList.toggle('focus', !p.hidden && +p.dataset.k === k));
    if (+$('mask-key').value !== k) { $('mask-key').value = String(k); this._layers(); }
    this._skeletonPanel();
    this.proposalPanel();
    if (this.timeline) this.timeline.render();
  }

  /** The Proposals panel: the focused key's proposals, Accept all >= score, Dismiss. */
  proposalPanel() {
    if (!this.proposals || !this.doc) return;
    const k = this.focusedKey;
    $('proposals-info').textContent = this.proposals.describe(k);
    const n = this.proposals.visible(k).length;
    $('proposals-accept-all').disabled = !n;
    $('proposals-dismiss').disabled = !n;
  }

  acceptProposal(k, p) {
    const index = this.proposals.accept(k, [p], 'accept proposal');
    this.select({ k, kind: 'tj', index });
    this.flash(`proposal (score ${p.score.toFixed(2)}) accepted as T-junction ${index} of key${k}`);
  }

  // ---------------------------------------------------------------- the timeline's structural edits

  /** A structural edit made by the server on the saved shot (edits in the page are saved first), then the
   *  shot reopened at the key the answer names. `call(etag)` sends the request. */
  async structural(what, call, keyAfter) {
    if (this.doc.isDirty()) {
      await this.save();
      if (this.doc.isDirty()) return;  // the save was refused: its message shows
    }
    this.clearError();
    try {
      const got = await call(this.etag);
      await this._reopen(got.k ?? keyAfter(got));
      const dropped = got.dropped?.length ? ` (${got.dropped.join(', ')} dropped: its frames no longer line up)` : '';
      this.flash(`${what}${dropped}; rerunning`);
    } catch (e) {
      if (e instanceof ApiError) this.showError(e.message, e.field);
      else this.showError(`${what} failed: ${e.message}`, null);
    }
  }

  async _reopen(k) {
    this.info = await getJSON('/api/info');
    this.stages.setGraph(this.info);
    this.results.setGraph(this.info);
    await this._open(k);
    this.changed();
    this.refreshPlan();
    this.loadWarnings();
  }

  addKey(frame, file) {
    if (!Number.isInteger(frame) || frame < 1) { this.flash('give the new key\'s frame, 1 or more'); return; }
    const url = `/api/keys?frame=${frame}&name=${encodeURIComponent(file.name)}`;
    return this.structural(`${file.name} added as a key at frame ${frame}`, (etag) => sendBytes('POST', url, file, etag));
  }

  removeKey(k) {
    return this.structural(`key${k} removed (its file stays; shot.json.bak has the shot before)`,
      (etag) => sendJSON('DELETE', `/api/keys/${k}`, {}, etag ? { 'If-Match': etag } : {}), () => Math.max(0, k - 1));
  }

  moveKey(k, frame) {
    if (!Number.isInteger(frame)) { this.flash('a key\'s frame is a whole number'); this.timeline.render(); return; }
    return this.structural(`key${k} moved to frame ${frame}`,
      (etag) => sendJSON('POST', `/api/keys/${k}/move`, { frame }, etag ? { 'If-Match': etag } : {}));
  }

  /** Depth by wheel: consecutive notches on one joint make one undo step. */
  wheelDepth(k, j, step) {
    const idx = this.doc.keyPoseIndex(k);
    if (idx < 0) return;
    const same = this._wheel && this._wheel.k === k && this._wheel.j === j && this.history.open === this._wheel.tx;
    if (!same) this._wheel = { k, j, tx: this.history.begin('joint depth') };
    const joint = this.doc.shot.poses[idx].joints[j];
    joint[2] = Math.round((joint[2] + step) * 1000) / 1000;
    clearTimeout(this._wheelTimer);
    this._wheelTimer = setTimeout(() => { if (this.history.open === this._wheel.tx) { this.history.commit(); this.changed(); } }, 600);
    this.changed(false);
  }

  // ---------------------------------------------------------------- masks

  /** The layer a brush stroke on keyframe k paints, created inside transaction tx when needed. */
  brushLayer(k, tx) {
    const s = this.doc.structure[k];
    const [H, W] = this.doc.size;
    const active = this.activeLayer[k];
    if (active === 'fg') {
      if (!s.fg) {
        // a foreground painted from scratch would be almost empty: start from the predicted one
        const layer = new MaskLayer(W, H);
        if (this.predicted[k]) layer.copyFrom(this.predicted[k].fg);
        s.fg = this.doc.addLayer(layer);
        this.flash(this.predicted[k] ? 'foreground started from the prediction' : 'no prediction: foreground starts empty');
      }
      return this.doc.layer(s.fg);
    }
    if (typeof active === 'number' && s.occ[active]) return this.doc.layer(s.occ[active]);
    this.newRegion(k, tx);
    return this.doc.layer(s.occ[s.occ.length - 1]);
  }

  newRegion(k, tx = null) {
    const own = !tx;
    if (own) this.history.begin('new region');
    const [H, W] = this.doc.size;
    this.doc.structure[k].occ.push(this.doc.addLayer(new MaskLayer(W, H)));
    this.activeLayer[k] = this.doc.structure[k].occ.length - 1;
    if (own) { this.history.commit(); this.changed(); }
  }

  fromPrediction(k) {
    const p = this.predicted[k];
    if (!p) { this.flash('no prediction available'); return; }
    const [H, W] = this.doc.size;
    const copy = (src) => { const l = new MaskLayer(W, H); l.copyFrom(src); return this.doc.addLayer(l); };
    this.edit('start from the prediction', () => {
      this.doc.structure[k] = { fg: copy(p.fg), occ: p.occ.map(copy) };
      this.activeLayer[k] = p.occ.length ? 0 : 'fg';
    });
  }

  deleteLayer(k, kind, index) {
    this.edit(kind === 'fg' ? 'remove manual foreground' : 'delete region', () => {
      if (kind === 'fg') this.doc.structure[k].fg = null;
      else this.doc.structure[k].occ.splice(index, 1);
    });
    const n = this.doc.structure[k].occ.length;
    if (typeof this.activeLayer[k] === 'number' && this.activeLayer[k] >= n) this.activeLayer[k] = n ? n - 1 : 'fg';
    this._layers();
  }

  _layers() {
    const k = +$('mask-key').value;
    const s = this.doc.structure[k];
    const rows = [];
    const row = (colour, text, active, onPick, onDelete, field) => {
      const div = document.createElement('div');
      div.className = `layer${active ? ' active' : ''}`;
      div.dataset.field = field;
      if (this.errorItem && this.errorItem.field === field) div.classList.add('error');
      const sw = document.createElement('span');
      sw.className = 'sw'; sw.style.background = colour;
      const name = document.createElement('span');
      name.className = 'name'; name.textContent = text; name.title = text;
      div.append(sw, name);
      div.addEventListener('click', onPick);
      if (onDelete) {
        const del = document.createElement('button');
        del.textContent = '×'; del.title = 'delete this manual mask';
        del.addEventListener('click', (e) => { e.stopPropagation(); onDelete(); });
        div.append(del);
      }
      rows.push(div);
    };
    const pick = (v) => () => { this.activeLayer[k] = v; this._layers(); };
    const label = (id) => { const l = this.doc.layer(id); return `${l.name || 'new'}${l.missing ? ' (missing)' : ''}`; };
    row(FOREGROUND_COLOUR, s.fg ? `foreground · ${label(s.fg)}` : 'foreground · predicted',
      this.activeLayer[k] === 'fg', pick('fg'), s.fg ? () => this.deleteLayer(k, 'fg') : null, `masks.foreground[${k}]`);
    s.occ.forEach((id, i) => row(regionColour(i), `region ${i} · ${label(id)}`,
      this.activeLayer[k] === i, pick(i), () => this.deleteLayer(k, 'occ', i), `masks.occlusion[${k}][${i}]`));
    // a stage's warning about a manual occlusion mask marks its row too (the saved shot's mask i)
    const saved = JSON.parse(this.doc.saved).masks?.occlusion?.[k] || [];
    for (const w of this.warnings || []) {
      if (w.k !== k || w.kind !== 'manual occlusion mask' || w.index === null) continue;
      const div = rows.find((r) => r.dataset.field === `masks.occlusion[${k}][${w.index}]`);
      if (!div || this.doc.layer(s.occ[w.index])?.name !== saved[w.index]) continue;
      div.classList.add('warn');
      div.title = `${w.stage}: ${w.problem}${w.fix ? `; fix: ${w.fix}` : ''}`;
    }
    if (!s.occ.length) {
      const n = this.predicted[k] ? this.predicted[k].occ.length : 0;
      const div = document.createElement('div');
      div.className = 'muted small';
      div.textContent = `occlusion: predicted (${n} region${n === 1 ? '' : 's'}); a new region replaces the prediction`;
      rows.push(div);
    }
    $('layers').replaceChildren(...rows);
  }

  // ---------------------------------------------------------------- joint inspector

  _inspector() {
    const el = $('inspector');
    const sel = this.selected;
    if (!sel || sel.kind !== 'joint') {
      el.className = 'muted';
      el.textContent = sel && sel.kind === 'tj' ? `T-junction ${sel.index} of key${sel.k} (Delete removes it)` : 'Click a joint.';
      return;
    }
    const idx = this.doc.keyPoseIndex(sel.k);
    const joint = this.doc.keyPose(sel.k)[sel.index];
    if (!joint) { el.textContent = ''; return; }
    const active = document.activeElement;
    if (active && active.closest && active.closest('#inspector')) return;  // do not rebuild under the user's typing
    el.className = '';
    el.replaceChildren();
    const names = this.doc.jointNames(), parents = this.doc.parents();
    const title = document.createElement('div');
    title.className = 'muted small';
    title.textContent = `key${sel.k} (poses[${idx}].joints[${sel.index}])`;
    const nameRow = document.createElement('label');
    nameRow.className = 'row';
    const name = document.createElement('input');
    name.type = 'text'; name.id = 'joint-name'; name.value = names[sel.index]; name.spellcheck = false;
    name.addEventListener('change', () => this.skeletonEdit('rename joint', () => renameJoint(this.doc.shot, sel.index, name.value)));
    nameRow.append('name ', name);
    const parentRow = document.createElement('label');
    parentRow.className = 'row';
    const parent = document.createElement('select');
    parent.id = 'joint-parent';
    const options = [['-1', '(root)'], ...names.map((n, j) => [String(j), n]).filter(([j]) => +j !== sel.index)];
    parent.replaceChildren(...options.map(([v, text]) => { const o = document.createElement('option'); o.value = v; o.textContent = text; return o; }));
    parent.value = String(parents[sel.index]);
    parent.disabled = parents[sel.index] === -1;  // the root stays the root: re-parent its children instead
    parent.addEventListener('change', () => this.skeletonEdit('re-parent joint', () => reparent(this.doc.shot, sel.index, +parent.value)));
    parentRow.append('parent ', parent);
    el.append(title, nameRow, parentRow);
    ['x', 'y', 'z'].forEach((axis, a) => {
      const label = document.createElement('label');
      label.className = 'row';
      const input = document.createElement('input');
      input.type = 'number'; input.step = a === 2 ? '0.1' : '1'; input.value = String(joint[a]);
      input.id = `joint-${axis}`;
      input.addEventListener('change', () => {
        const v = parseFloat(input.value);
        if (!Number.isFinite(v)) return;
        this.edit(`joint ${axis}`, () => { this.doc.keyPose(sel.k)[sel.index][a] = v; });
      });
      label.append(`${axis} `, input);
      el.append(label);
    });
    const del = document.createElement('button');
    del.id = 'joint-delete'; del.textContent = 'Delete joint'; del.title = 'Delete the joint (Delete); its children go to its parent';
    del.addEventListener('click', () => this.removeJoint(sel.index));
    el.append(del);
  }

  // ---------------------------------------------------------------- the skeleton

  /** A skeleton edit as one undo step; an edit that cannot be made changes nothing and says why. */
  skeletonEdit(label, fn) {
    try {
      this.edit(label, fn);
      return true;
    } catch (e) {
      if (!(e instanceof SkeletonError)) throw e;
      this.history.commit();  // nothing changed: no undo step
      this.changed();
      this.flash(e.message);
      return false;
    }
  }

  /** A Skeleton-tool gesture on keyframe k: from a joint (or paper) to (x, y), released on joint `target`. */
  skeletonGesture(k, from, at, target, moved) {
    const [x, y] = at;
    if (from !== null && (!moved || target === from)) { this.select({ k, kind: 'joint', index: from }); return; }
    if (from !== null && target !== null) {
      const names = this.doc.jointNames();
      if (this.skeletonEdit('re-parent joint', () => reparent(this.doc.shot, target, from))) {
        this.flash(`${names[target]} now hangs from ${names[from]}`);
        this.select({ k, kind: 'joint', index: target });
      }
      return;
    }
    // a new joint: the child of the joint dragged from, else of the selected one, else of the nearest; the first is the root
    let parent = from;
    const pose = this.doc.keyPose(k);
    if (parent === null && this.selected?.kind === 'joint' && this.selected.k === k) parent = this.selected.index;
    if (parent === null && pose.length) {
      parent = pose.reduce((best, p, j) => (Math.hypot(p[0] - x, p[1] - y) < Math.hypot(pose[best][0] - x, pose[best][1] - y) ? j : best), 0);
    }
    let added = null;
    if (this.skeletonEdit('add joint', () => { added = addJoint(this.doc.shot, k, x, y, parent === null ? -1 : parent); })) {
      this.select({ k, kind: 'joint', index: added });
      this.flash(`added ${this.doc.jointNames()[added]}${parent === null ? ' (the root)' : ` under ${this.doc.jointNames()[parent]}`}: rename it in the inspector`);
    }
  }

  removeJoint(j) {
    const name = this.doc.jointNames()[j];
    this.select(null);
    if (this.skeletonEdit('delete joint', () => deleteJoint(this.doc.shot, j))) this.flash(`deleted ${name}`);
  }

  /** Place the chosen template in box [x0, y0, x1, y1] of keyframe k (Template tool). */
  placeTemplate(k, box) {
    const tpl = this.template;
    if (!tpl) { this.flash('choose a template first'); return; }
    if (Math.abs(box[2] - box[0]) < 8 || Math.abs(box[3] - box[1]) < 8) { this.flash('drag a bigger box around the character'); return; }
    let replaced = false;
    this.skeletonEdit(`place ${tpl.name}`, () => { replaced = applyTemplate(this.doc.shot, tpl, k, box); });
    this.select(null);
    this.flash(replaced ? `${tpl.name} skeleton placed on every key; drag its box on the other keys to place them there`
      : `${tpl.name} placed on key${k}`);
  }

  copyKeyPose(from, to) {
    if (!this.doc.keyPose(from).length) { this.flash(`key${from} has no pose yet`); return; }
    this.skeletonEdit(`copy key${from}'s pose to key${to}`, () => copyPose(this.doc.shot, from, to));
    this.flash(`key${from}'s pose copied to key${to}`);
  }

  _skeletonPanel() {
    const names = this.doc.jointNames();
    const info = $('skeleton-info');
    info.textContent = names.length
      ? `${names.length} joint${names.length === 1 ? '' : 's'}, root ${names[this.doc.parents().indexOf(-1)] ?? '?'}`
      : 'No skeleton yet: choose a template and drag its box around the character, or add joints with the Skeleton tool (J).';
    const k = this.focusedKey, to = this.shownKeys().find((i) => i !== k);  // the other pane's key
    const copy = $('copy-pose');
    copy.textContent = to === undefined ? 'Copy pose (one key only)' : `Copy key${k}'s pose to key${to}`;
    copy.dataset.from = String(k); copy.dataset.to = String(to ?? k);
    copy.disabled = to === undefined || !this.doc.keyPose(k).length;
  }

  /** The shot-level fields (format, keyframes, frames): shown, `frames` editable. */
  _shotFields() {
    const shot = this.doc.shot;
    $('field-format').textContent = JSON.stringify(shot.format ?? null);
    $('set-format').hidden = shot.format === 'inbetween-shot/1' || shot.format === 'inbetween-shot/2';
    $('field-keyframes').textContent = Array.isArray(shot.keyframes) ? shot.keyframes.join(', ') : JSON.stringify(shot.keyframes ?? null);
    const frames = $('frames');
    $('frames-row').hidden = shot.format === V2;  // v1 only: a v2 shot's frames follow its key frames
    if (document.activeElement !== frames) frames.value = Number.isInteger(shot.frames) ? String(shot.frames) : '';
    this._fieldAnchors();
  }

  /** A save or load error whose field has no joint, T-junction or mask layer to show it at: at the panel row
   *  of that field (the longest data-anchor prefix of it). */
  _fieldAnchors() {
    document.querySelectorAll('[data-anchor]').forEach((el) => {
      el.classList.remove('error');
      el.querySelector(':scope > .field-error')?.remove();
    });
    const err = this.errorItem;
    if (!err || !err.field || err.kind) return;
    if (document.querySelector(`#layers [data-field="${CSS.escape(err.field)}"]`)) return;
    const f = err.field;
    let best = null, bestLen = -1;
    for (const el of document.querySelectorAll('[data-anchor]')) {
      for (const a of el.dataset.anchor.split(' ')) {
        const hit = f === a || f.startsWith(`${a}.`) || f.startsWith(`${a}[`);
        if (hit && a.length > bestLen) { best = el; bestLen = a.length; }
      }
    }
    if (!best) return;
    best.classList.add('error');
    const div = document.createElement('div');
    div.className = 'field-error';
    div.dataset.field = f;
    div.textContent = err.message;
    best.append(div);
  }

  // ---------------------------------------------------------------- saving and reruns

  async save() {
    this.history.commit();
    this.doc.assignNames();
    this.clearError();
    $('save').disabled = true;
    try {
      const uploads = this.doc.toUpload();
      for (const layer of uploads) await putPNG(`/api/masks/${encodeURI(layer.name)}`, await layer.toBlob());
      const shot = this.doc.toShot();
      this.etag = await putVersioned('/api/shot', shot, this.etag);
      this.doc.markSaved(shot, uploads);
      this.flash('saved; rerunning');
      this.changed();
    } catch (e) {
      if (e instanceof ApiError) this.showError(e.message, e.field);
      else this.showError(`save failed: ${e.message}`, null);
    } finally {
      $('save').disabled = false;
    }
  }

  async run() {
    try { await sendJSON('POST', '/api/run', {}); } catch (e) { this.showError(e.message, e.field); }
  }

  async refreshPlan() {
    try {
      this.plan = await getJSON('/api/plan');
      this.stages.setPlan(this.plan);
      this.redraw();  // warnings of stale stages are drawn dashed
    } catch (e) {
      if (e instanceof ApiError && e.status === 400) this.showError(e.message, e.field);
    }
  }

  stale(stage) { return !!(this.plan && this.plan.stages[stage] && this.plan.stages[stage].state !== 'fresh'); }

  async onStatus(st) {
    const prev = this.status;
    this.status = st;
    this.stages.setStatus(st);
    const finished = st.state !== 'running' && (!prev || prev.state === 'running' || prev.seq !== st.seq);
    if (finished && prev) {
      // the plan taken before this rerun says nothing about its result: the panel shows the status until
      // the new plan is in (then "stale" if the saved shot still needs stages, "done" if not)
      this.plan = null;
      this.stages.setPlan(null);
      await this.refreshPlan();
      this.loading = new Map();  // every key's stored masks may have changed: reload when shown
      this.proposals.reset();
      await Promise.all(this.shownKeys().map((k) => this._ensureKey(k)));
      await this.loadWarnings();
      await this.results.refresh();
      this.redraw();
      this._layers();
    }
  }

  // ---------------------------------------------------------------- errors and messages

  /** Show a save error in the bar, and next to the item its field names (joint, T-junction, mask layer). */
  showError(message, field) {
    const bar = $('error-bar');
    bar.hidden = false;
    bar.textContent = message;
    bar.dataset.field = field || '';
    const short = field && message.includes(`${field}: `) ? message.split(`${field}: `).slice(1).join(`${field}: `) : message;
    this.errorItem = { field, message: short };
    let m;
    if (field && (m = field.match(/^poses\[(\d+)\]\.joints\[(\d+)\]/))) {
      const i = +m[1], j = +m[2];
      const k = keyPoseIndices(this.doc.shot).indexOf(i);  // a joint of a key pose: shown at it
      if (k >= 0 && this.doc.shot.poses[i]?.joints?.[j]) {
        Object.assign(this.errorItem, { k, kind: 'joint', pose: i, index: j });
        this.focusKey(k);
      }
      this._showView('annotate');
    } else if (field && (m = field.match(/^t_junctions\[(\d+)\]\[(\d+)\]/))) {
      if (this.doc.shot.t_junctions?.[+m[1]]?.[+m[2]]) {
        Object.assign(this.errorItem, { k: +m[1], kind: 'tj', index: +m[2] });
        this.focusKey(+m[1]);
      }
      this._showView('annotate');
    } else if (field && (m = field.match(/^masks\.(?:foreground|occlusion)\[(\d+)\]/)) && +m[1] < this.doc.structure.length) {
      this.focusKey(+m[1]);
      this._showView('annotate');
    }
    this._layers();
    this._fieldAnchors();
    this.redraw();
  }

  clearError() {
    $('error-bar').hidden = true;
    this.errorItem = null;
    this._layers();
    this._fieldAnchors();
    this.redraw();
  }

  flash(text) {
    $('dirty').textContent = text;
    $('dirty').title = text;  // the whole message, when the header cuts it short
    clearTimeout(this._flashTimer);
    this._flashTimer = setTimeout(() => this.changed(), 2500);
  }

  // ---------------------------------------------------------------- wiring

  _showView(name) {
    document.querySelectorAll('.tab').forEach((t) => t.classList.toggle('active', t.dataset.view === name));
    document.querySelectorAll('.view').forEach((v) => { v.hidden = v.id !== `view-${name}`; });
    this.view = name;
    if (name === 'annotate') this.keys.forEach((v) => v.draw());
    if (name === 'pose') this.pose.enter();
    if (name === 'results') this.results.draw();
  }

  setTool(tool) {
    this.tool = tool;
    document.querySelectorAll('#tools button').forEach((b) => b.classList.toggle('active', b.dataset.tool === tool));
    this.redraw();
  }

  setBrush(r) {
    this.brush = Math.max(1, Math.min(60, r));
    $('brush').value = String(this.brush);
    $('brush-size').textContent = String(this.brush);
  }

  _wire() {
    this.view = 'annotate';
    document.querySelectorAll('.tab').forEach((t) => t.addEventListener('click', () => this._showView(t.dataset.view)));
    document.querySelectorAll('#tools button').forEach((b) => b.addEventListener('click', () => this.setTool(b.dataset.tool)));
    $('brush').addEventListener('input', () => this.setBrush(+$('brush').value));
    $('overlays').replaceChildren(...OVERLAYS.map(([key, label]) => {
      const l = document.createElement('label');
      const box = document.createElement('input');
      box.type = 'checkbox'; box.checked = this.overlays.has(key); box.dataset.overlay = key;
      box.addEventListener('change', () => {
        box.checked ? this.overlays.add(key) : this.overlays.delete(key);
        if (key === 'proposals' && box.checked) this.proposals.dismissed.clear();  // ticked: see them again
        this.redraw();
        this.proposalPanel();
      });
      l.append(box, ` ${label}`);
      return l;
    }));
    $('mask-key').addEventListener('change', () => { this.focusKey(+$('mask-key').value); this._layers(); });
    $('template').replaceChildren(...Object.keys(this.templates).map((n) => { const o = document.createElement('option'); o.value = o.textContent = n; return o; }));
    const pickTemplate = () => { this.template = { name: $('template').value, ...this.templates[$('template').value] }; };
    pickTemplate();
    $('template').addEventListener('change', () => { pickTemplate(); this.setTool('template'); });
    $('place-template').addEventListener('click', () => this.setTool('template'));
    $('copy-pose').addEventListener('click', () => this.copyKeyPose(+$('copy-pose').dataset.from, +$('copy-pose').dataset.to));
    $('set-format').addEventListener('click', () => this.edit('set format', () => { this.doc.shot.format = 'inbetween-shot/1'; }));
    $('frames').addEventListener('change', () => {
      const v = $('frames').value.trim();
      this.edit('frames', () => { if (v === '') delete this.doc.shot.frames; else this.doc.shot.frames = Number(v); });
    });
    $('new-region').addEventListener('click', () => this.newRegion(+$('mask-key').value));
    $('proposals-accept-all').addEventListener('click', () => {
      const min = parseFloat($('proposals-min').value);
      const n = this.proposals.acceptAll(this.focusedKey, Number.isFinite(min) ? min : 0);
      this.flash(n ? `${n} proposal${n === 1 ? '' : 's'} accepted as T-junctions of key${this.focusedKey}` : 'no proposal scores that much');
    });
    $('proposals-dismiss').addEventListener('click', () => {
      this.proposals.dismiss(this.focusedKey);
      this.redraw();
      this.proposalPanel();
    });
    $('from-prediction').addEventListener('click', () => this.fromPrediction(+$('mask-key').value));
    $('undo').addEventListener('click', () => this.history.undo());
    $('redo').addEventListener('click', () => this.history.redo());
    $('save').addEventListener('click', () => this.save());
    $('run').addEventListener('click', () => this.run());
    $('help-open').addEventListener('click', () => { $('help').hidden = false; });
    $('help-close').addEventListener('click', () => { $('help').hidden = true; });
    renderHelp($('help-table'));
    document.querySelectorAll('select').forEach((sel) => sel.addEventListener('change', () => sel.blur()));
    window.addEventListener('keydown', (e) => this._key(e));
    window.addEventListener('keyup', (e) => { if (e.code === 'Space') this.spaceHeld = false; });
    window.addEventListener('resize', () => { this.redraw(); if (this.view === 'results') this.results.draw(); if (this.view === 'pose') this.pose.draw(); });
    window.addEventListener('beforeunload', (e) => { if (this.doc && this.doc.isDirty()) e.preventDefault(); });
  }

  _key(e) {
    // text fields and menus keep their keys; checkboxes and sliders do not (arrows step frames, not sliders)
    const typing = e.target.matches && e.target.matches('input[type=number], input[type=text], textarea, select');
    if (e.code === 'Space' && !typing) { this.spaceHeld = true; if (this.view === 'annotate') e.preventDefault(); }
    const action = actionFor(e);
    if (!action || (typing && !['save', 'escape'].includes(action))) return;
    const run = this._actions()[action];
    if (!run) return;
    e.preventDefault();
    run(e);
  }

  _actions() {
    const nudge = (e) => {
      if (this.view === 'results') { this.results.show(this.results.index + (e.key === 'ArrowLeft' || e.key === 'ArrowUp' ? -1 : 1)); return; }
      const sel = this.selected;
      if (!sel) return;
      const step = e.shiftKey ? 0.1 : 1;
      const [dx, dy] = { ArrowLeft: [-step, 0], ArrowRight: [step, 0], ArrowUp: [0, -step], ArrowDown: [0, step] }[e.key];
      this.edit('nudge', () => {
        const p = sel.kind === 'joint' ? this.doc.keyPose(sel.k)[sel.index] : this.doc.shot.t_junctions[sel.k][sel.index];
        p[0] = Math.round((p[0] + dx) * 10) / 10;
        p[1] = Math.round((p[1] + dy) * 10) / 10;
      });
    };
    return {
      'tool-select': () => this.setTool('select'), 'tool-tjunction': () => this.setTool('tjunction'),
      'tool-paint': () => this.setTool('paint'), 'tool-erase': () => this.setTool('erase'),
      'tool-skeleton': () => this.setTool('skeleton'), 'tool-template': () => this.setTool('template'),
      'brush-smaller': () => this.setBrush(this.brush - 2), 'brush-larger': () => this.setBrush(this.brush + 2),
      'new-region': () => this.newRegion(this.focusedKey),
      'key-prev': () => { if (this.focusedKey > 0) this.focusKey(this.focusedKey - 1); },
      'key-next': () => { if (this.focusedKey < keyCount(this.doc.shot) - 1) this.focusKey(this.focusedKey + 1); },
      delete: () => {
        const sel = this.selected;
        if (sel && sel.kind === 'joint') { this.removeJoint(sel.index); return; }
        if (!sel || sel.kind !== 'tj') return;
        this.select(null);
        this.edit('delete T-junction', () => this.doc.shot.t_junctions[sel.k].splice(sel.index, 1));
      },
      nudge,
      undo: () => this.history.undo(), redo: () => this.history.redo(), save: () => this.save(),
      fit: () => this.keys.forEach((v) => v.fit()),
      'view-annotate': () => this._showView('annotate'), 'view-pose': () => this._showView('pose'),
      'view-results': () => this._showView('results'),
      play: () => this.results.togglePlay(),
      onion: () => { $('onion').checked = !$('onion').checked; this.results.draw(); },
      'add-pose': () => { if (this.view === 'pose') this.pose.addPose(); },
      help: () => { $('help').hidden = !$('help').hidden; },
      escape: () => { $('help').hidden = true; this.select(null); this.clearError(); },
    };
  }
}


const app = new App();
window.editorApp = app;  // for the browser console
app.boot().catch((e) => {
  const bar = $('error-bar');
  bar.hidden = false;
  bar.textContent = `the editor could not start: ${e.message}`;
});
