"""Road departure facts of the CARLA backend (against the in-memory fake server)."""

from __future__ import annotations

from carla_testkit import DrivingStack, fake_backend, situation, small_map

from sitcov.av import AVStack, Control
from sitcov.sim import Judge


class SteerOff(AVStack):
    """Drives at full lock to the right from the start: off the road within a few metres."""

    name = "test-steer-off"

    def reset(self, info) -> None:
        pass

    def step(self, observation) -> Control:
        return Control(throttle=0.5, brake=0.0, steer=-1.0)


def test_ego_on_its_route_stays_on_the_road(tmp_path) -> None:
    backend, server = fake_backend(small_map(tmp_path))
    server.collision_radius = 0.0
    outcome = backend.run(situation("R-B", "L-B", "c4"), DrivingStack(), seed=1)
    assert outcome.end_reason == "goal"
    assert outcome.metrics["road_departure_time"] is None
    assert outcome.metrics["lane_departure_time"] is None  # not reported by this backend


def test_ego_steering_off_the_road_is_a_road_departure(tmp_path) -> None:
    backend, server = fake_backend(small_map(tmp_path))
    server.collision_radius = 0.0
    outcome = backend.run(situation(), SteerOff(), seed=1)
    t = outcome.metrics["road_departure_time"]
    assert t is not None and 0.0 < t < outcome.sim_time
    assert outcome.status == "pass"  # the backend reports the fact, the judge decides
    assert Judge.from_spec("default")(outcome).kind == "road_departure"
    assert Judge.from_spec("paper")(outcome).status == "pass"


def test_a_road_everywhere_never_departs(tmp_path) -> None:
    backend, server = fake_backend(small_map(tmp_path))
    server.collision_radius, server.road_half_width = 0.0, 500.0
    outcome = backend.run(situation(), SteerOff(), seed=1)
    assert outcome.metrics["road_departure_time"] is None
