"""The agreement experiment: run seeds per pair, pairing, Wilson intervals, refusal, rows file."""

from __future__ import annotations

import csv
import json
from dataclasses import asdict
from pathlib import Path

import pytest

from sitcov._seeding import run_seed
from sitcov.analysis import wilson_interval
from sitcov.campaign import _agreement as ag
from sitcov.cli import main
from sitcov.errors import ConfigError
from sitcov.sim import WORLD_MODEL_VERSION

#: A fake run fails when its run seed mod 100 is below this: P(fail) = 0.4 for any side.
FAIL_BELOW = 40


def fake_run(job: ag.Job) -> dict:
    """A run whose verdict depends only on its run seed (the same rule for PEM and camera).

    So a pair whose two sides share a run seed agrees on every situation, and a pair whose
    sides have independent run seeds agrees with probability 0.4² + 0.6² = 0.52.
    """
    seed = ag.stream_seed(job.stream, job.seed, job.index)
    failed = seed % 100 < FAIL_BELOW
    return {
        **asdict(job),
        "situation_id": f"sit-{job.seed}-{job.index}",
        "run_seed": seed,
        "status": "fail" if failed else "pass",
        "failed": failed,
        "aeb_time": None if failed else 1.25,
        "cpu_s": 0.5,
        "wall_s": 0.75,
        "world_model": WORLD_MODEL_VERSION,
        "judge": ag.DEFAULT_JUDGE,
    }


def test_each_pair_compares_the_same_situation_under_the_stated_run_seeds() -> None:
    for seed in (2, 4, 7):
        for index in range(300):
            a, b = ag.stream_seed("A", seed, index), ag.stream_seed("B", seed, index)
            assert a == run_seed(seed, index)  # stream A is the campaign's run seed
            assert b == ag.second_run_seed(seed, index) and a != b
    # stream B never reproduces a stream-A seed of the same evaluation (a separate stream)
    stream_a = {ag.stream_seed("A", s, i) for s in (2, 4) for i in range(1000)}
    stream_b = {ag.stream_seed("B", s, i) for s in (2, 4) for i in range(1000)}
    assert len(stream_b) == 2000 and not stream_a & stream_b
    # the three like-for-like pairs are built the same way: side A on A, side B on B
    for name in ("pem-camera", "camera-camera", "pem-pem"):
        (_, sa), (_, sb) = ag.PAIRS[name]
        assert (sa, sb) == ("A", "B")
    (pa, sa), (pb, sb) = ag.PAIRS["pem-camera-shared-seed"]
    assert {pa, pb} == {"pem", "camera"} and sa == sb
    with pytest.raises(ConfigError, match="stream"):
        ag.stream_seed("C", 2, 0)


def test_plan_runs_every_needed_side_once_camera_first() -> None:
    jobs = ag.plan_jobs([2, 4], 5, list(ag.PAIRS))
    assert len(jobs) == len(set(jobs)) == 2 * 5 * 4  # camera A/B and PEM A/B
    kinds = [j.perception for j in jobs]
    assert kinds == sorted(kinds)  # "camera" < "pem": the slow runs are scheduled first
    pem_only = ag.plan_jobs([2], 3, ["pem-pem"])
    assert {(j.perception, j.stream) for j in pem_only} == {("pem", "A"), ("pem", "B")}
    shared = ag.plan_jobs([2], 3, ["pem-camera-shared-seed"])
    assert {(j.perception, j.stream) for j in shared} == {("camera", "A"), ("pem", "A")}


