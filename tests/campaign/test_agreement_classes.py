"""``sitcov experiment agreement --kind``: one kind's situations, its PEM's seeds held out."""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

import pytest

from sitcov.campaign import _agreement as ag
from sitcov.errors import ConfigError


def fake_run(job: ag.Job) -> dict:
    """A run whose verdict depends only on its run seed."""
    seed = ag.stream_seed(job.stream, job.seed, job.index)
    failed = seed % 100 < 40
    return {**asdict(job), "situation_id": f"s-{job.seed}-{job.index}", "run_seed": seed,
            "status": "fail" if failed else "pass", "failed": failed, "aeb_time": None,
            "cpu_s": 0.5, "wall_s": 0.5}  # fmt: skip


@pytest.mark.parametrize("kind", ["pedestrian", "cyclist"])
def test_kind_restricts_the_situations(tmp_path: Path, kind: str) -> None:
    summary = ag.run_agreement(
        seeds=[2], situations=30, out=tmp_path / "r.csv", pairs=["pem-camera"], kind=kind,
        allow_calibration_seeds=True, run_job=fake_run,
    )  # fmt: skip
    assert summary["kind"] == kind
    bins = ag.situation_bins([2], 30, kind)
    assert all(kind in b["intsit"] and b["actor2"] == "none" for b in bins.values())
    assert "--kind " + kind in ag.command_line(
        seeds=[2], situations=30, out="r.csv", pairs="all", workers=1, pem=None, allow=True,
        kind=kind,
    )  # fmt: skip


def test_the_class_pems_calibration_seeds_are_refused(tmp_path: Path) -> None:
    classes = tmp_path / "c.yaml"
    classes.write_text("meta: {calibration_seeds: [7]}\nclasses: {}\n")
    with pytest.raises(ConfigError, match=r"\[7\]"):
        ag.run_agreement(
            seeds=[7], situations=2, out=tmp_path / "r.csv", kind="pedestrian",
            pem_classes=str(classes), run_job=fake_run,
        )  # fmt: skip
