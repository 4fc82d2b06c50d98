"""One recorded run as OpenSCENARIO: trajectories within tolerance, every road user, the
stored verdict as parameters, a valid ASAM OpenSCENARIO 1.2 document."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import pytest
from needs import need_module, need_schema

from sitcov.av import make_stack
from sitcov.hyperspace import Situation
from sitcov.sim import Trace
from sitcov.sim.embedded import EmbeddedBackend
from sitcov.sim.xosc import RunFacts, environment, facts_of, run_scenario, simplify
from sitcov.sim.xosc._scenario import TOLERANCE


def _interp(kept, t):
    for a, b in zip(kept, kept[1:], strict=False):
        if a[0] <= t <= b[0]:
            f = (t - a[0]) / (b[0] - a[0])
            return a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2])
    raise AssertionError(t)


def test_simplify_keeps_every_row_within_tolerance(rng):
    rows, x, y, h, v = [], 0.0, 0.0, 0.0, 0.0
    for k in range(600):  # accelerate, turn, stop, wait, go: a car's day
        v = max(0.0, v + float(rng.uniform(-1.5, 2.0)) * 0.05)
        h += float(rng.uniform(-0.05, 0.05))
        x, y = x + v * math.cos(h) * 0.05, y + v * math.sin(h) * 0.05
        rows.append((k * 0.05, x, y, h, v))
    kept = simplify(rows)
    assert kept[0] == rows[0] and kept[-1] == rows[-1]
    assert len(kept) < len(rows)
    for r in rows:
        px, py = _interp(kept, r[0])
        assert math.hypot(px - r[1], py - r[2]) <= TOLERANCE + 1e-9


def test_simplify_compresses_constant_velocity_to_its_ends():
    rows = [(0.05 * k, 2.0 * 0.05 * k, 1.0, 0.0, 2.0) for k in range(200)]
    assert simplify(rows) == [rows[0], rows[-1]]


def _recorded(intsit, actor2="none", av="no-perception"):
    values = {"friction": 0.8, "intsit": intsit, "actor2": actor2}
    bins = {"friction": "0.8", "intsit": "x", "actor2": "y"}
    sit = Situation(bins, values)
    stack = make_stack(av)
    outcome = EmbeddedBackend(map="crossroads").run(sit, stack, 7, record=True)
    stack.close()
    return sit, outcome


def _facts(outcome, **changes):
    base = RunFacts(
        "c",
        3,
        7,
        "f2",
        outcome.status,
        outcome.kind,
        outcome.end_reason,
        outcome.metrics.get("collision_actor") or "",
        outcome.collision_time or -1.0,
        outcome.sim_time,
    )
    return RunFacts(**{**base.__dict__, **changes})


def _tostring(scenario) -> str:
    return ET.tostring(scenario.get_element(), encoding="unicode")


def _root(sit, trace, facts, road="x.xodr") -> ET.Element:
    scenario = run_scenario(sit, trace, facts, road_file=road, map_name="crossroads")
    return ET.fromstring(_tostring(scenario))


def test_scenario_has_every_road_user_on_its_stored_trajectory():
    need_module("scenariogeneration", "xosc")
    sit, outcome = _recorded(
        {"ego": "B-T", "ov": "L-R", "conflict": "k1", "kind": "car"},
        {"kind": "pedestrian", "route": "XTR", "behaviour": "cross"},
    )
    trace = outcome.trace
    root = _root(sit, trace, _facts(outcome), "crossroads.xodr")
    names = {o.get("name") for o in root.iter("ScenarioObject")}
    assert names == {"hero", *trace.actors}
    assert root.find("RoadNetwork/LogicFile").get("filepath") == "crossroads.xodr"
    for action in root.iter("FollowTrajectoryAction"):
        vertices = list(action.iter("Vertex"))
        times = [float(v.get("time")) for v in vertices]
        assert times == sorted(times) and len(times) >= 2
    params = {p.get("name"): p.get("value") for p in root.iter("ParameterDeclaration")}
    assert params["sitcov_fault"] == "f2" and params["sitcov_seed"] == "7"
    assert params["sitcov_status"] == outcome.status
    assert params["sitcov_situation"] == sit.id
    # the pedestrian entity is a Pedestrian with sitcov's box
    ped = next(o for o in root.iter("ScenarioObject") if o.find("Pedestrian") is not None)
    dims = ped.find("Pedestrian/BoundingBox/Dimensions")
    assert float(dims.get("width")) == pytest.approx(trace.meta["actors"][ped.get("name")]["width"])


def test_first_vertex_is_the_stored_start_and_the_hero_box_is_sitcovs():
    need_module("scenariogeneration", "xosc")
    sit, outcome = _recorded({"ego": "B-L", "ov": "R-B", "conflict": "k2", "kind": "car"})
    root = _root(sit, outcome.trace, _facts(outcome))
    hero = next(o for o in root.iter("ScenarioObject") if o.get("name") == "hero")
    dims = hero.find("Vehicle/BoundingBox/Dimensions")
    assert float(dims.get("length")) == pytest.approx(outcome.trace.meta["length"])
    assert float(hero.find("Vehicle/Axles/RearAxle").get("positionX")) == 0.0
    first = next(root.iter("FollowTrajectoryAction")).find(".//Vertex/Position/WorldPosition")
    t, x, y, h, _ = outcome.trace.ego[0]
    assert (float(first.get("x")), float(first.get("y"))) == pytest.approx((x, y), abs=1e-3)


def test_a_road_user_that_left_the_world_is_deleted_then():
    need_module("scenariogeneration", "xosc")
    sit, outcome = _recorded({"ego": "B-L", "ov": "R-B", "conflict": "k2", "kind": "car"})
    trace = outcome.trace
    short = Trace(trace.ego, trace.ov, trace.meta, {**trace.actors, "ov": trace.actors["ov"][:40]})
    text = _tostring(
        run_scenario(
            sit, short, _facts(outcome, sim_time=30.0), road_file="x.xodr", map_name="crossroads"
        )
    )
    assert "DeleteEntityAction" in text and "ov_route_end" in text
    text = _tostring(
        run_scenario(sit, trace, _facts(outcome), road_file="x.xodr", map_name="crossroads")
    )
    assert "DeleteEntityAction" not in text


def test_scenario_is_valid_openscenario_1_2(tmp_path):
    need_module("scenariogeneration", "xosc")
    xmlschema = need_module("xmlschema", "test")
    schema = xmlschema.XMLSchema(str(need_schema("OpenSCENARIOv1.2.xsd")))
    sit, outcome = _recorded(
        {"ego": "L-R", "ov": "R-B", "conflict": "k1", "kind": "cyclist"},
        {"kind": "pedestrian", "route": "XBL", "behaviour": "hesitate"},
    )
    path = tmp_path / "s.xosc"
    env = environment({"cloudiness": 50.0, "precipitation": 30.0, "fog_density": 40.0})
    scenario = run_scenario(
        sit, outcome.trace, _facts(outcome), road_file="x.xodr", map_name="crossroads",
        environment=env,
    )  # fmt: skip
    scenario.write_xml(str(path))
    assert list(schema.iter_errors(str(path))) == []


def test_facts_of_a_stored_run_name_the_road_user_hit():
    _, outcome = _recorded({"ego": "B-L", "ov": "R-B", "conflict": "k2", "kind": "car"})

    class Run:
        campaign, index, seed, config = "c", 1, 7, {"fault": None}

    facts = facts_of(Run, outcome)
    assert facts.fault == "none" and facts.status == outcome.status
    hit = outcome.metrics.get("collision_actor") or ("ov" if outcome.collision else "")
    assert outcome.collision and facts.collision_actor == hit == "ov"
    assert facts.collision_time == outcome.collision_time
