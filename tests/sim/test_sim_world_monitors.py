"""World monitors one by one, on hand-made worlds with known answers."""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest

from sitcov.sim.embedded._actors import Actor
from sitcov.sim.embedded._bodies import body_spec, make_body
from sitcov.sim.embedded._map import Conflict
from sitcov.sim.embedded._monitors import (
    ActorCollisionMonitor,
    CollisionMonitor,
    DistanceMonitor,
    EarlyEndMonitor,
    GoalMonitor,
    LeaveMapRule,
    PETMonitor,
    ProximityMonitor,
    TTCMonitor,
)
from sitcov.sim.embedded._path import Path

LINE = Path.from_points([(float(x), 0.0) for x in range(-50, 51)])


def actor(name: str, kind: str, x: float, y: float = 0.0, yaw: float = 0.0, **kw) -> Actor:
    a = Actor(name, kind, body_spec(kind), make_body(kind, x, y, yaw), LINE, **kw)
    a.s = x + 50.0
    return a


def world(ego: Actor, *others: Actor, t: float = 0.0, k: int = 0, aeb: float | None = None):
    w = SimpleNamespace(
        ego=ego,
        actors=list(others),
        t=t,
        k=k,
        mu=1.0,
        collision=None,
        driver=SimpleNamespace(aeb_time=aeb, latched=aeb is not None),
    )
    relate(w)
    return w


def relate(w) -> None:
    """What World.step does after moving: relative positions and gaps."""
    e = w.ego.body
    for a in w.actors:
        a.prev_gap = a.gap
        a.dx, a.dy = a.body.x - e.x, a.body.y - e.y
        a.gap = math.hypot(a.dx, a.dy) if a.active else math.inf


def report(monitor, w) -> dict:
    per = {a.name: {} for a in w.actors}
    run: dict = {}
    monitor.report(run, per, w)
    return {**run, **per}


def test_distance_is_the_gap_between_the_boxes() -> None:
    ego = actor("ego", "car", 0.0)
    ped = actor("p", "pedestrian", 10.0)
    w = world(ego, ped)
    mon = DistanceMonitor(w)
    mon.update(w)
    expected = 10.0 - 0.5 * body_spec("car").length - 0.25
    assert report(mon, w)["p"]["min_distance"] == pytest.approx(expected)


def test_collision_ends_the_run_and_names_the_actor() -> None:
    ego = actor("ego", "car", 0.0)
    far = actor("far", "car", 30.0)
    bike = actor("bike", "cyclist", 2.5, 0.5)
    bike.body.vx = 4.0
    w = world(ego, far, bike)
    mon = CollisionMonitor(w)
    assert mon.update(w) == "collision" and w.collision is bike
    out = report(mon, w)
    assert out["bike"]["collided"] and not out["far"]["collided"]
    assert out["_collision_speed"] == pytest.approx(4.0)
    # where: inside both boxes (the overlap's centroid), the ego's heading, the kind hit
    x, y = out["collision_point"]
    assert 2.5 - bike.half_l < x < ego.half_l and abs(y - 0.25) < 0.5
    assert out["collision_heading"] == 0.0 and out["collision_kind"] == "cyclist"
    w2 = world(actor("ego", "car", 0.0), actor("p", "pedestrian", 2.6))  # 0.1 m apart
    mon2 = CollisionMonitor(w2)
    assert mon2.update(w2) is None
    out2 = report(mon2, w2)
    assert out2["collision_point"] is None and out2["collision_kind"] is None


def test_ttc_of_a_head_on_approach() -> None:
    ego = actor("ego", "car", 0.0)
    other = actor("o", "car", 20.0, yaw=math.pi)
    other.body.vx = 5.0
    w = world(ego, other)
    mon = TTCMonitor(w)
    mon.update(w)
    radii = 2.0 * math.sqrt(body_spec("car").length * body_spec("car").width / math.pi)
    assert report(mon, w)["o"]["min_ttc"] == pytest.approx((20.0 - radii) / 5.0)


def test_drac_of_a_head_on_approach_is_the_closing_speed_over_twice_the_ttc() -> None:
    """DRAC = |v_rel| / (2 TTC) (Cooper & Ferguson 1976): the deceleration that stops the
    relative motion of the discs over the distance left, (20 - radii) m at 5 m/s."""
    ego = actor("ego", "car", 0.0)
    other = actor("o", "car", 20.0, yaw=math.pi)
    other.body.vx = 5.0
    w = world(ego, other)
    mon = ProximityMonitor(w)
    mon.update(w)
    radii = 2.0 * math.sqrt(body_spec("car").length * body_spec("car").width / math.pi)
    facts = report(mon, w)
    assert facts["o"]["max_drac"] == pytest.approx(5.0**2 / (2.0 * (20.0 - radii)))
    assert facts["max_drac"] == facts["o"]["max_drac"]
    other.body.vx = -5.0  # moving away: no TTC, no DRAC
    w2 = world(actor("ego", "car", 0.0), other)
    mon2 = ProximityMonitor(w2)
    mon2.update(w2)
    assert report(mon2, w2)["max_drac"] is None


