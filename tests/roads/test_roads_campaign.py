"""A campaign on an imported OpenDRIVE junction, end to end: map import, hyperspace derive,
run, summary, report, explain (the paper's T-junction of CARLA's Town03, and the test T)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from sitcov.cli import main
from tests.roads._shared import DATA, town03


def _campaign(tmp_path: Path, map_file: Path, capsys, runs: int) -> dict:
    hs = tmp_path / "hs.yaml"
    main(["hyperspace", "derive", "--map", str(map_file), "--actors", "car,pedestrian,cyclist"])
    capsys.readouterr()
    main(
        [
            "hyperspace",
            "derive",
            "--map",
            str(map_file),
            "--actors",
            "car,pedestrian,cyclist",
            "--out",
            str(hs),
        ]
    )
    db = tmp_path / "c.db"
    main(
        [
            "run",
            "--hyperspace",
            str(hs),
            "--runs",
            str(runs),
            "--db",
            str(db),
            "--seed",
            "3",
            "--executor",
            "serial",
        ]
    )
    capsys.readouterr()
    main(["summary", "--db", str(db), "--json"])
    summary = json.loads(capsys.readouterr().out)
    # one failing run drawn (and animated) on the imported road, not the default four: the
    # same code path per picture, and the pictures were ~60 % of this test's time
    main(["report", "--db", str(db), "--out", str(tmp_path / "report"), "--pictures", "1"])
    assert (tmp_path / "report" / "index.html").is_file()
    capsys.readouterr()
    main(["explain", "--db", str(db), "--json"])
    json.loads(capsys.readouterr().out)
    return summary


@pytest.mark.slow
def test_a_campaign_runs_on_the_imported_town03_t_junction(tmp_path: Path, capsys) -> None:
    out = tmp_path / "town03-t.yaml"
    main(
        [
            "map",
            "import",
            str(town03()),
            "--near=-74.63,136.34",
            "--legs",
            "B,L,R",
            "--out",
            str(out),
        ]
    )
    summary = _campaign(tmp_path, out, capsys, 60)
    assert summary["runs"] == 60 and summary["errors"] == 0
    assert 0 < summary["failures"] < 60


@pytest.mark.slow
def test_a_campaign_runs_on_the_test_xodr_directly(tmp_path: Path, capsys) -> None:
    summary = _campaign(tmp_path, DATA / "t-junction.xodr", capsys, 40)
    assert summary["runs"] == 40 and summary["errors"] == 0
    kinds = summary["elements"]["intsit"]
    assert any("pedestrian" in label for label in kinds)
