"""The campaign commands end to end (on the fakes): run, summary, export, replay."""

from __future__ import annotations

import csv
import io
import json
import sqlite3
import xml.etree.ElementTree as ET

import pytest
from campaign_fakes import BACKEND, GENERATOR, STACK
from cli_helpers import run_cli as sitcov
from needs import need_module

FAKE = ["--generator", GENERATOR, "--backend", BACKEND, "--av", STACK, "--executor", "serial"]


@pytest.fixture
def db(tmp_path, capsys):
    path = tmp_path / "c.db"
    code, out, err = sitcov(capsys, "run", "--db", str(path), *FAKE, "--runs", "30", "--seed", "3")
    assert code == 0, err
    return path, out, err


def test_run_prints_summary_and_replay_lines(db):
    path, out, err = db
    assert "runs executed" in out and "failure rate" in out and "pairwise coverage" in out
    assert f"sitcov replay --db {path} default:" in out
    assert "no effect in this backend: cloudiness" in err  # the fake ignores the weather


def test_summary_json_is_the_design_object(db, capsys):
    path, _, _ = db
    code, out, _ = sitcov(capsys, "summary", "--db", str(path), "--json")
    assert code == 0
    summary = json.loads(out)
    with sqlite3.connect(path) as con:
        fails = con.execute("SELECT count(*) FROM runs WHERE status='fail'").fetchone()[0]
    assert summary["runs"] == 30 and summary["failures"] == fails and summary["errors"] == 0
    friction = summary["elements"]["friction"]
    assert sum(b["generated"] for b in friction.values()) == 30
    assert set(summary["coverage"]) >= {"bins_covered", "bins_total", "pairwise"}
    code, out, _ = sitcov(capsys, "summary", "--db", str(path))
    assert code == 0 and "worst bins" in out


def test_resume_with_another_config_is_one_clear_error(db, capsys):
    path, _, _ = db
    code, out, err = sitcov(capsys, "run", "--db", str(path), *FAKE, "--runs", "30", "--seed", "4")
    assert code == 2
    assert "different config (seed: 3 -> 4)" in err and "Traceback" not in err + out


def test_bad_config_file_names_file_and_field(tmp_path, capsys):
    cfg = tmp_path / "camp.yaml"
    cfg.write_text("runs: -3\n")
    code, _, err = sitcov(capsys, "run", "--db", str(tmp_path / "x.db"), "--config", str(cfg))
    assert code == 2 and "camp.yaml: runs: expected" in err


def test_exports(db, capsys, tmp_path):
    path, _, _ = db
    code, out, _ = sitcov(capsys, "export", "--db", str(path), "--format", "csv")
    rows = list(csv.DictReader(io.StringIO(out)))
    assert code == 0 and len(rows) == 30
    assert [int(r["index"]) for r in rows] == list(range(30))
    assert {"status", "seed", "min_distance", "bin.friction", "value.intsit"} <= set(rows[0])
    fails = sum(r["status"] == "fail" for r in rows)

    code, out, _ = sitcov(capsys, "export", "--db", str(path), "--format", "junit")
    suite = ET.fromstring(out).find("testsuite")
    assert suite.get("name") == "default" and suite.get("tests") == "30"
    assert suite.get("failures") == str(fails)
    cases = suite.findall("testcase")
    assert len(cases) == 30 and sum(c.find("failure") is not None for c in cases) == fails
    props = {p.get("name"): p.get("value") for p in cases[0].iter("property")}
    assert cases[0].get("name") == props["situation_id"] and "friction=" in props["bins"]

    code, out, _ = sitcov(capsys, "export", "--db", str(path), "--format", "json")
    data = json.loads(out)
    assert len(data["runs"]) == 30 and data["campaigns"][0]["name"] == "default"
    assert data["runs"][5]["situation"]["bins"] == {
        k: rows[5][f"bin.{k}"] for k in data["runs"][5]["situation"]["bins"]
    }

    pq = need_module("pyarrow.parquet", "parquet")
    out_file = tmp_path / "runs.parquet"
    code, _, _ = sitcov(
        capsys, "export", "--db", str(path), "--format", "parquet", "--out", str(out_file)
    )
    table = pq.read_table(out_file)
    assert code == 0 and table.num_rows == 30
    assert table.column("status").to_pylist() == [r["status"] for r in rows]

    code, _, err = sitcov(capsys, "export", "--db", str(path), "--format", "xls")
    assert code == 2 and "--format" in err and "junit" in err


def test_replay_reproduces_and_detects_a_tampered_outcome(db, capsys):
    path, _, _ = db
    code, out, _ = sitcov(capsys, "replay", "--db", str(path), "default:4")
    assert code == 0 and "reproduced" in out
    code, out, _ = sitcov(capsys, "replay", "--db", str(path), "4")  # one campaign: INDEX is enough
    assert code == 0 and "reproduced" in out
    with sqlite3.connect(path) as con:
        (raw,) = con.execute("SELECT outcome FROM runs WHERE idx = 4").fetchone()
        data = json.loads(raw)
        data["sim_time"] = data["sim_time"] + 1.0
        con.execute("UPDATE runs SET outcome = ? WHERE idx = 4", (json.dumps(data),))
    code, out, _ = sitcov(capsys, "replay", "--db", str(path), "default:4")
    assert code == 1 and "DID NOT REPRODUCE" in out and "sim_time" in out


def test_replay_errors(db, capsys, tmp_path):
    path, _, _ = db
    code, _, err = sitcov(capsys, "replay", "--db", str(path), "default:999")
    assert code == 2 and "has no run 999" in err
    code, _, err = sitcov(capsys, "replay", "--db", str(path), "nope:1")
    assert code == 2 and "no campaign 'nope'" in err
    code, _, err = sitcov(capsys, "summary", "--db", str(tmp_path / "missing.db"))
    assert code == 2 and "missing.db: no such campaign database" in err
