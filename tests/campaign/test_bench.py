"""`sitcov bench` and the bench function."""

from __future__ import annotations

import json
from collections import Counter

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