def test_agreement_follows_the_construction(tmp_path: Path) -> None:
    """Independent run seeds agree at 0.52, a shared run seed at 1.0 (with this fake).

    2 seeds × 1000 situations: the standard deviation of an agreement of 0.52 is 0.0112,
    so ±0.06 is 5.4 σ (false failure < 1e-7); pairing a run with itself, or two sides on
    the same run seed, would give 1.0 and fail for certain.
    """
    summary = ag.run_agreement(
        seeds=[2, 4], situations=1000, out=tmp_path / "rows.csv", run_job=fake_run
    )
    pairs = summary["pairs"]
    shared = pairs["pem-camera-shared-seed"]["pooled"]
    assert shared["n"] == 2000 and shared["agreement"] == 1.0
    for name in ("pem-camera", "camera-camera", "pem-pem"):
        row = pairs[name]["pooled"]
        assert row["n"] == 2000
        assert abs(row["agreement"] - 0.52) < 0.06, (name, row)
        assert abs(row["failure_rate_a"] - 0.4) < 0.06 and abs(row["failure_rate_b"] - 0.4) < 0.06
        assert row["agree"] + row["a_fails_b_passes"] + row["b_fails_a_passes"] == row["n"]
        assert row["failures_a"] - row["failures_b"] == (
            row["a_fails_b_passes"] - row["b_fails_a_passes"]
        )
        per_seed = pairs[name]["per_seed"]
        assert sum(s["agree"] for s in per_seed.values()) == row["agree"]
    # PEM vs camera across seeds agrees as often as the camera with itself here, by design
    cam, pem = pairs["camera-camera"]["pooled"], pairs["pem-camera"]["pooled"]
    assert abs(cam["agreement"] - pem["agreement"]) < 0.06


def test_bin_differences_count_each_situation_in_its_bins(tmp_path: Path) -> None:
    summary = ag.run_agreement(seeds=[3], situations=50, out=tmp_path / "r.csv", run_job=fake_run)
    shared = summary["pairs"]["pem-camera-shared-seed"]["bin_differences"]
    assert shared and all(d["max_difference"] == 0.0 for d in shared.values())
    # hand-made rows: one element, two bins; side A fails everything, side B nothing in bin "y"
    rows = []
    bins = {}
    for i in range(6):
        bins[(0, i)] = {"fog": "x" if i < 2 else "y"}
        for perception, stream in (("camera", "A"), ("camera", "B")):
            failed = stream == "A" or i < 2
            rows.append({"seed": 0, "index": i, "perception": perception, "stream": stream,
                         "status": "fail" if failed else "pass", "failed": failed})  # fmt: skip
    diffs = ag.bin_differences(rows, "camera-camera", bins)
    assert diffs == {"fog": {"max_difference": 1.0, "min_n": 2}}


def test_intervals_are_wilson_and_unjudged_runs_are_left_out(tmp_path: Path) -> None:
    def run(job: ag.Job) -> dict:
        row = fake_run(job)
        if job.index < 3 and job.perception == "camera" and job.stream == "A":
            row.update(status="error", failed=False)
        return row

    summary = ag.run_agreement(seeds=[5], situations=40, out=tmp_path / "r.csv", run_job=run)
    for name, result in summary["pairs"].items():
        row = result["pooled"]
        camera_a = ("camera", "A") in ag.PAIRS[name]
        assert row["not_judged"] == (3 if camera_a else 0)
        assert row["n"] == 40 - row["not_judged"]
        lo, hi = wilson_interval(row["agree"], row["n"])
        assert row["agreement_ci95"] == [round(lo, 4), round(hi, 4)]
        assert row["agreement_ci95"][0] <= row["agreement"] <= row["agreement_ci95"][1]
        lo, hi = wilson_interval(row["failures_b"], row["n"])
        assert row["failure_rate_b_ci95"] == [round(lo, 4), round(hi, 4)]


