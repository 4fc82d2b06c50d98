"""Behaviour of the CARLA backend against the in-memory fake of the client surface."""

from __future__ import annotations

import math
import socket
import sys
import time

import numpy as np
import pytest
from carla_testkit import WEATHER, DrivingStack, centred_car, fake_backend, situation, small_map
from needs import need_module

from sitcov.av import LatchedReferenceStack
from sitcov.errors import BackendUnavailableError, ConfigError, MissingExtraError
from sitcov.sim import Backend, Judge, conditions_from_values, make_backend
from sitcov.sim._progress import RouteProgress
from sitcov.sim.carla import CarlaBackend
from sitcov.sim.carla._fake import BASE_TIRE_FRICTION


def _index(log: list[tuple], name: str, *, last: bool = False) -> int:
    idx = [i for i, entry in enumerate(log) if entry[0] == name]
    assert idx, f"{name} never called"
    return idx[-1] if last else idx[0]


def test_registered_and_an_interface_implementation() -> None:
    from sitcov import _plugins

    assert _plugins.load("backend", "carla", Backend) is CarlaBackend
    assert "friction" in CarlaBackend.effects(CarlaBackend.__new__(CarlaBackend))


def test_run_sets_up_and_restores_the_world_and_destroys_everything(tmp_path) -> None:
    backend, server = fake_backend(small_map(tmp_path))
    stack = DrivingStack()
    dry = situation(friction=0.4, precipitation=0.0, precipitation_deposits=0.0)
    outcome = backend.run(dry, stack, seed=3)
    log = server.log
    # synchronous with the fixed step first, original (asynchronous) settings restored last
    first, final = _index(log, "apply_settings"), _index(log, "apply_settings", last=True)
    assert log[first][1:] == (True, 0.05)
    assert log[final][1:] == (False, None)
    assert first < _index(log, "spawn") and final > _index(log, "destroy", last=True)
    assert not server.settings.synchronous_mode
    # weather: the seven elements by their CARLA names, exactly the situation's values
    applied = log[_index(log, "set_weather")][1]
    assert {k: applied[k] for k in WEATHER} == {k: dry.values[k] for k in WEATHER}
    assert applied["fog_density"] == 100.0 and applied["cloudiness"] == 20.0
    # friction: every wheel of both vehicles scaled by mu (dry road: mu = friction)
    assert conditions_from_values(dry.values).mu == pytest.approx(0.4)
    physics = [entry for entry in log if entry[0] == "physics"]
    assert len(physics) == 2
    for entry in physics:
        assert entry[2] == pytest.approx([BASE_TIRE_FRICTION * 0.4] * 4)
    readback = outcome.metrics["tire_friction"]
    assert len(readback) == 2 and sum(readback, []) == pytest.approx([1.4] * 8)
    assert outcome.metrics["friction_scale"] == pytest.approx(0.4)
    # every actor and sensor destroyed, sensors stopped before they are destroyed
    spawned = {entry[2] for entry in log if entry[0] == "spawn"}
    destroyed = {entry[1] for entry in log if entry[0] == "destroy"}
    assert len(spawned) == 4 and spawned == destroyed and not server.actors
    assert not [entry for entry in log if entry[0] == "destroy_while_listening"]
    # the camera per CameraSpec, attached to the ego
    camera = next(e for e in log if e[0] == "spawn" and e[1] == "sensor.camera.rgb")
    assert camera[3]["image_size_x"] == "800" and camera[3]["image_size_y"] == "450"
    assert float(camera[3]["fov"]) == 100.0
    assert outcome.status in ("pass", "fail") and outcome.metrics["attempts"] == 1


def test_carla_profile_wetness_leaves_the_wheels_alone(tmp_path) -> None:
    """As CARLA itself: weather is rendering only; the friction element alone scales."""
    backend, _ = fake_backend(small_map(tmp_path))
    dry = backend.run(situation(friction=0.8, wetness=0.0), DrivingStack(), seed=1)
    wet = backend.run(situation(friction=0.8, wetness=100.0), DrivingStack(), seed=1)
    assert wet.metrics["tire_friction"] == dry.metrics["tire_friction"]
    assert wet.metrics["physics"] == "carla" and wet.metrics["friction_scale"] == 0.8


