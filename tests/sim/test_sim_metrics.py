"""min_ttc and pet: one definition (sitcov.sim._metrics), the same in both backends."""

from __future__ import annotations

import math

import pytest
from _sim_helpers import make_situation

from sitcov.av import NoPerceptionStack
from sitcov.sim._metrics import (
    ZoneClock,
    disc_radius,
    post_encroachment_time,
    time_to_collision,
    zone_clocks,
)
from sitcov.sim.carla._metrics import MetricTracker, VehicleState
from sitcov.sim.embedded import EmbeddedBackend
from sitcov.sim.embedded._map import find_conflict
from sitcov.sim.embedded._path import Path


def test_disc_time_to_collision_by_hand():
    assert time_to_collision(10.0, 0.0, -5.0, 0.0, 2.0) == pytest.approx(8.0 / 5.0)
    assert time_to_collision(1.0, 0.5, 3.0, 0.0, 2.0) == 0.0  # already touching
    assert time_to_collision(10.0, 0.0, 5.0, 0.0, 2.0) is None  # moving apart
    assert time_to_collision(10.0, 5.0, -5.0, 0.0, 2.0) is None  # passes 5 m to the side
    # oblique: the discs touch when the gap |p + v t| first equals the radius
    t = time_to_collision(10.0, 1.0, -4.0, 0.0, 2.0)
    assert math.hypot(10.0 - 4.0 * t, 1.0) == pytest.approx(2.0)
    assert disc_radius(4.0, 2.0) == pytest.approx(math.sqrt(8.0 / math.pi))


def test_post_encroachment_time_by_hand():
    assert post_encroachment_time((1.0, 2.0), (3.5, 4.0), False) == pytest.approx(1.5)
    assert post_encroachment_time((3.5, 4.0), (1.0, 2.0), False) == pytest.approx(1.5)
    assert post_encroachment_time((1.0, 3.0), (2.0, 4.0), False) == 0.0  # overlapping
    assert post_encroachment_time((1.0, 2.0), (3.0, None), True) == 0.0  # collided
    assert post_encroachment_time((1.0, None), (3.0, 4.0), False) is None  # first never left
    assert post_encroachment_time((1.0, 2.0), (None, None), False) is None  # OV never came
    clock = ZoneClock(start=10.0, end=15.0, half_length=2.0)
    for t, s in ((0.0, 5.0), (1.0, 8.0), (2.0, 16.0), (3.0, 17.5)):
        clock.update(t, s)
    assert (clock.entered, clock.left) == (1.0, 3.0)  # front at 10 m; rear past 15 m


def straight(x0, y0, x1, y1, n=60):
    return [(x0 + (x1 - x0) * k / n, y0 + (y1 - y0) * k / n) for k in range(n + 1)]


def test_carla_tracker_follows_the_definition_on_a_crossing_by_hand():
    """Ego east along y = 0 from x = -40, OV north along x = 0 from y = -55, both 10 m/s.

    Swept paths (width 1.8 m) overlap for |x| < 1.8 on the ego route (arc 38.2..41.8 m)
    and |y| < 1.8 on the OV's (53.2..56.8 m). The ego's rear leaves at (41.8 + 2.3) / 10
    = 4.41 s, the OV's front arrives at (53.2 - 2.3) / 10 = 5.09 s: PET = 0.68 s. The
    constant-velocity discs (radius 1.62 m each) miss by 10.6 m: no TTC.
    """
    tracker = MetricTracker(straight(-40, 0, 40, 0), straight(0, -55, 0, 40))
    dt, hl, hw = 0.05, 2.3, 0.9
    for k in range(int(8.0 / dt)):
        t = k * dt
        ego = VehicleState(-40 + 10 * t, 0.0, 0.0, 10.0, 0.0, hl, hw)
        ov = VehicleState(0.0, -55 + 10 * t, math.pi / 2, 0.0, 10.0, hl, hw)
        tracker.update(t, ego, ov)
    # tolerance: one tick plus the 0.5 m resampling of the swept-path overlap, at 10 m/s
    assert tracker.pet(collided=False) == pytest.approx(0.68, abs=dt + 0.1)
    assert tracker.pet(collided=True) == 0.0
    assert tracker.min_ttc is None


def test_carla_tracker_time_to_collision_head_on_by_hand():
    """Head-on at 10 m/s each from 80 m apart: TTC(t) = (80 - 20 t - 2 r) / 20."""
    tracker = MetricTracker(straight(-40, 0, 40, 0), straight(40, 0, -40, 0))
    hl, hw = 2.3, 0.9
    r = disc_radius(2 * hl, 2 * hw)
    for k in range(31):  # t = 0 .. 3 s
        t = 0.1 * k
        ego = VehicleState(-40 + 10 * t, 0.0, 0.0, 10.0, 0.0, hl, hw)
        ov = VehicleState(40 - 10 * t, 0.0, math.pi, -10.0, 0.0, hl, hw)
        tracker.update(t, ego, ov)
    assert tracker.min_ttc == pytest.approx((80 - 20 * 3.0 - 2 * r) / 20)
    assert tracker.min_distance == pytest.approx(80 - 60 - 2 * hl)


def embedded_pet_from_trace(outcome) -> float | None:
    """PET recomputed from a recorded embedded run by the definition in sitcov.sim._metrics."""
    meta = outcome.trace.meta
    ego_path, ov_path = Path.from_points(meta["ego_route"]), Path.from_points(meta["ov_route"])
    conflict = find_conflict(ego_path, ov_path, meta["width"])
    clocks = zone_clocks(conflict, 0.5 * meta["length"], 0.5 * meta["length"])
    tracks = ((clocks[0], ego_path, outcome.trace.ego), (clocks[1], ov_path, outcome.trace.ov))
    for clock, path, rows in tracks:
        hint = 0
        for t, x, y, *_ in rows:
            s, hint = path.track(x, y, hint)
            clock.update(t, s)
    return post_encroachment_time(*clocks, outcome.collision)


@pytest.mark.parametrize("intsit", [1, 4, 7, 10])
def test_embedded_pet_is_the_definition_applied_to_its_own_trajectories(intsit):
    backend = EmbeddedBackend(adversary={"switch_distance": 1e9})  # the OV cruises at once
    outcome = backend.run(make_situation(intsit), NoPerceptionStack(), seed=0, record=True)
    again = embedded_pet_from_trace(outcome)
    if outcome.pet is None:
        assert again is None
    else:
        dt = outcome.trace.meta["dt"]
        assert again == pytest.approx(outcome.pet, abs=dt + 1e-9)
