"""Failure kinds through campaigns: the judge as configuration, physics plumbing, the store
migration of old databases, and the kind breakdown of summary, exports and report."""

from __future__ import annotations

import csv
import io
import json
import sqlite3
from pathlib import Path

import pytest
from campaign_fakes import BACKEND, GENERATOR, STACK, fake_outcome
from campaign_helpers import fake_config
from cli_helpers import run_cli as sitcov
from judge_fakes import DEPARTING, departing_outcome

from sitcov._seeding import ask_rng, run_seed
from sitcov.campaign import load_config, open_store, run_campaign
from sitcov.campaign._build import build_backend
from sitcov.campaign._export import export
from sitcov.campaign._sqlite import SCHEMA_VERSION
from sitcov.campaign._summary import summarize_store, summary_table
from sitcov.errors import ConfigError
from sitcov.generation import make_generator
from sitcov.hyperspace import load_hyperspace
from sitcov.sim import FAILURE_KINDS, WORLD_MODEL_VERSION, Judge

# --- the judge is configuration; the facts are not -------------------------------------------


def _kinds(store, name):
    return [r.failure_kind for r in store.runs(name)]


def test_the_judge_decides_verdicts_from_identical_facts():
    store = open_store(None)
    for judge in ("default", "paper", "strict"):
        # a non-learning generator: a learning one is told the judged verdicts (as it
        # should be), so its situations would differ between judges after the first batch
        cfg = fake_config(name=judge, generator="random", backend=DEPARTING, judge=judge, runs=60)
        run_campaign(cfg, store)
    runs = {j: store.runs(j) for j in ("default", "paper", "strict")}
    # same situations and seeds, same facts (metrics) whatever the judge
    for a, b, c in zip(runs["default"], runs["paper"], runs["strict"], strict=True):
        assert a.seed == b.seed == c.seed and a.situation == b.situation
        assert a.outcome.metrics == b.outcome.metrics == c.outcome.metrics
        raw = departing_outcome(a.situation, a.seed)
        for run in (a, b, c):
            judge = Judge.from_spec(run.config["judge"])
            assert run.failure_kind == judge.kind(raw) and run.status == judge(raw).status
    kinds = {j: _kinds(store, j) for j in runs}
    assert set(kinds["paper"]) <= {"pass", "collision", "ego_stationary"}
    assert "road_departure" in kinds["default"] and "lane_departure" in kinds["strict"]
    fails = {j: store.count_runs(j, "fail") for j in runs}
    assert fails["paper"] < fails["default"] < fails["strict"]  # each judge counts more


def test_resuming_with_another_judge_is_refused():
    store = open_store(None)
    run_campaign(fake_config(runs=8), store)
    with pytest.raises(ConfigError, match=r"judge: 'default' -> 'paper'"):
        run_campaign(fake_config(runs=16, judge="paper"), store)


def test_physics_reaches_backends_that_take_it():
    cfg = fake_config(backend=DEPARTING, physics="physical")
    assert build_backend(cfg).physics == "physical"
    store = open_store(None)
    run_campaign(fake_config(backend=DEPARTING, physics="physical", runs=4), store)
    assert {r.outcome.metrics["physics"] for r in store.runs("default")} == {"physical"}
    # backend_options.physics is the same setting, stored in one place
    moved = load_config(overrides={"backend_options": {"physics": "physical"}})
    assert moved.physics == "physical" and "physics" not in moved.backend_options
    with pytest.raises(ConfigError, match="disagree"):
        load_config(overrides={"physics": "carla", "backend_options": {"physics": "physical"}})


def test_a_backend_without_physics_profiles_runs_carla_only():
    assert build_backend(fake_config()) is not None  # carla: nothing to pass
    with pytest.raises(ConfigError, match="physics: expected 'carla': backend .* no physics"):
        build_backend(fake_config(physics="physical"))


# --- summary, exports and report break failures down by kind --------------------------------


@pytest.fixture
def judged_db(tmp_path):
    path = tmp_path / "kinds.db"
    with open_store(path) as store:
        run_campaign(fake_config(name="k", backend=DEPARTING, judge="strict", runs=80), store)
    return path