def test_physical_profile_wetness_lowers_the_friction_that_reaches_the_wheels(tmp_path) -> None:
    backend, _ = fake_backend(small_map(tmp_path), physics="physical")
    dry = backend.run(situation(friction=0.8, wetness=0.0), DrivingStack(), seed=1)
    wet = backend.run(situation(friction=0.8, wetness=100.0), DrivingStack(), seed=1)
    assert wet.metrics["tire_friction"][0][0] < dry.metrics["tire_friction"][0][0]
    assert wet.metrics["physics"] == "physical" and wet.metrics["mu"] < dry.metrics["mu"]
    assert "no side force" in backend.effects()["wind_intensity"]


def test_unknown_physics_profile_is_a_config_error(tmp_path) -> None:
    with pytest.raises(ConfigError, match=r"physics: expected carla \| physical"):
        fake_backend(small_map(tmp_path), physics="realistic")


def test_camera_frames_reach_the_stack_at_10_hz_in_the_sitcov_frame(tmp_path) -> None:
    backend, server = fake_backend(small_map(tmp_path))
    stack = DrivingStack()
    server.collision_radius = 0.0  # let the ego drive through
    outcome = backend.run(situation("L-B", "R-B", "c4"), stack, seed=1)
    obs = stack.observations
    images = [o for o in obs if o.image is not None]
    assert images[0].image.shape == (450, 800, 3) and images[0].image.dtype == np.uint8
    assert [o.t for o in images[:3]] == pytest.approx([0.0, 0.1, 0.2])
    # sitcov frame: CARLA (x, y, yaw) -> (x, -y, -yaw); the L spawn is (-40, 1.75, 0 deg)
    assert (obs[0].ego.x, obs[0].ego.y) == pytest.approx((-40.0, -1.75))
    assert stack.info.route[0] == pytest.approx((-40.0, -1.75), abs=1.1)
    assert stack.info.goal == pytest.approx((-1.75, -30.0))
    # steering sign: following its route the ego reaches the goal (a sign error would not)
    assert outcome.end_reason == "goal" and outcome.status == "pass"


@pytest.mark.parametrize(
    "intsit", [("L-R", "B-R", "c1"), ("B-L", "R-L", "c2"), ("R-B", "L-B", "c4")]
)
def test_ego_follows_left_and_right_turns_to_its_goal(tmp_path, intsit) -> None:
    backend, server = fake_backend(small_map(tmp_path))
    server.collision_radius = 0.0
    stack = DrivingStack()
    outcome = backend.run(situation(*intsit), stack, seed=1, record=True)
    assert outcome.end_reason == "goal"
    ego = outcome.trace.ego
    assert ego[0][0] == 0.0 and len(ego) == outcome.metrics["ticks"] + 1
    route = stack.info.route  # sitcov frame, like the trace
    worst = max(min(math.dist((x, y), p) for p in route) for _, x, y, _, _ in ego)
    assert worst < 3.0  # a wrong steering sign would leave the route at once
    m = outcome.metrics  # route progress facts, as the embedded world reports them
    assert m["route_completion"] == 1.0 and m["time_to_goal"] is not None
    assert m["route_incomplete_time"] is None and not m["ego_stopped"]


def test_scripted_collision_fails_the_run(tmp_path) -> None:
    backend, server = fake_backend(small_map(tmp_path))
    server.collide_at_tick = 41
    outcome = backend.run(situation(), DrivingStack(), seed=1)
    assert (outcome.status, outcome.end_reason, outcome.collision) == ("fail", "collision", True)
    # tick 1 settles physics (friction read-back); tick 2 is t = 0; tick 41 is t = 1.95 s
    assert outcome.collision_time == pytest.approx(1.95)
    assert outcome.collision_speed is not None and outcome.min_distance is not None
    m = outcome.metrics  # where: a point in the map frame, the ego's heading, the car hit
    assert len(m["collision_point"]) == 2 and all(math.isfinite(v) for v in m["collision_point"])
    assert math.isfinite(m["collision_heading"]) and m["collision_kind"] == "car"
    assert "max_drac" in m
    assert not server.actors


def test_adversary_meets_a_blind_ego(tmp_path) -> None:
    """The shared timing law brings the OV to the conflict point with the ego."""
    backend, _ = fake_backend(small_map(tmp_path))
    outcome = backend.run(situation("L-R", "B-R", "c1"), DrivingStack(), seed=1)
    assert outcome.status == "fail" and outcome.metrics["ov_released_at"] is not None


