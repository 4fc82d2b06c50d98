"""Pedestrians, cyclists and extra cars in CARLA (fake server): spawned from the embedded
map's routes, driven by the embedded controllers through WalkerControl / VehicleControl."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from carla_testkit import SMALL_MAP, WEATHER, DrivingStack, fake_backend, small_map

from sitcov.errors import ConfigError
from sitcov.hyperspace import Situation
from sitcov.sim.carla import load_carla_map
from sitcov.sim.carla._actors import Frame
from sitcov.sim.embedded._bodies import body_spec
from sitcov.sim.embedded._map import load_map
from sitcov.sim.embedded._routes import actor_route, kerb_positions

DT = 0.05


def scene(intsit: dict[str, str], **slots: Any) -> Situation:
    values: dict[str, Any] = {**WEATHER, "friction": 1.0, "intsit": intsit, **slots}
    return Situation({k: str(v) for k, v in values.items()}, values)


PEDESTRIAN_OV = {"ego": "L-B", "ov": "XBL", "kind": "pedestrian"}
CYCLIST_OV = {"ego": "L-R", "ov": "B-L", "kind": "cyclist"}
CAR_OV = {"ego": "L-B", "ov": "R-B", "conflict": "c4"}


def walker_controls(server: Any, actor_id: int) -> list[tuple[float, float, float]]:
    return [e[2:] for e in server.log if e[0] == "walker_control" and e[1] == actor_id]


def spawned(server: Any) -> dict[str, int]:
    return {e[1]: e[2] for e in server.log if e[0] == "spawn"}


def test_a_blind_ego_hits_the_timed_pedestrian(tmp_path: Path) -> None:
    backend, server = fake_backend(small_map(tmp_path))
    out = backend.run(scene(PEDESTRIAN_OV), DrivingStack(), seed=1)
    assert (out.status, out.end_reason) == ("fail", "collision")
    assert out.metrics["collision_actor"] == "ov"
    assert out.metrics["collision_kind"] == "pedestrian"
    assert out.collision_speed is not None and out.collision_speed > 0.0
    assert len(out.metrics["collision_point"]) == 2  # where the ego hit the pedestrian
    spawn = next(e for e in server.log if e[0] == "spawn" and e[1].startswith("walker."))
    assert spawn[1] == "walker.pedestrian.0001"
    assert spawn[3]["is_invincible"] == "false"  # a walker that can be hit
    assert server.actors == {}  # everything destroyed


#: A lane route like the fake server's for the ego's L-B (CARLA frame): east to the
#: junction centre, a sharp corner, then on to leg B's goal, beside the embedded ego path.
CORNER_ROUTE = [(float(x), -1.75 * x / 40.0) for x in range(-40, 1)] + [
    (-1.75 * y / 30.0, float(y)) for y in range(1, 31)
]


def test_timed_twins_meet_the_ego_on_its_carla_route(tmp_path: Path) -> None:
    """The timing law measures the ego on the route it drives in CARLA, not on the embedded
    ego path: the twin's conflict is the one with that route, and the ego's arc length
    follows it through a corner the ego cuts (the blind-ego collisions depend on both)."""
    from sitcov.sim.carla._actors import Scene, plan_scene
    from sitcov.sim.carla._metrics import VehicleState
    from sitcov.sim.embedded._map import find_conflict

    spec = load_carla_map(small_map(tmp_path))
    sit = scene(PEDESTRIAN_OV)
    planned = plan_scene(spec, sit.values, 1, CORNER_ROUTE)
    frame = Frame.of(spec)
    ego_path = planned.ego.route
    expected = [frame.to_map(x, -y, 0.0)[:2] for x, y in CORNER_ROUTE]
    assert [c for p in ego_path.points for c in p] == pytest.approx(
        [c for p in expected for c in p]
    )
    (ped,) = planned.actors
    gap = 0.5 * (body_spec("car").width + body_spec("pedestrian").width)
    conflict = find_conflict(ego_path, ped.route, gap)
    assert ped.controller.s_ego == pytest.approx(conflict.s_ego)
    assert ped.controller.s_self == pytest.approx(conflict.s_ov)
    # without the route: the embedded ego path, a different ruler (about 24 m longer here)
    embedded = plan_scene(spec, sit.values, 1).actors[0].controller.s_ego
    assert abs(embedded - conflict.s_ego) > 5.0
    # an ego cutting the corner inside (as the fake server's ego drove it): its arc length
    # keeps growing past the corner
    view = Scene(planned, [], [(x, -y) for x, y in CORNER_ROUTE], DT, 1.0)
    ego_xy = [(float(x), 1.75 * x / 40.0) for x in range(-40, -4)]
    ego_xy += [(-3.44, -0.58), (-2.21, -1.79), (-1.38, -3.31), (-0.88, -4.97), (-0.62, -6.69)]
    ego_xy += [(-0.52 - 0.04 * j, -8.42 - j) for j in range(20)]
    arc = []
    for k, (sx, sy) in enumerate(ego_xy):
        view.observe(k * 0.2, VehicleState(sx, sy, 0.0, 5.0, 0.0, 2.4, 0.9), record=False)
        arc.append(planned.ego.s)
    assert np.all(np.diff(arc) > 0.0)
    assert arc[-1] == pytest.approx(ego_path.length - 2.6, abs=0.5)  # y = -27.4: 2.6 m to go


@pytest.mark.slow
@pytest.mark.parametrize("intsit", [PEDESTRIAN_OV, CYCLIST_OV], ids=["pedestrian", "cyclist"])
def test_a_blind_ego_hits_timed_road_users_on_every_seed(tmp_path: Path, intsit: dict) -> None:
    backend, _ = fake_backend(small_map(tmp_path))
    for seed in range(4):
        out = backend.run(scene(intsit), DrivingStack(), seed=seed)
        assert (out.status, out.end_reason) == ("fail", "collision"), seed
        assert out.metrics["collision_kind"] == intsit["kind"]


def test_walker_control_is_unit_direction_and_body_limited_speed(tmp_path: Path) -> None:
    backend, server = fake_backend(small_map(tmp_path))
    backend.run(scene(PEDESTRIAN_OV), DrivingStack(), seed=1)
    controls = walker_controls(server, spawned(server)["walker.pedestrian.0001"])
    assert controls, "the walker got no WalkerControl"
    spec = body_spec("pedestrian")
    speeds = [c[2] for c in controls]
    assert max(speeds) > 0.5 and all(0.0 <= v <= spec.v_max for v in speeds)
    for dx, dy, _ in controls:
        assert math.hypot(dx, dy) == pytest.approx(1.0)
    # the body model's limits: speed rises at most a_max * dt per tick
    steps = np.diff(speeds)
    assert steps.max() <= spec.a_max * DT + 1e-9
    # it stands first (waits for the ego), then walks
    assert speeds[0] == 0.0


def test_pedestrian_spawns_at_the_crosswalk_route_start(tmp_path: Path) -> None:
    backend, _ = fake_backend(small_map(tmp_path))
    out = backend.run(scene(PEDESTRIAN_OV), DrivingStack(), seed=1, record=True)
    route = actor_route(load_map("t-junction"), "pedestrian", "XBL")
    frame = Frame.of(load_carla_map(small_map(tmp_path)))
    x, y, _ = frame.to_sitcov(*route.point_at(0.0))
    t0, px, py, _, _ = out.trace.actors["ov"][0]
    assert (t0, px, py) == pytest.approx((0.0, x, y), abs=1e-9)
    assert out.trace.meta["actors"]["ov"]["kind"] == "pedestrian"


def test_a_pedestrian_told_to_stop_at_the_kerb_stays_off_the_road(tmp_path: Path) -> None:
    backend, _ = fake_backend(small_map(tmp_path))
    ped = {"kind": "pedestrian", "route": "XBL", "behaviour": "kerb"}
    out = backend.run(scene(CAR_OV, actor2=ped), DrivingStack(), seed=2, record=True)
    assert out.metrics["collision_actor"] != "actor2"
    rows = out.trace.actors["actor2"]
    frame = Frame.of(load_carla_map(small_map(tmp_path)))
    route = actor_route(load_map("t-junction"), "pedestrian", "XBL")
    kerb = kerb_positions(load_map("t-junction"), "XBL")[0]
    n = len(route.xs)
    walked = [route.project(*frame.to_map(x, y, 0.0)[:2], 0, 0, n)[0] for _, x, y, _, _ in rows]
    assert max(walked) > 0.5 * kerb  # it did walk up to the kerb ...
    assert max(walked) <= kerb  # ... and not beyond


def test_a_blind_ego_hits_the_timed_cyclist_on_a_two_wheeler(tmp_path: Path) -> None:
    backend, server = fake_backend(small_map(tmp_path))
    out = backend.run(scene(CYCLIST_OV), DrivingStack(), seed=1)
    assert (out.status, out.metrics["collision_kind"]) == ("fail", "cyclist")
    bike = spawned(server)["vehicle.diamondback.century"]
    # the bicycle's tyres get the situation's friction like the cars'
    assert any(e[0] == "physics" and e[1] == bike for e in server.log)
    assert out.metrics["actors"]["ov"]["blueprint"] == "vehicle.diamondback.century"


def test_a_scripted_car_stops_where_its_controller_says(tmp_path: Path) -> None:
    """The embedded ScriptedController's stop point holds in CARLA within half a metre,
    short of where the route the CARLA ego really drives meets the car's (scripted traffic
    keeps the embedded scene's conflict: it must be a real one on the CARLA route too)."""
    from sitcov.sim.carla._actors import plan_scene
    from sitcov.sim.embedded._map import find_conflict
    from sitcov.sim.embedded._path import Path as RoutePath

    backend, _ = fake_backend(small_map(tmp_path))
    sit = scene(
        {"ego": "B-L", "ov": "L-R", "conflict": "c1"},
        actor2={"kind": "car", "route": "R-L", "behaviour": "stop"},
    )
    stack = DrivingStack()
    out = backend.run(sit, stack, seed=1, record=True)
    (car,) = plan_scene(backend.map, sit.values, 1).actors
    frame = Frame.of(backend.map)
    route = car.route
    rows = out.trace.actors["actor2"]
    mx, my, _ = frame.to_map(rows[-1][1], rows[-1][2], 0.0)
    s, _ = route.project(mx, my, 0, 0, len(route.xs))
    assert rows[-1][4] == pytest.approx(0.0, abs=0.05)  # standing
    assert s == pytest.approx(car.controller.stop_at, abs=0.75)
    assert stack.info is not None
    driven = RoutePath.from_points([frame.to_map(x, y, 0.0)[:2] for x, y in stack.info.route])
    real = find_conflict(driven, route, body_spec("car").width)
    assert real is not None, "the CARLA ego's route never meets the scripted car's"
    assert math.dist(real.point, car.conflict.point) < 4.0  # the fake lanes cut the corner
    assert s < real.s_ov  # it stood short of the zone the ego drives through