def test_summary_breaks_failures_down_by_kind(judged_db):
    with open_store(judged_db) as store:
        summary = summarize_store(store)
        runs = store.runs("k")
    judged = sum(r.status in ("pass", "fail") for r in runs)
    by_kind = summary["failures_by_kind"]
    for kind in ("collision", "road_departure", "lane_departure"):
        n = sum(r.failure_kind == kind for r in runs)
        assert by_kind[kind]["failures"] == n > 0
        assert by_kind[kind]["failure_rate"] == pytest.approx(n / judged)
    assert sum(k["failures"] for k in by_kind.values()) == summary["failures"]
    assert summary["physics"] == "carla" and summary["judge"] == "strict"
    assert summary["judge_counts"] == list(FAILURE_KINDS)
    assert summary["world_model"] == WORLD_MODEL_VERSION and not summary["legacy_world_model"]
    # events: every fact, counted or not (here the strict judge counts all)
    assert summary["events_by_kind"]["lane_departure"] >= by_kind["lane_departure"]["failures"]
    for per_bin in summary["elements"].values():  # per bin: the kinds add up to the failures
        for stats in per_bin.values():
            assert sum(stats["failures_by_kind"].values()) == stats["failures"]
    text = io.StringIO()
    from rich.console import Console

    Console(file=text, width=120).print(summary_table(summary))
    shown = text.getvalue()
    assert "road departure" in shown and "lane departure" in shown
    assert "strict (collision + ego stationary + road departure + lane departure" in shown


def test_exports_carry_the_failure_kind(judged_db, tmp_path):
    with open_store(judged_db) as store:
        expected = {r.index: r.failure_kind for r in store.runs("k")}
        out = io.StringIO()
        export(store, "csv", out)
        rows = list(csv.DictReader(io.StringIO(out.getvalue())))
        assert {int(r["index"]): r["failure_kind"] for r in rows} == expected
        out = io.StringIO()
        export(store, "json", out)
        data = json.loads(out.getvalue())
        assert {r["index"]: r["failure_kind"] for r in data["runs"]} == expected
        assert data["campaigns"][0]["judge"] == "strict"
        assert data["campaigns"][0]["physics"] == "carla"
        # route progress facts: columns in CSV, statistics per campaign in JSON
        metrics = {r.index: r.outcome.metrics for r in store.runs("k") if r.outcome}
        for row in rows:
            want = metrics[int(row["index"])]
            assert float(row["route_completion"]) == want["route_completion"]
            assert row["ego_stationary"] == str(want["ego_stationary"])
        done = data["campaigns"][0]["route_completion"]
        assert done["runs"] == len(metrics) and 0.0 < done["mean"] < 1.0
        pq_path = tmp_path / "k.parquet"
        export(store, "parquet", str(pq_path))
    import pyarrow.parquet as pq

    table = pq.read_table(pq_path).to_pydict()
    assert dict(zip(table["index"], table["failure_kind"], strict=True)) == expected
    with sqlite3.connect(judged_db) as db:  # and the column, for SQL users
        stored = dict(db.execute("SELECT idx, failure_kind FROM runs WHERE campaign = 'k'"))
    assert stored == expected


def test_report_shows_judge_physics_and_kinds(judged_db, tmp_path):
    from sitcov.report import build_report

    html = build_report(judged_db, tmp_path / "rep", pictures=0).read_text()
    section = html.split("Failures by kind", 1)[1].split("</table>", 1)[0]
    for kind in ("collision", "road departure", "lane departure", "blocked", "ego stationary"):
        assert kind in section
    assert "strict" in html and "carla" in html
    assert "Route completion" in html and "goal" in html
    # strict counts every kind: only the other road users' collisions are left to say
    uncounted = html.split("Events the judge does not count", 1)[1].split("</table>", 1)[0]
    assert uncounted.count("<tr><td>") == 1 and "two other road users" in uncounted


