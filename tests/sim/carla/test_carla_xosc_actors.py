"""OpenSCENARIO export of every road user: pedestrians as Pedestrian, cyclists as bicycle
Vehicles, on the embedded map's routes, with their controllers' triggers (structure checks:
the project has no OpenSCENARIO XSD validation test)."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest
from carla_testkit import WEATHER
from needs import need_module

from sitcov.errors import ConfigError
from sitcov.hyperspace import Situation
from sitcov.sim.carla import export_xosc, load_carla_map
from sitcov.sim.carla._actors import Frame
from sitcov.sim.embedded._bodies import body_spec
from sitcov.sim.embedded._map import load_map
from sitcov.sim.embedded._routes import actor_route
from sitcov.sim.embedded._scene import own_speed

xosc = need_module("scenariogeneration.xosc", "xosc")

PEDESTRIAN_OV = {"ego": "L-B", "ov": "XBL", "kind": "pedestrian"}
CAR_OV = {"ego": "L-B", "ov": "R-B", "conflict": "c4"}


def scene(intsit: dict[str, str], **slots: Any) -> Situation:
    values: dict[str, Any] = {**WEATHER, "friction": 1.0, "intsit": intsit, **slots}
    return Situation({k: str(v) for k, v in values.items()}, values)


def export(tmp_path: Path, sit: Situation) -> ET.Element:
    (path,) = export_xosc([sit], tmp_path)
    return ET.parse(path).getroot()


def entity(root: ET.Element, name: str) -> ET.Element:
    obj = root.find(f"Entities/ScenarioObject[@name='{name}']")
    assert obj is not None, f"no entity {name}"
    return obj


def events(root: ET.Element, name: str) -> dict[str, ET.Element]:
    group = root.find(f".//ManeuverGroup[@name='{name}_group']")
    assert group is not None and group.find("Actors/EntityRef").get("entityRef") == name
    return {e.get("name"): e for e in group.iter("Event")}


def speed(event: ET.Element) -> float:
    return float(event.find(".//AbsoluteTargetSpeed").get("value"))


def test_a_pedestrian_ov_is_a_pedestrian_entity_on_its_crosswalk(tmp_path: Path) -> None:
    root = export(tmp_path, scene(PEDESTRIAN_OV))
    ped = entity(root, "adversary").find("Pedestrian")
    assert ped is not None and ped.get("pedestrianCategory") == "pedestrian"
    assert ped.get("model") == "walker.pedestrian.0001" and float(ped.get("mass")) > 0.0
    spec = body_spec("pedestrian")
    dims = ped.find("BoundingBox/Dimensions")
    assert [float(dims.get(k)) for k in ("length", "width", "height")] == [
        spec.length,
        spec.width,
        spec.height,
    ]
    # teleported to the crosswalk route's start, in OpenSCENARIO's frame (= sitcov's)
    frame = Frame.of(load_carla_map("Town03"))
    x, y, h = frame.to_sitcov(*actor_route(load_map("t-junction"), "pedestrian", "XBL").point_at(0))
    pos = root.find(".//Private[@entityRef='adversary']//TeleportAction//WorldPosition")
    assert (float(pos.get("x")), float(pos.get("y"))) == pytest.approx((x, y))
    assert float(pos.get("h")) == pytest.approx(h)
    # it walks at its walking speed when the hero comes close, and a collision stops it all
    (walk,) = events(root, "adversary").values()
    assert speed(walk) == pytest.approx(own_speed("pedestrian", 0, 0), abs=1e-3)  # seed 0's
    assert 1.0 <= speed(walk) <= 1.8
    assert walk.find(".//EntityRef").get("entityRef") == "hero"
    stops = root.findall("Storyboard/StopTrigger//CollisionCondition/EntityRef")
    assert [s.get("entityRef") for s in stops] == ["adversary"]


def test_cyclists_are_bicycle_vehicles_and_every_entity_can_collide(tmp_path: Path) -> None:
    sit = scene(
        CAR_OV,
        actor2={"kind": "cyclist", "route": "R-L", "behaviour": "stop-go"},
        actor3={"kind": "pedestrian", "route": "XLR", "behaviour": "hesitate"},
        actor4="none",
    )
    root = export(tmp_path, sit)
    names = [o.get("name") for o in root.findall("Entities/ScenarioObject")]
    assert names == ["hero", "adversary", "actor2", "actor3"]
    bike = entity(root, "actor2").find("Vehicle")
    assert bike.get("vehicleCategory") == "bicycle"
    assert bike.get("name") == "vehicle.diamondback.century"
    assert float(bike.find("Performance").get("maxSpeed")) == body_spec("cyclist").v_max
    assert entity(root, "adversary").find("Vehicle").get("vehicleCategory") == "car"
    stops = root.findall("Storyboard/StopTrigger//CollisionCondition/EntityRef")
    assert [s.get("entityRef") for s in stops] == ["adversary", "actor2", "actor3"]
    route = root.findall(".//Private[@entityRef='actor2']//AssignRouteAction//Waypoint")
    assert len(route) >= 3


def test_stop_go_and_hesitate_stop_then_go_on_after_their_wait(tmp_path: Path) -> None:
    sit = scene(
        CAR_OV,
        actor2={"kind": "cyclist", "route": "R-L", "behaviour": {"name": "stop-go", "wait": 3}},
        actor3={"kind": "pedestrian", "route": "XLR", "behaviour": "hesitate"},
    )
    root = export(tmp_path, sit)
    bike = events(root, "actor2")
    assert list(bike) == ["actor2_go", "actor2_stop", "actor2_go_again"]
    assert speed(bike["actor2_stop"]) == 0.0 and speed(bike["actor2_go_again"]) > 0.0
    again = bike["actor2_go_again"].find(".//Condition")
    assert float(again.get("delay")) == 3.0
    assert again.find(".//EntityRef").get("entityRef") == "actor2"  # it reached its stop
    walker = events(root, "actor3")
    assert list(walker) == ["actor3_walk", "actor3_kerb", "actor3_cross"]
    assert float(walker["actor3_cross"].find(".//Condition").get("delay")) == 1.5


def test_a_pedestrian_that_stays_at_the_kerb_never_crosses(tmp_path: Path) -> None:
    sit = scene(CAR_OV, actor2={"kind": "pedestrian", "route": "XBL", "behaviour": "kerb"})
    walker = events(export(tmp_path, sit), "actor2")
    assert list(walker) == ["actor2_walk", "actor2_kerb"]
    # it stops on the sidewalk: the stop point lies before the kerb on its route
    kerb = walker["actor2_kerb"].find(".//ReachPositionCondition/Position/WorldPosition")
    frame = Frame.of(load_carla_map("Town03"))
    route = actor_route(load_map("t-junction"), "pedestrian", "XBL")
    mx, my, _ = frame.to_map(float(kerb.get("x")), float(kerb.get("y")), 0.0)
    s, _ = route.project(mx, my, 0, 0, len(route.xs))
    assert 0.0 < s < load_map("t-junction").sidewalk_width


def test_export_with_actors_is_deterministic_and_read_back(tmp_path: Path) -> None:
    sit = scene(PEDESTRIAN_OV, actor2={"kind": "cyclist", "route": "R-L"})
    (a,) = export_xosc([sit], tmp_path / "a")
    (b,) = export_xosc([sit], tmp_path / "b")
    assert a.read_bytes() == b.read_bytes()
    parsed = xosc.ParseOpenScenario(str(a))
    assert [o.name for o in parsed.entities.scenario_objects] == ["hero", "adversary", "actor2"]


def test_timed_cyclist_starts_when_the_hero_is_its_travel_time_away(tmp_path: Path) -> None:
    sit = scene({"ego": "L-R", "ov": "B-L", "kind": "cyclist"})
    (approach,) = events(export(tmp_path, sit), "adversary").values()
    spec = body_spec("cyclist")
    v = own_speed("cyclist", 0, 0)  # the export's seed 0 draws it
    assert speed(approach) == pytest.approx(v, abs=1e-3) and 3.0 <= v <= 7.0
    radius = float(approach.find(".//ReachPositionCondition").get("tolerance"))
    # the hero's distance at 25 km/h covers at least the cyclist's ramp-up time
    assert radius > 25.0 / 3.6 * v / (2.0 * spec.a_max)
    assert math.isfinite(radius)


def test_a_bad_actor_slot_is_a_one_line_error(tmp_path: Path) -> None:
    bad = scene(CAR_OV, actor2={"kind": "horse", "route": "XBL"})
    with pytest.raises(ConfigError, match="actor2.kind") as err:
        export_xosc([bad], tmp_path)
    assert "\n" not in str(err.value)