def test_extra_actors_are_measured_traced_and_deterministic(tmp_path: Path) -> None:
    backend, server = fake_backend(small_map(tmp_path))
    sit = scene(
        CAR_OV,
        actor2={"kind": "pedestrian", "route": "XBL", "behaviour": "cross"},
        actor3={"kind": "cyclist", "route": "R-L", "behaviour": "cruise"},
        actor4="none",
    )
    a = backend.run(sit, DrivingStack(), seed=3, record=True)
    b = backend.run(sit, DrivingStack(), seed=3, record=True)
    assert a.metrics["actors"] == b.metrics["actors"]
    assert a.trace.actors == b.trace.actors
    kinds = {name: m["kind"] for name, m in a.metrics["actors"].items()}
    assert kinds == {"ov": "car", "actor2": "pedestrian", "actor3": "cyclist"}
    assert set(a.trace.actors) == {"ov", "actor2", "actor3"}
    meta = a.trace.meta["actors"]
    assert {n: m["kind"] for n, m in meta.items()} == kinds
    assert meta["ov"]["length"] == pytest.approx(4.8) and len(meta["ov"]["route"]) > 10
    assert all(m["min_distance"] is not None for m in a.metrics["actors"].values())
    # the scripted cyclist moved along its route
    rows = a.trace.actors["actor3"]
    assert math.dist(rows[0][1:3], rows[-1][1:3]) > 5.0
    assert server.actors == {}


