"""Schema 5: the collision location, the kind of road user hit and the run's largest DRAC
as columns; a version-4 file (as sitcov wrote it before) opens, is filled from what it
stored, and still summarises, exports and reports; a read-only one is read as it is."""

from __future__ import annotations

import csv
import io
import json
import math
import sqlite3
from contextlib import closing
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import run_cli as sitcov
from needs import need_module

from sitcov.av import make_stack
from sitcov.campaign import CampaignInfo, PlannedRun, open_store
from sitcov.campaign._sqlite import METRIC_COLUMNS, SCHEMA_VERSION
from sitcov.campaign._summary import summarize_store
from sitcov.generation import make_generator
from sitcov.hyperspace import load_hyperspace
from sitcov.sim import WORLD_MODEL_VERSION
from sitcov.sim.embedded import EmbeddedBackend

#: metrics keys that version-4 runs did not have
NEW_KEYS = ("collision_point", "collision_heading", "collision_kind", "max_drac")
N = 40


def _campaign(db: Path) -> None:
    """A campaign of ``N`` embedded runs (every third one traced) in a new file."""
    hs = load_hyperspace()
    gen, backend, stack = make_generator("random", hs), EmbeddedBackend(), make_stack("reference")
    plan = [PlannedRun(i, gen.ask(np.random.default_rng(i)), i) for i in range(N)]
    config = {"name": "c", "runs": N, "generator": "random", "backend": "embedded", "seed": 0}
    info = CampaignInfo(
        name="c",
        config=config,
        hyperspace=hs.to_dict(),
        sitcov_version="test",
        created="2026-01-01T00:00:00+00:00",
        generator="random",
        world_version=WORLD_MODEL_VERSION,
    )
    store = open_store(db)
    store.create_campaign(info, plan)
    for run in plan:
        outcome = backend.run(run.situation, stack, run.seed, record=run.index % 3 == 0)
        store.record_result("c", run.index, outcome, 0.01)
    store.close()


def _downgrade(db: Path) -> None:
    """Make ``db`` the version-4 file the sitcov before schema 5 wrote: no new columns,
    no new metrics in the outcomes (traces kept their collision point then already)."""
    with closing(sqlite3.connect(db)) as con, con:
        for column in METRIC_COLUMNS:
            con.execute(f"ALTER TABLE runs DROP COLUMN {column}")
        paths = ", ".join(f"'$.metrics.{k}'" for k in NEW_KEYS)
        con.execute(f"UPDATE runs SET outcome = json_remove(outcome, {paths})")
        con.execute("UPDATE schema_version SET version = 4")


@pytest.fixture(scope="module")
def new_db(tmp_path_factory) -> Path:
    db = tmp_path_factory.mktemp("v5") / "new.db"
    _campaign(db)
    return db


@pytest.fixture
def old_db(new_db: Path, tmp_path: Path) -> Path:
    db = tmp_path / "old.db"
    db.write_bytes(new_db.read_bytes())
    _downgrade(db)
    return db


def _columns(db: Path) -> dict[int, dict]:
    with closing(sqlite3.connect(db)) as con:
        con.row_factory = sqlite3.Row
        rows = con.execute(
            f"SELECT idx, collision, trace, outcome, {', '.join(METRIC_COLUMNS)} FROM runs"
        ).fetchall()
    return {r["idx"]: dict(r) for r in rows}


def test_a_new_file_stores_the_facts_in_columns_equal_to_the_outcome(new_db: Path) -> None:
    assert SCHEMA_VERSION == 5
    rows = _columns(new_db)
    collided = [r for r in rows.values() if r["collision"]]
    assert len(collided) >= 3 and len(collided) < N  # both kinds of run are there
    for r in rows.values():
        metrics = json.loads(r["outcome"])["metrics"]
        point = metrics["collision_point"]
        assert [r["collision_x"], r["collision_y"]] == (point or [None, None])
        assert r["collision_heading"] == metrics["collision_heading"]
        assert r["collision_kind"] == metrics["collision_kind"]
        assert r["max_drac"] == metrics["max_drac"]
        assert (point is not None) == bool(r["collision"])
        assert r["collision_kind"] in ((None,) if not r["collision"] else ("car",))
    assert all(r["max_drac"] is None or r["max_drac"] > 0 for r in rows.values())
    assert sum(r["max_drac"] is not None for r in rows.values()) > N // 2


