"""Inputs refused with one line before any work or write (issue 26): a hyperspace naming an
unknown route or an actor key typo, ``report --out`` naming a file, ``--workers`` beyond
its bound; and a campaign never starts more workers than it has runs left."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import yaml

from sitcov.campaign import CampaignConfig, open_store, run_campaign
from sitcov.campaign._config import max_workers
from sitcov.cli import main
from sitcov.hyperspace import load_hyperspace


def _one_line_error(capsys, args: list[str]) -> str:
    with pytest.raises(SystemExit) as info:
        main(args)
    out, err = capsys.readouterr()
    assert info.value.code == 2, (out, err)
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), err
    assert "Traceback" not in out + err
    return lines[0]


def _edited(tmp_path: Path, name: str, element: str, index: int, edit) -> Path:
    doc = load_hyperspace(name).to_dict()
    for axis in doc["axes"]:
        for el in axis["elements"]:
            if el["name"] == element:
                edit(el["bins"][index]["value"])
    path = tmp_path / "hs.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def test_an_unknown_route_fails_at_load_time(tmp_path, capsys) -> None:
    hs = _edited(tmp_path, "t-junction", "intsit", 2, lambda v: v.update(ov="B-X"))
    db = tmp_path / "c.db"
    line = _one_line_error(capsys, ["run", "--hyperspace", str(hs), "--db", str(db), "--runs", "3"])
    assert f"{hs}: intsit.bins[2] (IntSit-3).value.ov: expected one of" in line
    assert "on map t-junction, got 'B-X'" in line
    assert not db.exists()  # refused before the database was created


def test_an_actor_key_typo_fails_at_load_time(tmp_path, capsys) -> None:
    derived = Path(__file__).parents[2] / "sitcov/hyperspace/data/derived/t-junction.yaml"

    def typo(value: dict) -> None:
        value["behavior"] = "cruise"  # American spelling: the key is ``behaviour``

    doc = yaml.safe_load(derived.read_text())
    (actor2,) = [e for a in doc["axes"] for e in a["elements"] if e["name"] == "actor2"]
    typo(actor2["bins"][1]["value"])
    hs = tmp_path / "derived.yaml"
    hs.write_text(yaml.safe_dump(doc, sort_keys=False))
    line = _one_line_error(capsys, ["run", "--hyperspace", str(hs), "--db", str(tmp_path / "c.db")])
    label = actor2["bins"][1]["label"]
    assert f"{hs}: actor2.bins[1] ({label}).value.behavior: expected kind, route, behaviour" in line
    assert "mappingproxy" not in line  # the value is shown as written


def test_report_out_naming_a_file_is_one_line(tmp_path, capsys) -> None:
    db = tmp_path / "c.db"
    store = open_store(db)
    run_campaign(CampaignConfig(runs=4, executor="serial"), store)
    store.close()
    taken = tmp_path / "report.html"
    taken.write_text("mine")
    line = _one_line_error(capsys, ["report", "--db", str(db), "--out", str(taken)])
    assert "--out" in line and "names an existing file" in line
    assert taken.read_text() == "mine"
    line = _one_line_error(capsys, ["report", "--db", str(db), "--out", str(taken / "sub")])
    assert "lies under" in line


def test_workers_beyond_the_bound_are_refused(tmp_path, capsys) -> None:
    too_many = str(max_workers() + 1)
    assert max_workers() == 4 * (os.cpu_count() or 1)
    db = tmp_path / "c.db"
    line = _one_line_error(capsys, ["run", "--db", str(db), "--runs", "2", "--workers", too_many])
    assert f"workers: expected at most {max_workers()} (4 per CPU core" in line
    assert not db.exists()
    faults = ["experiment", "faults", "--db", str(db), "--runs", "2", "--seeds", "1"]
    assert "at most" in _one_line_error(capsys, [*faults, "--workers", too_many])
    race = ["experiment", "race", "--db", str(db), "--runs", "2", "--seeds", "1"]
    assert "at most" in _one_line_error(capsys, [*race, "--workers", too_many])


def test_a_campaign_starts_no_more_workers_than_runs_left(tmp_path, monkeypatch) -> None:
    import sitcov.campaign._runner as runner

    started: list[int] = []
    real = runner.make_executor

    def spy(config, backend=None):
        started.append(config.workers)
        return real(config, backend)

    monkeypatch.setattr(runner, "make_executor", spy)
    store = open_store(tmp_path / "c.db")
    config = CampaignConfig(runs=2, executor="serial", workers=6, batch_size=4)
    run_campaign(config, store)
    run_campaign(config.model_copy(update={"runs": 3}), store)  # extended by one run
    store.close()
    assert started == [2, 1]