def test_paper_situation_spawns_only_the_two_cars(tmp_path: Path) -> None:
    backend, server = fake_backend(small_map(tmp_path))
    out = backend.run(scene(CAR_OV), DrivingStack(), seed=1)
    ids = [e[1] for e in server.log if e[0] == "spawn" and not e[1].startswith("sensor.")]
    assert ids == ["vehicle.tesla.model3", "vehicle.audi.tt"]
    assert "actors" not in out.metrics and "collision_actor" not in out.metrics


def test_a_four_wheeled_bicycle_blueprint_is_a_one_line_error(tmp_path: Path) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(SMALL_MAP + "bicycle_blueprint: vehicle.audi.tt\n", encoding="utf-8")
    backend, server = fake_backend(path)
    with pytest.raises(ConfigError, match="bicycle_blueprint.*two-wheeled") as err:
        backend.run(scene(CYCLIST_OV), DrivingStack(), seed=1)
    assert "\n" not in str(err.value)
    assert server.actors == {}  # what was spawned before the error is gone


@pytest.mark.parametrize(
    ("field", "value"),
    [("walker_blueprint", "vehicle.audi.tt"), ("bicycle_blueprint", "walker.pedestrian.0001")],
)
def test_map_file_rejects_a_blueprint_of_the_wrong_family(
    tmp_path: Path, field: str, value: str
) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(SMALL_MAP + f"{field}: {value}\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=field):
        load_carla_map(path)


def test_a_route_the_embedded_map_lacks_is_a_one_line_error(tmp_path: Path) -> None:
    backend, _ = fake_backend(small_map(tmp_path))
    bad = scene(CAR_OV, actor2={"kind": "pedestrian", "route": "XQL"})
    with pytest.raises(ConfigError, match="XQL"):
        backend.run(bad, DrivingStack(), seed=1)


def test_frame_round_trip_and_carla_mirror() -> None:
    rng = np.random.default_rng(7)
    for _ in range(50):
        frame = Frame(*rng.uniform(-100, 100, 2), rng.uniform(-math.pi, math.pi))
        x, y, h = rng.uniform(-50, 50), rng.uniform(-50, 50), rng.uniform(-3, 3)
        assert frame.to_map(*frame.to_sitcov(x, y, h)) == pytest.approx((x, y, h))
        cx, cy, yaw = frame.to_carla(x, y, h)
        sx, sy, sh = frame.to_sitcov(x, y, h)
        assert (cx, cy, yaw) == pytest.approx((sx, -sy, -math.degrees(sh)))


def test_carla_check_looks_up_the_walker_and_bicycle_blueprints(tmp_path: Path) -> None:
    backend, _ = fake_backend(small_map(tmp_path))
    report = backend.check()["road_users"]
    assert "walker.pedestrian.0001" in report and "vehicle.diamondback.century" in report
    path = tmp_path / "bad.yaml"
    path.write_text(SMALL_MAP + "bicycle_blueprint: vehicle.tesla.model3\n", encoding="utf-8")
    bad, _ = fake_backend(path)
    with pytest.raises(ConfigError, match="4 wheels"):
        bad.check()


def test_a_derived_car_conflict_takes_its_point_from_the_embedded_scene(tmp_path: Path) -> None:
    """Derived situations label conflicts k1, k2, ...: the map file has only the paper's."""
    from sitcov.sim.carla._actors import conflict_point
    from sitcov.sim.embedded._scene import build_actors, parse_scene

    spec = load_carla_map("Town03")
    sit = scene({"ego": "L-B", "ov": "R-B", "conflict": "k99"})
    jmap = load_map("t-junction")
    _, (ov,) = build_actors(jmap, parse_scene(sit.values), sit.values, 0, _params())
    x, y, _ = Frame.of(spec).to_carla(*ov.conflict.point, 0.0)
    assert conflict_point(spec, sit.values, "k99") == pytest.approx((x, y))
    assert conflict_point(spec, sit.values, "c4") == spec.conflict_points["c4"]
    backend, server = fake_backend("Town03")
    out = backend.run(sit, DrivingStack(), seed=1)
    assert out.status in ("pass", "fail") and server.actors == {}
    apart = scene({"ego": "L-B", "ov": "B-R", "conflict": "k98"})  # two right turns
    with pytest.raises(ConfigError, match="conflict_points"):
        conflict_point(spec, apart.values, "k98")


def _params() -> Any:
    from sitcov.sim._adversary import AdversaryParams

    return AdversaryParams()


@pytest.mark.slow
def test_the_shipped_derived_hyperspace_runs_and_exports(tmp_path: Path) -> None:
    """Situations of the derived T-junction hyperspace run on the fake Town03 without an
    error, a blind ego collides in most, nothing stays behind, and every one exports."""
    from sitcov.generation import generate, make_generator
    from sitcov.hyperspace import load_hyperspace
    from sitcov.sim.carla import export_xosc

    hs = load_hyperspace("sitcov/hyperspace/data/derived/t-junction.yaml")
    sits = list(generate(make_generator("sitcov", hs), 16, 0, 0))
    backend, server = fake_backend("Town03")
    statuses = [backend.run(s, DrivingStack(), seed=1).status for s in sits]
    assert "error" not in statuses and statuses.count("fail") >= len(sits) // 2
    assert server.actors == {}
    assert len(export_xosc(sits, tmp_path)) == len({s.id for s in sits})
