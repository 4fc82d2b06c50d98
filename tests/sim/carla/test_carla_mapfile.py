"""Map files: the shipped Town03 data and clear errors for bad files."""

from __future__ import annotations

import math

import pytest
from carla_testkit import SMALL_MAP, small_map

from sitcov.errors import ConfigError
from sitcov.sim.carla import available_maps, load_carla_map


def test_town03_holds_the_papers_coordinates_exactly() -> None:
    m = load_carla_map("Town03")
    assert m.town == "Town03" and "town03" in available_maps()
    assert (m.junction.x, m.junction.y) == (-74.63, -136.34)
    assert m.conflict_points == {
        "c1": (-74.63, -136.34),
        "c2": (-74.63, -139.28),
        "c4": (-89.0, -136.5),
    }
    ego = {k: (p.x, p.y, p.yaw) for k, p in m.ego_spawns.items()}
    assert ego == {
        "B": (-74.32, -50.0, 270.0),
        "L": (-145.36, -91.61, 270.0),
        "R": (15.09, -138.7, 180.0),
    }
    assert m.goals == {"B": (-85.2, -30.0), "L": (-148.97, -76.77), "R": (30.0, -135.95)}
    ov = {k: (p.x, p.y, p.yaw) for k, p in m.ov_spawns.items()}
    assert ov == {
        "L": (-109.0, -136.0, 0.0),
        "B": (-74.70, -114.95, 270.0),
        "B-L": (-78.70, -114.95, 270.0),
        "R": (-55.08, -139.5, 180.0),
    }


def test_movement_lookup() -> None:
    m = load_carla_map("town03")  # names are case-insensitive
    assert (m.ov_spawn("B-L").x, m.ov_spawn("B-R").x) == (-78.70, -74.70)
    assert m.goal("L-R") == (30.0, -135.95)
    with pytest.raises(ConfigError, match="c3"):
        m.conflict_point("c3")
    with pytest.raises(ConfigError, match="intsit"):
        m.ego_spawn("LB")


def _left_of(junction: tuple[float, float], x: float, y: float, heading: float) -> float:
    """Signed distance [m] of (x, y) to the left of the line through ``junction`` along
    ``heading`` [rad] (sitcov's right-handed frame)."""
    return -math.sin(heading) * (x - junction[0]) + math.cos(heading) * (y - junction[1])


def test_small_map_drives_on_the_right_as_carla_and_its_embedded_map(tmp_path) -> None:
    """Every spawn is half a lane right of its direction of travel, every goal half a lane
    right of the way out, as on CARLA's roads and on the embedded map that places the
    pedestrians, cyclists and extra cars (a left-hand leg puts the CARLA ego in the lane
    the embedded world's oncoming traffic uses, and conflicts move or vanish)."""
    from sitcov.sim.carla._actors import Frame
    from sitcov.sim.embedded._map import load_map

    spec = load_carla_map(small_map(tmp_path))
    jmap = load_map(spec.embedded_map)
    frame = Frame.of(spec)
    junction, half = (frame.x0, frame.y0), 0.5 * jmap.lane_width
    inbound = {}
    for table in (spec.ego_spawns, spec.ov_spawns):
        for key, sp in table.items():
            leg, heading = key.split("-")[0], -math.radians(sp.yaw)  # CARLA -> sitcov
            inbound[leg] = heading
            assert _left_of(junction, sp.x, -sp.y, heading) == pytest.approx(-half), key
            out = next(m for m in jmap.movements if m.startswith(f"{leg}-"))
            ex, ey, eh = frame.to_sitcov(*jmap.ego_path(out).point_at(0.0))
            assert math.cos(eh - heading) > 0.99, key  # the embedded lane goes the same way
            assert _left_of(junction, ex, ey, heading) == pytest.approx(-half), key
    assert set(inbound) == set(spec.goals)
    for leg, (gx, gy) in spec.goals.items():
        assert _left_of(junction, gx, -gy, inbound[leg] + math.pi) == pytest.approx(-half), leg


def test_another_map_is_a_file(tmp_path) -> None:
    path = tmp_path / "small.yaml"
    path.write_text(SMALL_MAP, encoding="utf-8")
    m = load_carla_map(path)
    assert m.name == "small-t" and m.legs == ("B", "L", "R")


@pytest.mark.parametrize(
    ("edit", "field"),
    [
        (("town: Town03", "town: 3"), "town"),
        (("  B: [-1.75, 30.0]", "  B: [-1.75]"), "goals.B"),
        (
            ("junction: {x: 0.0, y: 0.0, radius: 12.0}", "junction: {x: 0.0, y: 0.0, radius: -1}"),
            "junction.radius",
        ),
        (("name: small-t", "name: small-t\ncolour: red"), "colour"),
        (("  R: {x: 25.0, y: -1.75, yaw: 180.0}", "  X: {x: 25.0, y: -1.75, yaw: 180.0}"), "X"),
    ],
)
def test_bad_map_files_name_file_and_field(tmp_path, edit, field) -> None:
    old, new = edit
    assert old in SMALL_MAP
    path = tmp_path / "bad.yaml"
    path.write_text(SMALL_MAP.replace(old, new), encoding="utf-8")
    with pytest.raises(ConfigError) as info:
        load_carla_map(path)
    assert str(path) in str(info.value) and field in str(info.value)


def test_unknown_map_name_lists_the_shipped_ones() -> None:
    with pytest.raises(ConfigError, match="town03"):
        load_carla_map("Town99")
