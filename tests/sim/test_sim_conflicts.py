"""Typed conflicts derived from geometry, one test per type on the shipped maps."""

from __future__ import annotations

import pytest

from sitcov.sim._adversary import PAPER_INTSITS
from sitcov.sim.embedded import load_map
from sitcov.sim.embedded._conflicts import conflict_type, typed_conflict
from sitcov.sim.embedded._routes import actor_route


def _cars(name: str, ego: str, ov: str) -> str | None:
    jmap = load_map(name)
    return conflict_type(jmap.ego_path(ego), jmap.ov_path(ov), "car")


def _actor(name: str, ego: str, kind: str, route: str) -> str | None:
    jmap = load_map(name)
    return conflict_type(jmap.ego_path(ego), actor_route(jmap, kind, route), kind)


def test_t_junction_car_conflicts_are_the_paper_s_twelve_and_split_by_exit() -> None:
    tmap = load_map("t-junction")
    typed = {
        (e, o): _cars("t-junction", e, o)
        for e in tmap.movements
        for o in tmap.movements
        if _cars("t-junction", e, o) in ("crossing", "merging")
    }
    assert set(typed) == set(PAPER_INTSITS)
    for (ego, ov), kind in typed.items():  # merging = same exit leg
        assert (kind == "merging") == (ego[-1] == ov[-1]), (ego, ov)


@pytest.mark.parametrize(
    ("name", "ego", "ov", "expected"),
    [
        ("t-junction", "L-R", "B-L", "crossing"),
        ("crossroads", "B-T", "L-R", "crossing"),
        ("crossroads", "B-L", "T-B", "crossing"),  # left turn across the oncoming lane
        ("t-junction", "L-B", "R-B", "merging"),
        ("merge", "W-E", "M-E", "merging"),  # on-ramp
        ("merge", "M-E", "W-E", "merging"),
        ("roundabout", "B-R", "L-R", "merging"),  # entering ahead of a circulating car
        ("t-junction", "L-B", "L-R", "diverging"),  # queued behind a car that turns off
        ("roundabout", "B-L", "B-R", "diverging"),
        ("t-junction", "L-B", "L-B", "following"),
        ("merge", "W-E", "W-E", "following"),
        ("t-junction", "L-B", "R-L", None),  # opposite lanes never meet
        ("crossroads", "B-R", "T-L", None),
    ],
)
def test_car_car_types(name: str, ego: str, ov: str, expected: str | None) -> None:
    assert _cars(name, ego, ov) == expected


def test_a_single_lane_roundabout_has_no_crossing() -> None:
    rmap = load_map("roundabout")
    kinds = {_cars("roundabout", e, o) for e in rmap.movements for o in rmap.movements}
    assert kinds == {"merging", "diverging", "following", None}


def test_crossing_is_symmetric_on_the_crossroads() -> None:
    cmap = load_map("crossroads")
    for e in cmap.movements:
        for o in cmap.movements:
            assert (_cars("crossroads", e, o) == "crossing") == (
                _cars("crossroads", o, e) == "crossing"
            ), (e, o)


@pytest.mark.parametrize(
    ("name", "ego", "route", "expected"),
    [
        ("t-junction", "L-B", "XLL", "pedestrian_crossing"),  # its own approach
        ("t-junction", "L-B", "XBR", "pedestrian_crossing"),  # its exit leg
        ("t-junction", "L-B", "XRL", None),  # a leg it never drives on
        ("roundabout", "B-T", "XTL", "pedestrian_crossing"),
    ],
)
def test_pedestrian_crossing(name: str, ego: str, route: str, expected: str | None) -> None:
    assert _actor(name, ego, "pedestrian", route) == expected


@pytest.mark.parametrize(
    ("name", "ego", "route", "expected"),
    [
        ("crossroads", "B-R", "B-T", "cyclist_right_hook"),  # car turns right across it
        ("crossroads", "T-L", "T-B", "cyclist_right_hook"),
        ("t-junction", "L-B", "L-R", "cyclist_right_hook"),
        ("crossroads", "B-T", "B-R", None),  # the cyclist turns right behind the car's line
        ("crossroads", "B-T", "L-R", "cyclist_crossing"),
        ("crossroads", "L-R", "L-T", "cyclist_crossing"),  # cyclist turns left: not a hook
        ("t-junction", "L-R", "L-R", None),  # same lane, the cyclist keeps right: no overlap
        ("crossroads", "B-T", "B-L", "cyclist_crossing"),  # car straight on, cyclist turns left
        # roundabout exits: both circulate, the car leaves the ring across the cyclist on
        # its right (the ring's left curve must not hide the car's right turn)
        ("roundabout", "B-R", "B-T", "cyclist_right_hook"),
        ("roundabout", "L-T", "B-L", "cyclist_right_hook"),
        ("roundabout", "T-B", "L-R", "cyclist_right_hook"),
        ("roundabout", "B-L", "L-R", "cyclist_crossing"),  # entry: the cyclist passes in front
        ("skewed-cross", "B-R", "B-L", "cyclist_right_hook"),  # as on the crossroads
    ],
)
def test_cyclist_conflicts(name: str, ego: str, route: str, expected: str | None) -> None:
    assert _actor(name, ego, "cyclist", route) == expected


def test_same_lane_conflict_is_timed_where_the_routes_split() -> None:
    tmap = load_map("t-junction")
    ego, ov = tmap.ego_path("L-B"), tmap.ov_path("L-R")
    typed = typed_conflict(ego, ov, "car")
    assert typed is not None and typed.type == "diverging"
    # not the OV's spawn (its first overlap) but inside the junction, past the mouth
    spawn_gap = tmap.spawns["ego"]["L"] - tmap.spawns["ov"]["L"]
    assert typed.conflict.s_ego > spawn_gap + 10.0
    assert typed.conflict.s_ov > 10.0
    assert typed.conflict.point[0] > -tmap.legs["L"].mouth
