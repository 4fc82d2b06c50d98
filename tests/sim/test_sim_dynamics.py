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


@pytest.mark.parametrize("mu", [0.1, 0.2, 1.0])
def test_stopping_distance_within_friction_and_abs_limits(mu: float) -> None:
    """A full brake never beats mu*g (rolling resistance is a tyre force, inside the
    budget) and, as an ABS does, uses most of it: at least 85 % of mu*g on average."""
    car = Vehicle(default_params(), 0.0, 0.0, 0.0, V25)
    for _ in range(400):
        car.step(0.0, 1.0, 0.0, mu)
        if car.speed == 0.0:
            break
    limit = V25**2 / (2 * mu * G)
    assert car.speed == 0.0
    assert limit <= car.x <= limit / 0.85
    assert abs(car.y) < 1e-9


def _course(car: Vehicle) -> float:
    """Direction of travel over ground [rad]."""
    c, s = math.cos(car.yaw), math.sin(car.yaw)
    return math.atan2(car.vx * s + car.vy * c, car.vx * c - car.vy * s)


@pytest.mark.parametrize("mu", [0.5, 0.8])
def test_full_brake_in_a_curve_keeps_steering(mu: float) -> None:
    """Braking at full in a curve the road can hold: the car keeps turning (ABS leaves
    the tyres lateral grip) instead of sliding straight on."""
    steer, v0 = 0.06, 12.0
    car = Vehicle(default_params(), 0.0, 0.0, 0.0, v0)
    for _ in range(60):  # settle into the curve
        car.step(max(0.0, min(1.0, v0 - car.speed)), 0.0, steer, mu)
    c0, x0, y0 = _course(car), car.x, car.y
    for _ in range(20):
        car.step(max(0.0, min(1.0, v0 - car.speed)), 0.0, steer, mu)
    radius = math.hypot(car.x - x0, car.y - y0) / (_course(car) - c0)
    assert 20.0 < radius < 80.0  # a real curve, turning left
    c1, travelled, px, py = _course(car), 0.0, car.x, car.y
    while car.speed > 5.0:  # full brake; the dynamic tyre model governs this range
        car.step(0.0, 1.0, steer, mu)
        travelled += math.hypot(car.x - px, car.y - py)
        px, py = car.x, car.y
        assert car.r > 0.05  # still yawing into the curve
    turned = _course(car) - c1
    assert turned > 0.7 * travelled / radius  # follows (most of) the curve


@pytest.mark.parametrize("speed", [1.5, 3.0])
def test_low_speed_tight_turn_respects_friction(speed: float) -> None:
    """At walking pace, full lock on mu = 0.1: the path's lateral acceleration stays at
    ~mu*g (the kinematic model is not allowed to turn without grip); on a dry road the
    same turn is much sharper, so the limit is the friction's."""

    def peak_lateral(mu: float) -> float:
        car = Vehicle(default_params(), 0.0, 0.0, 0.0, speed)
        prev, peak = None, 0.0
        for _ in range(80):
            err = speed - car.speed
            car.step(max(0.0, min(1.0, err)), max(0.0, min(1.0, -err)), 1.0, mu)
            c, s = math.cos(car.yaw), math.sin(car.yaw)
            wx, wy = car.vx * c - car.vy * s, car.vx * s + car.vy * c
            if prev is not None and math.hypot(wx, wy) > 0.2:
                ax, ay = (wx - prev[0]) / 0.05, (wy - prev[1]) / 0.05
                peak = max(peak, abs(ax * wy - ay * wx) / math.hypot(wx, wy))
            prev = (wx, wy)
        return peak

    icy = peak_lateral(0.1)
    assert 0.5 * 0.1 * G < icy < 1.15 * 0.1 * G
    assert peak_lateral(1.0) > 3 * icy


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


def test_abs_share_is_within_commonroads_combined_slip_tyre() -> None:
    """The braking share and the side force it leaves are no more than CommonRoad's own
    Pacejka combined-slip tyre for this car gives while an ABS holds the wheel at the slip
    of peak braking force (slip angle 0.05 rad): the ellipse is conservative."""
    from vehiclemodels.parameters_vehicle2 import parameters_vehicle2
    from vehiclemodels.utils import tire_model as mf

    from sitcov.sim.embedded._dynamics import ABS_SHARE

    tyre, fz, alpha = parameters_vehicle2().tire, 4000.0, 0.05
    slips = [i / 1000 for i in range(1, 400)]
    fx_pure = [abs(mf.formula_longitudinal(-k, 0.0, fz, tyre)) for k in slips]
    k_abs = slips[fx_pure.index(max(fx_pure))]
    fy_peak = max(abs(mf.formula_lateral(a / 1000, 0.0, fz, tyre)[0]) for a in range(1, 400))
    fx0 = mf.formula_longitudinal(-k_abs, 0.0, fz, tyre)
    fy0, mu_y = mf.formula_lateral(alpha, 0.0, fz, tyre)
    fx = abs(mf.formula_longitudinal_comb(-k_abs, alpha, fx0, tyre)) / max(fx_pure)
    fy = abs(mf.formula_lateral_comb(-k_abs, alpha, 0.0, mu_y, fz, fy0, tyre)) / fy_peak
    assert 0.05 < k_abs < 0.3  # the slip window an ABS controls
    assert fx >= ABS_SHARE
    assert fy >= math.sqrt(1.0 - ABS_SHARE**2)
