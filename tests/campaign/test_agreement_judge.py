"""The agreement experiment's judge: what fails a run on both sides (``--judge``)."""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

import pytest

from sitcov.campaign import _agreement as ag
from sitcov.errors import ConfigError
from sitcov.sim import WORLD_MODEL_VERSION, Judge


def judged_run(judge: str):
    """A fake ``run_job`` whose rows say they were judged by ``judge``."""

    def run(job: ag.Job) -> dict:
        seed = ag.stream_seed(job.stream, job.seed, job.index)
        failed = seed % 100 < 40
        return {
            **asdict(job), "situation_id": f"sit-{job.seed}-{job.index}", "run_seed": seed,
            "status": "fail" if failed else "pass", "failed": failed, "aeb_time": None,
            "cpu_s": 0.5, "wall_s": 0.5, "world_model": WORLD_MODEL_VERSION, "judge": judge,
        }  # fmt: skip

    return run


def test_judge_text_is_the_canonical_setting() -> None:
    assert ag.judge_text(None) == ag.DEFAULT_JUDGE == "paper"
    assert ag.judge_text("default") == "default"
    assert ag.judge_text(["collision", "ego_stationary"]) == "paper"  # a named judge's kinds
    assert ag.judge_text("road_departure,collision") == "collision,road_departure"
    with pytest.raises(ConfigError, match="judge"):
        ag.judge_text("crash")


def test_rows_and_summary_name_the_judge_and_camera_rows_are_reused_only_from_it(
    tmp_path: Path,
) -> None:
    """Rows written before the judge was recorded read as ``paper``; a camera row is
    reused only by an experiment with its judge (another judge's verdict of the same run
    may differ), and the summary and its command name the judge."""
    first = tmp_path / "a.csv"
    ag.run_agreement(seeds=[3], situations=6, out=first, run_job=judged_run("paper"),
                     pairs=["camera-camera"])  # fmt: skip
    assert {r["judge"] for r in ag.read_rows(first)} == {"paper"}
    calls: list[ag.Job] = []

    def counting(job: ag.Job) -> dict:
        calls.append(job)
        return judged_run("default")(job)

    summary = ag.run_agreement(seeds=[3], situations=6, out=tmp_path / "b.csv",
                               run_job=counting, pairs=["pem-camera"], camera_rows=first,
                               judge="default")  # fmt: skip
    assert summary["judge"] == "default"
    assert {j.perception for j in calls} == {"pem", "camera"}  # no paper row reused
    assert {r["judge"] for r in ag.read_rows(tmp_path / "b.csv")} == {"default"}
    calls.clear()
    ag.run_agreement(seeds=[3], situations=6, out=tmp_path / "c.csv", run_job=counting,
                     pairs=["pem-camera"], camera_rows=first)  # fmt: skip
    assert {j.perception for j in calls} == {"pem"}  # the paper camera rows reused
    line = ag.command_line(seeds=[3], situations=6, out="b.csv", pairs="pem-camera",
                           workers=1, pem=None, allow=False, judge="default")  # fmt: skip
    assert line.endswith("--judge default")
    assert "--judge" not in ag.command_line(seeds=[3], situations=6, out="c.csv",
                                            pairs="pem-camera", workers=1, pem=None,
                                            allow=False)  # fmt: skip


def test_rows_of_two_judges_are_not_pooled(tmp_path: Path) -> None:
    ag.run_agreement(seeds=[3], situations=4, out=tmp_path / "a.csv", run_job=judged_run("paper"),
                     pairs=["pem-pem"])  # fmt: skip
    ag.run_agreement(seeds=[5], situations=4, out=tmp_path / "b.csv",
                     run_job=judged_run("default"), pairs=["pem-pem"],
                     judge="default")  # fmt: skip
    assert ag.pool_rows_files([tmp_path / "a.csv"], ["pem-pem"])["judge"] == "paper"
    with pytest.raises(ConfigError, match="one judge"):
        ag.pool_rows_files([tmp_path / "a.csv", tmp_path / "b.csv"], ["pem-pem"])


def test_a_side_runs_verdict_is_its_judges() -> None:
    """Real PEM runs of seed 8's first 30 situations: each row's verdict is the judge's
    verdict of the very run, and the campaigns' default judge (road departures, blocked
    and unfinished routes count) differs from the backend's own status on some of them
    (24 of seed 8's first 100 with the reference stack)."""
    from sitcov._seeding import ask_rng

    rows = {}
    for name in ("paper", "default"):
        runner = ag.SideRunner(ag.SideSettings(judge=name))
        backend, stack = runner._side("pem")
        judge = Judge.from_spec(name)
        for index in range(30):
            job = ag.Job(8, index, "pem", "A", ag.DEFAULT_STACK)
            row = runner(job)
            situation = runner.generator.ask(ask_rng(8, index))
            outcome = backend.run(situation, stack, ag.stream_seed("A", 8, index))
            assert row["judge"] == name and row["failed"] == judge(outcome).failed
            assert row["status"] == judge(outcome).status
            rows[name, index] = row["failed"]
    differ = sum(rows["paper", i] != rows["default", i] for i in range(30))
    assert differ >= 3, differ
