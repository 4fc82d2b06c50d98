"""`sitcov bench` and the bench function."""

from __future__ import annotations

import json
from collections import Counter

import pytest
from typer.testing import CliRunner

from sitcov.campaign import CampaignConfig, open_store, run_campaign
from sitcov.campaign._bench import bench
from sitcov.cli import app


def test_bench_runs_exactly_what_a_random_campaign_runs() -> None:
    """The bench times the runs a ``random`` campaign with the same seed stores: the same
    failures and end reasons, counted here from the campaign's rows, not from the bench."""
    result = bench(8, seed=3)
    store = open_store(None)
    run_campaign(CampaignConfig(generator="random", runs=8, seed=3, executor="serial"), store)
    outcomes = [r.outcome for r in store.runs("default")]
    assert result["runs"] == 8
    assert result["failures"] == sum(o.failed for o in outcomes)
    assert result["end_reasons"] == dict(Counter(o.end_reason for o in outcomes))
    steps = sum(o.metrics["steps"] for o in outcomes) / 8
    assert result["mean_steps"] == steps and 20 < steps <= 1200
    assert result["cpu_s"] > 0 and result["wall_s"] > 0


def test_cli_bench_json() -> None:
    out = CliRunner().invoke(app, ["bench", "--runs", "3", "--seed", "1", "--json"])
    assert out.exit_code == 0, out.output
    data = json.loads(out.output)
    assert data["runs"] == 3 and data["runs_per_s"] > 0


def test_cli_bench_text() -> None:
    out = CliRunner().invoke(app, ["bench", "--runs", "2"])
    assert out.exit_code == 0, out.output
    assert "runs/s" in out.output and "mean sim steps" in out.output


def test_rounds_time_the_same_runs_and_report_the_median_round() -> None:
    one = bench(4, seed=2)
    three = bench(4, seed=2, rounds=3)
    speeds = three["rounds_runs_per_s"]
    assert three["rounds"] == 3 and len(speeds) == 3
    assert three["runs_per_s"] == sorted(speeds)[1]
    assert three["runs_per_s"] == 4 / three["cpu_s"]
    for key in ("failures", "end_reasons", "mean_steps"):
        assert three[key] == one[key], key


def test_rounds_that_disagree_are_an_error(monkeypatch) -> None:
    """Every round runs the same seeds: other outcomes in a later round mean a run is not
    reproducible, which the bench must not average away."""

    from sitcov.campaign import _bench

    real = _bench._timed_pass
    calls = []

    def flaky(*args):
        result = real(*args)
        calls.append(1)
        if len(calls) == 2:
            failed, reason, steps = result["outcomes"][0]
            result["outcomes"][0] = (not failed, reason, steps)
        return result

    monkeypatch.setattr(_bench, "_timed_pass", flaky)
    with pytest.raises(RuntimeError, match="other outcomes"):
        _bench.bench(3, seed=1, rounds=2)


def test_cli_bench_rounds_text() -> None:
    out = CliRunner().invoke(app, ["bench", "--runs", "2", "--rounds", "2"])
    assert out.exit_code == 0, out.output
    assert "median of 2 rounds" in out.output