def test_report_says_what_the_paper_judge_does_not_count(tmp_path):
    from sitcov.report import build_report

    path = tmp_path / "paper.db"
    with open_store(path) as store:
        run_campaign(fake_config(name="p", backend=DEPARTING, judge="paper", runs=60), store)
        summary = summarize_store(store)
    html = build_report(path, tmp_path / "rep", pictures=0).read_text()
    section = html.split("Events the judge does not count", 1)[1].split("</table>", 1)[0]
    for kind, n in summary["not_counted"].items():
        assert f'<td>{kind.replace("_", " ")}</td><td class="n">{n}</td>' in section
    assert "blocked" in section and "road departure" in section
    assert "two other road users" in section


# --- an old database ----------------------------------------------------------------------------

#: The store schema (version 2) as sitcov wrote it before failure kinds (kept literally).
V2_SQL = """
CREATE TABLE schema_version (version INTEGER NOT NULL);
INSERT INTO schema_version VALUES (2);
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
ALTER TABLE runs ADD COLUMN replay_of TEXT;
CREATE INDEX runs_by_situation ON runs (situation_id);
"""

#: A campaign config as stored before physics profiles and judges existed.
OLD_CONFIG = {
    "name": "old",
    "hyperspace": "t-junction",
    "generator": GENERATOR,
    "generator_options": {},
    "backend": BACKEND,
    "backend_options": {},
    "av": STACK,
    "fault": None,
    "av_params": None,
    "runs": 30,
    "seed": 3,
    "batch_size": 10,
    "executor": "serial",
    "workers": 1,
    "ray_address": None,
    "run_timeout": None,
    "record_traces": False,
    "replay_failures_first": False,
    "tags": {},
}


@pytest.fixture
def old_db(tmp_path) -> Path:
    """A version-2 file with one finished campaign (28 judged runs, 1 error, 1 pending)."""
    path = tmp_path / "old.db"
    hs = load_hyperspace()
    gen = make_generator("random", hs)
    with sqlite3.connect(path) as db:
        db.executescript(V2_SQL)
        db.execute(
            "INSERT INTO campaigns VALUES (?,?,?,?,?,?,?,?,?)",
            ("old", json.dumps(OLD_CONFIG), json.dumps(hs.to_dict()), "0.3.0",
             "2026-10-01T00:00:00+00:00", GENERATOR, "{}", 20, "{}"),
        )  # fmt: skip
        for i in range(30):
            sit, seed = gen.ask(ask_rng(3, i)), run_seed(3, i)
            row = [sit.id, json.dumps(dict(sit.bins)), json.dumps(sit.to_dict()["values"]), seed]
            if i == 29:
                status, outcome = "pending", None
            elif i == 28:
                status, outcome = "error", {"status": "error", "end_reason": "error"}
            else:
                outcome = fake_outcome(sit, seed).to_dict()
                status = outcome["status"]
            db.execute(
                "INSERT INTO runs (campaign, idx, situation_id, bins, vals, seed, status, "
                "end_reason, collision, outcome, wall_time) VALUES ('old',?,?,?,?,?,?,?,?,?,?)",
                (i, *row, status, (outcome or {}).get("end_reason"),
                 (outcome or {}).get("collision"), json.dumps(outcome) if outcome else None,
                 0.01 if outcome else None),
            )  # fmt: skip
    return path


def test_old_database_migrates_failed_runs_to_collisions(old_db):
    with sqlite3.connect(old_db) as db:
        old = dict(db.execute("SELECT idx, status FROM runs"))
    with open_store(old_db) as store:
        assert store.schema_version() == SCHEMA_VERSION == 5
        info = store.campaign("old")
        assert info.legacy and info.world_version is None
        kinds = {r.index: r.failure_kind for r in store.runs("old")}
    with sqlite3.connect(old_db) as db:
        column = dict(db.execute("SELECT idx, failure_kind FROM runs"))
    expected = {
        i: None if s == "pending" else ("collision" if s == "fail" else s) for i, s in old.items()
    }
    assert column == kinds == expected
    assert "collision" in expected.values() and "pass" in expected.values()


