"""The report's failure rates by road user and conflict type: the stored numbers, one row
each for the paper's hyperspace, every kind for a derived one; pictures of every actor."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from report_fakes import add_campaign

from sitcov.analysis import breakdowns
from sitcov.campaign import CampaignInfo, PlannedRun, open_store
from sitcov.campaign._breakdown import slot_types
from sitcov.hyperspace import load_hyperspace
from sitcov.report import build_report
from sitcov.report._traces import _complete
from sitcov.sim import Outcome, Trace

CROSSROADS = Path(__file__).resolve().parents[2] / "sitcov/hyperspace/data/derived/crossroads.yaml"


def _tables(html: str) -> dict[str, dict[str, list[str]]]:
    """``By <title>`` -> row name -> its cells, from the breakdown section."""
    section = html.split('id="breakdown"', 1)[1].split("</section>", 1)[0]
    out = {}
    for title, body in re.findall(r"<h3>By ([^<]+)</h3>\s*<table>(.*?)</table>", section, re.S):
        rows = re.findall(r"<tr><td>([^<]+)</td>(.*?)</tr>", body, re.S)
        out[title] = {
            name: re.findall(r'<td class="n">([^<]*)</td>', cells) for name, cells in rows
        }
    return out


def test_the_paper_hyperspace_gives_one_row_each(make_db, tmp_path):
    db = make_db("paper.db", lambda s: add_campaign(s, "p", 200, seed=3))
    html = build_report(db, tmp_path / "out", pictures=0).read_text()
    tables = _tables(html)
    assert list(tables) == ["actor kind", "conflict type", "the road user the ego hit"]
    assert list(tables["actor kind"]) == ["car"] and list(tables["conflict type"]) == ["crossing"]
    with open_store(db) as store:
        runs = list(store.runs())
    judged = [r for r in runs if r.status in ("pass", "fail")]
    fails = sum(r.status == "fail" for r in judged)
    assert tables["actor kind"]["car"][:2] == [str(len(runs)), f"{fails} / {len(judged)}"]
    # two-car runs store no kind hit: every collision was with the car OV
    hits = tables["the road user the ego hit"]
    assert hits == {"car": [str(len(runs)), f"{fails} / {len(judged)}", *hits["car"][2:4], "100%"]}


def _derived_store(store) -> None:
    """300 synthetic runs on the derived crossroads: pedestrians fail more often."""
    hs = load_hyperspace(str(CROSSROADS))
    rng = np.random.default_rng(11)
    plans = []
    while len(plans) < 300:
        bins = {e.name: str(rng.choice(e.labels)) for e in hs.elements}
        if hs.is_allowed(bins):
            plans.append(PlannedRun(len(plans), hs.situation_from_bins(bins, rng), len(plans)))
    info = CampaignInfo(name="d", config={"hyperspace": str(CROSSROADS)}, hyperspace=hs.to_dict(),
                        sitcov_version="t", created="2026-01-01T00:00:00+00:00",
                        generator="random")  # fmt: skip
    store.create_campaign(info, plans)
    for p in plans:
        ped = "pedestrian" in p.situation.bins["intsit"] + p.situation.bins["actor2"]
        fail = rng.random() < (0.7 if ped else 0.2)
        status = "fail" if fail else "pass"
        # a pedestrian in the scene is the one hit; other collisions store no kind (they hit
        # the intersection situation's road user)
        hit = {"collision_kind": "pedestrian"} if fail and ped else {}
        outcome = Outcome(status=status, end_reason="goal", collision=fail, metrics=hit)
        store.record_result("d", p.index, outcome, 0.01)


def test_a_derived_campaign_shows_every_kind_with_the_stored_numbers(make_db, tmp_path):
    db = make_db("derived.db", _derived_store)
    html = build_report(db, tmp_path / "out", pictures=0).read_text()
    tables = _tables(html)
    assert set(tables["actor kind"]) == {"car", "cyclist", "pedestrian"}
    with open_store(db) as store:
        runs = list(store.runs())
    hs = load_hyperspace(str(CROSSROADS))
    expected = breakdowns(hs, runs, slot_types(hs))
    for kind, row in expected["actor_kind"].items():
        assert tables["actor kind"][kind][1] == f"{row['failures']} / {row['judged']}"
    for ctype, row in expected["conflict_type"].items():
        if row["generated"]:
            assert tables["conflict type"][ctype.replace("_", " ")][0] == str(row["generated"])
    ped, car = expected["actor_kind"]["pedestrian"], expected["actor_kind"]["car"]
    assert ped["ci95"][0] > car["failure_rate"]  # the synthetic weak spot stands out
    hits = tables["the road user the ego hit"]
    assert set(hits) == set(expected["hit_kind"]) == {"car", "cyclist", "pedestrian"}
    for kind, row in expected["hit_kind"].items():
        assert hits[kind][1] == f"{row['collisions']} / {row['judged']}"
    # recount: a run hit the stored kind, else its intsit's kind
    fails = [r for r in runs if r.status == "fail"]
    for kind, row in expected["hit_kind"].items():
        n = sum(
            (r.outcome.metrics.get("collision_kind") or r.situation.values["intsit"]["kind"])
            == kind
            for r in fails
        )
        assert row["collisions"] == n, kind
    assert sum(r["share"] for r in expected["hit_kind"].values()) == pytest.approx(1.0)


def test_a_stored_trace_without_the_further_actors_is_simulated_again():
    rows = [(0.0, 0.0, 0.0, 0.0, 0.0)]
    meta = {"actors": {"ov": {"kind": "car"}, "actor2": {"kind": "pedestrian"}}}
    assert not _complete(Trace(ego=rows, ov=rows, meta=meta))
    assert _complete(Trace(ego=rows, ov=rows, meta=meta, actors={"ov": rows, "actor2": rows}))
    assert _complete(Trace(ego=rows, ov=rows, meta={}))  # the paper's two cars
    assert not _complete(None)
