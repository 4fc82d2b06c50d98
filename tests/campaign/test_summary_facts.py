"""``summarize_store`` on SQLite reads per-run facts straight from SQL; the result must be
what the run records give (the in-memory store's path) and what the outcomes say."""

from __future__ import annotations

import json

from campaign_helpers import fake_config
from judge_fakes import DEPARTING

from sitcov.campaign import open_store, run_campaign
from sitcov.campaign._facts import iter_facts, record_facts
from sitcov.campaign._summary import FINISHED, summarize_store
from sitcov.sim._judge import event_times

CAMPAIGNS = {
    "paper": {"backend": DEPARTING, "judge": "paper", "generator": "random"},
    "strict": {"backend": DEPARTING, "judge": "strict", "generator": "random"},
    "errors": {"backend_options": {"raise_rate": 0.2}},
}


def _fill(store) -> None:
    for name, changes in CAMPAIGNS.items():
        run_campaign(fake_config(name=name, runs=48, **changes), store)


def _key(facts: dict) -> str:
    return json.dumps(facts, sort_keys=True)


def test_sql_facts_equal_the_record_facts(tmp_path):
    with open_store(tmp_path / "c.db") as store:
        _fill(store)
        for name in (*CAMPAIGNS, None):
            sql = [_key(f) for f in iter_facts(store, name, FINISHED)]
            records = [_key(record_facts(r)) for r in store.iter_runs(name, FINISHED)]
            assert sorted(sql) == sorted(records)
            assert len(sql) == (48 if name else 144)
        events = [set(f["events"]) for f in iter_facts(store, "strict")]
        for kind in ("lane_departure", "ego_stationary", "blocked", "route_incomplete"):
            assert any(kind in e for e in events), kind
        assert any(f["actor_collisions"] for f in iter_facts(store, "strict"))
        outcomes = [set(event_times(r.outcome)) for r in store.iter_runs("strict")]
        assert sorted(map(sorted, events)) == sorted(map(sorted, outcomes))


def test_summary_of_sqlite_equals_the_in_memory_store(tmp_path):
    memory = open_store(None)
    _fill(memory)
    with open_store(tmp_path / "c.db") as sqlite:
        _fill(sqlite)
        for name in (*CAMPAIGNS, None):
            expected, got = summarize_store(memory, name), summarize_store(sqlite, name)
            # the campaigns' judges are listed in store order, which the stores may not share
            assert sorted(got.pop("judge")) == sorted(expected.pop("judge"))
            assert got == expected
    paper = summarize_store(memory, "paper")
    # the paper judge counts collisions only; departures still show as events
    assert paper["failures_by_kind"]["road_departure"]["failures"] == 0
    assert paper["events_by_kind"]["road_departure"] > 0
    assert summarize_store(memory, "errors")["errors"] > 0
    # what the paper's judge does not count is said: departures, no progress
    assert {"road_departure", "blocked", "route_incomplete"} <= set(paper["not_counted"])
    assert paper["not_counted"]["blocked"] == paper["events_by_kind"]["blocked"]
    strict = summarize_store(memory, "strict")
    assert strict["not_counted"] == {}
    done = strict["route_completion"]
    assert done["runs"] == strict["passes"] + strict["failures"] and done["without"] == 0
    assert sum(done["distribution"].values()) == done["runs"]
    assert 0.0 < done["goal_rate"] < 1.0 and 0.0 < done["mean"] < 1.0
    assert strict["actor_collisions"]["runs"] > 0


def test_total_wall_time_in_sql_equals_the_sum_over_runs(tmp_path):
    from sitcov.campaign._facts import total_wall_time

    memory = open_store(None)
    run_campaign(fake_config(name="c", runs=20), memory)
    with open_store(tmp_path / "c.db") as store:
        run_campaign(fake_config(name="c", runs=20), store)
        for s in (memory, store):
            expected = sum(r.wall_time or 0.0 for r in s.iter_runs("c"))
            assert total_wall_time(s, "c") == expected > 0
