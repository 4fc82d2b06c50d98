"""Road users that react (``_yielding``) and plausible speeds (``_bodies.SPEEDS``, the paced
timed pedestrians and cyclists): issue 23."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from sitcov.av import Control, NoPerceptionStack, Observation, RunInfo
from sitcov.hyperspace import Situation
from sitcov.sim.embedded import EmbeddedBackend
from sitcov.sim.embedded._bodies import SPEEDS, SpeedDistribution
from sitcov.sim.embedded._map import load_map
from sitcov.sim.embedded._routes import actor_route
from sitcov.sim.embedded._scene import ego_route, own_speed
from sitcov.sim.embedded._yielding import (
    CROSS,
    IDM,
    OPPOSITE,
    SAME,
    idm_accel,
    route_zones,
)


def situation(**values: Any) -> Situation:
    return Situation(bins={k: str(v) for k, v in values.items()}, values=values)


class HaltAt(NoPerceptionStack):
    """Drives its route blindly, then stands for good from the route point nearest to
    arc length ``at`` [m] on."""

    name = "halt-at"

    def __init__(self, at: float) -> None:
        super().__init__()
        self.at = at

    def reset(self, info: RunInfo) -> None:
        super().reset(info)
        pts = np.asarray(info.route)
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])
        self.pts, self.stop = pts, int(np.searchsorted(s, self.at))
        self.halted = False

    def step(self, observation: Observation) -> Control:
        control = super().step(observation)
        if not self.halted:
            e = observation.ego
            self.halted = int(np.argmin(np.hypot(*(self.pts - (e.x, e.y)).T))) >= self.stop
        return Control(0.0, 1.0, control.steer) if self.halted else control


# --- zones and the IDM ---------------------------------------------------------------------


def test_zones_say_whether_routes_cross_run_together_or_meet_head_on() -> None:
    m = load_map("t-junction")
    car = lambda r: actor_route(m, "car", r)  # noqa: E731
    walk = lambda r: actor_route(m, "pedestrian", r)  # noqa: E731
    (crossing,) = route_zones(car("L-R"), car("R-B"), 2.0)
    assert crossing.relation == CROSS
    assert 0.0 < crossing.sa0 < crossing.sa1 < car("L-R").length
    shared = route_zones(car("L-B"), car("L-R"), 2.0)
    assert shared[0].relation == SAME and shared[0].sa0 == pytest.approx(0.0)
    (head_on,) = route_zones(walk("XBL"), walk("XBR"), 0.8)
    assert head_on.relation == OPPOSITE
    assert route_zones(car("L-B"), car("B-R"), 2.0) == ()  # never meet


def test_idm_keeps_its_desired_speed_on_a_free_road_and_brakes_for_a_standing_obstacle() -> None:
    p = IDM["car"]
    assert idm_accel(p, 5.0, 5.0, 1e9, 0.0) == pytest.approx(0.0, abs=1e-9)
    assert idm_accel(p, 0.0, 5.0, 1e9, 0.0) == pytest.approx(p.a)
    # closer to a standing obstacle, or faster towards it: harder braking
    far, near = idm_accel(p, 5.0, 7.0, 15.0, 5.0), idm_accel(p, 5.0, 7.0, 8.0, 5.0)
    assert near < far < 0.0
    assert idm_accel(p, 0.0, 7.0, p.s0, 0.0) == pytest.approx(0.0)  # stands at s0
    assert idm_accel(p, 1.0, 7.0, 0.0, 1.0) == -math.inf  # touching: brake fully


# --- plausible speeds ----------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kind", "mean", "low", "high"), [("pedestrian", 1.34, 1.0, 1.8), ("cyclist", 4.8, 3.0, 7.0)]
)
def test_speeds_are_drawn_within_what_people_do_around_the_studies_mean(
    kind: str, mean: float, low: float, high: float
) -> None:
    dist = SPEEDS[kind]
    assert (dist.low, dist.high) == (low, high)
    rng = np.random.default_rng(0)
    draws = np.array([dist.draw(rng) for _ in range(4000)])
    assert draws.min() >= low and draws.max() <= high
    assert abs(float(np.median(draws)) - mean) < 0.05 * mean
    # own streams: reproducible per (seed, actor), different across actors and runs
    assert own_speed(kind, 7, 1) == own_speed(kind, 7, 1)
    assert len({own_speed(kind, 7, i) for i in range(5)}) == 5
    assert own_speed("car", 7, 1) is None


def test_a_distribution_that_never_draws_in_range_falls_back_to_its_mean() -> None:
    assert SpeedDistribution(10.0, 0.01, 0.0, 1.0).draw(np.random.default_rng(0)) == 10.0


def test_a_situations_speed_overrides_the_drawn_one() -> None:
    s = situation(
        intsit={"ego": "L-B", "ov": "B-R", "conflict": "none"},
        actor2={"kind": "pedestrian", "route": "XBL", "behaviour": {"name": "cross", "speed": 1.1}},
    )
    o = EmbeddedBackend().run(s, NoPerceptionStack(), seed=3, record=True)
    assert max(r[4] for r in o.trace.actors["actor2"]) == pytest.approx(1.1)


@pytest.mark.parametrize("kind", ["pedestrian", "cyclist"])
def test_a_timed_pedestrian_or_cyclist_meets_a_blind_ego_at_its_own_speed(kind: str) -> None:
    ov = "XBL" if kind == "pedestrian" else "R-B"
    s = situation(intsit={"ego": "L-B", "ov": ov, "conflict": "k", "kind": kind})
    for seed in range(4):
        o = EmbeddedBackend().run(s, NoPerceptionStack(), seed=seed, record=True)
        assert o.collision and o.metrics["collision_kind"] == kind
        speeds = [r[4] for r in o.trace.ov]
        first = next(i for i, v in enumerate(speeds) if v > 0.0)
        # it stood until it went, then never went slower than people do once up to speed
        walking = [v for v in speeds[first:] if v >= SPEEDS[kind].low]
        assert walking and max(speeds) <= SPEEDS[kind].high + 1e-9
        assert min(speeds[first + speeds[first:].index(walking[0]) :]) >= SPEEDS[kind].low - 0.2


# --- reacting -------------------------------------------------------------------------------


def test_a_car_after_its_switch_stops_for_an_ego_standing_in_its_path() -> None:
    # gain 0: the OV stands until its switch, then cruises on at 15 km/h and comes to the
    # conflict well after the ego, which stands there
    m = load_map("t-junction")
    s = situation(intsit={"ego": "L-B", "ov": "R-B", "conflict": "c4"})
    conflict = m.scenario("L-B", "R-B", 1.61, 1.61).conflict
    backend = EmbeddedBackend(adversary={"gain": 0.0}, early_end=False, sim_timeout=30.0)
    o = backend.run(s, HaltAt(conflict.s_ego + 3.0), seed=0, record=True)
    assert o.metrics["ov_switch_time"] is not None  # it cruised on after its switch...
    assert not o.collision  # ... and stopped short of the standing ego
    assert o.trace.ov[-1][4] < 0.05 and o.trace.ego[-1][4] < 0.05
    ov, ego = o.trace.ov[-1], o.trace.ego[-1]
    assert math.hypot(ov[1] - ego[1], ov[2] - ego[2]) < 10.0  # it came close, then waited


@pytest.mark.parametrize("pause", [2.5, 4.0])
def test_a_hesitating_pedestrian_stops_short_of_an_ego_standing_on_the_crosswalk(pause) -> None:
    # it waits at the kerb while the ego comes; the ego halts on the crosswalk
    m = load_map("t-junction")
    walk = actor_route(m, "pedestrian", "XBL")
    (zone,) = route_zones(ego_route(m, "L-B"), walk, 1.2)
    s = situation(
        intsit={"ego": "L-B", "ov": "B-R", "conflict": "none"},
        actor2={
            "kind": "pedestrian",
            "route": "XBL",
            "behaviour": {"name": "hesitate", "pause": pause},
        },
    )
    for seed in range(3):
        o = EmbeddedBackend(early_end=False, sim_timeout=25.0).run(
            s, HaltAt(zone.sa0 - 1.5), seed=seed, record=True
        )
        assert not o.collision
        assert max(r[4] for r in o.trace.actors["actor2"]) > 0.9  # it did set off


def test_a_scripted_car_queues_behind_a_car_that_stops_for_good() -> None:
    s = situation(
        intsit={"ego": "L-B", "ov": "B-R", "conflict": "none"},
        actor2={"kind": "car", "route": "R-L", "behaviour": "stop"},
        actor3={"kind": "car", "route": "R-L", "behaviour": "cruise"},
    )
    o = EmbeddedBackend(early_end=False, sim_timeout=30.0).run(s, HaltAt(5.0), seed=0, record=True)
    assert o.metrics["actor_collisions"] == []
    first, second = o.trace.actors["actor2"][-1], o.trace.actors["actor3"][-1]
    assert first[4] < 0.05 and second[4] < 0.05  # both stand, one behind the other
    gap = math.hypot(first[1] - second[1], first[2] - second[2]) - 4.5
    assert 1.0 < gap < 6.0
