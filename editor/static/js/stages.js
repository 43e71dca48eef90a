// The rerun panel: every stage of the graph with what the running rerun does (ran, cached, running with its
// progress), or between reruns what the saved shot needs (the plan: fresh, stale, missing), streamed from
// /api/events. Between reruns the plan is the truth: a shot changed since its last rerun reads "stale", not
// "done", whatever that rerun's status says (after a reload too).

const fmt = (s) => (s < 10 ? s.toFixed(1) : s.toFixed(0));

export class StagesPanel {
  constructor(info) {
    this.stages = info.stages;
    this.parents = info.parents;
    this.list = document.getElementById('stage-list');
    this.pill = document.getElementById('run-state');
    this.note = document.getElementById('run-note');
    this.error = document.getElementById('run-error');
    this.plan = null;
    this.status = null;
    this.willRun = new Set();
    this.warnings = {};
    document.getElementById('out-dir').textContent = `frames: ${info.out_dir}/frames`;
    // the running stage's seconds tick on between status events
    setInterval(() => { if (this.status && this.status.state === 'running') this.render(); }, 1000);
  }

  /** A new stage graph (keys were added or removed). */
  setGraph(info) { this.stages = info.stages; this.parents = info.parents; this.plan = null; this.render(); }

  /** The stages downstream of the changed sources, in graph order (what saving now would rerun). */
  downstream(sources) {
    const hit = new Set(sources);
    const out = new Set();
    for (const s of this.stages) if (this.parents[s].some((p) => hit.has(p) || out.has(p))) out.add(s);
    return out;
  }

  setPlan(plan) { this.plan = plan; this.render(); }
  setStatus(status) { this.status = status; this.render(); }
  setWillRun(set) { this.willRun = set; this.render(); }
  /** {stage: [warning text, ...]} of the stored stages. */
  setWarnings(byStage) { this.warnings = byStage; this.render(); }

  /** Stages the plan says the next run executes (empty while no plan is known). */
  notFresh() {
    return this.plan ? this.stages.filter((n) => this.plan.stages[n] && this.plan.stages[n].state !== 'fresh') : [];
  }

  /** The panel's state: running > failed > stale (the plan says stages must rerun) > the status's own. */
  state() {
    const st = this.status;
    if (st && (st.state === 'running' || st.state === 'failed')) return st.state;
    if (this.notFresh().length) return 'stale';
    return st ? st.state : 'idle';
  }

  render() {
    const st = this.status;
    const state = this.state();
    const stale = this.notFresh();
    const running = state === 'running' && st.running_stage;
    this.pill.textContent = running ? `running ${st.running_stage}` : state === 'stale' ? `${stale.length} stale` : state;
    this.pill.className = `pill ${state}`;
    this.pill.dataset.state = state;
    this.pill.dataset.seq = st ? st.seq : 0;
    this.pill.dataset.running = running ? st.running_stage : '';
    const notes = [];
    if (st && st.seq) notes.push(`rerun #${st.seq} (${st.reason})${state === 'stale' ? ` ${st.state}` : ''}`);
    if (st && st.note) notes.push(st.note);
    if (state === 'done' && st.started && st.finished) notes.push(`${(st.finished - st.started).toFixed(1)} s`);
    if (state === 'stale') notes.push('the saved shot changed since: Run (or Save) reruns the stale stages');
    this.note.textContent = notes.join(' · ');
    this.error.hidden = !(st && st.error);
    this.error.textContent = st && st.error ? st.error : '';
    this.list.replaceChildren(...this.stages.map((name) => this._row(name, st, state)));
  }

  /** "12 s", with the stage's progress when it reports one, else against what it took last time. */
  _running(name, st) {
    const since = st.running_since ? Math.max(0, Date.now() / 1000 - st.running_since) : null;
    const p = st.stage_progress && st.stage_progress.stage === name ? st.stage_progress : null;
    const last = st.last_seconds && st.last_seconds[name];
    let text = since === null ? 'running…' : `running ${fmt(since)} s`, share = null, title = '';
    if (p && p.bound) {
      text += ` · ${p.done}/≤${p.bound}`;
      share = p.done / p.bound;
      title = `${p.done} of at most ${p.bound} RIFE blends done`;
    } else if (last && since !== null) {
      text += ` of ~${fmt(last)}`;
      share = Math.min(1, since / last);
      title = `it took ${fmt(last)} s the last time it ran`;
    }
    return { text, share, title };
  }

  _row(name, st, state) {
    const li = document.createElement('li');
    li.dataset.stage = name;
    const label = document.createElement('span');
    label.className = 'name';
    const full = document.createElement('span');
    full.className = 'text';  // cut short with an ellipsis where the panel is narrow; the warning count stays shown
    full.textContent = name;
    label.append(full);
    label.title = name;  // in full, where a narrow panel cuts it short
    const what = document.createElement('span');
    what.className = 'st';
    let row, text, title = '', share = null;
    const p = this.plan && this.plan.stages[name];
    if (state === 'running' || state === 'failed' || (p && p.state === 'fresh') || !this.plan) {
      const done = st && st.seq ? st.stages[name] : null;
      if (done) {
        row = done.cached ? 'cached' : 'ran';
        text = done.cached ? 'cached' : `re-ran ${done.seconds.toFixed(2)} s`;
      } else if (state === 'running' && st.running && name in st.running) {
        row = 'running';
        ({ text, share, title } = this._running(name, st));
      } else if (state === 'running') {
        row = 'pending'; text = '…';
      } else {
        row = p ? p.state : 'unknown'; text = row;
      }
    } else {
      row = p.state;
      text = p.state;
      title = p.causes.join('; ');
    }
    li.className = row + (this.willRun.has(name) ? ' willrun' : '');
    li.dataset.state = row;
    li.title = title || (this.willRun.has(name) ? 'saving now reruns this stage' : '');
    what.textContent = text;
    const warnings = this.warnings[name];
    if (warnings && warnings.length) {
      const w = document.createElement('span');
      w.className = 'w';
      w.textContent = `⚠${warnings.length}`;
      w.title = warnings.join('\n');
      w.dataset.count = String(warnings.length);
      label.append(w);
    }
    li.append(label, what);
    if (share !== null) {
      const bar = document.createElement('span');
      bar.className = 'bar';
      const fill = document.createElement('span');
      fill.style.width = `${Math.round(share * 100)}%`;
      bar.append(fill);
      li.append(bar);
      li.style.flexWrap = 'wrap';
      bar.style.flexBasis = '100%';
    }
    return li;
  }
}

/** Call onStatus with every status the server streams (EventSource reconnects by itself). */
export function followStatus(onStatus) {
  const source = new EventSource('/api/events');
  source.onmessage = (e) => onStatus(JSON.parse(e.data));
  return source;
}
