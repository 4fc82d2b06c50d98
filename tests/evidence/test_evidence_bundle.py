"""`sitcov evidence`: the folder, its OpenLABEL files, and a manifest that changes when and
only when an input changes."""

from __future__ import annotations

import json
import shutil
from functools import partial
from importlib import resources
from pathlib import Path

import pytest

from sitcov.campaign import CampaignConfig, open_store, run_campaign
from sitcov.cli import main
from sitcov.errors import ConfigError
from sitcov.evidence import build_evidence

ODD = """name: moderate-weather
approach: permissive
attributes:
  environment.weather.rainfall: {max: 7.6}
  scenery.drivable_area.surface_condition.friction: {in: [wet, dry]}
  dynamic_elements.traffic.agent_type: {in: [car, pedestrian, bus]}
"""


def _campaign(path: Path, runs: int, **config) -> Path:
    store = open_store(path)
    try:
        run_campaign(CampaignConfig(runs=runs, seed=5, executor="serial", **config), store)
    finally:
        store.close()
    return path


@pytest.fixture(scope="module", autouse=True)
def _one_failure_picture():
    """The evidence reports of this module draw one failing run, not the report's default
    four: each picture is a re-simulation, a drawing and an animation (~2 CPU-s), and
    nothing here is about their number; one still puts a picture and its GIF into every
    report and into the manifest's hashed artefacts. (``build_evidence`` looks
    ``sitcov.report.build_report`` up when it builds, so the patch reaches it.)"""
    import sitcov.report

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(sitcov.report, "build_report", partial(sitcov.report.build_report, pictures=1))
        yield


@pytest.fixture(scope="module")
def db(tmp_path_factory) -> Path:
    return _campaign(tmp_path_factory.mktemp("ev") / "c.db", 80)


@pytest.fixture(scope="module")
def folder(db: Path, tmp_path_factory) -> tuple[Path, dict, Path]:
    odd = tmp_path_factory.mktemp("odd") / "odd.yaml"
    odd.write_text(ODD)
    out = tmp_path_factory.mktemp("out") / "evidence"
    summary = build_evidence(db, out, odd=odd, criterion="rate<0.05@0.95")
    return out, summary, odd


def test_the_folder_holds_every_artefact(folder):
    out, summary, _ = folder
    for name in (
        "records.jsonl",
        "odd_coverage.json",
        "residual_risk.json",
        "triggering_conditions.json",
        "manifest.json",
        "report/index.html",
    ):
        assert (out / name).is_file(), name
    records = [json.loads(line) for line in (out / "records.jsonl").read_text().splitlines()]
    assert len(records) == summary["runs"] == 80
    assert len({r["id"] for r in records}) == 80
    assert len(list((out / "openlabel").glob("TC-*.json"))) == 80
    inside = sum(r["odd"]["inside"] for r in records)
    assert inside == summary["in_odd"]["runs"] + sum(
        r["actual_result"]["status"] == "error" and r["odd"]["inside"] for r in records
    )
    # records outside the ODD say why, inside ones do not
    assert all(bool(r["odd"]["outside_because"]) != r["odd"]["inside"] for r in records)
    # the unused ODD value "bus" is listed as never exercised
    assert "dynamic_elements.traffic.agent_type = bus" in summary["never_exercised_in_odd"]


def test_openlabel_files_validate_against_asam_schema(folder):
    from needs import need_module

    need_module("openlabel_checker", "test")
    from openlabel_checker.schema_check import check_json_schema

    out, _, _ = folder
    for path in sorted((out / "openlabel").glob("*.json"))[:40]:
        result = check_json_schema(json.loads(path.read_text()))
        assert not result.issues, (path.name, result.issues[:2])


def test_risk_verdict_matches_the_records(folder):
    out, summary, _ = folder
    records = [json.loads(line) for line in (out / "records.jsonl").read_text().splitlines()]
    judged = [r for r in records if r["odd"]["inside"] and r["actual_result"]["status"] != "error"]
    failed = [r for r in judged if r["actual_result"]["status"] in ("fail", "timeout")]
    verdict = summary["verdict"]
    assert (verdict["judged"], verdict["failures"]) == (len(judged), len(failed))


def _manifest(out: Path) -> dict:
    return json.loads((out / "manifest.json").read_text())


