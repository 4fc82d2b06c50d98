"""The run loop on the fakes: batch protocol, executors agree, errors, timeouts, resume."""

from __future__ import annotations

import pytest
from campaign_fakes import FakeGenerator, fake_outcome, raises
from campaign_helpers import db_rows, fake_config

from sitcov._seeding import ask_rng, run_seed
from sitcov.campaign import open_store, run_campaign
from sitcov.errors import ConfigError
from sitcov.hyperspace import load_hyperspace


def expected_situations(runs: int, seed: int, batch: int) -> list:
    """The batch protocol replayed by hand: tell batch k, then ask batch k+1."""
    hs = load_hyperspace(None)
    gen, out, told = FakeGenerator(hs), [], 0
    while len(out) < runs:
        for s in out[told:]:
            gen.tell(s, fake_outcome(s, run_seed(seed, out.index(s))))
        told = len(out)
        for i in range(len(out), min(len(out) + batch, runs)):
            out.append(gen.ask(ask_rng(seed, i)))
    return out


def test_serial_follows_the_batch_protocol_exactly():
    store = open_store(None)
    cfg = fake_config(runs=30, batch_size=7)
    result = run_campaign(cfg, store)
    runs = store.runs(cfg.name)
    assert [r.index for r in runs] == list(range(30))
    assert [r.situation for r in runs] == expected_situations(30, cfg.seed, 7)
    assert [r.seed for r in runs] == [run_seed(cfg.seed, i) for i in range(30)]
    assert all(r.outcome == fake_outcome(r.situation, r.seed) for r in runs)
    assert result.executed == 30 and result.runs == 30
    assert result.failures == sum(r.status == "fail" for r in runs) > 0
    # the learning generator's stored state has been told all batches but the last
    assert store.campaign(cfg.name).generator_state["told"] == 28
    assert store.campaign(cfg.name).batch_start == 28


def test_processes_and_serial_store_identical_rows(tmp_path):
    rows = {}
    for label, changes in {
        "serial": {"executor": "serial"},
        "p2": {"executor": "processes", "workers": 2},
    }.items():
        path = tmp_path / f"{label}.db"
        with open_store(path) as store:
            run_campaign(fake_config(runs=40, **changes), store)
        rows[label] = db_rows(path)
    assert len(rows["serial"]) == 40
    assert rows["serial"] == rows["p2"]


@pytest.mark.parametrize(
    ("executor", "source"), [("serial", "stack"), ("processes", "stack"), ("serial", "backend")]
)
def test_raising_runs_are_errors_and_the_rest_complete(executor, source):
    store = open_store(None)
    where = {"av_params": {"raise_rate": 0.1}}
    if source == "backend":
        where = {"backend_options": {"raise_rate": 0.1}}
    cfg = fake_config(runs=60, executor=executor, workers=2, **where)
    result = run_campaign(cfg, store)
    runs = store.runs(cfg.name)
    expected_errors = [r.index for r in runs if raises(r.seed, 0.1)]
    assert 2 <= len(expected_errors) <= 15
    assert [r.index for r in runs if r.status == "error"] == expected_errors
    for r in runs:
        if r.status == "error":
            head, _, trace = r.outcome.message.partition("\n")
            assert head == (
                f"ValueError: fake stack refused seed {r.seed}"
                if source == "stack"
                else f"RuntimeError: fake backend exploded on seed {r.seed}"
            )
            assert trace.startswith("Traceback (most recent call last):")
            assert "campaign_fakes.py" in trace and trace.endswith(head)
        else:
            assert r.outcome == fake_outcome(r.situation, r.seed)
    assert result.errors == len(expected_errors) and result.counts["pending"] == 0


@pytest.mark.parametrize("executor", ["serial", "processes"])
def test_runs_over_the_wall_time_limit_are_timeouts(executor):
    import numpy as np

    store = open_store(None)
    cfg = fake_config(
        runs=12,
        executor=executor,
        workers=2,
        run_timeout=0.5,
        backend_options={"hang_rate": 0.15},
    )
    run_campaign(cfg, store)
    runs = store.runs(cfg.name)
    hangs = [r.index for r in runs if np.random.default_rng([r.seed, 5]).random() < 0.15]
    assert hangs, "the seed should make at least one run hang"
    assert [r.index for r in runs if r.status == "timeout"] == hangs
    for r in runs:
        if r.status == "timeout":
            assert r.outcome.end_reason == "wall_timeout"
            assert "wall-time limit of 0.5 s" in r.outcome.message
        else:
            assert r.outcome == fake_outcome(r.situation, r.seed)


