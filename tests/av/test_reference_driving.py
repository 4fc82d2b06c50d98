"""Route following of the reference stack: PID signs, straight and turning routes, speed."""

from __future__ import annotations

import math
import random

import pytest
from _kinematic import cross_track, drive

from sitcov.av import LateralPID, LongitudinalPID, ReferenceStack, heading_error
from sitcov.av._base import EgoState, Observation, RunInfo
from sitcov.av._pid import window_pid
from sitcov.perception import CameraSpec


def test_heading_error_sign_and_magnitude():
    # Target to the left of an east-facing car is a positive (counter-clockwise) error.
    assert heading_error(0, 0, 0.0, 10, 10) == pytest.approx(math.pi / 4)
    assert heading_error(0, 0, 0.0, 10, -10) == pytest.approx(-math.pi / 4)
    # Heading north, target due east: a right turn of 90 degrees.
    assert heading_error(0, 0, math.pi / 2, 5, 0) == pytest.approx(-math.pi / 2)
    assert heading_error(1, 1, 0.3, 1, 1) == 0.0


def test_lateral_pid_matches_carla_window_formula():
    pid = LateralPID(0.58, 0.02, 0.5, 0.05)
    errors = [0.1 * (i % 4) for i in range(13)]
    outs = [pid.update(e) for e in errors]
    # Independent formula: window of the last 10 errors, D from the last two.
    for i in range(1, len(errors)):
        window = errors[max(0, i - 9) : i + 1]
        expected = 0.58 * errors[i] + 0.02 * (errors[i] - errors[i - 1]) / 0.05
        expected += 0.5 * sum(window) * 0.05
        assert outs[i] == pytest.approx(expected)
    assert outs[0] == pytest.approx(0.58 * errors[0])


def test_longitudinal_pid_throttles_below_and_brakes_above_target():
    pid = LongitudinalPID(0.15, 0.05, 0.07, 0.05)
    assert pid.step(25.0, 0.0) == 1.0  # clipped
    pid.reset()
    assert pid.step(25.0, 40.0) < 0.0


def test_follows_straight_route_from_an_offset_and_holds_speed():
    route = [(float(i), 0.0) for i in range(300)]
    rows = drive(ReferenceStack(), route, start=(0.0, 1.5, 0.2), steps=400)
    late = rows[200:]
    assert max(abs(r[1]) for r in late) < 0.3  # converged onto the lane centre [m]
    speeds = [r[3] * 3.6 for r in late]
    assert sum(speeds) / len(speeds) == pytest.approx(25.0, abs=1.0)
    assert max(speeds) < 27.5
    # Speed regulation never brakes harder than CARLA's 0.3 cap.
    assert all(r[4].brake <= 0.3 + 1e-12 for r in rows)


@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_follows_a_turn_left_and_right(direction):
    # 40 m straight, a quarter circle of radius 15 m, then 60 m straight, points ~1 m apart.
    radius = 15.0
    route = [(float(i), 0.0) for i in range(40)]
    arc = int(radius * math.pi / 2)
    for k in range(arc + 1):
        a = k / arc * math.pi / 2
        route.append((40.0 + radius * math.sin(a), direction * radius * (1 - math.cos(a))))
    for i in range(1, 60):
        route.append((40.0 + radius, direction * (radius + i)))
    rows = drive(ReferenceStack(), route, start=(0.0, 0.0, 0.0), steps=500)
    driving = [r for r in rows if r[4].brake < 1.0]  # before the end-of-route stop
    worst = max(cross_track(route, r[0], r[1]) for r in driving)
    assert worst < 1.0  # stays well inside its 3.5 m lane [m]
    end = rows[-1]
    # Went round the corner the right way and stopped at the end of the route.
    assert math.hypot(end[0] - route[-1][0], end[1] - route[-1][1]) < 3.0
    assert end[3] == 0.0
    assert math.cos(end[2] - direction * math.pi / 2) > 0.99
    assert rows[-1][4].brake == 1.0 and not rows[-1][4].info