def test_calibration_seeds_from_the_pem_file(tmp_path: Path) -> None:
    assert ag.calibration_seeds() is not None  # the shipped file says which seeds
    params = "params:\n  bias: -0.5\n"
    listed = tmp_path / "listed.yaml"
    listed.write_text("meta:\n  calibration_seeds: [3, 1]\n  camera_runs: {seed: 9}\n" + params)
    assert ag.calibration_seeds(listed) == [1, 3]  # the explicit list wins
    old = tmp_path / "old.yaml"
    old.write_text("meta:\n  camera_runs: {seed: 1, runs: 600}\n" + params)
    assert ag.calibration_seeds(old) == [1]
    bare = tmp_path / "bare.yaml"
    bare.write_text(params)
    assert ag.calibration_seeds(bare) is None
    bad = tmp_path / "bad.yaml"
    bad.write_text("meta:\n  calibration_seeds: one\n" + params)
    with pytest.raises(ConfigError, match="meta.calibration_seeds"):
        ag.calibration_seeds(bad)


def test_overlapping_seeds_are_refused_unless_allowed() -> None:
    ag.check_seeds([2, 4], [1], allow=False, pem_file="pem.yaml")
    with pytest.raises(ConfigError, match=r"--seeds: \[1\] calibrated the PEM"):
        ag.check_seeds([1, 2], [1], allow=False, pem_file="pem.yaml")
    with pytest.raises(ConfigError, match="names no calibration seeds"):
        ag.check_seeds([2], None, allow=False, pem_file="pem.yaml")
    ag.check_seeds([1, 2], [1], allow=True, pem_file="pem.yaml")
    ag.check_seeds([2], None, allow=True, pem_file="pem.yaml")


def test_cli_refuses_calibration_seeds_in_one_line_before_any_run(tmp_path: Path, capsys) -> None:
    listed = tmp_path / "pem.yaml"
    listed.write_text("meta:\n  calibration_seeds: [7]\nparams:\n  bias: -0.5\n")
    out = tmp_path / "rows.csv"
    args = ["experiment", "agreement", "--pem", str(listed), "--out", str(out)]
    with pytest.raises(SystemExit) as exc:
        main([*args, "--seeds", "2,7", "--situations", "3", "--pairs", "pem-pem"])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "[7] calibrated the PEM" in err and "Traceback" not in err
    assert not out.exists()
    for bad in (["--seeds", "2,x"], ["--seeds", "2,2"], ["--pairs", "pem-cam"],
                ["--out", str(tmp_path / "rows.txt")], ["--judge", "crash"]):  # fmt: skip
        with pytest.raises(SystemExit) as exc:
            main([*args, "--situations", "2", *bad])
        assert exc.value.code == 2
        assert capsys.readouterr().err.strip().count("\n") == 0


@pytest.mark.parametrize("suffix", [".csv", ".jsonl"])
def test_rows_file_schema(tmp_path: Path, suffix: str) -> None:
    out = tmp_path / f"rows{suffix}"
    ag.run_agreement(seeds=[2, 4], situations=7, out=out, run_job=fake_run)
    if suffix == ".csv":
        with open(out, newline="") as fh:
            assert tuple(next(csv.reader(fh))) == ag.ROW_FIELDS
    else:
        first = json.loads(out.read_text().splitlines()[0])
        assert tuple(first) == ag.ROW_FIELDS
    rows = ag.read_rows(out)
    assert len(rows) == 2 * 7 * 4
    keys = {(r["seed"], r["index"], r["perception"], r["stream"]) for r in rows}
    assert len(keys) == len(rows)  # one row per run
    expected = ag.sort_rows(fake_run(j) for j in ag.plan_jobs([2, 4], 7, list(ag.PAIRS)))
    assert rows == [{k: r[k] for k in ag.ROW_FIELDS} for r in expected]  # typed round trip
    # the same situation on every side of a pair
    by_index = {}
    for r in rows:
        by_index.setdefault((r["seed"], r["index"]), set()).add(r["situation_id"])
    assert all(len(ids) == 1 for ids in by_index.values())


