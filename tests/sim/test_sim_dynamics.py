"""Vehicle dynamics: braking at the friction limit, cornering limits, drive, wind."""

from __future__ import annotations

import math

import pytest

from sitcov.sim._adversary import pure_pursuit
from sitcov.sim.embedded import Vehicle, default_params, load_map

G = 9.81
V25 = 25 / 3.6  # [m/s]


def test_parameters_are_commonroad_bmw_320i() -> None:
    from vehiclemodels.parameters_vehicle2 import parameters_vehicle2

    ref = parameters_vehicle2()
    p = default_params()
    assert (p.mass, p.iz, p.lf, p.lr) == (ref.m, ref.I_z, ref.a, ref.b)
    assert (p.length, p.width, p.steer_max) == (ref.l, ref.w, ref.steering.max)
    assert p.c_front == pytest.approx(-ref.tire.p_ky1 / ref.tire.p_dy1)


@pytest.mark.parametrize("mu", [0.2, 1.0])
def test_stopping_distance_matches_friction_limit(mu: float) -> None:
    car = Vehicle(default_params(), 0.0, 0.0, 0.0, V25)
    for _ in range(400):
        car.step(0.0, 1.0, 0.0, mu)
        if car.speed == 0.0:
            break
    expected = V25**2 / (2 * mu * G)
    assert car.speed == 0.0
    assert car.x == pytest.approx(expected, rel=0.10)
    assert abs(car.y) < 1e-9 and car.x > 0


def test_full_throttle_is_a_saloon() -> None:
    car = Vehicle(default_params(), 0.0, 0.0, 0.0)
    car.step(1.0, 0.0, 0.0, 1.0)
    assert car.speed / 0.05 == pytest.approx(3.0, rel=0.1)  # ~3 m/s^2 from rest
    for _ in range(199):
        car.step(1.0, 0.0, 0.0, 1.0)
    assert 15 < car.speed * 3.6 < 110  # 10 s of full throttle


def test_no_reversing_under_brake() -> None:
    car = Vehicle(default_params(), 0.0, 0.0, 0.0, 1.0)
    for _ in range(100):
        car.step(0.0, 1.0, 0.3, 0.5)
    assert car.speed == 0.0 and car.vx >= 0.0


def _drive_turn(move: str, speed: float, mu: float) -> float:
    """Follow a turn at constant target speed; return the max lateral offset [m]."""
    jmap = load_map()
    route = jmap.route(*move.split("-"))
    p = default_params()
    s0 = 110 - 40  # 40 m before the junction mouth... on the inbound lane
    x, y, h = route.point_at(s0)
    car = Vehicle(p, x, y, h, speed)
    s, i = route.project(x, y, -1)
    worst = 0.0
    while s < route.length - 60:
        look = max(4.0, 0.8 * car.speed)
        tx, ty, _ = route.point_at(s + look)
        c, sn = math.cos(car.yaw), math.sin(car.yaw)
        delta = pure_pursuit(car.x - p.lr * c, car.y - p.lr * sn, car.yaw, tx, ty, p.wheelbase)
        err = speed - car.speed
        car.step(max(0.0, min(1.0, err)), max(0.0, min(1.0, -err)), delta / p.steer_max, mu)
        s, i = route.project(car.x, car.y, -1)
        worst = max(worst, abs(route.lateral_offset(car.x, car.y)))
    return worst


LANE_MARGIN = (3.5 - 1.61) / 2  # lateral offset at which the body crosses the lane line [m]


@pytest.mark.parametrize("move", ["B-L", "B-R"])
def test_fast_turn_on_low_friction_leaves_lane(move: str) -> None:
    assert _drive_turn(move, V25, 0.2) > LANE_MARGIN + 0.5


@pytest.mark.parametrize(
    ("move", "speed", "mu"),
    [("B-L", V25, 1.0), ("B-R", V25, 1.0), ("B-L", 10 / 3.6, 0.2), ("B-R", 10 / 3.6, 0.2)],
)
def test_turn_within_limits_stays_in_lane(move: str, speed: float, mu: float) -> None:
    assert _drive_turn(move, speed, mu) < LANE_MARGIN


def test_steady_cornering_saturates_at_mu_g() -> None:
    """Lateral acceleration in a full-lock turn never exceeds mu*g (plus numerical slack)."""
    for mu in (0.3, 0.8):
        car = Vehicle(default_params(), 0.0, 0.0, 0.0, 10.0)
        peak = 0.0
        for _ in range(60):
            car.step(0.3, 0.0, 0.8, mu)
            peak = max(peak, abs(car.vx * car.r))
        assert peak < mu * G * 1.15


def test_crosswind_pushes_sideways() -> None:
    calm = Vehicle(default_params(), 0.0, 0.0, 0.0, 10.0)
    windy = Vehicle(default_params(), 0.0, 0.0, 0.0, 10.0)
    for _ in range(40):
        calm.step(0.2, 0.0, 0.0, 1.0)
        windy.step(0.2, 0.0, 0.0, 1.0, lateral_accel=1.0)
    assert abs(calm.y) < 1e-9
    # pushed left by a 1 m/s^2 side force; the tyres' slip forces resist, so it drifts
    # far less than the free-body 2 m over 2 s
    assert 0.05 < windy.y < 2.0
    assert windy.vy > 0.0
