"""OpenSCENARIO export: valid XML that scenariogeneration reads back, one file per situation."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import pytest
from carla_testkit import situation
from needs import need_module

from sitcov.errors import ConfigError
from sitcov.sim.carla import export_xosc, load_carla_map, situations_from_json
from sitcov.sim.carla._xosc import approach_speed, ego_start

xosc = need_module("scenariogeneration.xosc", "xosc")

#: The paper's twelve intersection situations (its Table 1).
INTSITS = [
    ("L-B", "R-B", "c4"), ("L-R", "R-B", "c4"), ("L-R", "B-R", "c1"), ("L-R", "B-L", "c1"),
    ("B-L", "L-R", "c1"), ("B-L", "R-L", "c2"), ("B-L", "R-B", "c2"), ("B-R", "L-R", "c1"),
    ("R-L", "B-L", "c2"), ("R-B", "B-L", "c2"), ("R-B", "L-R", "c4"), ("R-B", "L-B", "c4"),
]  # fmt: skip


def test_one_valid_file_per_situation(tmp_path) -> None:
    sits = [situation(*i, friction=0.2) for i in INTSITS]
    paths = export_xosc(sits + sits[:2], tmp_path)  # duplicates are written once
    assert len(paths) == 12 and {p.stem for p in paths} == {s.id for s in sits}
    town = load_carla_map("Town03")
    for sit, path in zip(sits, paths, strict=True):
        root = ET.parse(path).getroot()  # well-formed XML
        assert root.tag == "OpenSCENARIO"
        assert root.find("FileHeader").get("revMajor") == "1"
        assert root.find(".//LogicFile").get("filepath") == "Town03"
        # friction: the backend's scale (dry road: the friction value itself)
        assert float(root.find(".//RoadCondition").get("frictionScaleFactor")) == 0.2
        # the ego's spawn in OpenSCENARIO's right-handed frame: (x, -y), heading -yaw; a
        # left turn from the stem starts in the stem's left lane (4 m left of the map's)
        move = sit.values["intsit"]["ego"]
        spawn = ego_start(town, move)
        assert spawn.x == pytest.approx(town.ego_spawn(move).x - (4.0 if move == "B-L" else 0))
        hero = root.find(".//Private[@entityRef='hero']//TeleportAction//WorldPosition")
        assert float(hero.get("x")) == spawn.x and float(hero.get("y")) == -spawn.y
        assert float(hero.get("h")) == pytest.approx(-math.radians(spawn.yaw))
        stop = root.find("Storyboard/StopTrigger")
        assert len(stop.findall("ConditionGroup")) == 3


def _read_back(path) -> None:
    parsed = xosc.ParseOpenScenario(str(path))
    assert [o.name for o in parsed.entities.scenario_objects] == ["hero", "adversary"]
    assert parsed.storyboard.init is not None


def test_scenariogeneration_reads_a_file_back(tmp_path) -> None:
    (path,) = export_xosc([situation(*INTSITS[3])], tmp_path)
    _read_back(path)


@pytest.mark.slow
def test_scenariogeneration_reads_all_twelve_back(tmp_path) -> None:
    for path in export_xosc([situation(*i) for i in INTSITS], tmp_path):
        _read_back(path)


def test_weather_and_parameters_carry_the_situation(tmp_path) -> None:
    sit = situation(fog_density=100.0, fog_distance=0.0, cloudiness=80.0, precipitation=60.0)
    (path,) = export_xosc([sit], tmp_path)
    root = ET.parse(path).getroot()
    weather = root.find(".//Weather")
    assert weather.get("cloudState") == "rainy"
    assert int(root.find(".//Fog").get("visualRange")) < 100  # dense fog
    assert float(root.find(".//Precipitation").get("intensity")) == pytest.approx(0.6)
    params = {p.get("name"): p.get("value") for p in root.iter("ParameterDeclaration")}
    assert params["sitcov_situation"] == sit.id and float(params["carla_fog_density"]) == 100.0


def test_export_is_deterministic(tmp_path) -> None:
    sit = situation()
    (a,) = export_xosc([sit], tmp_path / "a")
    (b,) = export_xosc([sit], tmp_path / "b")
    assert a.read_bytes() == b.read_bytes()


def test_approach_speed_meets_the_ego_at_the_conflict_point() -> None:
    d_ego, d_ov = 80.0, 30.0
    v = approach_speed(d_ego, d_ov)
    a, v_ego = 2.0, 25 / 3.6
    t_ego = (d_ego - v_ego**2 / (2 * a)) / v_ego + v_ego / a  # ramp, then cruise
    t_ov = (d_ov - v * v / (2 * a)) / v + v / a
    assert t_ov == pytest.approx(t_ego, rel=1e-6)


def test_situations_from_json_forms(tmp_path) -> None:
    import json

    a, b = situation(), situation("B-L", "L-R", "c1")
    lines = "\n".join(json.dumps(s.to_dict()) for s in (a, b))
    assert situations_from_json(lines) == [a, b]
    assert situations_from_json(json.dumps([a.to_dict()])) == [a]
    file = tmp_path / "s.jsonl"
    file.write_text(lines)
    assert situations_from_json(f"@{file}") == [a, b]
    with pytest.raises(ConfigError, match="bins"):
        situations_from_json('{"id": 1}')
    with pytest.raises(ConfigError, match="JSON"):
        situations_from_json("{nope")
