"""The flakiness experiment on the fake backend, whose failure probability is known."""

from __future__ import annotations

import pytest
from campaign_helpers import fake_config

from sitcov.campaign import open_store
from sitcov.campaign._flaky import flakiness_lines, flakiness_table, run_flakiness_experiment
from sitcov.campaign._summary import summarize_store
from sitcov.errors import ConfigError


def _base(runs: int = 120):
    cfg = fake_config(name="fl/base", runs=runs, generator="sitcov-min", seed=5)
    return cfg.model_copy(update={"tags": {"experiment": "flakiness", "group": "fl", "repeat": 0}})


def test_flip_rates_match_the_fake_backends_failure_probabilities(tmp_path):
    store = open_store(tmp_path / "f.db")
    table = run_flakiness_experiment(store, _base(), repeats=4)
    # FakeBackend fails with p = 0.6 at friction <= 0.2 and 0.15 above: flip = 2 p (1 - p)
    low = [table["elements"]["friction"][b] for b in ("0.1", "0.2")]
    high = [table["elements"]["friction"][b] for b in ("0.6", "0.8", "1.0")]
    flip_low = sum(s["flip"] * s["situations"] for s in low) / sum(s["situations"] for s in low)
    flip_high = sum(s["flip"] * s["situations"] for s in high) / sum(s["situations"] for s in high)
    # 40 and 60 situations x 4 seeds: the standard error is about 0.04; 3.5 SE tolerance
    assert flip_low == pytest.approx(0.48, abs=0.14)
    assert flip_high == pytest.approx(0.255, abs=0.12)
    assert table["campaigns"] == ["fl/base", "fl/r1", "fl/r2", "fl/r3"]
    assert table["overall"]["runs"] == 480 and table["repeats"] == 4
    assert "flaky" in flakiness_lines(table)[0]


def test_repeats_replay_the_situations_with_new_seeds_and_keep_coverage(tmp_path):
    store = open_store(tmp_path / "f.db")
    run_flakiness_experiment(store, _base(30), repeats=3)
    base = {r.index: r for r in store.iter_runs("fl/base")}
    for name in ("fl/r1", "fl/r2"):
        for r in store.iter_runs(name):
            assert r.situation.to_dict() == base[r.index].situation.to_dict()
            assert r.seed != base[r.index].seed
    assert summarize_store(store, "fl/base")["runs"] == 30  # situations counted once
    # running again completes nothing new and gives the same table
    again = run_flakiness_experiment(store, _base(30), repeats=3)
    assert again == flakiness_table(store, "fl")
    assert store.count_runs("fl/r2") == 30


def test_bad_repeats_and_missing_group_are_one_line_errors(tmp_path):
    store = open_store(tmp_path / "f.db")
    with pytest.raises(ConfigError, match="--repeats"):
        run_flakiness_experiment(store, _base(10), repeats=1)
    with pytest.raises(ConfigError, match="no campaign 'nope/base'"):
        flakiness_table(store, "nope")


def test_cli_runs_needed_and_flakiness(tmp_path, capsys):
    import json

    from campaign_fakes import BACKEND, STACK
    from cli_helpers import run_cli

    code, out, _ = run_cli(capsys, "runs-needed", "--margin", "0.05")
    assert code == 0 and out.startswith("381 runs per bin")
    code, out, _ = run_cli(capsys, "runs-needed", "--below", "0.05")
    assert code == 0 and out.startswith("59 runs without a failure")
    code, _, err = run_cli(capsys, "runs-needed", "--margin", "0.05", "--rate", "2")
    assert code != 0 and "--rate" in err
    db = str(tmp_path / "f.db")
    args = ("experiment", "flakiness", "--db", db, "--situations", "12", "--repeats", "2",
            "--backend", BACKEND, "--av", STACK, "--executor", "serial", "--json")  # fmt: skip
    code, out, _ = run_cli(capsys, *args)
    table = json.loads(out)
    assert code == 0 and table["overall"]["situations"] == 12 and table["repeats"] == 2