def test_aeb_time_recorded_and_run_ends(tmp_path) -> None:
    backend, server = fake_backend(small_map(tmp_path))
    server.collision_radius = 0.0
    stack = LatchedReferenceStack(detector=centred_car)
    outcome = backend.run(situation(), stack, seed=1)
    assert outcome.aeb_fired and outcome.aeb_time == pytest.approx(0.0)
    assert outcome.end_reason in ("stopped", "sim_timeout") and outcome.status == "pass"
    assert not server.actors
    m = outcome.metrics  # braked at once: no progress, the route never completed
    assert m["route_completion"] < 0.05 and m["time_to_goal"] is None
    assert m["route_incomplete_time"] == m["time_budget"] and m["ego_stopped"]
    assert Judge.from_spec("route_incomplete")(outcome).kind == "route_incomplete"


def test_route_progress_follows_the_pose_along_the_route() -> None:
    progress = RouteProgress([(0.0, 0.0), (10.0, 0.0), (10.0, 10.0)], 1.0, 60.0)
    poses = [(0, 0.5, 0.0), (6, 0.4, 5.0), (10.2, 4.0, 5.0), (9.8, 3.0, 0.1)]
    for t, (x, y, v) in enumerate(poses):
        progress.update(float(t), x, y, v, 1.0)
    facts = progress.facts("sim_timeout", latched=False)
    assert facts["route_completion"] == pytest.approx(14.0 / 19.0)  # the farthest point
    assert facts["standstill_time"] == 2.0 and facts["ego_stopped"]
    assert facts["route_incomplete_time"] == 60.0 and facts["time_to_goal"] is None
    progress.update(4.0, 10.0, 9.5, 3.0, 1.0)
    done = progress.facts("goal", latched=False)
    assert done["route_completion"] == 1.0 and done["time_to_goal"] == 4.0


def test_everything_destroyed_and_settings_restored_when_the_stack_raises(tmp_path) -> None:
    backend, server = fake_backend(small_map(tmp_path))
    with pytest.raises(ZeroDivisionError):
        backend.run(situation(), DrivingStack(raise_at=5), seed=1)
    assert not server.actors
    assert not server.settings.synchronous_mode
    assert server.log[-1][0] == "apply_settings"


def test_disconnect_on_tick_is_retried_once(tmp_path) -> None:
    backend, server = fake_backend(small_map(tmp_path))
    server.fail_ticks = 1
    outcome = backend.run(situation(), DrivingStack(), seed=1)
    assert outcome.status in ("pass", "fail") and outcome.metrics["attempts"] == 2
    assert server.connections == 2  # reconnected
    assert not server.actors


def test_persistent_server_failure_gives_an_error_outcome(tmp_path) -> None:
    backend, server = fake_backend(small_map(tmp_path))
    server.fail_ticks = 10**6
    outcome = backend.run(situation(), DrivingStack(), seed=1)
    assert (outcome.status, outcome.end_reason) == ("error", "error")
    assert "time-out" in outcome.message and "twice" in outcome.message
    assert server.connections == 2 and not server.actors
    assert not server.settings.synchronous_mode


def test_friction_that_does_not_take_effect_is_an_error(tmp_path) -> None:
    backend, server = fake_backend(small_map(tmp_path))
    server.ignore_physics = True
    outcome = backend.run(situation(friction=0.2), DrivingStack(), seed=1)
    assert outcome.status == "error" and "friction" in outcome.message
    assert not server.actors


def test_friction_trigger_mode_spawns_a_trigger_over_the_junction(tmp_path) -> None:
    backend, server = fake_backend(small_map(tmp_path), friction_mode="trigger")
    backend.run(situation(friction=0.5), DrivingStack(), seed=1)
    trigger = next(e for e in server.log if e[0] == "spawn" and e[1] == "static.trigger.friction")
    assert float(trigger[3]["friction"]) == pytest.approx(BASE_TIRE_FRICTION * 0.5)
    assert float(trigger[3]["extent_x"]) == pytest.approx(1200.0)  # 12 m in cm
    assert not server.actors


def test_town_loaded_once_and_map_cached_across_runs() -> None:
    backend, server = fake_backend("Town03")
    server.collide_at_tick = 5
    for _ in range(2):
        backend.run(situation(), DrivingStack(), seed=1)
    assert [e for e in server.log if e[0] == "load_world"] == [("load_world", "Town03")]
    assert len([e for e in server.log if e[0] == "get_map"]) == 2  # before and after loading