class Crash(Exception):
    pass


@pytest.mark.parametrize("crash_after", [1, 8, 13, 27])
def test_crash_and_resume_equals_uninterrupted(tmp_path, crash_after):
    ref = tmp_path / "ref.db"
    with open_store(ref) as store:
        run_campaign(fake_config(runs=30), store)
    path = tmp_path / "crash.db"

    def crash(p):
        if p.event == "run" and p.executed == crash_after:
            raise Crash

    with open_store(path) as store, pytest.raises(Crash):
        run_campaign(fake_config(runs=30), store, progress=crash)
    with open_store(path) as store:
        assert store.count_runs(status="pending") > 0 or crash_after % 8 == 0
        result = run_campaign(fake_config(runs=30, executor="processes", workers=2), store)
        assert result.resumed
    assert db_rows(path) == db_rows(ref)


def test_extend_and_reject_a_different_config():
    store = open_store(None)
    run_campaign(fake_config(runs=16), store)
    result = run_campaign(fake_config(runs=24), store)
    assert result.executed == 8 and result.runs == 24 and result.resumed
    assert store.campaign("default").config["runs"] == 24
    again = run_campaign(fake_config(runs=24, workers=2, executor="processes"), store)
    assert again.executed == 0
    with pytest.raises(ConfigError, match=r"different config \(seed: 3 -> 4\)"):
        run_campaign(fake_config(runs=24, seed=4), store)


def test_no_effect_elements_are_announced():
    events = []
    run_campaign(fake_config(runs=2), open_store(None), progress=events.append)
    assert events[0].event == "start" and events[-1].event == "end"
    assert "friction" not in events[0].no_effect and "intsit" not in events[0].no_effect
    assert set(events[0].no_effect) == set(load_hyperspace(None).element_names) - {
        "friction",
        "intsit",
    }
    assert [e.done for e in events if e.event == "run"] == [1, 2]


def test_replay_failures_first():
    store = open_store(None)
    run_campaign(fake_config(name="old", runs=24), store)
    failures = store.runs("old", "fail")
    assert failures
    result = run_campaign(
        fake_config(name="new", runs=len(failures) + 5, replay_failures_first=True), store
    )
    new = store.runs("new")
    k = len(failures)
    assert result.replayed == k
    assert [r.replay_of for r in new[:k]] == [f"old:{r.index}" for r in failures]
    assert [(r.situation, r.seed) for r in new[:k]] == [(r.situation, r.seed) for r in failures]
    assert all(r.status == "fail" for r in new[:k])  # deterministic: they fail again
    assert all(r.replay_of is None for r in new[k:])
    assert [r.seed for r in new[k:]] == [run_seed(3, i) for i in range(k, k + 5)]


def test_record_traces_are_stored_per_run(tmp_path):
    with open_store(tmp_path / "t.db") as store:
        run_campaign(fake_config(runs=4, record_traces=True, executor="processes"), store)
        run = store.get_run("default", 2)
        assert run.outcome.trace.meta == {"seed": run.seed}
        assert [list(p) for p in run.outcome.trace.ov] == [[0.0, 9.0, 9.0, 1.0, run.seed % 5]]
        assert run.outcome == fake_outcome(run.situation, run.seed)  # traces do not compare


def test_f1_campaigns_pin_the_threshold_they_resolved_to(monkeypatch):
    """F1's threshold comes from the PEM: the stored campaign records it, and a resume after
    a recalibration that moves it is refused (one campaign, one threshold)."""
    from sitcov.av import _faults
    from sitcov.av._fault_map import f1_threshold
    from sitcov.campaign import CampaignConfig
    from sitcov.campaign._runner import F1_THRESHOLD_TAG, check_fault_tags, fault_tags

    f1 = CampaignConfig(av="reference", fault="f1", executor="serial", workers=1)
    tags = fault_tags(f1)
    assert tags == {F1_THRESHOLD_TAG: round(f1_threshold(), 6)}
    assert 0.5 < tags[F1_THRESHOLD_TAG] < 0.95
    assert fault_tags(CampaignConfig(av="reference", fault="f2")) == {}
    assert fault_tags(CampaignConfig(av="reference")) == {}
    check_fault_tags("c", tags, f1)  # same PEM: resumes
    check_fault_tags("c", {}, f1)  # stored before thresholds were pinned: resumes
    monkeypatch.setitem(_faults.FAULTS, "f1", {"threshold": 0.61})  # a recalibrated PEM
    with pytest.raises(ConfigError, match=r"threshold .* now resolves to 0.61"):
        check_fault_tags("c", tags, f1)
