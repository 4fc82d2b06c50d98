"""A derived hyperspace's map reaches the backend and the stored config; summary, exports
and traces carry what the breakdown by road user needs; old databases still summarise."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import pytest
from cli_helpers import run_cli as sitcov
from test_failure_kinds import old_db  # noqa: F401 - the fixture

from sitcov.campaign import CampaignConfig, open_store
from sitcov.campaign._breakdown import slot_types
from sitcov.campaign._build import with_hyperspace_map
from sitcov.errors import ConfigError
from sitcov.hyperspace import load_hyperspace
from sitcov.sim import Outcome, Trace

DERIVED = Path(__file__).resolve().parents[2] / "sitcov/hyperspace/data/derived"
CROSSROADS = str(DERIVED / "crossroads.yaml")


def test_the_map_comes_from_the_hyperspace_metadata():
    hs = load_hyperspace(CROSSROADS)
    config = with_hyperspace_map(CampaignConfig(hyperspace=CROSSROADS), hs)
    assert config.backend_options["map"] == "crossroads"
    same = CampaignConfig(hyperspace=CROSSROADS, backend_options={"map": "crossroads"})
    assert with_hyperspace_map(same, hs) == same


def test_a_contradicting_map_option_names_both_maps():
    hs = load_hyperspace(CROSSROADS)
    config = CampaignConfig(hyperspace=CROSSROADS, backend_options={"map": "roundabout"})
    with pytest.raises(ConfigError) as err:
        with_hyperspace_map(config, hs)
    text = str(err.value)
    assert "'roundabout'" in text and "'crossroads'" in text and "\n" not in text


def test_hyperspaces_without_a_map_and_other_backends_are_left_alone():
    paper = CampaignConfig()
    assert with_hyperspace_map(paper, load_hyperspace("t-junction")) == paper
    other = CampaignConfig(hyperspace=CROSSROADS, backend="carla")
    assert with_hyperspace_map(other, load_hyperspace(CROSSROADS)) == other


def test_slot_types_follow_the_map_geometry():
    types = slot_types(load_hyperspace(CROSSROADS))
    assert types is not None
    hs = load_hyperspace(CROSSROADS)
    # the intsit bins were typed by the same geometry when the hyperspace was derived
    for b in hs.element("intsit").bins:
        v = b.value
        assert types[(v["ego"], v["kind"], v["ov"])] == v["type"], b.label
    assert slot_types(load_hyperspace("t-junction")) is None  # no actor slots


@pytest.fixture(scope="module")
def derived_db(tmp_path_factory) -> Path:
    """A small campaign on the derived crossroads hyperspace, made by the CLI."""
    from sitcov.cli import main

    path = tmp_path_factory.mktemp("derived") / "d.db"
    args = ["run", "--db", str(path), "--hyperspace", CROSSROADS, "--runs", "12", "--seed", "5"]
    try:
        main([*args, "--executor", "serial", "--workers", "1", "--name", "d", "--record"])
    except SystemExit as exc:
        assert not exc.code
    return path


def test_a_derived_campaign_runs_on_its_map_and_stores_it(derived_db):
    with open_store(derived_db) as store:
        info = store.campaign("d")
        assert info.config["backend_options"]["map"] == "crossroads"
        runs = list(store.iter_runs("d"))
    assert {r.status for r in runs} <= {"pass", "fail"}  # every run ran on its map
    assert any(r.outcome.metrics.get("actors") for r in runs)


def test_resume_needs_no_map_option_and_a_wrong_one_is_one_line(derived_db, capsys):
    base = ["run", "--db", str(derived_db), "--hyperspace", CROSSROADS, "--name", "d"]
    code, _, err = sitcov(capsys, *base, "--seed", "5", "--executor", "serial", "--record")
    assert code == 0, err
    config = derived_db.parent / "wrong.yaml"
    config.write_text("backend_options: {map: t-junction}\n")
    code, _, err = sitcov(capsys, *base, "--config", str(config), "--name", "other")
    assert code != 0
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "'t-junction'" in lines[0] and "'crossroads'" in lines[0]


def test_summary_and_exports_break_down_by_road_user(derived_db, capsys):
    code, out, err = sitcov(capsys, "summary", "--db", str(derived_db), "--json")
    assert code == 0, err
    summary = json.loads(out)
    kinds = summary["breakdowns"]["actor_kind"]
    assert set(kinds) == {"car", "cyclist", "pedestrian"}
    code, out, _ = sitcov(capsys, "export", "--db", str(derived_db), "--format", "csv")
    rows = list(csv.DictReader(io.StringIO(out)))
    for kind, row in kinds.items():  # the export lets anyone recount the summary
        mine = [r for r in rows if kind in r["actor_kinds"].split(";")]
        assert len(mine) == row["generated"]
        assert sum(r["status"] == "fail" for r in mine) == row["failures"]
    for ctype, row in summary["breakdowns"]["conflict_type"].items():
        mine = [r for r in rows if ctype in r["conflict_types"].split(";")]
        assert len(mine) == row["generated"], ctype
    hits = summary["breakdowns"]["hit_kind"]
    collided = sum(r["collision"] == "True" for r in rows)
    assert sum(r["collisions"] for r in hits.values()) == collided
    for kind, row in hits.items():  # the export's hit_kind recounts the collisions per kind
        assert sum(r["hit_kind"] == kind for r in rows) == row["collisions"], kind
    code, out, _ = sitcov(capsys, "export", "--db", str(derived_db), "--format", "json")
    assert json.loads(out)["campaigns"][0]["breakdowns"] == summary["breakdowns"]
    code, out, _ = sitcov(capsys, "summary", "--db", str(derived_db))
    assert "failure rate by actor kind" in out and "pedestrian" in out
    assert "collisions by the road user hit" in out


def test_sql_facts_give_the_kind_each_run_hit(derived_db):
    from sitcov.campaign._facts import iter_facts, iter_run_facts, run_hit

    with open_store(derived_db) as store:
        records = {r.index: run_hit(r) for r in store.iter_runs("d")}
        facts = sorted(f["hit"] or "" for f in iter_facts(store, "d"))
        slim = {f.index: f.hit for f in iter_run_facts(store, "d")}
    assert slim == records and facts == sorted(h or "" for h in records.values())
    assert set(records.values()) <= {None, "car", "cyclist", "pedestrian"}


def test_stored_traces_keep_every_actor(tmp_path):
    from sitcov.campaign import CampaignInfo, PlannedRun
    from sitcov.hyperspace import Situation

    rows = [(0.0, 1.0, 2.0, 0.0, 1.0)]
    trace = Trace(
        ego=rows, ov=rows, meta={}, actors={"ov": rows, "actor2": [(0.0, 5.0, 6.0, 1.0, 0.5)]}
    )
    with open_store(tmp_path / "t.db") as store:
        hs = load_hyperspace()
        info = CampaignInfo(name="c", config={}, hyperspace=hs.to_dict(), sitcov_version="t",
                            created="2026-01-01T00:00:00+00:00", generator="random")  # fmt: skip
        store.create_campaign(info, [PlannedRun(0, Situation(bins={}, values={}), 1)])
        store.record_result("c", 0, Outcome(status="pass", end_reason="goal", trace=trace), 0.1)
        got = store.get_run("c", 0, with_trace=True).outcome.trace
    assert [tuple(r) for r in got.actors["actor2"]] == [(0.0, 5.0, 6.0, 1.0, 0.5)]


def test_an_old_database_summarises_with_a_short_breakdown(old_db, capsys):  # noqa: F811
    code, out, err = sitcov(capsys, "summary", "--db", str(old_db), "--json")
    assert code == 0, err
    summary = json.loads(out)
    found = summary["breakdowns"]
    assert list(found["actor_kind"]) == ["car"] and list(found["conflict_type"]) == ["crossing"]
    assert found["actor_kind"]["car"]["failures"] == summary["failures"]
