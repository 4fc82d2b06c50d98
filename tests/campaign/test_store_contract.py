"""One contract suite for every Store implementation, plus SQLite-only schema tests."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest

from sitcov.campaign import CampaignInfo, PlannedRun, StoreError, open_store
from sitcov.campaign._sqlite import SCHEMA_VERSION
from sitcov.hyperspace import Situation
from sitcov.sim import Outcome, Trace

STORES = ["sqlite", "memory"]


@pytest.fixture(params=STORES)
def store(request, tmp_path):
    s = open_store(tmp_path / "c.db" if request.param == "sqlite" else None)
    yield s
    s.close()


def situation(i: int) -> Situation:
    return Situation(
        bins={"friction": f"b{i % 3}", "intsit": "IntSit-1"},
        values={"friction": 0.1 * (i % 3 + 1), "intsit": {"ego": "L-B", "ov": "R-B"}},
    )


def info(name: str = "c1", **kw) -> CampaignInfo:
    base = dict(
        name=name,
        config={"name": name, "runs": 10, "generator": "random"},
        hyperspace={"name": "h", "axes": []},
        sitcov_version="0.1.0",
        created="2026-01-01T00:00:00+00:00",
        generator="random",
        generator_state={"counts": [1, 2, 3]},
        tags={"experiment": "faults", "fault": "f1", "seed": 3},
    )
    base.update(kw)
    return CampaignInfo(**base)


def plans(start: int, n: int) -> list[PlannedRun]:
    return [PlannedRun(i, situation(i), 1000 + i) for i in range(start, start + n)]


def outcome(i: int) -> Outcome:
    failed = i % 2 == 1
    return Outcome(
        status="fail" if failed else "pass",
        end_reason="collision" if failed else "goal",
        sim_time=1.5 + i,
        collision=failed,
        min_distance=0.1 * i,
        min_ttc=None,
        metrics={"k": [1, 2], "x": 0.1 + 0.2},
    )


def test_campaign_roundtrip(store):
    store.create_campaign(info())
    got = store.campaign("c1")
    assert got.config == {"name": "c1", "runs": 10, "generator": "random"}
    assert got.generator_state == {"counts": [1, 2, 3]}
    assert got.tags == {"experiment": "faults", "fault": "f1", "seed": 3}
    assert got.hyperspace == {"name": "h", "axes": []}
    assert [c.name for c in store.campaigns()] == ["c1"]
    assert store.find_campaign("nope") is None


def test_unknown_and_duplicate_campaign_errors_name_location(store):
    store.create_campaign(info())
    with pytest.raises(StoreError, match="no campaign 'zz'.*c1"):
        store.campaign("zz")
    with pytest.raises(StoreError, match="already exists"):
        store.create_campaign(info())
    assert store.location in str(pytest.raises(StoreError, store.campaign, "zz").value)


def test_plan_batch_sets_state_and_pending_rows_atomically(store):
    store.create_campaign(info(), plans(0, 3))
    assert store.campaign("c1").batch_start == 0
    store.plan_batch("c1", {"counts": [9]}, plans(3, 4))
    got = store.campaign("c1")
    assert got.generator_state == {"counts": [9]}
    assert got.batch_start == 3
    assert store.count_runs("c1") == 7
    assert store.count_runs("c1", "pending") == 7
    # a duplicate index is refused and leaves state and rows untouched
    with pytest.raises((StoreError, sqlite3.IntegrityError)):
        store.plan_batch("c1", {"counts": [10]}, [*plans(7, 1), *plans(6, 1)])
    assert store.campaign("c1").generator_state == {"counts": [9]}
    assert store.count_runs("c1") == 7


def test_results_filters_and_order(store):
    store.create_campaign(info("b"), plans(0, 4))
    store.create_campaign(info("a", created="2026-01-02T00:00:00+00:00"), plans(0, 2))
    for i in (3, 0, 2):  # out of order, as workers deliver them
        store.record_result("b", i, outcome(i), wall_time=0.25)
    runs = store.runs()
    assert [(r.campaign, r.index) for r in runs] == [("a", 0), ("a", 1)] + [
        ("b", i) for i in range(4)
    ]
    b = store.runs("b")
    assert [r.status for r in b] == ["pass", "pending", "pass", "fail"]
    assert b[3].outcome == outcome(3)
    assert b[3].outcome.metrics == {"k": [1, 2], "x": 0.1 + 0.2}
    assert b[3].wall_time == 0.25 and b[1].wall_time is None and b[1].outcome is None
    assert b[0].situation == situation(0) and b[0].seed == 1000
    assert b[0].config["generator"] == "random"
    assert [r.index for r in store.runs("b", status="fail")] == [3]
    assert [r.index for r in store.iter_runs("b", ["pass", "fail"], start=2)] == [2, 3]
    assert store.count_runs(status="pending") == 3
    assert store.status_counts("b") == {
        "pending": 1,
        "pass": 2,
        "fail": 1,
        "error": 0,
        "timeout": 0,
    }
    with pytest.raises(StoreError, match="unknown run status"):
        store.count_runs("b", "weird")


def test_get_run_and_trace(store):
    store.create_campaign(info(), plans(0, 2))
    trace = Trace(ego=[(0.0, 1.0, 2.0, 0.5, 3.0)], ov=[(0.0, 5.0, 6.0, 0.0, 1.0)], meta={"m": 1})
    o = Outcome(status="fail", end_reason="collision", collision=True, trace=trace)
    store.record_result("c1", 1, o, 0.5)
    run = store.get_run("c1", 1)
    assert run.outcome.trace is not None
    assert [list(p) for p in run.outcome.trace.ego] == [[0.0, 1.0, 2.0, 0.5, 3.0]]
    assert run.outcome.trace.meta == {"m": 1}
    assert store.get_run("c1", 1, with_trace=False).outcome.trace is None
    assert store.runs("c1")[1].outcome.trace is None  # listing never loads traces
    with pytest.raises(StoreError, match="has no run 5"):
        store.get_run("c1", 5)
    with pytest.raises(StoreError):
        store.record_result("c1", 9, o, 0.1)


def test_update_config_and_replay_marker(store):
    store.create_campaign(info(), [PlannedRun(0, situation(0), 5, replay_of="old:7")])
    store.update_config("c1", {"name": "c1", "runs": 99})
    assert store.campaign("c1").config["runs"] == 99
    assert store.runs("c1")[0].replay_of == "old:7"
    assert store.runs("c1")[0].config["runs"] == 99


# -- SQLite only -------------------------------------------------------------------------------

#: The version-1 schema exactly as sitcov 0.1.0 first wrote it (kept literally: upgrade test).
V1_SQL = """
CREATE TABLE schema_version (version INTEGER NOT NULL);
INSERT INTO schema_version VALUES (1);
CREATE TABLE campaigns (name TEXT PRIMARY KEY, config TEXT NOT NULL, hyperspace TEXT NOT NULL,
  sitcov_version TEXT NOT NULL, created TEXT NOT NULL, generator TEXT NOT NULL,
  generator_state TEXT, batch_start INTEGER NOT NULL DEFAULT 0, tags TEXT NOT NULL DEFAULT '{}');
