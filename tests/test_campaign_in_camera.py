"""``benchmarks/campaign_in_camera.py``: the comparison it prints from a campaign's rows
(README and docs/pem.md quote it)."""

from __future__ import annotations

from typing import Any

from benchmark_modules import load_benchmark


def _rows() -> list[dict]:
    """40 runs from the left failing 30 on the PEM and 20 in camera mode (the 20 among the
    30), 40 from the right failing 10 in both, 20 ahead failing none."""
    rows = []
    for i in range(40):
        rows.append({"index": i, "intsit": "IntSit-5", "side": "left",
                     "pem_failed": int(i < 30), "camera_failed": int(i < 20)})  # fmt: skip
    for i in range(40, 80):
        fail = int(i < 50)
        rows.append({"index": i, "intsit": "IntSit-7", "side": "right",
                     "pem_failed": fail, "camera_failed": fail})  # fmt: skip
    for i in range(80, 100):
        rows.append({"index": i, "intsit": "IntSit-11", "side": "ahead",
                     "pem_failed": 0, "camera_failed": 0})  # fmt: skip
    return rows


def test_the_report_counts_rates_sides_and_agreement() -> None:
    lines = load_benchmark("campaign_in_camera").report(_rows())
    text = "\n".join(lines)
    rows = {x.split()[0] if not x.startswith("from") else " ".join(x.split()[:2]): x.split()
            for x in lines[1:8]}  # fmt: skip
    assert rows["all"][1:6] == ["100", "40.0%", "[30.9,", "49.8]", "30.0%"]
    assert rows["from left"][2:7] == ["40", "75.0%", "[59.8,", "85.8]", "50.0%"]
    assert rows["from right"][3] == rows["from right"][6] == "25.0%"
    assert [x.split()[0] for x in lines[5:8]] == ["IntSit-5", "IntSit-7", "IntSit-11"]
    assert "verdicts agree on 90/100 runs; PEM only fails 10, camera only 0" in text
    pem = next(x for x in lines if x.startswith("pem: "))
    camera = next(x for x in lines if x.startswith("camera: "))
    assert float(pem.rsplit(" ", 1)[1]) < 1e-4  # 30 of 40 against 10 of 40
    assert 0.01 < float(camera.rsplit(" ", 1)[1]) < 0.05  # 20 of 40 against 10 of 40


def test_across_seeds_pairs_the_two_streams_by_index() -> None:
    """camera@A vs camera@B, camera@A vs PEM@B and PEM@A vs PEM@B over the indexes both
    files hold (a run missing from one is left out)."""
    at_a = _rows()
    at_b = [dict(r, camera_failed=1 - r["camera_failed"] if r["index"] < 10 else
                 r["camera_failed"]) for r in _rows()[:-5]]  # fmt: skip
    lines = load_benchmark("campaign_in_camera").across_seeds(at_a, at_b)
    assert lines[0].split()[3:5] == ["85/95", "="]  # 10 camera verdicts flipped at B
    assert lines[1].split()[3] == "85/95"  # camera@A vs PEM@B: the 10 PEM-only fails
    assert lines[2].split()[3] == "95/95"


def _stored_campaign(tmp_path, runs: int, bench: Any) -> tuple[Any, list, Any]:
    """A default campaign of ``runs`` runs stored in ``tmp_path``, and a camera rows file
    for it in ``bench``'s fields (the loaded benchmark: loaded once per test, its worker
    function pickles by that module) with the camera failing the odd-index runs, 1.5 CPU-s
    each: (database, its runs, the rows file)."""
    import csv

    from sitcov.campaign import CampaignConfig, open_store, run_campaign

    db = tmp_path / "c.db"
    store = open_store(db)
    run_campaign(CampaignConfig(runs=runs, executor="serial", workers=1), store)
    stored = store.runs()
    store.close()
    known = tmp_path / "camera.csv"
    with known.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=bench.FIELDS)
        writer.writeheader()
        for r in stored:
            writer.writerow({"index": r.index, "intsit": "-", "side": "-", "pem_failed": 9,
                             "camera_failed": r.index % 2, "camera_status": "x",
                             "cpu_s": 1.5})  # fmt: skip
    return db, stored, known