@pytest.mark.parametrize("window", [1, 2, 10])
def test_flat_window_pid_gives_the_classes_bits(window):
    """``window_pid`` (the compiled route step's PID) equals ``_WindowPID.update``
    bit for bit, before and after its window fills."""
    pid = LateralPID(0.58, 0.02, 0.5, 0.05, window)
    gains = (0.0,) * 6 + (0.58, 0.02, 0.5, 0.05)
    st = [0.0, 0.0] + [0.0] * window
    rnd = random.Random(window)
    count = head = 0
    for _ in range(40):
        error = rnd.uniform(-1.0, 1.0)
        full = count == window
        count = window if full else count + 1
        got = window_pid(st, 0, 2, error, gains, 6, full, head, count)
        head = head + 1 if head + 1 < window else 0
        assert repr(got) == repr(pid.update(error))


def _reference_drive(route, params, steps):
    """The stack's route following written with the PID classes (the code before
    ``_route_step``): ``state -> (throttle, brake, steer)``, per step."""
    p = params
    lat = LateralPID(p["lat_kp"], p["lat_kd"], p["lat_ki"], 0.05, p["pid_window"])
    lon = LongitudinalPID(p["lon_kp"], p["lon_kd"], p["lon_ki"], 0.05, p["pid_window"])
    idx, done, prev, out = 0, False, 0.0, []
    for x, y, yaw, speed in steps:
        reach = p["lookahead_base"] + p["lookahead_gain"] * speed
        while idx < len(route) - 1 and math.hypot(route[idx][0] - x, route[idx][1] - y) < reach:
            idx += 1
        tx, ty = route[idx]
        if idx == len(route) - 1 and (done or math.hypot(tx - x, ty - y) < 1.0):
            done = True
            out.append((0.0, 1.0, 0.0))
            continue
        accel = lon.step(p["target_speed_kmh"], speed * 3.6)
        steer = lat.step(x, y, yaw, tx, ty)
        change = p["max_steer_change"]
        steer = min(max(steer, prev - change), prev + change)
        prev = steer = min(max(steer, -p["max_steer"]), p["max_steer"])
        if accel >= 0.0:
            out.append((min(accel, p["max_throttle"]), 0.0, steer))
        else:
            out.append((0.0, min(-accel, p["max_brake"]), steer))
    return out


@pytest.mark.parametrize("window", [1, 3, 10])
def test_route_step_gives_the_pid_classes_bits(window):
    """The stack's controls along a noisy drive to the end of a curved route equal those
    of the same controller written with the PID classes, bit for bit (either path)."""
    route = [(20.0 * math.sin(0.02 * k), 0.8 * k - 0.004 * k * k) for k in range(60)]
    stack = ReferenceStack(params={"pid_window": window})
    stack.reset(RunInfo(0.05, tuple(route), route[-1], "test", CameraSpec(), 0))
    rnd = random.Random(window)
    steps = []
    for k in range(400):
        x, y = route[min(k // 6, 59)]
        pose = (x + rnd.uniform(-1, 1), y + rnd.uniform(-1, 1), rnd.uniform(-3.2, 3.2))
        steps.append((*pose, rnd.choice([0.0, rnd.uniform(0.0, 12.0)])))
    got = [stack.step(Observation(0.0, EgoState(*s, 0.0))) for s in steps]
    want = _reference_drive(route, stack.params, steps)
    assert [repr((c.throttle, c.brake, c.steer)) for c in got] == [repr(w) for w in want]
    assert want[-1] == (0.0, 1.0, 0.0)  # the route was consumed


def test_route_state_is_a_fresh_copy_for_every_run() -> None:
    """The route step's array is made once per route object and copied for each run: a run
    that steps it (in place) leaves the next run's fresh, equal to one made anew."""
    from sitcov.av import _reference

    route = tuple((float(k), 0.5 * k) for k in range(40))
    gains = (3.0, 0.5, 25.0, 0.15, 0.05, 0.07, 0.58, 0.02, 0.5, 0.05, 4.0, 0.75, 0.3, 0.8, 0.1)
    first = _reference.route_state(gains, route)
    fresh = list(first)
    (_reference._STEP or _reference._step_kernel())(first, 3.0, 1.0, 0.4, 2.0)
    assert list(first) != fresh  # the step changed its state in place
    second = _reference.route_state(gains, route)
    assert second is not first and list(second) == fresh
    assert list(second) == list(_reference._route_state(gains, route))
    other = _reference.route_state(gains, tuple(route[:20]))
    assert len(other) != len(second)  # another route: its own array
