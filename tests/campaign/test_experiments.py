"""The seeded-fault experiment (Table 2): protocol, replays, resume, the table's arithmetic."""

from __future__ import annotations

import json
import time

import pytest

from sitcov.campaign import fault_table, open_store, run_campaign, run_fault_experiment
from sitcov.campaign._experiments import _base_config, _replay_into, campaign_name, split_runs
from sitcov.cli import main
from sitcov.errors import ConfigError

FAULTS = ("NF", "F1", "F2", "F3")


def _statuses(store, name):
    return [(r.situation.id, r.seed, r.status) for r in store.runs(campaign=name)]


def test_split_runs_like_the_paper():
    assert split_runs(100, 5) == [20] * 5
    assert split_runs(7, 3) == [3, 2, 2]
    assert sum(split_runs(1001, 7)) == 1001
    with pytest.raises(ConfigError, match="--runs"):
        split_runs(2, 3)
    with pytest.raises(ConfigError, match="--seeds"):
        split_runs(2, 0)


def test_small_experiment_with_the_real_backend(tmp_path, capsys):
    db = tmp_path / "faults.db"
    main(
        [
            "experiment",
            "faults",
            "--db",
            str(db),
            "--runs",
            "10",
            "--seeds",
            "2",
            "--generators",
            "random,sitcov",
            "--workers",
            "2",
            "--json",
        ]
    )
    table = json.loads(capsys.readouterr().out)["generators"]
    assert list(table) == ["random", "sitcov"]
    for row in table.values():
        assert row["runs"] == 10 and row["complete"]
        assert {"NF", "F1", "F2", "F3", "triggered", "newly_failing", "cured", "ci95"} <= set(row)
        for fault in FAULTS:
            assert 0 <= row[fault] <= 10
            lo, hi = row["ci95"][fault]
            assert 0.0 <= lo <= row[fault] / 10 <= hi <= 1.0
        for fault in FAULTS[1:]:
            assert row["triggered"][fault] == row[fault] - row["NF"]
            # paired counts explain the paper's difference exactly (no errors here)
            assert row["newly_failing"][fault] - row["cured"][fault] == row["triggered"][fault]

    store = open_store(db)
    try:
        names = {c.name for c in store.campaigns()}
        assert len(names) == 2 * 2 * 4
        for gen in ("random", "sitcov"):
            for s in range(2):
                nf = _statuses(store, campaign_name(gen, s, "NF"))
                assert len(nf) == 5
                for label in FAULTS[1:]:
                    other = _statuses(store, campaign_name(gen, s, label))
                    # identical situations and run seeds, only the outcome may differ
                    assert [(i, sd) for i, sd, _ in other] == [(i, sd) for i, sd, _ in nf]
                info = store.campaign(campaign_name(gen, s, "F2"))
                assert dict(info.tags) == {
                    "experiment": "faults",
                    "generator": gen,
                    "seed": s,
                    "fault": "F2",
                }
                assert info.config["fault"] == "f2"
        # the stored table is the printed one
        assert fault_table(store)["generators"] == table
    finally:
        store.close()


def test_resume_completes_a_partial_experiment(tmp_path):
    settings = dict(generators=["sitcov"], runs=6, seeds=2, executor="serial")
    full = open_store(tmp_path / "full.db")
    expected = run_fault_experiment(full, **settings)

    part = open_store(tmp_path / "part.db")
    try:
        # an interrupted experiment: seed 0's NF done, F1 planned but never run, nothing else
        opts = {
            "hyperspace": "t-junction",
            "av": "reference",
            "av_params": None,
            "backend": "embedded",
            "backend_options": {},
            "executor": "serial",
            "workers": 1,
        }
        base = _base_config("sitcov", 0, 3, 0, opts)
        run_campaign(base, part)
        f1 = base.model_copy(
            update={
                "name": campaign_name("sitcov", 0, "F1"),
                "fault": "f1",
                "tags": {**base.tags, "fault": "F1"},
            }
        )
        _replay_into(part, part.campaign(base.name), f1)
        assert part.count_runs(f1.name, "pending") == 3
        assert not fault_table(part)["generators"]["sitcov"]["complete"]

        resumed = run_fault_experiment(part, **settings)
        assert resumed == expected
        for c in full.campaigns():
            assert _statuses(part, c.name) == _statuses(full, c.name)
    finally:
        part.close()
        full.close()