def test_manifest_is_stable_and_follows_each_input(db, folder, tmp_path):
    """Two builds with the report (every artefact hashed, the report's included) give the
    same manifest; then each changed input moves only its own hash. Those three builds
    leave the report out (``report=False``): the inputs do not depend on it and the two
    artefacts compared there are not part of it, and the report's pictures are most of a
    build's time (~8 CPU-s each)."""
    out, _, odd = folder
    again = tmp_path / "again"  # the report names its folder: build in one place
    build_evidence(db, again, odd=odd, criterion="rate<0.05@0.95")
    first = _manifest(again)
    assert first["inputs"] == _manifest(out)["inputs"]
    build_evidence(db, again, odd=odd, criterion="rate<0.05@0.95")
    assert _manifest(again) == first  # same inputs, same hashes (artefacts included)

    # another criterion: only that input (and the files that show it) changes
    build_evidence(db, again, odd=odd, criterion="rate<0.01@0.95", report=False)
    changed = _manifest(again)
    moved = {k for k in first["inputs"] if first["inputs"][k] != changed["inputs"][k]}
    assert moved == {"criterion"}
    assert changed["artefacts"]["records.jsonl"] == first["artefacts"]["records.jsonl"]
    assert changed["artefacts"]["residual_risk.json"] != first["artefacts"]["residual_risk.json"]

    # another ODD file content: only the ODD input moves
    other = tmp_path / "odd2.yaml"
    other.write_text(ODD.replace("7.6", "2.5"))
    build_evidence(db, again, odd=other, criterion="rate<0.05@0.95", report=False)
    moved = {k for k, v in _manifest(again)["inputs"].items() if first["inputs"][k] != v}
    assert moved == {"odd"}

    # more runs in the database: the runs input moves, the configuration does not
    bigger = tmp_path / "bigger.db"
    shutil.copy(db, bigger)
    _campaign(bigger, 81)
    build_evidence(bigger, again, odd=odd, criterion="rate<0.05@0.95", report=False)
    moved = {k for k, v in _manifest(again)["inputs"].items() if first["inputs"][k] != v}
    assert moved == {"runs"}


def test_manifest_follows_the_stack(tmp_path):
    a = _campaign(tmp_path / "a.db", 6)
    b = _campaign(tmp_path / "b.db", 6, fault="f2")
    build_evidence(a, tmp_path / "ea", report=False)
    build_evidence(b, tmp_path / "eb", report=False)
    ma, mb = _manifest(tmp_path / "ea"), _manifest(tmp_path / "eb")
    assert ma["inputs"]["stack"]["sha256"] != mb["inputs"]["stack"]["sha256"]
    assert ma["inputs"]["hyperspace"] == mb["inputs"]["hyperspace"]


def test_errors_are_one_line(db, tmp_path, capsys):
    bad = tmp_path / "odd.yaml"
    bad.write_text("name: x\nattributes: {a: {min: 1, max: 0}}\n")
    with pytest.raises(SystemExit) as exit_:
        main(["evidence", "--db", str(db), "--out", str(tmp_path / "o"), "--odd", str(bad)])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert str(bad) in err and "attributes.a" in err and "Traceback" not in err
    with pytest.raises(ConfigError, match="--criterion"):
        build_evidence(db, tmp_path / "o", criterion="rate<5")
    (tmp_path / "file").write_text("x")
    with pytest.raises(ConfigError, match="--out"):
        build_evidence(db, tmp_path / "file")


@pytest.mark.slow
def test_a_derived_pedestrian_campaign_gives_evidence(tmp_path, capsys):
    derived = resources.files("sitcov.hyperspace").joinpath("data/derived/t-junction.yaml")
    db = _campaign(tmp_path / "ped.db", 150, hyperspace=str(derived))
    main(
        ["evidence", "--db", str(db), "--out", str(tmp_path / "ev"), "--criterion", "rate<0.1@0.9"]
    )
    text = capsys.readouterr().out
    assert "verdict (whole ODD)" in text
    coverage = json.loads((tmp_path / "ev" / "odd_coverage.json").read_text())
    users = coverage["attributes"]["dynamic_elements.traffic.agent_type"]
    assert {"car", "pedestrian", "cyclist"} <= set(users)
    assert coverage["attributes"]["scenery.junction.type"].keys() == {"t_junction"}
    tags = json.loads(next((tmp_path / "ev" / "openlabel").glob("*.json")).read_text())
    types = {t["type"] for t in tags["openlabel"]["tags"].values()}
    assert "IntersectionTJunction" in types and "WeatherRain" in types