CREATE TABLE runs (campaign TEXT NOT NULL REFERENCES campaigns(name), idx INTEGER NOT NULL,
  situation_id TEXT NOT NULL, bins TEXT NOT NULL, vals TEXT NOT NULL, seed INTEGER NOT NULL,
  status TEXT NOT NULL, end_reason TEXT, sim_time REAL, collision INTEGER, collision_time REAL,
  collision_speed REAL, min_distance REAL, min_ttc REAL, pet REAL, aeb_fired INTEGER,
  aeb_time REAL, message TEXT, outcome TEXT, wall_time REAL, trace TEXT,
  PRIMARY KEY (campaign, idx));
CREATE INDEX runs_by_status ON runs (campaign, status);
INSERT INTO campaigns VALUES ('old', '{"runs": 1}', '{"name": "h"}', '0.0.9',
  '2025-01-01T00:00:00+00:00', 'random', '{"n": 1}', 0, '{}');
INSERT INTO runs (campaign, idx, situation_id, bins, vals, seed, status, end_reason, outcome,
  wall_time) VALUES ('old', 0, 'x', '{"friction": "0.1"}', '{"friction": 0.1}', 42, 'fail',
  'collision', '{"status": "fail", "end_reason": "collision", "collision": true}', 1.0);
"""


def test_v1_file_is_upgraded_and_readable(tmp_path: Path):
    path = tmp_path / "v1.db"
    with sqlite3.connect(path) as db:
        db.executescript(V1_SQL)
    with open_store(path) as store:
        assert store.schema_version() == SCHEMA_VERSION
        run = store.get_run("old", 0)
        assert run.status == "fail" and run.seed == 42 and run.outcome.collision
        assert run.replay_of is None
        assert run.situation.bins == {"friction": "0.1"}
        assert store.campaign("old").generator_state == {"n": 1}
    with sqlite3.connect(path) as db:
        cols = {r[1] for r in db.execute("PRAGMA table_info(runs)")}
    assert "replay_of" in cols


def test_newer_schema_is_refused_with_a_clear_error(tmp_path: Path):
    path = tmp_path / "new.db"
    open_store(path).close()
    with sqlite3.connect(path) as db:
        db.execute("UPDATE schema_version SET version = ?", (SCHEMA_VERSION + 5,))
    with pytest.raises(StoreError, match=rf"new\.db: database schema version {SCHEMA_VERSION + 5}"):
        open_store(path)


def test_not_a_database_names_the_file(tmp_path: Path):
    bad = tmp_path / "notes.txt"
    bad.write_text("hello, I am not SQLite " * 100)
    with pytest.raises(StoreError, match="notes.txt: not a sitcov database"):
        open_store(bad)
    other = tmp_path / "other.db"
    with sqlite3.connect(other) as db:
        db.execute("CREATE TABLE t (x)")
    with pytest.raises(StoreError, match="other.db: not a sitcov database"):
        open_store(other)
    with pytest.raises(StoreError, match="nodir/x.db: directory .* does not exist"):
        open_store(tmp_path / "nodir" / "x.db")


def test_wal_and_persistence(tmp_path: Path):
    path = tmp_path / "p.db"
    with open_store(path) as s:
        s.create_campaign(info(), plans(0, 2))
        s.record_result("c1", 0, outcome(0), 0.1)
        mode = s._db.execute("PRAGMA journal_mode").fetchone()[0]
        sync = s._db.execute("PRAGMA synchronous").fetchone()[0]
    assert mode == "wal" and sync == 1  # NORMAL
    with open_store(path) as s:
        assert [r.status for r in s.runs("c1")] == ["pass", "pending"]


def test_key_order_of_states_and_bins_is_kept(store):
    """Generators may rely on dict order in their state; situations keep hyperspace order."""
    s = Situation(bins={"z": "1", "a": "2"}, values={"z": 1.0, "a": 2.0})
    store.create_campaign(
        info(generator_state={"zeta": {"b": 1, "a": 2}, "alpha": 0}), [PlannedRun(0, s, 1)]
    )
    state = store.campaign("c1").generator_state
    assert list(state) == ["zeta", "alpha"] and list(state["zeta"]) == ["b", "a"]
    assert list(store.get_run("c1", 0).bins) == ["z", "a"]
