"""The judge (facts -> verdict and failure kind) and the embedded backend's departure facts."""

from __future__ import annotations

import math

import pytest
from _sim_helpers import make_situation

from sitcov.av import AVStack, Control, make_stack
from sitcov.errors import ConfigError
from sitcov.sim import FAILURE_KINDS, JUDGES, Judge, Outcome, normalize_judge
from sitcov.sim.embedded import EmbeddedBackend, load_map
from sitcov.sim.embedded._monitors import DrivableArea, LaneDepartureMonitor, RoadDepartureMonitor


def facts(
    collision: float | None = None,
    road: float | None = None,
    lane: float | None = None,
    *,
    stationary: bool = False,
    blocked: float | None = None,
    incomplete: float | None = None,
) -> Outcome:
    """A backend outcome with the given first event times (None = did not happen)."""
    return Outcome(
        status="fail" if collision is not None else "pass",
        end_reason="collision" if collision is not None else "goal",
        sim_time=collision if collision is not None else 20.0,
        collision=collision is not None,
        collision_time=collision,
        metrics={
            "road_departure_time": road,
            "lane_departure_time": lane,
            "ego_stationary": stationary and collision is not None,
            "blocked_time": blocked,
            "route_incomplete_time": incomplete,
        },
    )


# --- the judge -----------------------------------------------------------------------------

CASES = [
    # (facts, default, paper, strict)
    (facts(), "pass", "pass", "pass"),
    (facts(collision=5.0), "collision", "collision", "collision"),
    (facts(road=4.0), "road_departure", "pass", "road_departure"),
    (facts(lane=3.0), "pass", "pass", "lane_departure"),
    (facts(lane=2.0, road=3.0), "road_departure", "pass", "lane_departure"),
    (facts(collision=6.0, road=4.0), "road_departure", "collision", "road_departure"),
    (facts(collision=4.0, road=6.0), "collision", "collision", "collision"),
    (facts(collision=4.0, road=4.0, lane=4.0), "collision", "collision", "collision"),
    # someone ran into the standing ego: the paper's judge counts it, default does not
    (facts(collision=5.0, stationary=True), "pass", "ego_stationary", "ego_stationary"),
    # no progress: default and strict fail it, the paper's judge does not
    (facts(blocked=12.0, incomplete=60.0), "blocked", "pass", "blocked"),
    (facts(incomplete=60.0), "route_incomplete", "pass", "route_incomplete"),
    (facts(road=30.0, incomplete=60.0), "road_departure", "pass", "road_departure"),
    (facts(collision=8.0, stationary=True, blocked=5.0), "blocked", "ego_stationary", "blocked"),
]


@pytest.mark.parametrize(("outcome", "default", "paper", "strict"), CASES)
def test_each_kind_under_each_named_judge(outcome, default, paper, strict):
    for name, expected in (("default", default), ("paper", paper), ("strict", strict)):
        judged = Judge.from_spec(name)(outcome)
        assert judged.kind == judged.failure_kind == expected, name
        assert judged.status == ("pass" if expected == "pass" else "fail")
        # the facts are untouched: judging again with another judge gives that judge's view
        assert judged.metrics == outcome.metrics and judged.collision == outcome.collision
    assert Judge.from_spec("paper")(Judge.from_spec("strict")(outcome)).kind == paper


def test_explicit_list_judge_counts_exactly_its_kinds():
    judge = Judge.from_spec(["lane_departure"])
    assert judge.counts == ("lane_departure",) and judge.name == "custom"
    assert judge(facts(collision=2.0)).status == "pass"  # a collision is not counted
    assert judge(facts(lane=1.0)).kind == "lane_departure"
    assert Judge.from_spec("road_departure,collision").name == "custom"
    spec = "route_incomplete,blocked,road_departure,collision"
    assert Judge.from_spec(spec).name == "default"
    assert Judge.from_spec("collision,road_departure,blocked").counts == (
        "collision",
        "road_departure",
        "blocked",
    )


def test_unjudgeable_runs_keep_their_status_and_kind():
    for status in ("error", "timeout"):
        out = Judge.from_spec("strict")(Outcome.errored("boom", status=status))
        assert out.status == status and out.kind == status


def test_a_fail_without_facts_is_a_collision_as_before_kinds_existed():
    legacy = Outcome(status="fail", end_reason="collision", sim_time=3.0)
    assert legacy.kind == "collision"  # no judge applied: derived
    assert Judge.from_spec("paper")(legacy).kind == "collision"


@pytest.mark.parametrize(
    ("spec", "canon"),
    [
        (None, "default"),
        ("paper", "paper"),
        (["ego_stationary", "collision"], "paper"),
        (["collision"], ["collision"]),
        (list(reversed(FAILURE_KINDS)), "strict"),
        ("lane_departure, collision", ["collision", "lane_departure"]),
    ],
)
def test_judge_settings_have_one_canonical_form(spec, canon):
    assert normalize_judge(spec) == canon
    assert set(JUDGES["default"]) == {"collision", "road_departure", "blocked", "route_incomplete"}
    assert JUDGES["paper"] == ("collision", "ego_stationary")
    assert JUDGES["strict"] == FAILURE_KINDS


@pytest.mark.parametrize("bad", ["", "crash", ["collision", "offroad"], []])
def test_bad_judge_settings_name_the_field_and_the_choices(bad):
    with pytest.raises(ConfigError, match="judge: expected one of default, paper, strict"):
        normalize_judge(bad)


# --- monitors and the drivable area ----------------------------------------------------------


