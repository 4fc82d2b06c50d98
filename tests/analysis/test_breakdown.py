"""Failure rates by actor kind and conflict type: the numpy tally against a per-run brute
force, hand-counted cases, the paper hyperspace's one-row answer, old hyperspaces."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sitcov.analysis import breakdowns, summarize, wilson_interval
from sitcov.analysis._breakdown import run_roles
from sitcov.hyperspace import Hyperspace, load_hyperspace

DERIVED = Path(__file__).resolve().parents[2] / "sitcov/hyperspace/data/derived"
STATUSES = ("pass", "fail", "error", "timeout", "pending")


def _space(intsit: list[dict], actor2: list[dict] | None = None) -> Hyperspace:
    """A small hyperspace: an intsit element and optionally an actor2 slot."""
    elements = [{"name": "intsit", "bins": intsit}]
    if actor2 is not None:
        elements.append({"name": "actor2", "bins": actor2})
    return Hyperspace.from_dict({"name": "t", "axes": [{"name": "a", "elements": elements}]})


SMALL = _space(
    [
        {"label": "c", "value": {"ego": "L-B", "ov": "R-B", "kind": "car", "type": "merging"}},
        {"label": "p", "value": {"ego": "L-B", "ov": "XBL", "kind": "pedestrian"}},
    ],
    [
        {"label": "none", "value": "none"},
        {"label": "bike", "value": {"kind": "cyclist", "route": "L-B"}},
        {"label": "ped", "value": {"kind": "pedestrian", "route": "XLL", "conflict": "x"}},
    ],
)


def _run(intsit: str, actor2: str, status: str) -> dict:
    return {"bins": {"intsit": intsit, "actor2": actor2}, "status": status}


def test_hand_counted_runs_overlap_by_kind_and_type():
    runs = [
        _run("c", "none", "fail"),
        _run("c", "bike", "pass"),
        _run("c", "ped", "fail"),
        _run("p", "bike", "fail"),
        _run("p", "none", "error"),
        _run("p", "ped", "pending"),  # not run: left out
    ]
    types = {("L-B", "cyclist", "L-B"): "cyclist_following"}
    out = breakdowns(SMALL, runs, types)
    kinds = {k: (r["generated"], r["failures"], r["judged"]) for k, r in out["actor_kind"].items()}
    assert kinds == {"car": (3, 2, 3), "cyclist": (2, 1, 2), "pedestrian": (3, 2, 2)}
    got = {k: (r["generated"], r["failures"]) for k, r in out["conflict_type"].items()}
    # an untyped pedestrian intsit is a crossing of its kind; "x" is the slot's own type
    assert got == {
        "merging": (3, 2),
        "pedestrian_crossing": (2, 1),
        "cyclist_following": (2, 1),
        "x": (1, 1),
    }
    row = out["actor_kind"]["pedestrian"]
    assert row["failure_rate"] == 1.0 and row["ci95"] == list(wilson_interval(2, 2))


def test_a_slot_without_a_known_type_adds_no_type_row():
    runs = [_run("c", "bike", "fail")]
    out = breakdowns(SMALL, runs)  # no slot typing
    assert out["conflict_type"]["merging"]["failures"] == 1
    assert "cyclist_following" not in out["conflict_type"]
    assert out["actor_kind"]["cyclist"]["failures"] == 1


def test_the_paper_hyperspace_gives_one_row_each_equal_to_the_totals():
    hs = load_hyperspace("t-junction")
    rng = np.random.default_rng(4)
    runs = [
        {
            "bins": {e.name: rng.choice(e.labels) for e in hs.elements},
            "status": rng.choice(STATUSES),
        }
        for _ in range(500)
    ]
    summary = summarize(hs, runs)
    found = summary["breakdowns"]
    assert list(found["actor_kind"]) == ["car"] and list(found["conflict_type"]) == ["crossing"]
    for row in (found["actor_kind"]["car"], found["conflict_type"]["crossing"]):
        assert row["failures"] == summary["failures"] and row["passes"] == summary["passes"]
        assert row["ci95"] == summary["ci95"]


def test_a_hyperspace_without_actor_elements_has_no_breakdown():
    hs = Hyperspace.from_dict(
        {
            "name": "w",
            "axes": [{"name": "a", "elements": [{"name": "friction", "bins": [{"value": 1.0}]}]}],
        }
    )
    runs = [{"bins": {"friction": "1.0"}, "status": "fail"}]
    assert breakdowns(hs, runs) == {} and summarize(hs, runs)["breakdowns"] == {}


@pytest.mark.parametrize("name", ["crossroads", "roundabout"])
def test_numpy_tally_equals_a_per_run_brute_force(name):
    hs = load_hyperspace(str(DERIVED / f"{name}.yaml"))
    rng = np.random.default_rng(7)
    # a fake geometry: every (ego, kind, route) of a slot typed by its kind and route
    types = {}
    for b in hs.element("actor2").bins:
        if isinstance(b.value, dict):
            for ego in {v.value["ego"] for v in hs.element("intsit").bins}:
                types[(ego, b.value["kind"], b.value["route"])] = f"t-{b.value['kind']}-{ego[0]}"
    runs = []
    for _ in range(800):
        bins = {e.name: str(rng.choice(e.labels)) for e in hs.elements}
        runs.append({"bins": bins, "status": str(rng.choice(STATUSES))})
    got = summarize(hs, iter(runs), types)["breakdowns"]
    expected: dict[str, dict[str, list[int]]] = {"actor_kind": {}, "conflict_type": {}}
    for run in runs:
        if run["status"] == "pending":
            continue
        values = {
            e: hs.element(e).bins[hs._label_index[hs.element_names.index(e)][b]].value
            for e, b in run["bins"].items()
        }
        kinds, ctypes = run_roles(values, types)
        for key, names in (("actor_kind", kinds), ("conflict_type", ctypes)):
            for n in names:
                cell = expected[key].setdefault(n, [0, 0])
                cell[0] += 1
                cell[1] += run["status"] == "fail"
    for key, rows in expected.items():
        assert {
            k: [r["generated"], r["failures"]] for k, r in got[key].items() if r["generated"]
        } == rows


def _hit(intsit: str, actor2: str, status: str, hit: str | None, kind: str | None) -> dict:
    return {**_run(intsit, actor2, status), "hit": hit, "failure_kind": kind}


def test_collisions_count_for_the_road_user_hit():
    runs = [
        _hit("c", "ped", "fail", "pedestrian", "collision"),
        _hit("c", "ped", "pass", None, None),
        _hit("c", "bike", "fail", None, "collision"),  # stores no kind: hit the intsit car
        _hit("p", "bike", "fail", "cyclist", "collision"),
        _hit("p", "none", "fail", None, "road_departure"),  # failed, hit nobody
        _hit("p", "none", "error", None, None),
    ]
    out = breakdowns(SMALL, runs)["hit_kind"]
    got = {k: (r["collisions"], r["generated"], r["judged"]) for k, r in out.items()}
    assert got == {"car": (1, 3, 3), "cyclist": (1, 2, 2), "pedestrian": (1, 5, 4)}
    assert out["pedestrian"]["collision_rate"] == 0.25
    assert out["pedestrian"]["ci95"] == list(wilson_interval(1, 4))
    assert [r["share"] for r in out.values()] == pytest.approx([1 / 3] * 3)


def test_a_kind_hit_that_the_hyperspace_does_not_list_gets_its_own_row():
    out = breakdowns(SMALL, [_hit("c", "none", "fail", "truck", "collision")])["hit_kind"]
    assert out["truck"]["collisions"] == 1 and out["truck"]["share"] == 1.0
    assert out["car"]["collisions"] == 0 and out["car"]["share"] == 0.0


def test_the_paper_hyperspace_hits_its_car_in_every_collision():
    hs = load_hyperspace("t-junction")
    rng = np.random.default_rng(5)
    runs = [
        {"bins": {e.name: rng.choice(e.labels) for e in hs.elements}, "status": str(s)}
        for s in rng.choice(STATUSES, 300)
    ]
    summary = summarize(hs, runs)
    car = summary["breakdowns"]["hit_kind"]["car"]
    assert car["collisions"] == summary["failures"] and car["share"] == 1.0
    assert car["collision_rate"] == summary["failure_rate"]


def test_row_order_lists_every_conflict_type_the_simulator_can_return() -> None:
    """analysis repeats the simulator's conflict types (it must not import the simulator);
    the copy may not drift from the source."""
    from sitcov.analysis._breakdown import TYPE_ORDER
    from sitcov.sim.embedded._conflicts import CONFLICT_TYPES

    assert TYPE_ORDER == CONFLICT_TYPES