def test_many_runs_leave_nothing_behind(tmp_path) -> None:
    backend, server = fake_backend(small_map(tmp_path))
    server.collide_at_tick = 4
    for i in range(40):
        backend.run(situation(friction=(0.1, 1.0)[i % 2]), DrivingStack(), seed=i)
    assert not server.actors
    listens = sum(1 for e in server.log if e[0] == "listen")
    stops = sum(1 for e in server.log if e[0] == "stop")
    assert listens == stops == 80
    assert len(backend._routes) == 2


def test_deterministic_on_the_fake(tmp_path) -> None:
    results = []
    for _ in range(2):
        backend, _ = fake_backend(small_map(tmp_path))
        results.append(backend.run(situation("B-L", "R-L", "c2"), DrivingStack(), seed=5))
    assert results[0] == results[1]


def test_worker_index_picks_its_server(tmp_path) -> None:
    backend, server = fake_backend(small_map(tmp_path), servers="a:2001,b:2002", worker_index=3)
    assert (backend.host, backend.port) == ("b", 2002)
    assert ("client", "b", 2002) in server.log


def test_bad_intsit_and_options_are_config_errors(tmp_path) -> None:
    backend, _ = fake_backend(small_map(tmp_path))
    with pytest.raises(ConfigError, match="c3"):
        backend.run(situation(conflict="c3"), DrivingStack(), seed=1)
    with pytest.raises(ConfigError, match="friction_mode"):
        fake_backend(small_map(tmp_path), friction_mode="ice")


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def test_no_server_is_one_clear_error_within_the_timeout() -> None:
    need_module("carla", "carla")
    port = _free_port()
    start = time.monotonic()
    with pytest.raises(BackendUnavailableError) as info:
        make_backend("carla", host="127.0.0.1", port=port, timeout=1.0)
    assert time.monotonic() - start < 5.0
    message = str(info.value)
    assert message == (
        f"no CARLA server at 127.0.0.1:{port} after 1s: "
        "start CarlaUE4.sh or pass --carla-host/--carla-port"
    )


def test_missing_carla_wheel_is_a_missing_extra_error(monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "carla", None)
    with pytest.raises(MissingExtraError, match=r"sitcov\[carla\]"):
        CarlaBackend(connect=False)


def test_frame_conversion_round_trip() -> None:
    from sitcov.sim.carla._geometry import steer_to_carla, to_sitcov

    x, y, yaw = to_sitcov(10.0, 5.0, 90.0)  # CARLA +y is to the right of +x
    assert (x, y, yaw) == pytest.approx((10.0, -5.0, -math.pi / 2))
    assert steer_to_carla(0.3) == pytest.approx(-0.3) and steer_to_carla(-2.0) == 1.0


def test_check_plans_every_route_of_the_map() -> None:
    backend, server = fake_backend("Town03")
    report = backend.check()
    # ego: 3 legs x 2 exits; OV: 3 legs x 2 exits + the stem's left-lane entry B-L
    assert report["routes"].startswith("13 planned")
    assert report["town"].endswith("Town03") and "warning" not in report
    assert not server.actors


def test_server_gone_between_runs_is_an_error_outcome_then_unavailable(tmp_path) -> None:
    backend, server = fake_backend(small_map(tmp_path))
    server.reachable = False
    outcome = backend.run(situation(), DrivingStack(), seed=1)
    assert outcome.status == "error" and "no CARLA server" in outcome.message
    with pytest.raises(BackendUnavailableError):
        backend.run(situation(), DrivingStack(), seed=1)


def test_a_stack_that_wants_objects_stops_with_one_line_and_leaves_nothing(tmp_path) -> None:
    """CARLA gives images only: a stack wanting objects (or detections) is refused in one
    line (a SetupError stops the campaign) and every actor is still destroyed."""
    from sitcov.errors import SetupError

    backend, server = fake_backend(small_map(tmp_path))
    stack = DrivingStack()
    stack.wants = "objects"
    with pytest.raises(SetupError, match="wants objects, which the carla backend does not give"):
        backend.run(situation(), stack, seed=3)
    spawned = sum(entry[0] == "spawn" for entry in server.log)
    destroyed = sum(entry[0] == "destroy" for entry in server.log)
    assert spawned and destroyed == spawned