def test_fault_table_arithmetic_on_hand_made_statuses(tmp_path):
    """Counts computed by hand for a tiny stored experiment with an error run."""
    from sitcov.campaign import CampaignInfo, PlannedRun
    from sitcov.hyperspace import load_hyperspace
    from sitcov.sim import Outcome

    hs = load_hyperspace()
    situation = hs.situation_from_bins({e.name: e.bins[0].label for e in hs.elements}, None)
    plan = {
        "NF": ["fail", "pass", "pass", "fail", "error"],
        "F1": ["fail", "fail", "fail", "pass", "fail"],
        "F2": ["pass", "pass", "pass", "pass", "pass"],
        "F3": ["fail", "pass", "pass", "error", "pass"],
    }
    store = open_store(tmp_path / "t.db")
    try:
        for label, statuses in plan.items():
            name = f"faults/g/s0/{label}"
            store.create_campaign(
                CampaignInfo(
                    name=name,
                    config={},
                    hyperspace=hs.to_dict(),
                    sitcov_version="t",
                    created="t",
                    generator="g",
                    tags={"experiment": "faults", "generator": "g", "seed": 0, "fault": label},
                ),
                [PlannedRun(i, situation, i) for i in range(5)],
            )
            for i, status in enumerate(statuses):
                outcome = (
                    Outcome.errored("x")
                    if status == "error"
                    else Outcome(status=status, end_reason="goal")
                )
                store.record_result(name, i, outcome, 0.0)
        row = fault_table(store)["generators"]["g"]
    finally:
        store.close()
    assert (row["NF"], row["F1"], row["F2"], row["F3"], row["runs"]) == (2, 4, 0, 1, 5)
    assert row["triggered"] == {"F1": 2, "F2": -2, "F3": -1}
    # paired counts are over runs judged on both sides: index 4 (NF error) is not newly
    # failing, and F3's errored index 3 (NF fail) is not cured (issue 26)
    assert row["newly_failing"] == {"F1": 2, "F2": 0, "F3": 0}  # indices 1, 2
    assert row["cured"] == {"F1": 1, "F2": 2, "F3": 0}
    assert row["errors"] == {"NF": 1, "F1": 0, "F2": 0, "F3": 1}
    assert row["complete"]
    # Wilson 95% for 2/5, computed independently
    z = 1.959963984540054
    p, n = 0.4, 5
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * ((p * (1 - p) / n + z * z / (4 * n * n)) ** 0.5) / (1 + z * z / n)
    assert row["ci95"]["NF"] == pytest.approx([centre - half, centre + half], abs=1e-6)


def test_bad_arguments(tmp_path):
    store = open_store(tmp_path / "x.db")
    try:
        with pytest.raises(ConfigError, match="--runs"):
            run_fault_experiment(store, runs=3, seeds=5)
        with pytest.raises(ConfigError, match="--generators"):
            run_fault_experiment(store, generators=[])
        with pytest.raises(ConfigError, match="nope"):
            run_fault_experiment(store, generators=["random", "nope"], runs=2, seeds=1)
        assert store.campaigns() == []  # nothing stored before the parts were checked
    finally:
        store.close()


@pytest.mark.slow
def test_full_protocol_triggers_every_fault(tmp_path, capsys):
    """The paper's 100 runs x 5 seeds for both generators (800 runs), on 2 workers.

    Its wall time is printed, not asserted: speed targets live in benchmarks."""
    start = time.perf_counter()
    main(["experiment", "faults", "--db", str(tmp_path / "t2.db"), "--workers", "2", "--json"])
    elapsed = time.perf_counter() - start
    table = json.loads(capsys.readouterr().out)["generators"]
    with capsys.disabled():
        print(
            f"\nfault experiment, 800 runs: {elapsed:.1f} s wall; "
            + "; ".join(f"{g}: " + "/".join(str(r[f]) for f in FAULTS) for g, r in table.items())
        )
    for row in table.values():
        assert row["runs"] == 100
        for fault in FAULTS[1:]:
            assert row[fault] > row["NF"], (fault, row)


def test_replays_keep_a_learning_generator_s_sequence(tmp_path):
    """failure-guided learns from outcomes after each batch: the fault campaigns must still
    see exactly the no-fault situations (generating them again would not)."""
    from sitcov.campaign import CampaignConfig

    store = open_store(tmp_path / "fg.db")
    try:
        run_fault_experiment(
            store,
            generators=["failure-guided"],
            runs=24,
            seeds=1,
            executor="serial",
            batch_size=4,
        )
        nf = [r.situation.id for r in store.runs(campaign="faults/failure-guided/s0/NF")]
        f1 = [r.situation.id for r in store.runs(campaign="faults/failure-guided/s0/F1")]
        assert f1 == nf
        # the same config generated afresh with the fault diverges once outcomes differ
        # (from run 12 on, when failure-guided's coverage floor is met and it starts learning)
        fresh = CampaignConfig(
            name="fresh",
            generator="failure-guided",
            runs=24,
            seed=0,
            batch_size=4,
            fault="f1",
            executor="serial",
            workers=1,
        )
        run_campaign(fresh, store)
        regenerated = [r.situation.id for r in store.runs(campaign="fresh")]
        assert regenerated != nf
    finally:
        store.close()
