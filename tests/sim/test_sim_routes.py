"""Routes per kind of road user: car lanes, cyclists right of the lane, crosswalk walks."""

from __future__ import annotations

import math
import pickle

import pytest

from sitcov.errors import ConfigError
from sitcov.sim.embedded import load_map
from sitcov.sim.embedded._path import Path
from sitcov.sim.embedded._routes import (
    actor_route,
    kerb_positions,
    offset_path,
    route_names,
    start_key,
)

MAPS = ("t-junction", "crossroads", "skewed-cross", "roundabout", "merge")


def test_route_names_per_kind() -> None:
    tmap = load_map("t-junction")
    assert route_names(tmap, "car") == tmap.movements == route_names(tmap, "cyclist")
    assert route_names(tmap, "pedestrian") == ("XBL", "XBR", "XLL", "XLR", "XRL", "XRR")
    assert route_names(load_map("crossroads"), "pedestrian")[-2:] == ("XTL", "XTR")
    assert route_names(load_map("merge"), "pedestrian") == ()  # no crosswalks
    assert route_names(load_map("merge"), "car") == ("W-E", "M-E")


@pytest.mark.parametrize("name", MAPS)
def test_cyclists_ride_bike_offset_right_of_the_lane_centre(name: str) -> None:
    jmap = load_map(name)
    for move in jmap.movements:
        car = actor_route(jmap, "car", move)
        bike = actor_route(jmap, "cyclist", move)
        offsets = [car.lateral_offset(*bike.point_at(s)[:2]) for s in range(0, int(bike.length), 7)]
        assert max(abs(o + jmap.bike_offset) for o in offsets) < 0.05, move


def test_pedestrian_starts_at_the_left_or_right_kerb_facing_the_junction() -> None:
    tmap = load_map("t-junction")  # leg B points south: facing the junction is facing north
    left, right = actor_route(tmap, "pedestrian", "XBL"), actor_route(tmap, "pedestrian", "XBR")
    assert left.xs[0] < 0 < left.xs[-1]  # west (left) to east
    assert right.xs[0] > 0 > right.xs[-1]
    reach = tmap.lane_width + tmap.sidewalk_width
    cw = tmap.legs["B"].crosswalk
    along = tmap.legs["B"].mouth + cw.offset + 0.5 * cw.width
    # from the outer edge of one sidewalk straight across to the other's, on the centre line
    assert left.points[0] == pytest.approx((-reach, -along))
    assert left.points[-1] == pytest.approx((reach, -along))
    assert max(abs(y + along) for y in left.ys) < 1e-9
    assert left.length == pytest.approx(2 * reach)
    s_on, s_off = kerb_positions(tmap, "XBL")
    assert left.point_at(s_on)[0] == pytest.approx(-tmap.lane_width)
    assert left.point_at(s_off)[0] == pytest.approx(tmap.lane_width)
    area = tmap.drivable_area
    assert not area.contains(*left.point_at(s_on - 0.1)[:2])
    assert area.contains(*left.point_at(s_on + 0.1)[:2])


def test_car_route_is_the_map_route_and_bad_names_fail() -> None:
    tmap = load_map("t-junction")
    assert actor_route(tmap, "truck", "L-B") == tmap.route("L", "B")
    for kind, route in (("car", "XBL"), ("pedestrian", "L-B"), ("pedestrian", "XTL")):
        with pytest.raises(ConfigError, match="route"):
            actor_route(tmap, kind, route)
    with pytest.raises(ConfigError, match="kind"):
        actor_route(tmap, "horse", "L-B")


def test_start_keys_tell_who_would_spawn_on_whom() -> None:
    assert start_key("car", "L-B") == start_key("truck", "L-R") == ("car", "L")
    assert start_key("cyclist", "L-B") != start_key("car", "L-B")
    assert start_key("pedestrian", "XBL") != start_key("pedestrian", "XBR")


def test_offset_path_is_parallel_at_a_corner() -> None:
    from sitcov.sim.embedded._path import Path

    corner = Path.from_points([(0.0, 0.0), (10.0, 0.0), (10.0, 10.0)])
    moved = offset_path(corner, -1.0)  # right of a left turn: outside the corner
    flat = [c for point in moved.points for c in point]
    assert flat == pytest.approx([0.0, -1.0, 11.0, -1.0, 11.0, 10.0])
    assert math.isclose(moved.length, 22.0)


def test_a_paths_cached_hash_and_points_behave_as_its_fields_do() -> None:
    """Equal paths hash alike (as dict keys of the per-route caches), a copy made after the
    caches filled (pickled to a worker) equals and hashes as the original, and the cached
    points and tracking array are the path's."""
    a = Path.from_points([(float(x), 0.1 * x * x) for x in range(30)])
    b = Path.from_points([(float(x), 0.1 * x * x) for x in range(30)])
    other = Path.from_points([(float(x), 0.1 * x * x + 1e-9) for x in range(30)])
    assert a == b and hash(a) == hash(b) and {a: 1}[b] == 1
    assert a != other and other not in {a: 1}
    assert a.points is a.points and a.points == tuple(zip(a.xs, a.ys, strict=True))
    assert a._track_array.tolist() == [list(a.xs), list(a.ys), list(a.ss)]
    copy = pickle.loads(pickle.dumps(a))
    assert copy == a and hash(copy) == hash(a) and copy.points == a.points