def test_pem_only_command_is_the_same_with_two_workers(tmp_path: Path, capsys) -> None:
    """Real PEM runs: the rows do not depend on the number of worker processes."""
    verdicts = {}
    for workers in (1, 2):
        out = tmp_path / f"w{workers}.jsonl"
        main(["experiment", "agreement", "--seeds", "2", "--situations", "8",
              "--pairs", "pem-pem", "--workers", str(workers), "--out", str(out)])  # fmt: skip
        printed = capsys.readouterr()
        assert "pem-pem" in printed.out and "Wilson 95%" in printed.out
        assert "planned: 0 camera runs + 16 PEM runs" in printed.err
        rows = ag.read_rows(out)
        verdicts[workers] = [(r["run_seed"], r["status"], r["aeb_time"]) for r in rows]
        summary = json.loads(out.with_name(f"w{workers}.summary.json").read_text())
        assert summary["pairs"]["pem-pem"]["pooled"]["n"] == 8
        assert summary["calibration_seeds"] == ag.calibration_seeds()
        assert summary["command"].startswith("sitcov experiment agreement --seeds 2 ")
    assert verdicts[1] == verdicts[2]


@pytest.mark.slow
def test_command_end_to_end_with_camera_mode(tmp_path: Path, ssd_model, capsys) -> None:
    """Every pair on 3 situations of seed 2, camera mode included, over 2 workers; the
    camera side at run seed A is the camera mode the calibration records."""
    from sitcov.calibration._camera_runs import camera_runs

    out = tmp_path / "rows.csv"
    main(["experiment", "agreement", "--seeds", "2", "--situations", "3", "--workers", "2",
          "--model", str(ssd_model), "--out", str(out)])  # fmt: skip
    assert "camera-camera" in capsys.readouterr().out
    rows = ag.read_rows(out)
    assert len(rows) == 3 * 4
    assert all(r["status"] in ("pass", "fail") for r in rows)
    assert all(r["run_seed"] == ag.stream_seed(r["stream"], 2, r["index"]) for r in rows)
    camera = [r for r in rows if r["perception"] == "camera"]
    assert all(r["cpu_s"] > 0.1 for r in camera)  # rendering + detection, not a PEM run
    summary = json.loads((tmp_path / "rows.summary.json").read_text())
    assert set(summary["pairs"]) == set(ag.PAIRS)
    assert summary["runs"] == {"camera": 6, "pem": 6, "camera_reused": 0}
    recorded = camera_runs(3, seed=2, model=ssd_model)
    camera_a = [r for r in camera if r["stream"] == "A"]
    assert [r.failed for r in recorded] == [r["failed"] for r in camera_a]
    assert [r.seed for r in recorded] == [r["run_seed"] for r in camera_a]


def test_camera_rows_of_an_earlier_file_are_reused_not_rerun(tmp_path: Path) -> None:
    """A recalibrated PEM re-runs only the PEM sides; every camera row comes from the file."""
    first = ag.run_agreement(seeds=[2, 4], situations=30, out=tmp_path / "a.csv", run_job=fake_run)
    old = ag.read_rows(tmp_path / "a.csv")
    # one camera row with a run seed that is not its stream's, one judged by an older world
    # model and one from a file that did not record it: each must be simulated again
    for row in old:
        key = (row["perception"], row["seed"], row["index"], row["stream"])
        if key == ("camera", 2, 3, "B"):
            row["run_seed"] += 1
        elif key == ("camera", 4, 7, "A"):
            row["world_model"] = WORLD_MODEL_VERSION - 1
        elif key == ("camera", 4, 8, "B"):
            row["world_model"] = None
    ag.write_rows(tmp_path / "old.csv", old)
    simulated: list[ag.Job] = []

    def counting(job: ag.Job) -> dict:
        simulated.append(job)
        return fake_run(job)

    second = ag.run_agreement(
        seeds=[2, 4], situations=30, out=tmp_path / "b.csv", run_job=counting,
        camera_rows=tmp_path / "old.csv",
    )  # fmt: skip
    camera = [j for j in simulated if j.perception == "camera"]
    assert camera == [ag.Job(2, 3, "camera", "B"), ag.Job(4, 7, "camera", "A"),
                      ag.Job(4, 8, "camera", "B")]  # fmt: skip
    assert sum(j.perception == "pem" for j in simulated) == 2 * 30 * 2
    assert second["runs"]["camera_reused"] == 2 * 30 * 2 - 3
    assert second["world_model"] == WORLD_MODEL_VERSION
    assert second["camera_rows_from"] == str(tmp_path / "old.csv")
    assert second["pairs"] == first["pairs"]
    assert ag.read_rows(tmp_path / "b.csv") == ag.read_rows(tmp_path / "a.csv")
    with pytest.raises(ConfigError, match="cannot read camera rows"):
        ag.run_agreement(
            seeds=[2], situations=2, out=tmp_path / "c.csv", run_job=fake_run,
            camera_rows=tmp_path / "missing.csv",
        )  # fmt: skip