def test_drivable_area_is_the_legs_and_the_junction():
    area = load_map("t-junction").drivable_area
    assert area.contains(0.0, 0.0)  # junction centre
    assert area.contains(0.0, -50.0) and area.contains(3.4, -50.0)  # stem, both lanes
    assert not area.contains(3.6, -50.0) and not area.contains(-3.6, -50.0)  # beyond kerbs
    assert not area.contains(20.0, -20.0)  # the corner between stem and arm
    assert area.contains(50.0, 3.4) and not area.contains(50.0, 3.6)
    # a box is on the road only when all four corners are
    assert area.contains_box(0.0, -50.0, math.pi / 2, 2.25, 0.8)
    assert not area.contains_box(2.8, -50.0, math.pi / 2, 2.25, 0.8)
    assert area.contains_box(0.0, -50.0, 0.0, 2.25, 0.8)  # a 4.5 m car across the 7 m road
    assert not area.contains_box(0.0, -50.0, 0.0, 4.0, 0.8)  # an 8 m one does not fit


def test_road_monitor_never_misses_a_corner_off_the_road():
    """The cheap pre-test may only skip poses whose box is on the road: compare it with
    the exact test over a grid of poses along routes of both maps (the full lane routes
    from each leg's very end, so route ends are covered, and the backend's ego routes)."""
    checked = 0
    for name in ("t-junction", "skewed-cross"):
        jmap = load_map(name)
        for move in jmap.movements[:6]:
            full = jmap.route(*move.split("-"))
            for route in (full, jmap.scenario(move, move).ego_route):
                checked += _check_monitor(jmap.drivable_area, route, *jmap.clearance(route))
    assert checked > 5000


def _check_monitor(area, route, left, right) -> int:
    n = 0
    for i in range(0, len(route.xs) - 1, 3):
        h = route.hs[i]
        for lat in (-2.5, -1.5, -0.9, 0.0, 0.9, 2.0, 4.0, 5.0):
            x, y = route.xs[i] - lat * math.sin(h), route.ys[i] + lat * math.cos(h)
            for dyaw in (-0.6, -0.2, 0.0, 0.3, 0.7):
                mon = RoadDepartureMonitor(area, route.hs, left, right, 2.25, 0.8)
                mon.update(1.0, x, y, h + dyaw, i, lat)
                off = not area.contains_box(x, y, h + dyaw, 2.25, 0.8)
                assert (mon.time is not None) == off, (i, lat, dyaw)
                n += 1
    return n


def test_lane_monitor_records_the_first_time_only():
    mon = LaneDepartureMonitor(1.0)
    for t, lat in ((0.1, 0.5), (0.2, -1.2), (0.3, 2.0)):
        mon.update(t, 0.0, 0.0, 0.0, 0, lat)
    assert mon.time == 0.2


def test_area_of_a_square_excludes_outside_points():
    area = DrivableArea([[(0, 0), (1, 0), (1, 1), (0, 1)]])
    assert area.contains(0.5, 0.5) and area.contains(1.0, 1.0)
    assert not area.contains(1.01, 0.5) and not area.contains(0.5, -0.01)


# --- the embedded backend reports the facts -----------------------------------------------------


class HardSteer(AVStack):
    """Drives off at full lock: leaves its lane, then the road (a stack that cannot steer)."""

    def __init__(self, steer: float) -> None:
        self.steer = steer

    def reset(self, info) -> None:
        pass

    def step(self, observation) -> Control:
        fast = observation.ego.speed < 8.0
        return Control(throttle=0.6 if fast else 0.0, brake=0.0, steer=self.steer)


@pytest.mark.parametrize("steer", [1.0, -1.0])
def test_embedded_ego_leaving_the_road_is_a_road_departure(steer):
    backend = EmbeddedBackend(sim_timeout=15.0)
    situation = make_situation(1, friction=1.0)
    raw = backend.run(situation, HardSteer(steer), seed=3)
    road, lane = raw.metrics["road_departure_time"], raw.metrics["lane_departure_time"]
    # (steering right, the front corner crosses the near kerb before the centre has
    # drifted beyond the lane tolerance: road departure can come first)
    assert road is not None and lane is not None and max(lane, road) < raw.sim_time
    assert raw.metrics["ego_left_lane"] is True
    assert raw.status == "pass" and not raw.collision  # the backend's own view: no collision
    assert Judge.from_spec("default")(raw).kind == "road_departure"
    first = "lane_departure" if lane < road else "road_departure"
    assert Judge.from_spec("strict")(raw).kind == first
    assert Judge.from_spec("paper")(raw).status == "pass"  # the paper's judge: not a failure
    # the facts do not depend on the judge: the same seed gives the same outcome
    assert backend.run(situation, HardSteer(steer), seed=3) == raw


def test_reference_stack_on_dry_road_stays_on_the_road():
    backend = EmbeddedBackend(early_end=True)
    stack = make_stack("reference")
    for intsit in range(1, 13):
        out = backend.run(make_situation(intsit, friction=1.0), stack, seed=intsit)
        assert out.metrics["road_departure_time"] is None, intsit
        assert out.metrics["lane_departure_time"] is None, intsit


def test_collisions_between_other_road_users_never_fail_the_ego():
    contact = {"actors": ["ov", "actor2"], "kinds": ["car", "pedestrian"], "time": 4.0}
    base = facts()
    outcome = Outcome(
        **{**base.to_dict(), "metrics": {**base.metrics, "actor_collisions": [contact]}}
    )
    for name in JUDGES:
        assert Judge.from_spec(name)(outcome).status == "pass", name
