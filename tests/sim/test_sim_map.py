"""Junction maps: routes, lane graph, conflict points, drawable geometry, file validation."""

from __future__ import annotations

import math

import pytest
import yaml
from _sim_helpers import INTSITS

from sitcov.errors import ConfigError
from sitcov.sim.embedded import load_map
from sitcov.sim.embedded._map import MAPS_DIR, JunctionMap

WIDTH = 1.61  # reference vehicle width [m]


@pytest.fixture(scope="module")
def tmap() -> JunctionMap:
    return load_map("t-junction")


def test_every_movement_routes(tmap: JunctionMap) -> None:
    assert set(tmap.movements) == {"L-B", "L-R", "B-L", "B-R", "R-L", "R-B"}
    for move in tmap.movements:
        a, b = move.split("-")
        route = tmap.route(a, b)
        gaps = [s1 - s0 for s0, s1 in zip(route.ss, route.ss[1:], strict=False)]
        assert max(gaps) <= 1.0 + 1e-6 and min(gaps) > 0.3
        # starts at the far end of leg a, ends at the far end of leg b
        assert math.hypot(route.xs[0], route.ys[0]) == pytest.approx(110, abs=0.1)
        assert math.hypot(route.xs[-1], route.ys[-1]) == pytest.approx(110, abs=0.1)
        # smooth: no kink above ~15 degrees between successive points
        kinks = [
            abs(math.remainder(h1 - h0, math.tau))
            for h0, h1 in zip(route.hs, route.hs[1:], strict=False)
        ]
        assert max(kinks) < math.radians(15)
        assert tmap.lane_sequence(a, b) == [f"{a}.in", f"{a}-{b}", f"{b}.out"]


def test_right_hand_traffic(tmap: JunctionMap) -> None:
    # B is the southern stem: its inbound lane heads north on the east side (x > 0)
    inbound = tmap.lane("B.in")
    assert inbound.xs[0] == pytest.approx(1.75) and inbound.ys[-1] > inbound.ys[0]
    # a right turn B->R is tighter (shorter) than a left turn B->L
    assert tmap.lane("B-R").length < tmap.lane("B-L").length


def test_spawn_distances_follow_town03(tmap: JunctionMap) -> None:
    for ego, ov, _ in INTSITS:
        scen = tmap.scenario(ego, ov)
        ex, ey = scen.ego_route.xs[0], scen.ego_route.ys[0]
        ox, oy = scen.ov_route.xs[0], scen.ov_route.ys[0]
        assert 50 <= math.hypot(ex, ey) <= 90
        assert 15 <= math.hypot(ox, oy) <= 40
        gx, gy = scen.ego_route.xs[-1], scen.ego_route.ys[-1]
        assert 20 <= math.hypot(gx, gy) - 12 <= 30  # goal 20-30 m beyond the junction mouth


@pytest.mark.parametrize(("ego", "ov", "label"), INTSITS)
def test_conflict_point_lies_on_both_routes(tmap: JunctionMap, ego, ov, label) -> None:
    scen = tmap.scenario(ego, ov, WIDTH, WIDTH)
    conflict = scen.conflict
    assert conflict is not None
    cx, cy = conflict.point
    ex, ey, _ = scen.ego_route.point_at(conflict.s_ego)
    assert math.hypot(cx - ex, cy - ey) < 0.05
    # within the swept width of the OV route, and just so: the first overlap
    assert abs(scen.ov_route.lateral_offset(cx, cy)) <= WIDTH + 1e-6
    before = scen.ego_route.point_at(conflict.s_ego - 0.5)
    assert abs(scen.ov_route.lateral_offset(before[0], before[1])) > WIDTH - 0.2
    # it is inside the junction area
    assert math.hypot(cx, cy) < 15
    assert conflict.s_ego <= conflict.s_ego_end and conflict.s_ov <= conflict.s_ov_end


def test_render_geometry_shape(tmap: JunctionMap) -> None:
    geometry = tmap.render_geometry()
    assert set(geometry) == {"road_polygons", "markings", "kerbs", "crosswalks", "sidewalks"}
    assert len(geometry["crosswalks"]) == 3 and len(geometry["sidewalks"]) == 6
    assert len(geometry["road_polygons"]) == 4  # three legs and the junction box
    for mark in geometry["markings"]:
        assert mark["style"] in ("solid", "dashed") and mark["color"] in ("white", "yellow")
        assert len(mark["points"]) >= 2
    assert all(len(k) >= 2 for k in geometry["kerbs"])
    # every route point lies on the road: inside some road polygon
    from shapely.geometry import Point, Polygon
    from shapely.ops import unary_union

    road = unary_union([Polygon(p) for p in geometry["road_polygons"]]).buffer(1e-6)
    for move in tmap.movements:
        route = tmap.route(*move.split("-"))
        assert all(road.contains(Point(p)) for p in route.points)


def test_second_map_is_only_a_file() -> None:
    cross = load_map("skewed-cross")
    assert len(cross.movements) == 12
    for move in cross.movements:
        assert cross.route(*move.split("-")).length > 150
    scen = cross.scenario("B-T", "L-R")
    assert scen.conflict is not None


def _write(tmp_path, data) -> str:
    path = tmp_path / "map.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


def _base() -> dict:
    return yaml.safe_load((MAPS_DIR / "t-junction.yaml").read_text())


@pytest.mark.parametrize(
    ("edit", "field"),
    [
        (lambda d: d.pop("lane_width"), "lane_width"),
        (lambda d: d["legs"]["B"].update(mouth="wide"), "legs.B.mouth"),
        (lambda d: d["legs"]["L"].update(length=5), "legs.L.length"),
        (lambda d: d["spawns"]["ego"].update(B=500), "spawns.ego.B"),
        (lambda d: d["spawns"]["ov"].pop("R"), "spawns.ov"),
        (lambda d: d.update(legs={"B": d["legs"]["B"]}), "legs"),
        (lambda d: d.update(goal_distance=5), "goal_distance"),
        (lambda d: d.update(colour="red"), "colour"),
    ],
)
def test_invalid_map_file_names_field(tmp_path, edit, field) -> None:
    data = _base()
    edit(data)
    path = _write(tmp_path, data)
    with pytest.raises(ConfigError) as info:
        load_map(path)
    message = str(info.value)
    assert path in message and field in message


def test_unknown_map_and_bad_yaml(tmp_path) -> None:
    with pytest.raises(ConfigError, match="t-junction"):
        load_map("no-such-map")
    bad = tmp_path / "bad.yaml"
    bad.write_text("legs: [unclosed")
    with pytest.raises(ConfigError, match="YAML"):
        load_map(str(bad))
    with pytest.raises(ConfigError, match="movement"):
        load_map().scenario("B-B", "L-R")