def test_a_version_4_file_is_upgraded_and_filled_from_what_it_stored(old_db: Path) -> None:
    with open_store(old_db) as store:
        before = {r.index: r.outcome for r in store.runs("c")}
    with open_store(old_db) as store:
        assert store.schema_version() == 5
        after = {r.index: r.outcome for r in store.runs("c")}
    assert after == before  # the outcomes themselves are untouched
    assert all(k not in o.metrics for o in after.values() for k in NEW_KEYS)
    rows = _columns(old_db)
    for r in rows.values():
        assert r["max_drac"] is None and r["collision_heading"] is None  # never recorded
        if not r["collision"]:
            assert r["collision_kind"] is r["collision_x"] is None
            continue
        assert r["collision_kind"] == "car"  # the paper's two-car runs hit the car
        traced = r["trace"] is not None
        assert (r["collision_x"] is not None) == traced
        if traced:
            meta = json.loads(r["trace"])["meta"]
            assert [r["collision_x"], r["collision_y"]] == meta["collision_point"]
    assert any(r["collision"] and r["trace"] for r in rows.values())


def test_a_version_4_file_summarises_exports_and_reports(old_db: Path, tmp_path, capsys):
    code, out, err = sitcov(capsys, "summary", "--db", str(old_db), "--json")
    assert code == 0, err
    assert json.loads(out)["runs"] == N
    code, out, err = sitcov(capsys, "export", "--db", str(old_db), "--format", "csv")
    assert code == 0, err
    rows = list(csv.DictReader(io.StringIO(out)))
    assert len(rows) == N and {r["collision_x"] for r in rows} == {""}  # not recorded then
    code, _, err = sitcov(capsys, "report", "--db", str(old_db), "--out", str(tmp_path / "r"))
    assert code == 0, err
    html = (tmp_path / "r" / "index.html").read_text()
    assert "stored without a location" in html


def test_a_read_only_version_4_file_is_read_as_it_is(old_db: Path, tmp_path: Path) -> None:
    from test_reliability_store import read_only_copy

    with read_only_copy(old_db, tmp_path / "ro") as path:
        store = open_store(path)
        assert store.schema_version() == 4
        assert summarize_store(store, "c")["runs"] == N
        assert all(math.isfinite(r.outcome.sim_time) for r in store.runs("c"))
        store.close()


def test_exports_carry_the_collision_location_and_drac_typed(new_db: Path, tmp_path: Path):
    """CSV and Parquet: the contact point, heading, speed and DRAC of each run as floats
    (pandas reads them as float64), equal to the stored metrics; the actor table's DRAC."""
    pd = need_module("pandas", "test")
    need_module("pyarrow", "parquet")
    from sitcov.campaign._export import COLLISION_COLUMNS, export_parquet

    out, actors = tmp_path / "runs.parquet", tmp_path / "actors.parquet"
    with open_store(new_db) as store:
        export_parquet(store, str(out))
        export_parquet(store, str(actors), per_actor=True)
    frame = pd.read_parquet(out)
    assert all(str(frame[c].dtype) == "float64" for c in COLLISION_COLUMNS)
    with open_store(new_db) as store:
        metrics = {r.index: r.outcome.metrics for r in store.runs("c")}
    for _, row in frame.iterrows():
        m = metrics[int(row["index"])]
        point = m["collision_point"]
        if point is None:
            assert math.isnan(row["collision_x"]) and math.isnan(row["collision_heading"])
        else:
            assert (row["collision_x"], row["collision_y"]) == tuple(point)
            assert row["collision_heading"] == m["collision_heading"]
            assert row["ego_collision_speed"] == m["ego_collision_speed"]
        drac = m["max_drac"]
        assert math.isnan(row["max_drac"]) if drac is None else row["max_drac"] == drac
    table = pd.read_parquet(actors)
    assert str(table["max_drac"].dtype) == "float64" and table["max_drac"].notna().any()