def test_pet_is_the_gap_between_the_ego_leaving_and_the_actor_entering() -> None:
    conflict = Conflict(point=(0.0, 0.0), s_ego=50.0, s_ego_end=52.0, s_ov=50.0, s_ov_end=52.0)
    ego = actor("ego", "car", -50.0)
    ped = actor("p", "pedestrian", -50.0, conflict=conflict)
    w = world(ego, ped)
    mon = PETMonitor(w)
    half = 0.5 * body_spec("car").length
    # ego front reaches the zone at t = 1, rear leaves at t = 2; pedestrian enters at t = 5
    for t, s_ego, s_ped in (
        (1.0, 50.0 - half, 0.0),
        (2.0, 52.0 + half + 0.01, 0.0),
        (5.0, 80.0, 49.75),
    ):
        w.t, ego.s, ped.s = t, s_ego, s_ped
        mon.update(w)
    assert report(mon, w)["p"]["pet"] == pytest.approx(3.0)


def test_leave_map_and_goal() -> None:
    ego = actor("ego", "car", 0.0)
    a = actor("a", "car", 0.0)
    w = world(ego, a)
    leave, goal = LeaveMapRule(w), GoalMonitor(w)
    assert goal.update(w) is None
    a.s = LINE.length - 1.0
    leave.update(w)
    assert not a.active
    ego.s = LINE.length - 1.0
    assert goal.update(w) == "goal"


class Controller:
    def __init__(self, stuck: bool) -> None:
        self._stuck = stuck

    def reach_speed(self, actor: Actor) -> float:
        return 4.0

    def stuck(self, actor: Actor) -> bool:
        return self._stuck


def test_early_end_needs_a_latched_standing_ego_and_no_actor_that_can_reach_it() -> None:
    ego = actor("ego", "car", 0.0)
    waiting = actor("w", "car", -20.0, controller=Controller(stuck=True))  # on the ego's line
    w = world(ego, waiting)
    mon = EarlyEndMonitor(w)
    assert mon.update(w) is None  # AEB has not fired
    w.driver.aeb_time, w.driver.latched = 1.0, True
    assert mon.update(w) == "stopped"  # the only actor is stuck
    moving = actor("m", "car", -20.0, controller=Controller(stuck=False))
    w2 = world(ego, moving, aeb=1.0)
    assert EarlyEndMonitor(w2).update(w2) is None  # it can still drive into the ego
    assert EarlyEndMonitor(w2, enabled=False).update(w2) is None
    aside = actor("s", "car", -20.0, y=30.0, controller=Controller(stuck=False))
    aside.route = Path.from_points([(-50.0, 30.0), (50.0, 30.0)])
    w3 = world(ego, aside, aeb=1.0)
    assert EarlyEndMonitor(w3).update(w3) == "stopped"  # its route passes 30 m away


def test_actor_actor_collisions_are_recorded_once_and_both_brake() -> None:
    ego = actor("ego", "car", -40.0)
    a, b = actor("a", "car", 10.0), actor("b", "pedestrian", 12.0, 0.3)
    a.body.vx = 3.0
    w = world(ego, a, b, t=4.0)
    mon = ActorCollisionMonitor(w)
    assert mon.update(w) is None  # never ends the run
    mon.update(w)
    events = report(mon, w)["_actor_collisions"]
    assert len(events) == 1 and events[0]["kinds"] == ["car", "pedestrian"]
    assert events[0]["time"] == 4.0 and events[0]["speed"] == pytest.approx(3.0)
    assert a.crashed and b.crashed and not ego.crashed


def test_proximity_monitor_reports_what_the_distance_and_ttc_monitors_do() -> None:
    """The built-in list's combined monitor: the same ``min_distance`` and ``min_ttc`` bits
    as the two separate monitors over a random approach of several actors (near, far and
    inactive ones, every fourth far step)."""
    rnd = __import__("random").Random(4)
    ego = actor("ego", "car", 0.0)
    others = [
        actor("o", "car", 30.0, 3.0, yaw=math.pi),
        actor("p", "pedestrian", 8.0, -6.0, yaw=0.5 * math.pi),
        actor("b", "cyclist", -25.0, 1.0),
    ]
    w = world(ego, *others)
    mons = [DistanceMonitor(w), TTCMonitor(w), ProximityMonitor(w)]
    for k in range(80):
        w.k = k
        for a in [ego, *others]:
            a.body.x += rnd.uniform(-0.3, 0.6) * (1.0 if a is ego else -0.5)
            a.body.y += rnd.uniform(-0.2, 0.2)
            a.body.yaw += rnd.uniform(-0.05, 0.05)
            a.body.vx = rnd.uniform(0.0, 6.0)
        others[2].active = k < 40
        relate(w)
        for m in mons:
            m.update(w)
    separate = {**report(mons[0], w), **{}}
    for name, facts in report(mons[1], w).items():
        separate[name] = {**separate[name], **facts} if isinstance(facts, dict) else facts
    combined = report(mons[2], w)
    assert sorted(combined) == sorted(separate)
    assert all(repr(combined[key]) == repr(separate[key]) for key in combined)
    assert all(combined[a.name]["min_ttc"] is not None for a in others[:2])
    dracs = [combined[a.name]["max_drac"] for a in others[:2]]
    assert all(d is not None and d > 0.0 for d in dracs)
    assert combined["max_drac"] == max(dracs)
