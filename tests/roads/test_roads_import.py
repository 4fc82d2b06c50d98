"""OpenDRIVE junctions as sitcov maps: legs, lane-level routes, crosswalks, derived conflicts,
the ``sitcov map import`` command and ``--map FILE.xodr``."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from sitcov.cli import main
from sitcov.errors import ConfigError
from sitcov.roads import junction_legs, junction_map_data, leg_names, list_junctions, read_opendrive
from sitcov.sim.embedded import JunctionMap, load_map
from sitcov.sim.embedded._derive import derive_conflicts
from sitcov.sim.embedded._routes import actor_route, kerb_positions, route_names
from tests.roads._shared import DATA

T_XODR = DATA / "t-junction.xodr"


def test_leg_names_follow_the_paper_and_the_shipped_maps() -> None:
    deg = math.radians
    assert leg_names([deg(270), deg(180), deg(0)]) == ["B", "L", "R"]
    assert leg_names([deg(0), deg(90), deg(180)]) == ["L", "B", "R"]  # stem north
    assert leg_names([deg(90), deg(0), deg(270), deg(180)]) == ["T", "R", "B", "L"]


def test_the_test_junction_is_listed_with_its_legs() -> None:
    (row,) = list_junctions(read_opendrive(T_XODR))
    assert row["id"] == "100"
    assert row["centre"] == pytest.approx([0.0, 0.0], abs=1e-9)
    legs = {leg["name"]: leg for leg in row["legs"]}
    assert {n: legs[n]["road"] for n in legs} == {"L": "1", "R": "2", "B": "3"}
    assert all(leg["lanes_in"] == 1 and leg["lanes_out"] == 1 for leg in legs.values())
    assert legs["B"]["heading_deg"] == pytest.approx(270.0)


def test_routes_follow_the_files_lanes() -> None:
    jmap = load_map(str(T_XODR))
    assert jmap.LAYOUT == "lanes"
    assert set(jmap.movements) == {"B-L", "B-R", "L-B", "L-R", "R-B", "R-L"}
    assert {leg.mouth for leg in jmap.legs.values()} == {10.0}
    # straight on: the lane centre 1.75 m right of the axis, end to end
    through = jmap.route("L", "R")
    assert np.allclose(through.ys, -1.75, atol=1e-6)
    assert through.length == pytest.approx(2 * 110.0, abs=0.05)
    # the right turn L-B: a quarter circle of radius 10 - 1.75 about (-10, -10)
    turn = jmap.lane("L-B")
    r = np.hypot(np.asarray(turn.xs) + 10.0, np.asarray(turn.ys) + 10.0)
    assert np.allclose(r, 8.25, atol=1e-3)
    # spawn and goal distances along the legs, from the centre
    ego = jmap.ego_path("B-L")
    assert (ego.xs[0], ego.ys[0]) == pytest.approx((1.75, -72.0), abs=1e-6)
    assert (ego.xs[-1], ego.ys[-1]) == pytest.approx((-35.0, 1.75), abs=1e-6)


def test_crosswalk_objects_become_pedestrian_routes() -> None:
    jmap = load_map(str(T_XODR))
    assert set(route_names(jmap, "pedestrian")) == {f"X{n}{s}" for n in "BLR" for s in "LR"}
    path = actor_route(jmap, "pedestrian", "XBL")
    # across the stem 3.5 m outside its mouth: from 2 m outside one kerb to 2 m beyond the other
    assert np.allclose(path.ys, -13.5, atol=1e-6)
    assert path.xs[0] == pytest.approx(-5.5) and path.xs[-1] == pytest.approx(5.5)
    assert kerb_positions(jmap, "XBL") == pytest.approx((2.0, 9.0), abs=0.26)


def test_derived_conflicts_match_the_shipped_t_junction() -> None:
    """The same T (stem south, arms west and east, one lane each way, crossings on every
    leg) gives the same typed conflicts as the shipped t-junction, for every kind."""

    def typed(jmap: JunctionMap) -> set[tuple[str, str, str, str]]:
        kinds = ("car", "cyclist", "pedestrian")
        return {(c.ego, c.kind, c.route, c.type) for c in derive_conflicts(jmap, kinds)}

    assert typed(load_map(str(T_XODR))) == typed(load_map("t-junction"))


def test_legs_can_be_dropped_and_unknown_ones_are_named() -> None:
    net = read_opendrive(T_XODR)
    data = junction_map_data(net, "100", legs=["B", "L"])
    assert set(data["lanes"]["routes"]) == {"B-L", "L-B"}
    with pytest.raises(ConfigError, match="legs: expected one of"):
        junction_map_data(net, "100", legs=["B", "X"])
    with pytest.raises(ConfigError, match=r"junction: expected a junction id of the file \(100\)"):
        junction_map_data(net, "7")
    assert [leg.name for leg in junction_legs(net, "100")] == ["L", "R", "B"]


def test_map_import_writes_a_map_that_loads_and_derives(tmp_path: Path, capsys) -> None:
    out = tmp_path / "t.yaml"
    main(["map", "import", str(T_XODR), "--out", str(out)])
    data = yaml.safe_load(out.read_text())
    assert data["layout"] == "lanes" and data["lanes"]["source"]["junction"] == "100"
    jmap = load_map(str(out))
    assert jmap.movements == load_map(str(T_XODR)).movements
    hs = tmp_path / "hs.yaml"
    main(
        ["hyperspace", "derive", "--map", str(out), "--actors", "car,pedestrian", "--out", str(hs)]
    )
    derived = yaml.safe_load(hs.read_text())
    assert derived["metadata"]["map"] == str(out)
    main(["map", "import", str(T_XODR), "--list"])
    text = capsys.readouterr().out
    assert "junction 100 (T) at (0, 0), 3 legs: L road 1 180 deg in 1 out 1" in text


def test_bad_input_is_one_line_naming_the_file(tmp_path: Path, capsys) -> None:
    with pytest.raises(SystemExit) as exit_:
        main(["map", "import", str(T_XODR), "--junction", "9"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err.strip()
    assert str(T_XODR) in err and "junction" in err and "\n" not in err
    bad = tmp_path / "bad.xodr"
    bad.write_text("<OpenDRIVE><road id='1' length='5'/></OpenDRIVE>")
    with pytest.raises(ConfigError, match=r"bad.xodr: road\[id=1\]/planView"):
        load_map(str(bad))


def test_a_file_with_several_junctions_needs_one_named(tmp_path: Path) -> None:
    net_text = T_XODR.read_text().replace(
        "</OpenDRIVE>", '<junction id="200" name="spare"></junction></OpenDRIVE>'
    )
    two = tmp_path / "two.xodr"
    two.write_text(net_text)
    with pytest.raises(ConfigError, match=r"two.xodr: junction: expected FILE.xodr#ID naming one"):
        load_map(str(two))
    assert load_map(f"{two}#100").movements


def test_lane_lengths_must_match_the_legs(tmp_path: Path) -> None:
    data = junction_map_data(read_opendrive(T_XODR), "100")
    data["lanes"]["routes"]["L-R"]["in"] = data["lanes"]["routes"]["L-R"]["in"][5:]
    with pytest.raises(ConfigError, match=r"lanes.routes.L-R.in: expected a lane as long as leg L"):
        JunctionMap(data, source="x.yaml")


def test_compare_puts_both_maps_in_one_frame() -> None:
    """The test T (mouths 10 m, arcs of radius 10 m) against the shipped t-junction (mouths
    12 m, tangent arcs): same legs, spawns within the mouth difference, conflict points
    within 2.5 m; moved by (3, 4) m, every spawn moves 5 m."""
    from sitcov.sim.embedded._compare import compare_maps

    t = load_map(str(T_XODR))
    same = compare_maps(load_map("t-junction"), t)
    assert set(same["legs"]) == {"B", "L", "R"}
    assert all(leg["heading_diff_deg"] == 0.0 for leg in same["legs"].values())
    assert len(same["conflicts"]) == 12
    assert all(c["distance"] < 2.5 for c in same["conflicts"].values())
    assert all(sp["ego"] < 1e-6 for sp in same["spawns"].values())
    moved = compare_maps(t, t, at_a=(3.0, 4.0, 0.0))
    assert all(sp["ego"] == pytest.approx(5.0) for sp in moved["spawns"].values())
    assert all(c["distance"] == pytest.approx(5.0, abs=0.01) for c in moved["conflicts"].values())


def test_mouth_crosswalks_where_the_file_has_none(tmp_path: Path) -> None:
    """Without crosswalk objects a leg has no crossing, unless asked: then one like the
    shipped maps' (1 m outside the mouth, 3 m wide) across the lanes between the sidewalks."""
    import re

    bare = tmp_path / "bare.xodr"
    bare.write_text(re.sub(r"<objects>.*?</objects>", "", T_XODR.read_text(), flags=re.S))
    net = read_opendrive(bare)
    assert junction_map_data(net, "100")["lanes"]["crosswalks"] == {}
    data = junction_map_data(net, "100", mouth_crosswalks=True)
    assert set(data["lanes"]["crosswalks"]) == {"B", "L", "R"}
    assert data["legs"]["B"]["crosswalk"] == {"offset": 1.0, "width": 3.0}
    jmap = JunctionMap(data, source="bare.yaml")
    path = actor_route(jmap, "pedestrian", "XBR")
    assert np.allclose(path.ys, -12.5, atol=1e-6)
    assert path.xs[0] == pytest.approx(5.5) and path.xs[-1] == pytest.approx(-5.5)
    assert kerb_positions(jmap, "XBR") == pytest.approx((2.0, 9.0), abs=0.26)


@pytest.mark.slow
def test_every_town03_junction_imports_or_says_why() -> None:
    """All 34 junctions of Town03: a map with derived conflicts, or one ConfigError line
    (junction 685: a leg whose lanes end 5.9 m out)."""
    from tests.roads._shared import town03

    net = read_opendrive(town03())
    imported, refused = 0, []
    for row in list_junctions(net):
        try:
            jmap = JunctionMap(junction_map_data(net, row["id"], mouth_crosswalks=True))
        except ConfigError as err:
            refused.append(row["id"])
            assert "\n" not in str(err)
            continue
        assert derive_conflicts(jmap, ("car", "cyclist", "pedestrian"))
        imported += 1
    assert imported == 33 and refused == ["685"]


def test_bench_runs_on_an_imported_map() -> None:
    from sitcov.campaign._bench import bench

    result = bench(6, 0, map=str(T_XODR), warmup=1)
    assert result["runs"] == 6 and result["runs_per_s"] > 0
