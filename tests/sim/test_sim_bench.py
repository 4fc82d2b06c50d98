"""`sitcov bench` and the bench function."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from sitcov.cli import app
from sitcov.sim.embedded import bench


def test_bench_reports_consistent_figures() -> None:
    result = bench(6, seed=3)
    assert result["runs"] == 6
    assert sum(result["end_reasons"].values()) == 6
    assert result["ms_per_run"] * result["runs_per_s"] == __import__("pytest").approx(1000.0)
    assert 20 < result["mean_steps"] <= 1200
    assert 0 <= result["failures"] <= 6


def test_cli_bench_json() -> None:
    out = CliRunner().invoke(app, ["bench", "--runs", "3", "--seed", "1", "--json"])
    assert out.exit_code == 0, out.output
    data = json.loads(out.output)
    assert data["runs"] == 3 and data["runs_per_s"] > 0


def test_cli_bench_text() -> None:
    out = CliRunner().invoke(app, ["bench", "--runs", "2"])
    assert out.exit_code == 0, out.output
    assert "runs/s" in out.output and "mean sim steps" in out.output