def test_pem_draws_rerun_takes_the_camera_verdicts_from_a_rows_file(tmp_path) -> None:
    """With --pem-draws and --camera-rows only the PEM side runs: its verdicts are the
    majorities PerceptionDraws gives for the stored situations and seeds, the camera's are
    the file's."""
    from sitcov.av import make_stack
    from sitcov.campaign._draws import PerceptionDraws
    from sitcov.sim import Judge
    from sitcov.sim.embedded import EmbeddedBackend

    bench = load_benchmark("campaign_in_camera")
    db, runs, known = _stored_campaign(tmp_path, 6, bench)
    rows = bench.rerun(db, "default", tmp_path / "out.csv", 1, pem_draws=3, camera_rows=known)
    judge = Judge.from_spec("default")
    draws = PerceptionDraws(EmbeddedBackend(), 3, lambda o: judge(o).failed)
    stack = make_stack("reference")
    for run, row in zip(runs, rows, strict=True):
        expected = judge(draws.run(run.situation, stack, run.seed)).failed
        assert int(row["pem_failed"]) == int(expected)
        assert int(row["camera_failed"]) == run.index % 2 and float(row["cpu_s"]) == 1.5


def test_a_pem_file_reruns_the_pem_side_with_that_file(tmp_path) -> None:
    """--pem FILE: the PEM side runs (one draw, even without --pem-draws) with that car
    PEM file: a PEM that never reports the car fails every run that the same worlds fail
    with the file's sensor, more than the stored (shipped PEM) verdicts."""
    import yaml

    from sitcov.av import make_stack
    from sitcov.perception import PEMSensor
    from sitcov.perception._pem_params import load_pem_params
    from sitcov.sim import Judge
    from sitcov.sim.embedded import EmbeddedBackend

    bench = load_benchmark("campaign_in_camera")
    db, runs, known = _stored_campaign(tmp_path, 8, bench)
    blind = tmp_path / "blind.yaml"
    params = load_pem_params().to_dict() | {"bias": -40.0}  # no score reaches the floor
    blind.write_text(yaml.safe_dump({"params": params}))
    rows = bench.rerun(db, "default", tmp_path / "out.csv", 1, camera_rows=known, pem_file=blind)
    judge = Judge.from_spec("default")
    backend = EmbeddedBackend(sensor=PEMSensor(blind))
    stack = make_stack("reference")
    for run, row in zip(runs, rows, strict=True):
        assert int(row["pem_failed"]) == int(
            judge(backend.run(run.situation, stack, run.seed)).failed
        )
    stored = sum(r.status == "fail" for r in runs)
    assert sum(int(row["pem_failed"]) for row in rows) > stored  # the file, not the shipped PEM


def test_rates_by_situation_bins_cross_elements_and_cut_at_values() -> None:
    """--by: groups by an element's bin or by below / from a value on, crossed."""
    bench = load_benchmark("campaign_in_camera")
    rows = _rows()
    bins = {r["index"]: {"precipitation": str(20 * (r["index"] % 6)),
                         "intsit": r["intsit"]} for r in rows}  # fmt: skip
    assert bench.group_of(bins[3], "precipitation>=50") == "precipitation>=50"
    assert bench.group_of(bins[2], "precipitation>=50,intsit") == (
        "precipitation<50 intsit=IntSit-5"
    )
    lines = bench.report_by(rows, bins, "precipitation>=50")
    body = {line.split()[0]: line.split() for line in lines[1:]}
    wet = [r for r in rows if 20 * (r["index"] % 6) >= 50]
    assert body["precipitation>=50"][1] == str(len(wet))
    rate = 100 * sum(r["pem_failed"] for r in wet) / len(wet)
    assert body["precipitation>=50"][2] == f"{rate:.1f}%"
