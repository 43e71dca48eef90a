"""The work-ahead (assets/ahead.py) without Dagster's steps: outputs written ahead, idle workers warming up."""
from __future__ import annotations

import sys
import threading
import time
from types import SimpleNamespace

import assets.ahead as ahead
from assets.compute import Outcome, StageResult
from ops.settings import Settings

TWO_KEYS = SimpleNamespace(n_keys=2)  # all the work-ahead reads of the shot: its graph


class _Store:
    """Records what the work-ahead writes ahead and discards."""

    def __init__(self):
        self.staged, self.discarded = [], []

    def stage(self, name, partition, value, digest, provenance=None):
        self.staged.append(name)

    def discard(self, name, partition):
        self.discarded.append(name)

    def hash(self, name, partition):
        return None


class _Context:
    def __init__(self):
        self.log = SimpleNamespace(log=lambda level, message: None)


def _outcome(name: str) -> Outcome:
    return Outcome(f"v-{name}", False, StageResult(name), 0.0, {"parents": {}}, None)


def test_each_new_output_is_written_ahead_before_its_step_takes_it(monkeypatch):
    monkeypatch.setattr(ahead, "run_stage", lambda name, env, parents, settings: _outcome(name))
    store = _Store()
    work = ahead.WorkAhead("p", ["key0/masks", "key0/refined_masks"], TWO_KEYS, {}, Settings(), store, {})
    work.start()
    try:
        for name in ("key0/masks", "key0/refined_masks"):
            outcome, _ = work.outcome(name, _Context())
            assert outcome.version == f"v-{name}" and name in store.staged
    finally:
        work.close()
    assert set(store.discarded) == {"key0/masks", "key0/refined_masks"}  # a no-op for outputs put in place


def test_an_idle_worker_loads_rife_before_rife_matrix_needs_it(monkeypatch):
    release, loaded, order = threading.Event(), threading.Event(), []

    def run_stage(name, env, parents, settings):
        if name == "seg0/key0/deformed_frames":
            assert release.wait(10)  # the other worker has nothing to do meanwhile
        order.append(name)
        return _outcome(name)

    def load():
        order.append("load rife")
        loaded.set()

    monkeypatch.setattr(ahead, "run_stage", run_stage)
    monkeypatch.setitem(ahead.STAGE_SPECS, "seg0/rife_matrix", SimpleNamespace(resources=("rife",)))
    names = ["seg0/key0/deformed_frames", "seg0/key1/deformed_frames", "seg0/rife_matrix"]
    work = ahead.WorkAhead("p", names, TWO_KEYS, {}, Settings(), _Store(), {"rife": SimpleNamespace(load=load)})
    work.start()
    try:
        assert loaded.wait(10)
        release.set()
        work.outcome("seg0/rife_matrix", _Context())
    finally:
        work.close()
    assert order.index("load rife") < order.index("seg0/rife_matrix") and order.count("load rife") == 1


def test_a_stage_takes_a_resource_given_early_without_waiting_for_the_rest():
    # the run gives the network and the inpainter as soon as Dagster is imported, the rest (the Definitions')
    # later: a stage asking for the inpainter gets it then; one asking for anything else waits for the rest,
    # and once the rest is given every name answers from it
    resources = ahead.Resources()
    early, definitions = object(), {"inpainter": object(), "shots": object()}
    got: dict[str, object] = {}
    threads = [threading.Thread(target=lambda n=n: got.__setitem__(n, getattr(resources, n)))
               for n in ("inpainter", "shots")]
    for t in threads:
        t.start()
    resources.provide_early({"inpainter": early})
    threads[0].join(10)
    assert got == {"inpainter": early} and threads[1].is_alive() and resources.known is None
    resources.provide(definitions)
    threads[1].join(10)
    assert got == {"inpainter": early, "shots": definitions["shots"]}
    assert resources.inpainter is definitions["inpainter"] and resources.get() == definitions


def test_a_stage_waiting_for_a_resource_fails_when_the_session_does():
    resources = ahead.Resources()
    resources.provide_early({"rife": object()})
    resources.fail(RuntimeError("no instance"))
    try:
        resources.shots
    except RuntimeError as e:
        assert "no instance" in str(e)
    else:
        raise AssertionError("a resource the session never gave must fail")


def test_while_working_ahead_a_thread_waits_at_most_a_millisecond_for_the_gil(monkeypatch):
    seen = []
    monkeypatch.setattr(ahead, "run_stage", lambda name, env, parents, settings: (
        seen.append(sys.getswitchinterval()), _outcome(name))[1])
    monkeypatch.setattr(ahead.processes, "pool", lambda: None)
    before = sys.getswitchinterval()
    with ahead.working_ahead("p", ["key0/masks"], TWO_KEYS, {}, Settings(), _Store(), {}) as work:
        work.outcome("key0/masks", _Context())
    assert seen == [ahead.GIL_SWITCH_S] and ahead.GIL_SWITCH_S < before
    assert sys.getswitchinterval() == before  # the process's own setting again


def test_the_next_stage_starts_while_its_parents_output_is_still_being_written(monkeypatch):
    computed, release = [], threading.Event()
    monkeypatch.setattr(ahead, "run_stage", lambda name, env, parents, settings: (computed.append(name),
                                                                                  _outcome(name))[1])

    class SlowStore(_Store):
        def stage(self, name, partition, value, digest, provenance=None):
            if name == "key0/masks":
                assert release.wait(10)
            super().stage(name, partition, value, digest, provenance)

    store = SlowStore()
    work = ahead.WorkAhead("p", ["key0/masks", "key0/refined_masks"], TWO_KEYS, {}, Settings(), store, {})
    work.start()
    try:
        deadline = time.monotonic() + 10
        while "key0/refined_masks" not in computed and time.monotonic() < deadline:
            time.sleep(0.01)
        assert computed == ["key0/masks", "key0/refined_masks"] and store.staged == []  # masks still being written
        release.set()
        for name in ("key0/masks", "key0/refined_masks"):  # a step still waits until its output is written
            work.outcome(name, _Context())
            assert name in store.staged
    finally:
        release.set()
        work.close()