def test_camera_rows_from_several_files_each_give_their_runs(tmp_path: Path) -> None:
    """``--camera-rows`` repeated: stream A's camera rows from one file, B's from another
    (a stale row in the first is taken from the second); nothing camera is simulated
    again, the rows are those of a run without reuse, and the command names both files."""
    ag.run_agreement(seeds=[3], situations=12, out=tmp_path / "all.csv", run_job=fake_run)
    rows = ag.read_rows(tmp_path / "all.csv")
    camera = [r for r in rows if r["perception"] == "camera"]
    first = [dict(r) for r in camera if r["stream"] == "A"]
    first[0]["world_model"] = WORLD_MODEL_VERSION - 1  # stale here, fresh in the second
    second = [r for r in camera if r["stream"] == "B" or r["index"] == first[0]["index"]]
    ag.write_rows(tmp_path / "one.csv", first)
    ag.write_rows(tmp_path / "two.csv", second)
    simulated: list[ag.Job] = []

    def counting(job: ag.Job) -> dict:
        simulated.append(job)
        return fake_run(job)

    files = [tmp_path / "one.csv", tmp_path / "two.csv"]
    summary = ag.run_agreement(
        seeds=[3], situations=12, out=tmp_path / "b.csv", run_job=counting, camera_rows=files
    )
    assert [j for j in simulated if j.perception == "camera"] == []
    assert summary["runs"]["camera_reused"] == 2 * 12
    assert summary["camera_rows_from"] == [str(f) for f in files]
    assert ag.read_rows(tmp_path / "b.csv") == rows
    line = ag.command_line(
        seeds=[3], situations=12, out="b.csv", pairs="all", workers=1, pem=None,
        allow=False, camera_rows=["one.csv", "two.csv"],
    )  # fmt: skip
    assert "--camera-rows one.csv --camera-rows two.csv" in line


def test_agreement_pool_of_the_published_rows_files(tmp_path: Path, capsys) -> None:
    """README's pooled figure is printed by a command: PEM vs camera over the 600 situations
    of seeds 2, 4 and 8, 9 (docs/data) agree on 512 = 85.3 % [82.3, 87.9]."""
    data = Path(__file__).parents[2] / "docs" / "data"
    files = [str(data / "agreement-seeds-8-9.csv"), str(data / "agreement-seeds-2-4.csv")]
    main(["experiment", "agreement-pool", *files, "--json"])
    pooled = json.loads(capsys.readouterr().out)
    row = pooled["pairs"]["pem-camera"]
    assert (row["n"], row["agree"], row["agreement"]) == (600, 512, 0.8533)
    assert row["agreement_ci95"] == [0.8228, 0.8794]
    main(["experiment", "agreement-pool", *files, "--pairs", "pem-camera"])
    assert "85.3% [82.3, 87.9]" in capsys.readouterr().out
    with pytest.raises(ConfigError, match="the same run twice"):
        ag.pool_rows_files([Path(files[0]), Path(files[0])], ["pem-camera"])
