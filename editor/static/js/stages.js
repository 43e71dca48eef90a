// The rerun panel: every stage of the graph with what the last rerun did (re-ran, cached) or, between
// reruns, what the next one would do (fresh, stale, missing), streamed from /api/events.

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
    document.getElementById('out-dir').textContent = `frames: ${info.out_dir}/frames`;
  }

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

  render() {
    const st = this.status;
    const state = st ? st.state : 'idle';
    this.pill.textContent = state === 'running' && st.running_stage ? `running ${st.running_stage}` : state;
    this.pill.className = `pill ${state}`;
    this.pill.dataset.state = state;
    this.pill.dataset.seq = st ? st.seq : 0;
    const notes = [];
    if (st && st.seq) notes.push(`rerun #${st.seq} (${st.reason})`);
    if (st && st.note) notes.push(st.note);
    if (state === 'done' && st.started && st.finished) notes.push(`${(st.finished - st.started).toFixed(1)} s`);
    this.note.textContent = notes.join(' · ');
    this.error.hidden = !(st && st.error);
    this.error.textContent = st && st.error ? st.error : '';
    this.list.replaceChildren(...this.stages.map((name) => this._row(name, st)));
  }

  _row(name, st) {
    const li = document.createElement('li');
    li.dataset.stage = name;
    const label = document.createElement('span');
    label.textContent = name;
    const what = document.createElement('span');
    what.className = 'st';
    let state, text, title = '';
    const done = st && st.seq ? st.stages[name] : null;
    if (done) {
      state = done.cached ? 'cached' : 'ran';
      text = done.cached ? 'cached' : `re-ran ${done.seconds.toFixed(2)} s`;
    } else if (st && st.state === 'running') {
      state = st.running_stage === name ? 'running' : 'pending';
      text = state === 'running' ? 'running…' : '…';
    } else {
      const p = this.plan && this.plan.stages[name];
      state = p ? p.state : 'unknown';
      text = state;
      title = p ? p.causes.join('; ') : '';
    }
    li.className = state + (this.willRun.has(name) ? ' willrun' : '');
    li.dataset.state = state;
    li.title = title || (this.willRun.has(name) ? 'saving now reruns this stage' : '');
    what.textContent = text;
    li.append(label, what);
    return li;
  }
}

/** Call onStatus with every status the server streams (EventSource reconnects by itself). */
export function followStatus(onStatus) {
  const source = new EventSource('/api/events');
  source.onmessage = (e) => onStatus(JSON.parse(e.data));
  return source;
}
