// T-junction proposals (GET /api/proposals, editor/proposals.py): read from the ink for keys that arrive without
// clicks. Drawn as hollow markers; a click on one accepts it (a T-junction in the document, undoable); a click
// always wins: a proposal within CLICK_WINS_PX of a T-junction of the document is not shown.

import { getJSON } from './api.js';
import { keyCount } from './skeleton.js';

const CLICK_WINS_PX = 5;  // image pixels, as the server's editor/proposals.py CLICK_WINS_PX
const round1 = (v) => Math.round(v * 10) / 10;

export class Proposals {
  constructor(app) {
    this.app = app;
    this.byKey = new Map();      // key -> {state: 'loading' | 'ready' | 'error', list, error}
    this.dismissed = new Set();  // keys whose proposals are hidden for this session (Dismiss)
  }

  /** Forget what was fetched (a rerun ended, the shot was reopened): fetched again when shown, instant when the
   *  key's drawing and pose did not change (the server's cache). */
  reset() { this.byKey = new Map(); }

  /** Whether key k shows its proposals: the overlay is on, or the key has no T-junctions yet; not dismissed. */
  shows(k) {
    if (this.dismissed.has(k)) return false;
    return this.app.overlays.has('proposals') || !(this.app.doc.shot.t_junctions?.[k]?.length);
  }

  /** Fetch key k's proposals once; the views redraw when they are in. */
  ensure(k) {
    if (this.byKey.has(k)) return;
    const entry = { state: 'loading', list: [], error: null };
    this.byKey.set(k, entry);
    getJSON(`/api/proposals?key=${k}`).then((got) => {
      entry.state = 'ready';
      entry.list = got.proposals;
    }).catch((e) => {
      entry.state = 'error';
      entry.error = e.message;
    }).finally(() => {
      if (this.byKey.get(k) !== entry) return;  // reset meanwhile
      this.app.redraw();
      this.app.proposalPanel();
    });
  }

  /** Key k's proposals not within CLICK_WINS_PX of one of its T-junctions in the document, best first. */
  list(k) {
    const got = this.byKey.get(k);
    if (!got || got.state !== 'ready') return [];
    const clicks = this.app.doc.shot.t_junctions?.[k] || [];
    return got.list.filter((p) => clicks.every(([x, y]) => Math.hypot(p.x - x, p.y - y) > CLICK_WINS_PX));
  }

  /** What key k's panes draw and pick: its proposals when it shows them (fetched on first need), else none. */
  visible(k) {
    if (!this.shows(k)) return [];
    this.ensure(k);
    return this.list(k);
  }

  /** Accept proposals `ps` of key k as T-junctions: one undo step. Returns the index of the first new one. */
  accept(k, ps, label) {
    if (!ps.length) return -1;
    const shot = this.app.doc.shot;
    let first = -1;
    this.app.edit(label, () => {
      if (!Array.isArray(shot.t_junctions)) shot.t_junctions = Array.from({ length: keyCount(shot) }, () => []);
      while (shot.t_junctions.length <= k) shot.t_junctions.push([]);
      first = shot.t_junctions[k].length;
      for (const p of ps) shot.t_junctions[k].push([round1(p.x), round1(p.y)]);
    });
    return first;
  }

  acceptAll(k, minScore) {
    const ps = this.visible(k).filter((p) => p.score >= minScore);
    this.accept(k, ps, `accept ${ps.length} proposal${ps.length === 1 ? '' : 's'}`);
    return ps.length;
  }

  dismiss(k) { this.dismissed.add(k); }

  /** A line about key k's proposals for the panel. */
  describe(k) {
    if (this.dismissed.has(k)) return `key${k}: proposals dismissed (tick Proposals to see them again)`;
    if (!this.shows(k)) return `key${k} has T-junctions: tick Proposals to see the proposals too`;
    this.ensure(k);
    const got = this.byKey.get(k);
    if (got.state === 'loading') return `key${k}: reading proposals from the ink…`;
    if (got.state === 'error') return `key${k}: no proposals (${got.error})`;
    const ps = this.list(k);
    if (!ps.length) return `key${k}: no proposals`;
    return `key${k}: ${ps.length} proposal${ps.length === 1 ? '' : 's'} (best ${ps[0].score.toFixed(2)}); click one to accept it`;
  }
}