def test_old_campaign_summarises_exports_and_reports_as_legacy(old_db, tmp_path, capsys):
    code, out, err = sitcov(capsys, "summary", "--db", str(old_db), "--json")
    assert code == 0, err
    summary = json.loads(out)
    assert summary["runs"] == 29 and summary["errors"] == 1
    assert summary["failures_by_kind"]["collision"]["failures"] == summary["failures"] > 0
    assert summary["failures_by_kind"]["road_departure"]["failures"] == 0
    assert summary["physics"] == "legacy" and summary["world_model"] == "legacy"
    assert summary["judge"] == "paper" and summary["legacy_world_model"] is True
    # runs stored before route progress facts: counted apart, never as 0 completion
    assert summary["route_completion"]["runs"] == 0
    assert summary["route_completion"]["without"] == 28 and summary["not_counted"] == {}
    code, out, _ = sitcov(capsys, "summary", "--db", str(old_db))
    assert code == 0 and "legacy" in out
    code, out, _ = sitcov(capsys, "export", "--db", str(old_db), "--format", "csv")
    assert code == 0
    rows = list(csv.DictReader(io.StringIO(out)))
    assert {r["failure_kind"] for r in rows if r["status"] == "fail"} == {"collision"}
    code, _, err = sitcov(capsys, "report", "--db", str(old_db), "--out", str(tmp_path / "r"))
    assert code == 0, err
    html = (tmp_path / "r" / "index.html").read_text()
    assert "before physics profiles and failure kinds" in html


def test_old_campaign_cannot_be_resumed_or_extended(old_db, capsys):
    args = ["run", "--db", str(old_db), "--name", "old", "--generator", GENERATOR]
    args += ["--backend", BACKEND, "--av", STACK, "--executor", "serial", "--seed", "3"]
    for runs in ("30", "60"):  # resume (a pending run) and extend
        code, out, err = sitcov(capsys, *args, "--runs", runs, "--batch-size", "10")
        assert code == 2
        lines = err.strip().splitlines()
        assert len(lines) == 1, err
        assert "campaign 'old' was made with the legacy world model" in lines[0]
        assert "start a new campaign with another --name" in lines[0]
    with open_store(old_db) as store:  # nothing was run or changed
        assert store.count_runs("old", "pending") == 1
    code, _, err = sitcov(capsys, *args, "--name", "new", "--runs", "5")
    assert code == 0, err  # a new campaign in the same file is fine


# --- the flags --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("flag", "value", "message"),
    [
        ("--judge", "crash", "judge: expected one of default, paper, strict"),
        ("--judge", "collision,offroad", "judge: expected one of default, paper, strict"),
        ("--physics", "wet", "physics: expected input should be 'carla' or 'physical'"),
    ],
)
@pytest.mark.parametrize("command", [["run"], ["experiment", "faults"]])
def test_bad_judge_or_physics_flag_is_one_line_and_exit_2(
    tmp_path, capsys, command, flag, value, message
):
    db = tmp_path / "x.db"
    code, out, err = sitcov(capsys, *command, "--db", str(db), flag, value, "--runs", "8")
    assert code == 2
    assert err.strip().count("\n") == 0 and message in err and "Traceback" not in err
    assert not db.exists()  # refused before the database is created


def test_judge_flag_reaches_the_stored_config(tmp_path, capsys):
    db = tmp_path / "f.db"
    code, _, err = sitcov(
        capsys, "run", "--db", str(db), "--generator", GENERATOR, "--backend", DEPARTING,
        "--av", STACK, "--executor", "serial", "--runs", "20", "--judge", "paper",
        "--physics", "physical",
    )  # fmt: skip
    assert code == 0, err
    with open_store(db) as store:
        info = store.campaign("default")
        assert info.config["judge"] == "paper" and info.config["physics"] == "physical"
        assert info.world_version == WORLD_MODEL_VERSION
        assert {r.failure_kind for r in store.runs()} <= {"pass", "collision", "ego_stationary"}
