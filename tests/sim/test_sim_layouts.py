"""Map format 2 and the layouts: crosswalks, sidewalks, bike positions, roundabout, merge.

Every shipped map must serve the embedded backend unchanged (two cars, a run end to end).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from sitcov.av import ReferenceStack
from sitcov.errors import ConfigError
from sitcov.hyperspace import Situation
from sitcov.sim.embedded import EmbeddedBackend, load_map, render_topdown
from sitcov.sim.embedded._map import MAPS_DIR, JunctionMap
from sitcov.sim.embedded._routes import route_names

MAPS = ("t-junction", "crossroads", "skewed-cross", "roundabout", "merge")


def test_every_shipped_map_is_listed() -> None:
    assert sorted(p.stem for p in MAPS_DIR.glob("*.yaml")) == sorted(MAPS)


def test_format_1_file_loads_unchanged_without_the_new_features(tmp_path) -> None:
    data = yaml.safe_load((MAPS_DIR / "t-junction.yaml").read_text())
    for leg in data["legs"].values():
        del leg["crosswalk"]
    del data["sidewalk_width"], data["bike_offset"]
    data["format"] = 1
    old = JunctionMap(data, "old.yaml")
    new = load_map("t-junction")
    assert old.movements == new.movements
    for move in old.movements:
        assert old.route(*move.split("-")) == new.route(*move.split("-"))
        assert old.scenario(move, "R-B").conflict == new.scenario(move, "R-B").conflict
    assert route_names(old, "pedestrian") == ()  # no crosswalks: no pedestrian routes
    assert (old.sidewalk_width, old.bike_offset) == (2.0, 1.2)  # the defaults
    geo_old, geo_new = old.render_geometry(), new.render_geometry()
    for key in ("road_polygons", "markings", "kerbs"):
        assert geo_old[key] == geo_new[key]
    assert geo_old["crosswalks"] == [] and len(geo_new["crosswalks"]) == 3


def _edit(tmp_path, name: str, edit) -> str:
    data = yaml.safe_load((MAPS_DIR / f"{name}.yaml").read_text())
    edit(data)
    path = tmp_path / "map.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


@pytest.mark.parametrize(
    ("name", "edit", "field"),
    [
        ("t-junction", lambda d: d["legs"]["B"]["crosswalk"].pop("width"), "legs.B.crosswalk"),
        ("t-junction", lambda d: d["legs"]["B"]["crosswalk"].update(width=-1), "crosswalk.width"),
        (
            "t-junction",
            lambda d: d["legs"]["B"]["crosswalk"].update(offset=200),
            "legs.B.crosswalk",
        ),
        ("t-junction", lambda d: d.update(bike_offset=2.0), "bike_offset"),
        ("t-junction", lambda d: d.update(sidewalk_width="wide"), "sidewalk_width"),
        ("t-junction", lambda d: d.update(layout="spiral"), "layout"),
        ("t-junction", lambda d: d.update(format=3), "format"),
        ("roundabout", lambda d: d.pop("roundabout"), "roundabout"),
        ("roundabout", lambda d: d["roundabout"].update(entry_angle_deg=50), "entry_angle_deg"),
        ("roundabout", lambda d: d["legs"]["B"].update(mouth=15), "legs.B.mouth"),
        ("merge", lambda d: d["legs"]["M"].update(heading_deg=150), "legs.M.heading_deg"),
        ("merge", lambda d: d["legs"]["W"].update(heading_deg=170), "legs.W.heading_deg"),
        ("merge", lambda d: d["merge"].update(ramp="E"), "merge"),
        ("merge", lambda d: d["legs"]["M"].update(mouth=10), "legs.M.mouth"),
        (
            "merge",
            lambda d: d["legs"]["W"].update(crosswalk={"offset": 1, "width": 3}),
            "crosswalk",
        ),
        ("merge", lambda d: d["spawns"]["ov"].update(E=40), "spawns.ov"),
        ("roundabout", lambda d: d.update(merge={}), "merge"),
    ],
)
def test_invalid_layout_names_file_and_field(tmp_path, name, edit, field) -> None:
    path = _edit(tmp_path, name, edit)
    with pytest.raises(ConfigError) as info:
        load_map(path)
    message = str(info.value)
    assert path in message and field in message and "\n" not in message


@pytest.mark.parametrize("name", MAPS)
def test_routes_are_continuous_smooth_and_on_the_road(name: str) -> None:
    jmap = load_map(name)
    area = jmap.drivable_area
    for move in jmap.movements:
        route = jmap.route(*move.split("-"))
        steps = np.diff(np.column_stack([route.xs, route.ys]), axis=0)
        assert np.hypot(steps[:, 0], steps[:, 1]).max() <= 1.0 + 1e-6, move
        # no kinks: radius >= 7 m everywhere (the tightest: the skewed cross's 70-degree T-L)
        assert route.max_curvature < 1.0 / 7.0, move
        inside = area.contains_many(np.asarray(route.xs), np.asarray(route.ys))
        assert inside.all(), (move, np.flatnonzero(~inside)[:3])
        # the lane's full width is road too (a car on its lane never "leaves the road"),
        # away from the ends of the map (where the road stops)
        left, right = jmap.clearance(route)
        inner = [i for i, s in enumerate(route.ss) if 5.0 < s < route.length - 5.0]
        assert min(left[i] for i in inner) >= 0.5 * jmap.lane_width - 0.06, move
        assert min(right[i] for i in inner) >= 0.5 * jmap.lane_width - 0.06, move


def test_roundabout_routes_circulate_counter_clockwise() -> None:
    rmap = load_map("roundabout")
    for move in rmap.movements:
        route = rmap.route(*move.split("-"))
        on_ring = [
            (x, y, h)
            for x, y, h in zip(route.xs, route.ys, route.hs, strict=True)
            if abs(math.hypot(x, y) - rmap.radius) < 0.05
        ]
        assert on_ring, move
        for x, y, h in on_ring:  # the velocity points counter-clockwise (positive cross)
            assert x * math.sin(h) - y * math.cos(h) > 0.0, move


def test_merge_ramp_joins_the_main_lane_within_the_taper() -> None:
    mmap = load_map("merge")
    main, ramp = mmap.route("W", "E"), mmap.route("M", "E")
    # the last 100 m of both routes are the same lane
    for s in range(0, 100, 10):
        a = main.point_at(main.length - s)[:2]
        b = ramp.point_at(ramp.length - s)[:2]
        assert math.dist(a, b) < 1e-6
    scen = mmap.scenario("W-E", "M-E")
    assert scen.conflict is not None
    assert 0.0 < scen.conflict.point[0] < mmap.taper_length


@pytest.mark.parametrize("name", MAPS)
def test_backend_runs_two_cars_on_every_map(name: str, tmp_path) -> None:
    jmap = load_map(name)
    backend = EmbeddedBackend(map=name)
    pairs = [(e, o) for e in jmap.movements for o in jmap.movements]
    pairs = [p for p in pairs if jmap.scenario(*p).conflict is not None][:3]
    assert pairs
    for ego, ov in pairs:
        situation = Situation(
            bins={"intsit": "x", "friction": "1.0"},
            values={"intsit": {"ego": ego, "ov": ov, "conflict": "k1"}, "friction": 1.0},
        )
        outcome = backend.run(situation, ReferenceStack(), seed=3, record=True)
        assert outcome.end_reason in ("collision", "goal", "stopped", "sim_timeout")
        assert outcome.metrics["ego_route"] == ego and outcome.metrics["ov_route"] == ov
        assert outcome.metrics["road_departure_time"] is None, (ego, ov)
        assert outcome == backend.run(situation, ReferenceStack(), seed=3, record=True)
    png = render_topdown(outcome, tmp_path / f"{name}.png")
    assert png.stat().st_size > 10_000
